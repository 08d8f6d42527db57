/* Interaction pd_sph (PD solid - SPH fluid coupling):
 * - pairwise form: total momentum of a free coupled system conserved to round-off, energy
 *   balanced;
 * - equilibrium / consistency: the forces of a uniform stress (prestressed rock next to water
 *   at the same pressure, closed box) on every interface particle, for each form, and 1000
 *   steps of that state (the criterion, 1e-8 c);
 * - decohesion: solid particles next to high-pressure fluid are marked failed and lose bonds;
 * - set checks: exactly one of the two sets must publish F;
 * - a shape-tensor fluid's M_i includes the other set's particles (pd_sph pairwise both / fluid,
 *   continuum) and not with gradient: kernel. */
#include <check.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_pd_sph_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);
const ej_plugin_info *ej_plugin_continuum_info(void);
const ej_plugin_info *ej_plugin_ulpd_info(void);

typedef vscene prun;

/* Loads the printf-formatted scene with the coupling's plugins and creates its sim. */
static ej_err prun_try(prun *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(),     ej_plugin_ideal_gas_info(), ej_plugin_pd_sph_info(),
                               ej_plugin_tlpd_info(),    ej_plugin_elastic_info(),   ej_plugin_polynomial_info(),
                               ej_plugin_continuum_info(), ej_plugin_ulpd_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "pdsph", p, 8, fmt, ap);
  va_end(ap);
  return rc;
}

static void prun_free(prun *c) { vscene_free(c); }

/* A 2D elastic PD block hit by a moving fluid block; no boundaries. */
static const char scene_free[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 2e-4, cfl: 0.3}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "sets:\n"
    "  rock: {method: tlpd, material: rock, shape: {box: {min: [0, 0], max: [0.05, 0.05]}}, spacing: 0.0025}\n"
    "  water: {method: sph, material: water, shape: {box: {min: [-0.03, 0.01], max: [0, 0.04]}}, spacing: 0.0025,\n"
    "          velocity: [20, 3]}\n"
    "interactions:\n  - {model: pd_sph, sets: [water, rock], form: %s%s}\n";

START_TEST(test_pairwise_momentum)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_free, "pairwise", ""), EJ_OK);
  const ej_energy *E0 = &c.r.sim->energy;
  const double px0 = E0->momentum[0], py0 = E0->momentum[1];
  vrun_run(&c.r);
  const ej_energy *E = &c.r.sim->energy;
  /* the water really pushed the rock */
  ej_set *rock = c.r.sim->sets[0];
  const ej_real *v = ej_set_field(rock, "v"), *m = ej_set_field(rock, "m");
  double prock = 0;
  for (ej_idx i = 0; i < rock->n; ++i) prock += m[i] * v[3 * i];
  fprintf(stderr, "pairwise: rock momentum %.4e, total drift (%.3e, %.3e) of %.3e, balance %.3e of %.3e\n", prock,
          E->momentum[0] - px0, E->momentum[1] - py0, px0, E->balance, E->total0);
  ck_assert_double_gt(prock, 1e-3 * px0);
  ck_assert_double_lt(fabs(E->momentum[0] - px0), 1e-12 * px0);
  ck_assert_double_lt(fabs(E->momentum[1] - py0), 1e-12 * px0);
  ck_assert_double_lt(fabs(E->balance), 1e-2 * E->total0);
  prun_free(&c);
}
END_TEST

START_TEST(test_decohesion)
{
  prun c;
  /* a 20 m/s water jet gives ~ rho c v = 30 MPa: a 1 MPa threshold decoheres the rock face */
  ck_assert_int_eq(prun_try(&c, scene_free, "pairwise", ", decohesion_pressure: 1 MPa"), EJ_OK);
  vrun_run(&c.r);
  ej_set *rock = c.r.sim->sets[0];
  const int32_t *failed = ej_set_field_int(rock, "failed");
  const ej_real *x = ej_set_field(rock, "x");
  int nf = 0, deep = 0;
  for (ej_idx i = 0; i < rock->n; ++i)
    if (failed[i]) {
      ++nf;
      deep += x[3 * i] > 0.02; /* only the face next to the water decoheres */
    }
  fprintf(stderr, "decohesion: %d failed rock particles, %d deeper than 20 mm\n", nf, deep);
  ck_assert_int_gt(nf, 0);
  ck_assert_int_eq(deep, 0);
  prun_free(&c);
}
END_TEST

/* Decohesion acts on the solid's interface layer only (issue 8, third pass): a 1D rock next to
 * water at 220 MPa (material rho0 1100, EOS rho0 1000, C1 2.2e9) whose h is 3 of its spacings
 * (0.5 mm), one force evaluation. The rock's nearest particle is 0.75 mm from the water, the next
 * 1.75 mm. decohesion_reach 1 (default, contact within one rock spacing, 1 mm): only the first
 * layer fails. decohesion_reach 0 (the former rule: the pair's kernel support 2 hbar = 4.5 mm, cut
 * by the neighbour list's 3 mm): the layers the water does not touch fail too. */
static const char scene_contact[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 1.0, cfl: 0.3, max_steps: 1}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1100, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "sets:\n"
    "  rock: {method: tlpd, material: rock, shape: {box: {min: [0], max: [0.01]}}, spacing: 0.001}\n"
    "  water: {method: sph, material: water, renormalize: false, h_factor: 3,\n"
    "          shape: {box: {min: [-0.01], max: [0]}}, spacing: 0.0005}\n"
    "interactions:\n  - {model: pd_sph, sets: [water, rock], decohesion_pressure: 50 MPa%s}\n";

static int contact_failed(const char *extra, double *deepest)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_contact, extra), EJ_OK);
  vrun_run(&c.r);
  ej_set *rock = c.r.sim->sets[0];
  ck_assert_str_eq(ej_set_name(rock), "rock");
  const int32_t *failed = ej_set_field_int(rock, "failed");
  const ej_real *x0 = ej_set_field(rock, "x0");
  int nf = 0;
  *deepest = 0;
  for (ej_idx i = 0; i < rock->n; ++i)
    if (failed[i]) {
      ++nf;
      *deepest = fmax(*deepest, x0[3 * i]);
    }
  prun_free(&c);
  return nf;
}

START_TEST(test_decohesion_contact)
{
  double d1, d0;
  const int n1 = contact_failed("", &d1), n0 = contact_failed(", decohesion_reach: 0", &d0);
  fprintf(stderr, "decohesion contact: reach 1 dx: %d failed (deepest x0 %.2f mm); kernel support: %d (%.2f mm)\n",
          n1, d1 * 1e3, n0, d0 * 1e3);
  ck_assert_int_eq(n1, 1);
  ck_assert_double_lt(d1, 0.001);
  ck_assert_int_ge(n0, 3);
}
END_TEST

START_TEST(test_needs_one_solid)
{
  prun c;
  ej_err rc = prun_try(&c,
                       "ejecta: 1\ndimension: 1\ntime: {end: 1e-4}\n"
                       "materials:\n  w: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
                       "sets:\n  a: {method: sph, material: w, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n"
                       "  b: {method: sph, material: w, shape: {box: {min: [1], max: [2]}}, spacing: 0.1}\n"
                       "interactions:\n  - {model: pd_sph, sets: [a, b]}\n");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(strstr(f->msg, "one peridynamic set"));
  ck_assert_int_eq(f->where.line, 10); /* located at the interaction's node */
  ej_error_clear();
  prun_free(&c);
}
END_TEST

/* A closed 1D box (symmetry planes at both ends): a prestressed PD rock (sigma = -p0 I, written
 * into its hypoelastic stress after the sim is created) next to water at the same pressure
 * (material rho0 above the EOS rho0, so p = C1 mu = p0 at t = 0). No load: it must stay at rest. */
static const char scene_uniform[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 1.0, cfl: 0.4, max_steps: %d}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1001, eos: {model: polynomial, rho0: 1000, C1: 1e8}}\n"
    "sets:\n"
    "  rock: {method: tlpd, material: rock, shape: {box: {min: [0], max: [0.03]}}, spacing: 0.001%s}\n"
    "  water: {method: sph, material: water, renormalize: false, shape: {box: {min: [0.03], max: [0.06]}},\n"
    "          spacing: 0.001}\n"
    "interactions:\n  - {model: pd_sph, sets: [water, rock], form: %s}\n"
    "boundaries:\n  - symmetry: {point: [0], normal: [1]}\n  - symmetry: {point: [0.06], normal: [-1]}\n";

static const double uni_p0 = 1e8 * 0.001; /* C1 mu */

static ej_set *prun_set(prun *c, const char *name) { return vsim_set(c->r.sim, name); }

static void prun_uniform_x(prun *c, int steps, const char *form, const char *rock_extra)
{
  const bool diff = strcmp(form, "consistent") == 0 || strcmp(form, "paper") == 0;
  char f[64], rx[128];
  snprintf(f, sizeof f, "%s", form);
  snprintf(rx, sizeof rx, "%s%s", diff ? ", force_form: difference" : "", rock_extra);
  ck_assert_int_eq(prun_try(c, scene_uniform, steps, rx, f), EJ_OK);
  ej_set *rock = prun_set(c, "rock");
  ej_real *st = ej_set_field(rock, "stress");
  for (ej_idx i = 0; i < rock->n; ++i)
    for (int q = 0; q < 6; ++q) st[6 * i + q] = q < 3 ? -uni_p0 : 0;
  /* the accelerations of t = 0 were evaluated before the prestress: the state is uniform now */
  for (int k = 0; k < c->r.sim->n_sets; ++k) {
    ej_set *s = c->r.sim->sets[k];
    memset(ej_set_field(s, "a"), 0, 3 * sizeof(ej_real) * (size_t)s->n);
  }
  vrun_run(&c->r);
}

static void prun_uniform(prun *c, int steps, const char *form) { prun_uniform_x(c, steps, form, ""); }

/* Largest |a| of a set's particles within `near` of the interface x = 0.03, in units of the
 * acceleration p0 / (rho dx) that an unbalanced traction p0 would give one layer. */
static double uni_amax(prun *c, const char *name, double near, double rho, double *sum_ma)
{
  ej_set *s = prun_set(c, name);
  const ej_real *a = ej_set_field(s, "a"), *x = ej_set_field(s, "x"), *m = ej_set_field(s, "m");
  double amax = 0, sum = 0;
  for (ej_idx i = 0; i < s->n; ++i) {
    if (fabs(x[3 * i] - 0.03) > near) continue;
    amax = fmax(amax, fabs(a[3 * i]));
    sum += m[i] * a[3 * i];
  }
  if (sum_ma) *sum_ma = sum / (uni_p0 * 1.0); /* force per unit area over p0 */
  return amax / (uni_p0 / (rho * 0.001));
}

/* Largest |a| of a set's particles farther than `near` from the interface, same units. */
static double uni_amax_far(prun *c, const char *name, double near, double rho)
{
  ej_set *s = prun_set(c, name);
  const ej_real *a = ej_set_field(s, "a"), *x = ej_set_field(s, "x");
  double amax = 0;
  for (ej_idx i = 0; i < s->n; ++i)
    if (fabs(x[3 * i] - 0.03) > near) amax = fmax(amax, fabs(a[3 * i]));
  return amax / (uni_p0 / (rho * 0.001));
}

/* Equilibrium / consistency: the forces of one evaluation at a uniform stress. form consistent:
 * zero on every particle (round-off); pairwise owned: zero on every fluid particle and in the sum
 * over the solid's interface layer, not particle by particle (the PD sum form's free-surface
 * force is spread over its horizon, the pair reactions over the kernel support). */
START_TEST(test_uniform_stress_forces)
{
  const char *forms[] = {"consistent", "pairwise", "pairwise, pair_stress: both", "pairwise, pair_stress: fluid",
                         "paper", "pairwise, pair_weight: kernel"};
  for (int k = 0; k < 6; ++k) {
    prun c;
    prun_uniform(&c, 1, forms[k]);
    double srock, swater;
    const double ar = uni_amax(&c, "rock", 0.006, 2000, &srock), aw = uni_amax(&c, "water", 0.006, 1001, &swater);
    /* away from the interface (the symmetry walls and their mirror ghosts included) */
    const double far_r = uni_amax_far(&c, "rock", 0.006, 2000), far_w = uni_amax_far(&c, "water", 0.006, 1001);
    fprintf(stderr,
            "uniform stress, form %-28s: max |a| rock %.2e, water %.2e (of p0/(rho dx)); "
            "layer forces/p0: rock %+.3e, water %+.3e; farther than 6 mm: rock %.1e, water %.1e\n",
            forms[k], ar, aw, srock, swater, far_r, far_w);
    if (k == 0) {
      ck_assert_double_lt(ar, 1e-9);
      ck_assert_double_lt(aw, 1e-9);
    } else if (k == 1 || k == 5) {
      ck_assert_double_lt(aw, 1e-9);
      ck_assert_double_lt(fabs(srock), 2e-2); /* lattice sum of the kernel: 1.022 in 1D */
      /* not particle by particle (README "Equilibrium at uniform stress"): the residual is the PD sum
       * form's free-surface force minus the pair reactions, layer by layer; 1D, horizon 3, h = 2 dx,
       * computed from the lattice sums in the README. pair_weight kernel: largest 0.180 on the 4th
       * layer (3.5 dx deep, outside the kernel support of every fluid particle); bond (default,
       * issue 8 fourth pass): the reactions spread over the horizon (0.413, 0.425, 0.162 on layers
       * 0-2), largest -0.786 + 0.413 = -0.373 on the surface layer */
      ck_assert_double_gt(ar, k == 1 ? 0.36 : 0.17);
      ck_assert_double_lt(ar, k == 1 ? 0.38 : 0.19);
      /* and nowhere else: the walls and their ghosts are in equilibrium */
      ck_assert_double_lt(far_r, 1e-9);
      ck_assert_double_lt(far_w, 1e-9);
    } else if (k == 4) {
      /* 000's own form (paper) is not in equilibrium at a density jump by construction: the
       * standard SPH sum m_j (p_i/rho_i^2 + p_j/rho_j^2) leaves p/rho_i (r - 1)^2/r sum_solid V_j grad W
       * on a fluid particle (r = rho_solid/rho_fluid); first fluid particle, 1D, h = 2 dx:
       * 0.3125 (r - 1)^2 / r = 0.1558 p0/(rho dx) with r = 2000/1001 (README) */
      const double r = 2000.0 / 1001.0, pred = 0.3125 * (r - 1) * (r - 1) / r;
      ck_assert_double_lt(fabs(aw / pred - 1), 1e-2);
    }
    prun_free(&c);
  }
}
END_TEST

/* The equilibrium check: 1000 steps of the uniform state; velocities below 1e-8 of the
 * water's sound speed with form consistent. The pairwise (owned) form cannot meet it (its
 * per-layer residual, test_uniform_stress_forces and README): its measured bound is asserted,
 * and that it does not grow (1000 and 4000 steps: the solid's surface layers oscillate about a
 * shifted equilibrium; no instability). */
START_TEST(test_uniform_stress_at_rest)
{
  const char *forms[] = {"consistent", "pairwise", "pairwise", "pairwise", "pairwise, pair_weight: kernel"};
  const int steps[] = {1000, 1000, 4000, 1000, 1000};
  /* the fourth run: tlpd's hourglass penalty 5x 002's (diagnostic of the mechanism, README) */
  const char *rx[] = {"", "", "", ", hourglass_coefficient: 0.05", ""};
  const double cw = sqrt(1e8 / 1000.0);
  for (int k = 0; k < 5; ++k) {
    prun c;
    prun_uniform_x(&c, steps[k], forms[k], rx[k]);
    double vmax = 0;
    for (int q = 0; q < c.r.sim->n_sets; ++q) {
      ej_set *s = c.r.sim->sets[q];
      const ej_real *v = ej_set_field(s, "v");
      for (ej_idx i = 0; i < s->n; ++i) vmax = fmax(vmax, fabs(v[3 * i]));
    }
    fprintf(stderr, "uniform stress, form %s%s: max |v| / c = %.3e after %d steps (p0/(rho c^2) = %.1e)\n", forms[k],
            rx[k], vmax / cw, steps[k], uni_p0 / 1e8);
    if (k == 0) ck_assert_double_lt(vmax / cw, 1e-8);
    else if (k == 4) /* pair_weight kernel: measured 2.04e-5 after 1000 steps (README) */
      ck_assert_double_lt(vmax / cw, 2.5e-5);
    else /* bond (default): measured 9.58e-6 after 1000 steps, 4.81e-6 after 4000 (README): bounded, no growth */
      ck_assert_double_lt(vmax / cw, 1.2e-5);
    prun_free(&c);
  }
}
END_TEST

/* Continuity across the interface under a uniform dilatation (issue 8, 2026-11-29): every particle
 * of both sets moves with v = eps (x - x_c), div v = 2 eps (2D), so the exact density rate is
 * drho/dt = -2 eps rho everywhere. The water's h is 3 of its spacings, so its kernel reaches 6 mm
 * into the rock, as an expanded gas's does in a blast (sph h_max). The fluid's continuity sum over
 * the solid neighbours with weight 1 (pair_stress both and fluid: the SPH sum over the whole kernel)
 * gives the dilatation; `owned` counts the solid's part of the kernel twice (its factor 2 is the
 * half-volume argument of a relative motion at the interface, README), so it also counts the
 * solid's own dilatation twice: measured -2 eps (1 + the solid's share of the kernel). In the
 * buried-charge scenes this drove the products to the density floor (validation/buried_charge). */
static const char scene_dilate[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1.0, dt: 1e-9, max_steps: 1}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "sets:\n"
    "  rock: {method: tlpd, material: rock, shape: {box: {min: [0, 0], max: [0.02, 0.04]}}, spacing: 0.001}\n"
    "  water: {method: sph, material: water, renormalize: false, h_factor: 3,\n"
    "          shape: {box: {min: [-0.02, 0], max: [0, 0.04]}}, spacing: 0.001}\n"
    "interactions:\n  - {model: pd_sph, sets: [water, rock], pair_weight: kernel%s}\n";

/* mean of (drho/dt) / (-2 eps rho) over the water particles within `band` of the interface x = 0,
 * away from the free edges (15 mm < y < 25 mm), after one step of the uniform dilatation */
/* One step of the uniform dilatation v = eps (x - x_c), eps = 100 /s (0.1 m/s across the 2 mm of a
 * kernel, 1e-7 of strain in the step), on every set of c; then, over the particles of set `name`
 * within `band` of the interface x = 0 and away from the free edges (15 mm < y < 25 mm), the mean
 * of (drho/dt) / (-2 eps rho) and the largest |that - 1|. */
static void dilate_stats(prun *c, const char *name, double band, double *mean, double *maxerr)
{
  const double eps = 100.0;
  for (int k = 0; k < c->r.sim->n_sets; ++k) {
    ej_set *s = c->r.sim->sets[k];
    ej_real *v = ej_set_field(s, "v");
    const ej_real *x = ej_set_field(s, "x");
    for (ej_idx i = 0; i < s->n; ++i) {
      v[3 * i] = eps * x[3 * i];
      v[3 * i + 1] = eps * (x[3 * i + 1] - 0.02);
    }
  }
  vrun_run(&c->r);
  ej_set *w = prun_set(c, name);
  const ej_real *x = ej_set_field(w, "x"), *rho = ej_set_field(w, "rho"), *rd = ej_set_field(w, "rho_dot");
  ck_assert_ptr_nonnull(rd);
  double sum = 0, err = 0;
  int n = 0;
  for (ej_idx i = 0; i < w->n; ++i) {
    if (fabs(x[3 * i]) > band || x[3 * i + 1] < 0.015 || x[3 * i + 1] > 0.025) continue;
    const double q = rd[i] / (-2 * eps * rho[i]);
    sum += q, err = fmax(err, fabs(q - 1));
    ++n;
  }
  ck_assert_int_gt(n, 0);
  *mean = sum / n, *maxerr = err;
}

/* the mean ratio over the water within `band` of the rock */
static double dilate_ratio(const char *extra, double band)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_dilate, extra), EJ_OK);
  double mean, err;
  dilate_stats(&c, "water", band, &mean, &err);
  prun_free(&c);
  return mean;
}

START_TEST(test_continuity_dilatation)
{
  const double owned = dilate_ratio("", 0.0035), both = dilate_ratio(", pair_stress: both", 0.0035);
  const double fluid = dilate_ratio(", pair_stress: fluid", 0.0035);
  const double deep = dilate_ratio(", pair_stress: both", 0.013); /* to 7 mm from the water's free edge */
  fprintf(stderr, "uniform dilatation, water within 3.5 mm of the rock (h = 3 dx): drho/dt over the exact: owned %.4f, "
                  "both %.4f, fluid %.4f; both over the water to 13 mm from the rock %.4f\n",
          owned, both, fluid, deep);
  ck_assert_double_lt(fabs(both - 1), 0.05);
  ck_assert_double_lt(fabs(fluid - 1), 0.05);
  ck_assert_double_lt(fabs(deep - 1), 0.05);
  ck_assert_double_gt(owned, 1.2); /* the solid's share counted twice */
}
END_TEST

/* sph renormalize_interfaces (plugins/methods/sph/README.md "Renormalisation across interfaces"):
 * the continuity sum and the renormalisation sum over the set's own AND the coupled set's
 * neighbours give drho/dt = -dim eps rho for any linear velocity field on any arrangement, per
 * particle, wherever the clamp is not reached: here the fluid within 3.5 mm of the other set
 * (its kernel reaches 6 mm into it), through pd_sph (pair_stress both; the rock a tlpd set) and
 * through continuum (the other set an sph fluid of twice the density at 1.3 mm spacing, itself
 * renormalised across the interface). Own-set renormalisation alone (renormalize: true without
 * the option) divides a one-sided sum and is off by tens of per cent there. */
static const char scene_dilate_ren[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1.0, dt: 1e-9, max_steps: 1}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "  oil: {rho0: 2000, eos: {model: polynomial, rho0: 2000, C1: 4e9}}\n"
    "sets:\n"
    "  rock: {%s, shape: {box: {min: [0, 0], max: [0.02, 0.04]}}, spacing: %s}\n"
    "  water: {method: sph, material: water, h_factor: 3, renormalize: true%s,\n"
    "          shape: {box: {min: [-0.02, 0], max: [0, 0.04]}}, spacing: 0.001}\n"
    "interactions:\n  - {model: %s, sets: [water, rock]}\n";

START_TEST(test_renormalize_interfaces)
{
  const char *tl = "method: tlpd, material: rock", *oil = "method: sph, material: oil, h_factor: 2, "
                                                        "renormalize: true, renormalize_interfaces: true";
  const char *on = ", renormalize_interfaces: true";
  struct {
    const char *rock, *dx, *water, *model, *what;
    const char *set;
  } cases[] = {
      {tl, "0.001", on, "pd_sph, pair_stress: both", "pd_sph both, water", "water"},
      {tl, "0.001", "", "pd_sph, pair_stress: both", "pd_sph both, water, own-set renormalisation only", "water"},
      {oil, "0.0013", on, "continuum", "continuum, water", "water"},
      {oil, "0.0013", on, "continuum", "continuum, oil (1.3 mm)", "rock"},
      {oil, "0.0013", "", "continuum", "continuum, water, own-set renormalisation only", "water"},
  };
  double err[5];
  for (int k = 0; k < 5; ++k) {
    prun c;
    ck_assert_int_eq(prun_try(&c, scene_dilate_ren, cases[k].rock, cases[k].dx, cases[k].water, cases[k].model),
                     EJ_OK);
    double mean;
    dilate_stats(&c, cases[k].set, 0.0035, &mean, &err[k]);
    fprintf(stderr, "uniform dilatation, %s: max |drho/dt over the exact - 1| = %.3e within 3.5 mm\n", cases[k].what,
            err[k]);
    prun_free(&c);
  }
  ck_assert_double_lt(err[0], 1e-10);
  ck_assert_double_lt(err[2], 1e-10);
  ck_assert_double_lt(err[3], 1e-10);
  ck_assert_double_gt(err[1], 0.05);
  ck_assert_double_gt(err[4], 0.05);
  /* couplings that would count the other set's neighbours with another weight refuse it */
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_dilate_ren, tl, "0.001", on, "pd_sph"), EJ_ERR_INPUT);
  prun_free(&c);
  ej_error_clear();
  ck_assert_int_eq(prun_try(&c, scene_dilate_ren, oil, "0.0013", on, "continuum, continuity: blend"), EJ_ERR_INPUT);
  prun_free(&c);
  ej_error_clear();
  /* continuity: number (the default for this set) has no units without the renormalisation */
  ck_assert_int_eq(prun_try(&c,
                            "ejecta: 1\ndimension: 1\ntime: {end: 1e-4}\noutput: {file: out.h5}\n"
                            "materials:\n  w: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
                            "sets:\n  a: {method: sph, material: w, continuity: number, renormalize: false,\n"
                            "      shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n"),
                   EJ_ERR_INPUT);
  prun_free(&c);
  ej_error_clear();
  /* and the method refuses it where its own divergence is not the plain renormalised kernel sum */
  ck_assert_int_eq(prun_try(&c, scene_dilate_ren, oil, "0.0013", ", renormalize_interfaces: true, gradient: shape_tensor",
                            "continuum"),
                   EJ_ERR_INPUT);
  prun_free(&c);
  ej_error_clear();
}
END_TEST

/* The shape tensor of a fluid next to another set (continuum README "Shape tensor across an
 * interface"): water run by sph with gradient: shape_tensor next to a tlpd rock (pd_sph, pairwise,
 * pair_stress both) or next to more water with the kernel gradient (continuum), both at the same
 * 1 mm lattice, at rest, one step. With the couplings' default gradient: auto the other set's
 * particles enter M_i, so a water particle at the interface has the interior particle's M_i^-1 (one
 * lattice across both sets); with gradient: kernel its M_i is one-sided (M^-1_xx about twice). */
static const char scene_shape_share[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1.0, dt: 1e-9, max_steps: 1}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "sets:\n"
    "  rock: {%s, shape: {box: {min: [0, 0], max: [0.02, 0.04]}}, spacing: 0.001}\n"
    "  water: {method: sph, material: water, gradient: shape_tensor,\n"
    "          shape: {box: {min: [-0.02, 0], max: [0, 0.04]}}, spacing: 0.001}\n"
    "interactions:\n  - {model: %s, sets: [water, rock]%s}\n";

/* max over the water particles within 3.5 mm of x = 0 (15 mm < y < 25 mm) of
 * |M_inv_i - M_inv_interior| / |M_inv_interior| (largest component), the interior particle being
 * the one nearest (-10.5 mm, 20.5 mm) */
static double shape_share_err(const char *rock, const char *model, const char *extra)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_shape_share, rock, model, extra), EJ_OK);
  vrun_run(&c.r);
  ej_set *w = prun_set(&c, "water");
  const ej_real *x = ej_set_field(w, "x"), *M = ej_set_field(w, "M_inv");
  ck_assert_ptr_nonnull(M);
  ej_idx ref = -1;
  double d2 = INFINITY;
  for (ej_idx i = 0; i < w->n; ++i) {
    const double dx = x[3 * i] + 0.0105, dy = x[3 * i + 1] - 0.0205;
    if (dx * dx + dy * dy < d2) d2 = dx * dx + dy * dy, ref = i;
  }
  double scale = 0;
  for (int k = 0; k < 6; ++k) scale = fmax(scale, fabs(M[6 * ref + k]));
  double err = 0;
  int n = 0;
  for (ej_idx i = 0; i < w->n; ++i) {
    if (x[3 * i] < -0.0035 || x[3 * i + 1] < 0.015 || x[3 * i + 1] > 0.025) continue;
    for (int k = 0; k < 6; ++k) err = fmax(err, fabs(M[6 * i + k] - M[6 * ref + k]) / scale);
    ++n;
  }
  ck_assert_int_gt(n, 0);
  prun_free(&c);
  return err;
}

START_TEST(test_shape_tensor_share)
{
  const char *tl = "method: tlpd, material: rock", *wk = "method: sph, material: water";
  const double pd = shape_share_err(tl, "pd_sph", ", pair_stress: both");
  const double pdf = shape_share_err(tl, "pd_sph", ", pair_stress: fluid");
  const double pdk = shape_share_err(tl, "pd_sph", ", pair_stress: both, gradient: kernel");
  const double pdo = shape_share_err(tl, "pd_sph", ""); /* owned: not extended */
  const double co = shape_share_err(wk, "continuum", "");
  const double cok = shape_share_err(wk, "continuum", ", gradient: kernel");
  fprintf(stderr,
          "shape tensor next to another set, max |M_inv - M_inv interior| / |M_inv| within 3.5 mm: pd_sph both %.3e, "
          "fluid %.3e, both with gradient: kernel %.3e, owned %.3e; continuum %.3e, with gradient: kernel %.3e\n",
          pd, pdf, pdk, pdo, co, cok);
  ck_assert_double_lt(pd, 1e-10);
  ck_assert_double_lt(pdf, 1e-10);
  ck_assert_double_lt(co, 1e-10);
  ck_assert_double_gt(pdk, 0.3);
  ck_assert_double_gt(pdo, 0.3);
  ck_assert_double_gt(cok, 0.3);
}
END_TEST

/* A coupling reads its partner's stress and sound speed at the partner's mirror images too
 * (2026-12-02: tlpd's stress and c and ulpd's stress were not ghosted, so next to a symmetry plane
 * the images carried sigma = 0 and c = 0). A layered 2D scene between two symmetry planes y = 0
 * and y = 20 mm, uniform in y: solid (or gas) x < 30 mm, water (or gas) beyond, one step; the
 * acceleration of the SPH column next to the interface must not depend on y. */
static const char scene_images[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1.0, cfl: 0.3, max_steps: 1}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1001, eos: {model: polynomial, rho0: 1000, C1: 1e8}}\n"
    "  gas: {rho0: 1.0, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  left: {%s, shape: {box: {min: [0, 0], max: [0.03, 0.02]}}, spacing: 0.001}\n"
    "  right: {method: sph, %s, renormalize: false, shape: {box: {min: [0.03, 0], max: [0.06, 0.02]}}, spacing: 0.001}\n"
    "interactions:\n  - {model: %s, sets: [right, left]%s}\n"
    "boundaries:\n  - symmetry: {point: [0, 0], normal: [0, 1]}\n  - symmetry: {point: [0, 0.02], normal: [0, -1]}\n";

/* (max - min) of a_x over the right set's first column, over |a_x| of one particle of it */
static double images_spread(const char *left, const char *right, const char *model, const char *extra)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_images, left, right, model, extra), EJ_OK);
  vrun_run(&c.r);
  ej_set *w = prun_set(&c, "right");
  const ej_real *x = ej_set_field(w, "x"), *a = ej_set_field(w, "a");
  double ax[64];
  int n = 0;
  for (ej_idx i = 0; i < w->n && n < 64; ++i) /* the column at x = 30.5 mm (one step moves it by < 1e-5 m) */
    if (x[3 * i] < 0.031) ax[n++] = a[3 * i];
  ck_assert_int_eq(n, 20);
  double lo = ax[0], hi = ax[0], mid = ax[n / 2]; /* ax in y order of the lattice */
  for (int k = 1; k < n; ++k) lo = fmin(lo, ax[k]), hi = fmax(hi, ax[k]);
  prun_free(&c);
  ck_assert(fabs(mid) > 0);
  return (hi - lo) / fabs(mid);
}

START_TEST(test_images_carry_stress)
{
  const char *rock = "method: tlpd, material: rock, initial_stress: {uniform: [-1e5, -1e5, -1e5, 0, 0, 0]}";
  const double both = images_spread(rock, "material: water", "pd_sph", ", pair_stress: both");
  const double owned = images_spread(rock, "material: water", "pd_sph", ", pair_weight: kernel");
  const double gas = images_spread("method: ulpd, material: gas, p: 1e5", "material: gas, p: 1e5", "continuum",
                                   ", alpha: 0, beta: 0");
  fprintf(stderr,
          "coupling next to symmetry planes, spread of a_x over the interface column / |a_x|: pd_sph both %.2e, "
          "owned (kernel weight) %.2e, continuum ulpd-sph gas %.2e\n",
          both, owned, gas);
  /* before the fix (tlpd stress and c, ulpd stress not ghosted): 27, 0.15 and 168 */
  ck_assert_double_lt(both, 1e-9);
  ck_assert_double_lt(owned, 1e-9);
  ck_assert_double_lt(gas, 1e-9);
}
END_TEST

static Suite *pd_sph_suite(void)
{
  Suite *s = suite_create("pd_sph");
  TCase *tc = tcase_create("coupling");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_pairwise_momentum);
  tcase_add_test(tc, test_decohesion);
  tcase_add_test(tc, test_decohesion_contact);
  tcase_add_test(tc, test_needs_one_solid);
  tcase_add_test(tc, test_uniform_stress_forces);
  tcase_add_test(tc, test_uniform_stress_at_rest);
  tcase_add_test(tc, test_continuity_dilatation);
  tcase_add_test(tc, test_renormalize_interfaces);
  tcase_add_test(tc, test_shape_tensor_share);
  tcase_add_test(tc, test_images_carry_stress);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(pd_sph_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
