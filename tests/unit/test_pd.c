/* pd method (PMB and LPS as LAMMPS peri/pmb and peri/lps): bond force and energy against hand
 * values, the partial-volume scaling, the contact force, momentum conservation, energy
 * conservation of a vibrating block, critical-stretch breaking with the s0 history, the damage
 * measure, and a 10-step two-particle trajectory against an independent integration of the
 * LAMMPS formulas. */
#include <check.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "test_rng.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_pd_info(void);
const ej_plugin_info *ej_plugin_rigid_indenter_info(void);

typedef struct pd_fix {
  ej_registry *reg;
  const ej_method_ops *ops;
  void *cfg, *state;
  struct ej_model model;
  ej_set *set;
  ej_nbrlist *list;
  ej_real t, dt;
} pd_fix;

static const ej_param *find_param(const ej_param *t, const char *name)
{
  for (; t && t->name; ++t)
    if (!strcmp(t->name, name)) return t;
  ck_abort_msg("no parameter '%s'", name);
  return NULL;
}
static void set_real(pd_fix *f, const char *name, ej_real v)
{
  *(ej_real *)((char *)f->cfg + find_param(f->ops->params, name)->offset) = v;
}
static void set_bool(pd_fix *f, const char *name, bool v)
{
  *(bool *)((char *)f->cfg + find_param(f->ops->params, name)->offset) = v;
}

/* Registry, defaults, a set of n particles with the method's fields and x0. */
static void fix_open(pd_fix *f, int lps, ej_idx n)
{
  memset(f, 0, sizeof *f);
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_pd_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_METHOD, "pd", NULL, &ops), EJ_OK);
  f->ops = ops;
  f->cfg = ej_calloc(1, f->ops->config_size);
  ck_assert_int_eq(ej_params_defaults(f->ops->params, f->cfg), EJ_OK);
  *(int *)((char *)f->cfg + find_param(f->ops->params, "model")->offset) = lps;
  f->model = (struct ej_model){.name = "solid", .rho0 = 2200.0, .eos = NULL, .mat = NULL};
  ck_assert_int_eq(ej_set_create("solid", 0, 3, &f->set), EJ_OK);
  ck_assert_int_eq(ej_decl_probe(f->ops, f->cfg, f->set), EJ_OK);
  ck_assert_int_eq(f->set->nbr_config, EJ_NBR_REFERENCE);
  static const ej_field_decl x0 = {.name = "x0", .kind = EJ_VEC3, .flags = EJ_FIELD_POSITION, .unit = "m"};
  ck_assert_int_eq(ej_set_add_field(f->set, &x0, NULL), EJ_OK);
  ck_assert_int_eq(ej_set_reserve(f->set, n), EJ_OK);
  f->set->n = n;
  f->set->n_ghost = 0;
  f->set->t = &f->t;
  f->set->dt = &f->dt;
  int32_t *id = ej_set_field_int(f->set, "id");
  for (ej_idx i = 0; i < n; ++i) id[i] = (int32_t)i;
  ck_assert_int_eq(ej_nbrlist_create(&f->list), EJ_OK);
}

/* Particles placed by the caller in x (x0 = x unless already set): create, setup, families. */
static void fix_start(pd_fix *f, bool copy_x0)
{
  const ej_idx n = f->set->n;
  ej_real *x = ej_set_field(f->set, "x"), *x0 = ej_set_field(f->set, "x0");
  if (copy_x0) memcpy(x0, x, (size_t)n * 3 * sizeof *x);
  f->set->spacing_min = 1e-3;
  ck_assert_int_eq(f->ops->create(f->cfg, f->set, &f->model, &f->state), EJ_OK);
  ck_assert_int_eq(f->ops->setup(f->state, f->set), EJ_OK);
  ck_assert_int_eq(f->ops->support(f->state, f->set, (ej_range){0, n}, f->set->radius), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(f->list, 3, x0, f->set->radius, n, x0, f->set->radius, n, 0.0, true), EJ_OK);
  /* the core's bond flags, as ej_lists_from_build makes them for a reference family */
  f->set->n_bonds = f->list->pub.off[n];
  f->set->bond_flags = ej_calloc((size_t)f->set->n_bonds + 1, 1);
  ck_assert_ptr_nonnull(f->set->bond_flags);
}

static void fix_compute(pd_fix *f)
{
  const ej_idx n = f->set->n;
  memset(ej_set_field(f->set, "a"), 0, (size_t)n * 3 * sizeof(ej_real));
  const ej_range halves[2] = {{0, n / 2}, {n / 2, n}};
  for (int pass = 0; pass < 2; ++pass)
    for (int h = 0; h < 2; ++h)
      ck_assert_int_eq(f->ops->compute(f->state, f->set, &f->list->pub, pass, halves[h]), EJ_OK);
}

static void fix_post(pd_fix *f) { ck_assert_int_eq(f->ops->post_step(f->state, f->set, (ej_range){0, f->set->n}), EJ_OK); }

static void fix_close(pd_fix *f)
{
  if (f->state) f->ops->destroy(f->state);
  ej_nbrlist_destroy(f->list);
  ej_set_destroy(f->set);
  ej_free(f->cfg);
  ej_registry_destroy(f->reg);
}

static void set_mass(pd_fix *f, ej_real rho, ej_real vol)
{
  ej_real *m = ej_set_field(f->set, "m"), *v0 = ej_set_field(f->set, "vol0");
  for (ej_idx i = 0; i < f->set->n; ++i) v0[i] = vol, m[i] = rho * vol;
}

static double rel(double a, double b) { return fabs(a - b) / fmax(fabs(b), 1e-300); }

/* ------------------------------------------------------------------ hand values */

START_TEST(test_pmb_bond_hand)
{
  /* Two particles 1 mm apart stretched by s = 1e-3; the bond is well inside the horizon (no
   * partial volume): f_0 = c s V (x_1 - x_0)/r, a = f/rho, energy per side c s^2 r0 V / 4. */
  pd_fix f;
  fix_open(&f, 0, 2);
  const ej_real c = 1e20, V = 1e-9, rho = 2200, r0 = 1e-3, s = 1e-3, delta = 3.0001e-3;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", 1e-3);
  set_bool(&f, "contact", false);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  x0[0] = x0[1] = x0[2] = 0, x0[3] = r0, x0[4] = x0[5] = 0;
  memcpy(x, x0, 6 * sizeof *x);
  x[3] = r0 * (1 + s);
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a"), *e = ej_set_field(f.set, "e_pd"), *m = ej_set_field(f.set, "m");
  const ej_real want = c * s * V / rho;
  ck_assert_msg(rel(a[0], want) < 1e-12, "a_0 = %.15g, want %.15g", a[0], want);
  ck_assert_msg(rel(a[3], -want) < 1e-12, "a_1 = %.15g, want %.15g", a[3], -want);
  ck_assert(a[1] == 0 && a[2] == 0 && a[4] == 0 && a[5] == 0);
  ck_assert(fabs(m[0] * a[0] + m[1] * a[3]) <= 1e-15 * m[0] * fabs(a[0]));
  const ej_real e_want = 0.25 * c * s * s * r0 * V / rho; /* specific, per side */
  ck_assert_msg(rel(e[0], e_want) < 1e-9 && rel(e[1], e_want) < 1e-9, "e = %.15g %.15g, want %.15g", e[0], e[1],
                e_want);
  /* the pair energy V (e0 + e1) rho = c s^2 r0 V^2 / 2 has derivative c s V^2 = the force */
  ej_real dt = 1.0;
  ck_assert_int_eq(f.ops->stable_dt(f.state, f.set, (ej_range){0, 2}, &dt), EJ_OK);
  /* Silling & Askari 2005 Eq 16 with one bond: sqrt(2 rho / (V c / r0)) */
  ck_assert_msg(rel(dt, sqrt(2 * rho / (V * c / r0))) < 1e-12, "dt %g", dt);
  fix_close(&f);
}
END_TEST

START_TEST(test_volume_scaling)
{
  /* Bond at r0 = 2.9 lc with delta = 3.0001 lc: LAMMPS scales V_j by (delta + lc/2 - r0)/lc. */
  pd_fix f;
  fix_open(&f, 0, 2);
  const ej_real lc = 1e-3, c = 1e20, V = 1e-9, rho = 2200, r0 = 2.9e-3, s = 2e-4, delta = 3.0001e-3;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  set_bool(&f, "contact", false);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 6 * sizeof *x0);
  x0[4] = r0;
  memcpy(x, x0, 6 * sizeof *x);
  x[4] = r0 * (1 + s);
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a");
  const ej_real scale = (delta + 0.5 * lc - r0) / lc;
  ck_assert_msg(rel(a[1], c * s * V * scale / rho) < 1e-12, "a_y %.15g want %.15g", a[1], c * s * V * scale / rho);
  fix_close(&f);
  /* switched off: full volume */
  fix_open(&f, 0, 2);
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  set_bool(&f, "contact", false), set_bool(&f, "volume_scaling", false);
  x = ej_set_field(f.set, "x"), x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 6 * sizeof *x0);
  x0[4] = r0;
  memcpy(x, x0, 6 * sizeof *x);
  x[4] = r0 * (1 + s);
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  a = ej_set_field(f.set, "a");
  ck_assert(rel(a[1], c * s * V / rho) < 1e-12);
  fix_close(&f);
}
END_TEST

START_TEST(test_contact_hand)
{
  /* Two particles 1.2 lc apart in the reference configuration (no bond: delta = 1.1 lc), pushed to
   * 0.8 lc: d = min(0.9 * 1.2 lc, 1.35 lc) = 1.08 lc; force density 15 c V (d - r)/delta. */
  pd_fix f;
  fix_open(&f, 0, 2);
  const ej_real lc = 1e-3, c = 1e20, V = 1e-9, rho = 2200, delta = 1.1e-3;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 6 * sizeof *x0);
  x0[5] = 1.2 * lc;
  memcpy(x, x0, 6 * sizeof *x);
  x[5] = 0.8 * lc;
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a"), *e = ej_set_field(f.set, "e_pd");
  const ej_real d = 0.9 * 1.2 * lc, fd = 15.0 * c * V * (d - 0.8 * lc) / delta;
  ck_assert_msg(rel(a[2], -fd / rho) < 1e-12, "a_z %.15g want %.15g", a[2], -fd / rho);
  ck_assert(rel(a[5], fd / rho) < 1e-12);
  const ej_real e_want = 15.0 * c * V * (d - 0.8 * lc) * (d - 0.8 * lc) / (4 * delta) / rho;
  ck_assert_msg(rel(e[0], e_want) < 1e-12, "contact energy %.15g want %.15g", e[0], e_want);
  fix_close(&f);
}
END_TEST

/* ------------------------------------------------------------------ block tests */

static double rng_u(uint64_t *s) { return rng_uniform(s) - 0.5; }

/* side^3 lattice of spacing 1 mm, horizon 3.0001 mm, rho 2200, positions perturbed by amp lc. */
static void block(pd_fix *f, int lps, int side, double amp, uint64_t seed)
{
  const ej_idx n = side * side * side;
  fix_open(f, lps, n);
  const ej_real lc = 1e-3;
  set_real(f, "horizon", 3.0001e-3), set_real(f, "lattice_spacing", lc);
  if (lps) set_real(f, "bulk", 14.9e9), set_real(f, "shear", 14.9e9);
  else set_real(f, "c", 1.6863e22 * pow(0.0015001 / 3.0001e-3, 4));
  ej_real *x = ej_set_field(f->set, "x"), *x0 = ej_set_field(f->set, "x0");
  for (ej_idx i = 0; i < n; ++i) {
    x0[3 * i] = (i % side) * lc, x0[3 * i + 1] = ((i / side) % side) * lc, x0[3 * i + 2] = (i / (side * side)) * lc;
    for (int k = 0; k < 3; ++k) x[3 * i + k] = x0[3 * i + k] + amp * lc * rng_u(&seed);
  }
  set_mass(f, 2200, lc * lc * lc);
  fix_start(f, false);
}

START_TEST(test_contact_bonded)
{
  /* Two particles 1.0 lc apart, bonded (delta = 1.1 lc, no volume scaling), pushed to 0.5 lc: the
   * contact of a family pair is found in the bond loop, d = min(0.9 lc, 1.35 lc) = 0.9 lc, on top
   * of the bond force c V s with s = -0.5. */
  pd_fix f;
  fix_open(&f, 0, 2);
  const ej_real lc = 1e-3, c = 1e20, V = 1e-9, rho = 2200, delta = 1.1e-3;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  set_bool(&f, "volume_scaling", false);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 6 * sizeof *x0);
  x0[5] = lc;
  memcpy(x, x0, 6 * sizeof *x);
  x[5] = 0.5 * lc;
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a"), *e = ej_set_field(f.set, "e_pd");
  const ej_real d = 0.9 * lc, fc = 15.0 * c * V * (d - 0.5 * lc) / delta, fb = 0.5 * c * V;
  ck_assert_msg(rel(a[2], -(fb + fc) / rho) < 1e-12, "a_z %.15g want %.15g", a[2], -(fb + fc) / rho);
  ck_assert(rel(a[5], (fb + fc) / rho) < 1e-12);
  const ej_real e_want = (0.25 * c * V * 0.5 * 0.5 * lc + 15.0 * c * V * (d - 0.5 * lc) * (d - 0.5 * lc) / (4 * delta)) / rho;
  ck_assert_msg(rel(e[0], e_want) < 1e-12, "energy %.15g want %.15g", e[0], e_want);
  /* without contact: the bond force alone */
  fix_close(&f);
  fix_open(&f, 0, 2);
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  set_bool(&f, "volume_scaling", false), set_bool(&f, "contact", false);
  x = ej_set_field(f.set, "x"), x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 6 * sizeof *x0);
  x0[5] = lc;
  memcpy(x, x0, 6 * sizeof *x);
  x[5] = 0.5 * lc;
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  a = ej_set_field(f.set, "a");
  ck_assert_msg(rel(a[2], -fb / rho) < 1e-12, "no contact: a_z %.15g want %.15g", a[2], -fb / rho);
  fix_close(&f);
}
END_TEST

START_TEST(test_contact_crowded)
{
  /* 3x3x3 particles, no families (delta = 0.5 lc), the lattice squeezed to 0.85 lc: the centre
   * has 18 non-family particles within the list radius 1.7 lc (more than the 8 stored: searched in
   * the grid at the force evaluation), the corners 7. Every contact force against a brute-force
   * sum over all pairs: 15 c V (d - r)/delta with d = min(0.9 |xi|, 1.35 lc). */
  pd_fix f;
  fix_open(&f, 0, 27);
  const ej_real lc = 1e-3, c = 1e20, V = 1e-9, rho = 2200, delta = 0.5e-3;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  for (int k = 0; k < 27; ++k) {
    x0[3 * k] = (k % 3) * lc, x0[3 * k + 1] = (k / 3 % 3) * lc, x0[3 * k + 2] = (k / 9) * lc;
    for (int d = 0; d < 3; ++d) x[3 * k + d] = 0.85 * x0[3 * k + d];
  }
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a");
  double amax = 0, err = 0;
  for (int i = 0; i < 27; ++i) {
    double want[3] = {0, 0, 0};
    for (int j = 0; j < 27; ++j) {
      if (j == i) continue;
      double e2 = 0, r2 = 0, dd[3];
      for (int d = 0; d < 3; ++d) {
        const double e = x0[3 * i + d] - x0[3 * j + d];
        dd[d] = x[3 * i + d] - x[3 * j + d];
        e2 += e * e, r2 += dd[d] * dd[d];
      }
      const double dc = fmin(0.9 * sqrt(e2), 1.35 * lc), r = sqrt(r2);
      if (r >= dc) continue;
      const double fm = 15.0 * c * V * (dc - r) / delta; /* away from j */
      for (int d = 0; d < 3; ++d) want[d] += fm * dd[d] / r / rho;
    }
    for (int d = 0; d < 3; ++d) amax = fmax(amax, fabs(want[d])), err = fmax(err, fabs(a[3 * i + d] - want[d]));
  }
  ck_assert_msg(amax > 0, "no contact force");
  ck_assert_msg(err < 1e-12 * amax, "contact accelerations off by %g of %g", err, amax);
  fix_close(&f);
}
END_TEST

START_TEST(test_momentum)
{
  for (int lps = 0; lps < 2; ++lps) {
    pd_fix f;
    block(&f, lps, 6, 0.02, 7 + lps);
    fix_compute(&f);
    const ej_real *a = ej_set_field(f.set, "a"), *m = ej_set_field(f.set, "m");
    double p[3] = {0, 0, 0}, scale = 0;
    for (ej_idx i = 0; i < f.set->n; ++i)
      for (int k = 0; k < 3; ++k) p[k] += m[i] * a[3 * i + k], scale += fabs(m[i] * a[3 * i + k]);
    ck_assert_msg(scale > 0, "no forces");
    for (int k = 0; k < 3; ++k)
      ck_assert_msg(fabs(p[k]) < 1e-12 * scale, "model %d: net force %g of %g", lps, p[k], scale);
    fix_close(&f);
  }
}
END_TEST

/* Velocity Verlet by hand: kinetic + sum m e_pd stays constant to O(dt^2). */
START_TEST(test_energy_conservation)
{
  for (int lps = 0; lps < 2; ++lps) {
    pd_fix f;
    block(&f, lps, 5, 0.01, 11 + lps);
    const ej_idx n = f.set->n;
    fix_compute(&f);
    ej_real dt = 0;
    ck_assert_int_eq(f.ops->stable_dt(f.state, f.set, (ej_range){0, n}, &dt), EJ_OK);
    dt *= 0.05; /* O(dt^2) error: 4e-3 of E0 at 0.1 for LPS, below 2e-3 here */
    ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v"), *a = ej_set_field(f.set, "a");
    const ej_real *m = ej_set_field(f.set, "m"), *e = ej_set_field(f.set, "e_pd");
    double E0 = 0, emax = 0, Emin = INFINITY, Emax = -INFINITY;
    for (int step = 0; step <= 300; ++step) {
      if (step) {
        for (ej_idx i = 0; i < 3 * n; ++i) v[i] += 0.5 * dt * a[i], x[i] += dt * v[i];
        fix_compute(&f);
        for (ej_idx i = 0; i < 3 * n; ++i) v[i] += 0.5 * dt * a[i];
        fix_post(&f);
      }
      double E = 0, U = 0;
      for (ej_idx i = 0; i < n; ++i) {
        E += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
        U += m[i] * e[i];
      }
      if (!step) E0 = U;
      emax = fmax(emax, U);
      Emin = fmin(Emin, E + U), Emax = fmax(Emax, E + U);
    }
    ck_assert_msg(E0 > 0, "no initial elastic energy");
    ck_assert_msg((Emax - Emin) < 2e-3 * E0, "model %d: total energy varies by %g of %g", lps, Emax - Emin, E0);
    fix_close(&f);
  }
}
END_TEST

START_TEST(test_breaking_and_damage)
{
  /* Three particles on a line, 1 mm apart, horizon 1.5 mm (nearest-neighbour bonds only, no
   * partial volume since |1 mm - 1.5 mm| > lc/2 with lc = 0.8 mm). The right bond is stretched
   * past s00: it may not break in the first evaluation (s0 = DBL_MAX, as LAMMPS), then s0 =
   * s00 - alpha s_min and it breaks in the second; damage = 1 - V/(2V) for the middle one. */
  pd_fix f;
  fix_open(&f, 0, 3);
  const ej_real s00 = 5e-4, alpha = 0.25;
  set_real(&f, "horizon", 1.5e-3), set_real(&f, "c", 1e20), set_real(&f, "lattice_spacing", 0.8e-3);
  set_real(&f, "s00", s00), set_real(&f, "alpha", alpha);
  set_bool(&f, "contact", false);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 9 * sizeof *x0);
  x0[3] = 1e-3, x0[6] = 2e-3;
  memcpy(x, x0, 9 * sizeof *x);
  const ej_real sl = -2e-4, sr = 7e-4; /* left bond compressed, right bond stretched */
  x[0] = x0[0] - sl * 1e-3;
  x[6] = x0[6] + sr * 1e-3;
  set_mass(&f, 2200, 1e-9);
  fix_start(&f, false);
  const ej_real *s0 = ej_set_field(f.set, "s0"), *s0n = ej_set_field(f.set, "s0_new"), *d = ej_set_field(f.set, "damage");
  ck_assert(s0[0] == DBL_MAX && s0[1] == DBL_MAX);
  fix_compute(&f);
  fix_post(&f);
  ck_assert_msg(d[1] == 0.0 && d[2] == 0.0, "broke in the first evaluation");
  /* s0_i = max_j (s00 - alpha s_ij) = s00 - alpha min_j s_ij */
  ck_assert_msg(fabs(s0[1] - (s00 - alpha * sl)) < 1e-12, "s0[1] %.12g", s0[1]);
  ck_assert(fabs(s0[2] - (s00 - alpha * sr)) < 1e-12);
  ck_assert(fabs(s0[0] - (s00 - alpha * sl)) < 1e-12);
  (void)s0n;
  fix_compute(&f);
  fix_post(&f);
  ck_assert_msg(fabs(d[1] - 0.5) < 1e-15, "damage middle %g", d[1]);
  ck_assert_msg(d[2] == 1.0 && d[0] == 0.0, "damage ends %g %g", d[0], d[2]);
  const int32_t *nb = ej_set_field_int(f.set, "n_broken");
  ck_assert(nb[1] == 1 && nb[2] == 1 && nb[0] == 0);
  /* the broken bond is recorded in the core's bond flags (bit 0), from both ends */
  {
    const uint8_t *fl = ej_set_bond_flags(f.set);
    const ej_off *off = f.list->pub.off;
    const ej_idx *idx = f.list->pub.idx;
    int n_flag = 0;
    for (ej_idx i = 0; i < 3; ++i)
      for (ej_off k = off[i]; k < off[i + 1]; ++k)
        if (fl[k] & 1u) {
          ++n_flag;
          ck_assert((i == 1 && idx[k] == 2) || (i == 2 && idx[k] == 1));
        }
    ck_assert_int_eq(n_flag, 2);
  }
  /* irreversible: back to the reference positions, the bond stays broken and exerts no force */
  memcpy(x, x0, 9 * sizeof *x);
  x[6] = x0[6] + 1e-9;
  fix_compute(&f);
  const ej_real *a = ej_set_field(f.set, "a");
  ck_assert(a[6] == 0.0 && fabs(d[1] - 0.5) < 1e-15);
  /* the released energy is kept: w_frac = c s^2 r0 V / 4 / rho for each side */
  const ej_real *wf = ej_set_field(f.set, "w_frac");
  const ej_real st = sr; /* stretch at breaking */
  ck_assert_msg(rel(wf[2], 0.25 * 1e20 * st * st * 1e-3 * 1e-9 / 2200) < 1e-6, "w_frac %g", wf[2]);
  /* report */
  ej_series_value out[EJ_MAX_SERIES];
  int nout = 0;
  ck_assert_int_eq(f.ops->report(f.state, f.set, out, EJ_MAX_SERIES, &nout), EJ_OK);
  ck_assert_int_ge(nout, 2);
  ck_assert_str_eq(out[0].name, "damage_mean");
  ck_assert(fabs(out[0].value - 0.5) < 1e-12);
  ck_assert(out[1].value == 2.0);
  fix_close(&f);
}
END_TEST

/* Two particles 1 mm apart, one moving at 1 m/s away: 10 velocity-Verlet steps of the plugin
 * against the same LAMMPS formulas (pair_peri_pmb.cpp + fix nve) written out here. */
START_TEST(test_ten_steps)
{
  pd_fix f;
  fix_open(&f, 0, 2);
  const ej_real c = 1e22, V = 1.25e-10, rho = 2200, r0 = 5e-4, delta = 1.5001e-3, lc = 5e-4, dt = 1e-8;
  set_real(&f, "horizon", delta), set_real(&f, "c", c), set_real(&f, "lattice_spacing", lc);
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0"), *v = ej_set_field(f.set, "v");
  memset(x0, 0, 6 * sizeof *x0);
  x0[3] = r0;
  memcpy(x, x0, 6 * sizeof *x);
  v[3] = 1.0;
  set_mass(&f, rho, V);
  fix_start(&f, false);
  fix_compute(&f);
  ej_real *a = ej_set_field(f.set, "a");
  /* reference: 1D along x, LAMMPS arithmetic (rmass = rho, f = force density) */
  double X[2] = {0, r0}, U[2] = {0, 1.0}, F[2] = {0, 0};
  for (int step = 1; step <= 10; ++step) {
    for (int i = 0; i < 2; ++i) U[i] += 0.5 * dt * F[i] / rho, X[i] += dt * U[i];
    const double del = X[0] - X[1], r = fabs(del), dr = r - r0, st = dr / r0;
    const double rk = c * V * 1.0 * st, fb = -rk / r;
    F[0] = del * fb, F[1] = -del * fb;
    for (int i = 0; i < 2; ++i) U[i] += 0.5 * dt * F[i] / rho;
    for (ej_idx i = 0; i < 6; ++i) v[i] += 0.5 * dt * a[i], x[i] += dt * v[i];
    fix_compute(&f);
    for (ej_idx i = 0; i < 6; ++i) v[i] += 0.5 * dt * a[i];
    fix_post(&f);
  }
  ck_assert_msg(fabs(x[3] - X[1]) < 1e-15 * r0 && fabs(x[0] - X[0]) < 1e-15 * r0, "x %.17g vs %.17g", x[3], X[1]);
  ck_assert_msg(rel(v[3], U[1]) < 1e-12 && rel(v[0], U[0]) < 1e-9, "v %.17g vs %.17g, %.17g vs %.17g", v[3], U[1],
                v[0], U[0]);
  fix_close(&f);
}
END_TEST

START_TEST(test_config_errors)
{
  pd_fix f;
  fix_open(&f, 0, 1);
  set_real(&f, "horizon", 1e-3);
  /* PMB without c and without moduli */
  ck_assert_int_ne(f.ops->create(f.cfg, f.set, &f.model, &f.state), EJ_OK);
  ej_error_clear();
  f.state = NULL;
  fix_close(&f);
  fix_open(&f, 1, 1);
  set_real(&f, "horizon", 1e-3), set_real(&f, "bulk", 1e9);
  ck_assert_int_ne(f.ops->create(f.cfg, f.set, &f.model, &f.state), EJ_OK); /* LPS needs shear */
  ej_error_clear();
  f.state = NULL;
  fix_close(&f);
}
END_TEST

/* A notch segment (notch_a-notch_b) between particle 0 and particles 1, 2 leaves their bonds out of
 * the family: no force across it and no damage from it; the bond 1-2 on one side is kept. */
START_TEST(test_notch)
{
  pd_fix f;
  fix_open(&f, 0, 3);
  set_real(&f, "horizon", 2.5e-3), set_real(&f, "c", 1e20), set_real(&f, "lattice_spacing", 1e-3);
  set_bool(&f, "contact", false);
  ej_real *na = (ej_real *)((char *)f.cfg + find_param(f.ops->params, "notch_a")->offset);
  ej_real *nb = (ej_real *)((char *)f.cfg + find_param(f.ops->params, "notch_b")->offset);
  na[0] = -1e-3, na[1] = 0.5e-3, nb[0] = 1e-3, nb[1] = 0.5e-3;
  ej_real *x = ej_set_field(f.set, "x"), *x0 = ej_set_field(f.set, "x0");
  memset(x0, 0, 9 * sizeof *x0);
  x0[4] = 1e-3, x0[7] = 2e-3;
  memcpy(x, x0, 9 * sizeof *x);
  set_mass(&f, 2200, 1e-9);
  fix_start(&f, false);
  x[1] = -1e-6; /* stretch 0-1 and 0-2 (cut) */
  x[7] = 2.001e-3; /* stretch 1-2 (kept) */
  fix_compute(&f);
  fix_post(&f);
  const ej_real *a = ej_set_field(f.set, "a"), *d = ej_set_field(f.set, "damage");
  ck_assert_msg(a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0, "force across the notch: %g %g", a[0], a[1]);
  ck_assert_msg(a[4] > 0.0 && a[7] < 0.0, "bond 1-2 lost: %g %g", a[4], a[7]);
  ck_assert(d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0);
  fix_close(&f);
}
END_TEST

/* ------------------------------------------------------------------ restart and threads */

/* A PMB block (10 x 8 x 8 lattice, 640 particles: two chunks) shattered by a spherical indenter
 * at 300 m/s, touching at t = 0: bonds break before the cut at step 30. The same scene through the whole core
 * (scene, sim, checkpoint, restart), as tests/unit/test_determinism.c does for SPH. */
static const char pd_scene[] =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1.0, dt: 1.0e-7}\n"
    "output: {file: pd.h5, every: 1.0, fields: [v, damage]}\n"
    "materials:\n"
    "  glass: {rho0: 2200}\n"
    "sets:\n"
    "  target:\n"
    "    method: pd\n"
    "    model: pmb\n"
    "    material: glass\n"
    "    shape: {box: {min: [-0.0025, -0.002, -0.002], max: [0.0025, 0.002, 0.002]}}\n"
    "    spacing: 0.0005\n"
    "    horizon: 0.0015001\n"
    "    c: 1.6863e22\n"
    "    s00: 0.0005\n"
    "    alpha: 0.25\n"
    "    lattice_spacing: 0.0005\n"
    "interactions:\n"
    "  - {model: rigid_indenter, sets: [target], shape: sphere, center: [0, 0.0032, 0], velocity: [0, -300, 0],\n"
    "     radius: 0.0015, K: 1e17, per_volume: true}\n";

typedef struct pd_snap {
  ej_idx n;
  int64_t step;
  double *x, *v, *d; /* by particle id */
  int64_t broken;
} pd_snap;

static void pd_run(const char *dir, const char *out_name, int threads, int64_t steps, const char *restart, pd_snap *sn)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/pd.yaml", dir);
  snprintf(out, sizeof out, "%s/%s", dir, out_name);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = restart, .threads = threads};
  vrun r;
  memset(&r, 0, sizeof r);
  ck_assert_int_eq(ej_registry_create(&r.reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_pd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_rigid_indenter_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene, r.reg, &r.scene);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  r.scene->max_steps = steps;
  rc = ej_sim_create(r.scene, r.reg, &opts, &r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  vrun_run(&r);
  ck_assert_int_eq(r.sim->step, steps);
  const ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const int32_t *id = ej_set_field_int(s, "id"), *nb = ej_set_field_int(s, "n_broken");
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v"), *d = ej_set_field(s, "damage");
  sn->n = n;
  sn->step = r.sim->step;
  sn->x = calloc((size_t)n * 3, sizeof(double));
  sn->v = calloc((size_t)n * 3, sizeof(double));
  sn->d = calloc((size_t)n, sizeof(double));
  ck_assert(sn->x && sn->v && sn->d);
  sn->broken = 0;
  for (ej_idx i = 0; i < n; ++i) {
    const ej_idx k = id[i];
    ck_assert(k >= 0 && k < n);
    memcpy(sn->x + 3 * k, x + 3 * i, 3 * sizeof(double));
    memcpy(sn->v + 3 * k, v + 3 * i, 3 * sizeof(double));
    sn->d[k] = d[i];
    sn->broken += nb[i];
  }
  /* the core's flags agree with the per-particle counts */
  const uint8_t *fl = ej_set_bond_flags(s);
  int64_t nflag = 0;
  for (ej_off k = 0; k < s->n_bonds; ++k) nflag += fl[k] & 1u;
  ck_assert_int_eq(nflag, sn->broken);
  vrun_free(&r);
}

static void pd_snap_equal(const pd_snap *a, const pd_snap *b, const char *what)
{
  ck_assert_int_eq(a->n, b->n);
  ck_assert_int_eq(a->step, b->step);
  ck_assert_msg(a->broken == b->broken, "%s: %lld vs %lld broken bonds", what, (long long)a->broken,
                (long long)b->broken);
  const size_t n = (size_t)a->n;
  ck_assert_msg(memcmp(a->x, b->x, 3 * n * sizeof(double)) == 0, "%s: x differs", what);
  ck_assert_msg(memcmp(a->v, b->v, 3 * n * sizeof(double)) == 0, "%s: v differs", what);
  ck_assert_msg(memcmp(a->d, b->d, n * sizeof(double)) == 0, "%s: damage differs", what);
}

static void pd_snap_free(pd_snap *s) { free(s->x), free(s->v), free(s->d); }

START_TEST(test_restart_and_threads_bitwise)
{
  char dir[64], half[128];
  vrun_dir(dir, sizeof dir, "pdrs");
  char scene[128];
  snprintf(scene, sizeof scene, "%s/pd.yaml", dir);
  vrun_write(scene, pd_scene);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  enum { STEPS = 60 };
  pd_snap full, first, cont, one;
  pd_run(dir, "full.h5", 2, STEPS, NULL, &full);
  pd_run(dir, "half.h5", 2, STEPS / 2, NULL, &first);
  pd_run(dir, "cont.h5", 2, STEPS, half, &cont);
  pd_run(dir, "one.h5", 1, STEPS, NULL, &one);
  ck_assert_int_gt(full.n, 512);
  /* the restart must carry broken bonds: some broke before the cut, more after it */
  ck_assert_msg(first.broken > 0 && full.broken > first.broken, "broken bonds %lld at the cut, %lld at the end",
                (long long)first.broken, (long long)full.broken);
  pd_snap_equal(&full, &cont, "uninterrupted vs restarted");
  pd_snap_equal(&full, &one, "2 threads vs 1 thread");
  pd_snap_free(&full), pd_snap_free(&first), pd_snap_free(&cont), pd_snap_free(&one);
  const char *names[] = {"pd.yaml", "full.h5", "full.xdmf", "half.h5", "half.xdmf", "cont.h5", "cont.xdmf",
                         "one.h5", "one.xdmf"};
  vrun_cleanup(dir, names, 9);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("pd");
  TCase *tc = tcase_create("pd");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_pmb_bond_hand);
  tcase_add_test(tc, test_volume_scaling);
  tcase_add_test(tc, test_contact_hand);
  tcase_add_test(tc, test_contact_bonded);
  tcase_add_test(tc, test_contact_crowded);
  tcase_add_test(tc, test_momentum);
  tcase_add_test(tc, test_energy_conservation);
  tcase_add_test(tc, test_breaking_and_damage);
  tcase_add_test(tc, test_ten_steps);
  tcase_add_test(tc, test_config_errors);
  tcase_add_test(tc, test_notch);
  tcase_add_test(tc, test_restart_and_threads_bitwise);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
