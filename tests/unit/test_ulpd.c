/* ulpd method: the velocity gradient of a linear field is exact at interior particles in 1, 2
 * and 3 D; momentum (and total energy) are conserved to round-off by the semi-discrete
 * equations and over a few velocity-Verlet steps of a random gas blob; a uniform gas in a
 * periodic box stays at rest; the shape-tensor guard counts an isolated pair; density floor and
 * pressure cutoff; the strength-model path (elastic: stress increment, objectivity under a
 * rigid spin); the time step. */
#include "method_fix.h"
#include "validation_common.h"
#include "test_rng.h"
#include "ejecta/tensor.h"
#include "rate_sums.h"

const ej_plugin_info *ej_plugin_ulpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

/* ------------------------------------------------------------------ helpers */

typedef method_fix ufix;

static void set_real(ufix *f, const char *name, ej_real v)
{
  *(ej_real *)((char *)f->mcfg + find_param(f->mops->params, name)->offset) = v;
}

/* Registry, default configs, ideal gas (gamma 1.4) and optionally the elastic strength model,
 * an empty set of n particles with the method's fields. */
static void fix_open(ufix *f, int dim, ej_idx n, bool elastic)
{
  memset(f, 0, sizeof *f);
  f->dim = dim;
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_ulpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_ideal_gas_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_elastic_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_METHOD, "ulpd", NULL, &ops), EJ_OK);
  f->mops = ops;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_EOS, "ideal_gas", NULL, &ops), EJ_OK);
  f->eops = ops;
  f->mcfg = ej_calloc(1, f->mops->config_size);
  f->ecfg = ej_calloc(1, f->eops->config_size);
  ck_assert_int_eq(ej_params_defaults(f->mops->params, f->mcfg), EJ_OK);
  ck_assert_int_eq(ej_params_defaults(f->eops->params, f->ecfg), EJ_OK);
  ck_assert_int_eq(f->eops->create(f->ecfg, &f->estate), EJ_OK);
  f->eos = (struct ej_eos){.ops = f->eops, .state = f->estate};
  f->model = (struct ej_model){.name = "gas", .rho0 = 1.0, .eos = &f->eos, .mat = NULL};
  if (elastic) {
    ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_MATERIAL, "elastic", NULL, &ops), EJ_OK);
    f->matops = ops;
    f->matcfg = ej_calloc(1, f->matops->config_size);
    ck_assert_int_eq(ej_params_defaults(f->matops->params, f->matcfg), EJ_OK);
    *(ej_real *)((char *)f->matcfg + find_param(f->matops->params, "E")->offset) = 2.5e9;
    *(ej_real *)((char *)f->matcfg + find_param(f->matops->params, "nu")->offset) = 0.25;
    ck_assert_int_eq(f->matops->create(f->matcfg, &f->matstate), EJ_OK);
    f->mat = (struct ej_material){.ops = f->matops, .state = f->matstate};
    f->model = (struct ej_model){.name = "solid", .rho0 = 1000.0, .eos = NULL, .mat = &f->mat};
  }
  ck_assert_int_eq(ej_set_create(elastic ? "solid" : "gas", 0, dim, &f->set), EJ_OK);
  f->set->t = &f->t;
  f->set->dt = &f->dt;
  ck_assert_int_eq(ej_decl_probe(f->mops, f->mcfg, f->set), EJ_OK);
  ck_assert_int_eq(f->set->nbr_config, EJ_NBR_CURRENT);
  const char *want[] = {"rho", "rho_dot", "e", "e_dot", "p", "c", "delta", "h", "stress", "w_visc", "w_visc_dot"};
  for (size_t k = 0; k < sizeof want / sizeof want[0]; ++k)
    ck_assert_msg(ej_set_find_field(f->set, want[k]) >= 0, "field '%s' not declared", want[k]);
  ck_assert_int_eq(f->set->fields[ej_set_find_field(f->set, "e")].energy, EJ_ENERGY_INTERNAL);
  ck_assert_int_eq(f->set->fields[ej_set_find_field(f->set, "w_visc")].energy, EJ_ENERGY_VISCOUS);
  ck_assert_int_eq(f->set->fields[ej_set_find_field(f->set, "stress")].kind, EJ_SYM6);
  ck_assert_int_eq(ej_set_reserve(f->set, n), EJ_OK);
  f->set->n = n;
  f->set->n_ghost = 0;
  int32_t *id = ej_set_field_int(f->set, "id");
  for (ej_idx i = 0; i < n; ++i) id[i] = (int32_t)i;
  ck_assert_int_eq(ej_nbrlist_create(&f->list), EJ_OK);
}

/* side^dim particles on a lattice of spacing dx centred on 0, optional jitter (fraction of dx). */
static ej_idx lattice(ufix *f, int dim, int side, ej_real dx, ej_real rho, ej_real e, ej_real jitter, bool elastic,
                      uint64_t seed)
{
  ej_idx n = 1;
  for (int d = 0; d < dim; ++d) n *= side;
  fix_open(f, dim, n, elastic);
  ej_real *x = ej_set_field(f->set, "x"), *m = ej_set_field(f->set, "m"), *vol0 = ej_set_field(f->set, "vol0");
  ej_real *r = ej_set_field(f->set, "rho"), *ee = ej_set_field(f->set, "e");
  const ej_real vol = pow(dx, dim), half = 0.5 * (side - 1);
  for (ej_idx i = 0; i < n; ++i) {
    ej_idx k = i;
    for (int d = 0; d < 3; ++d) {
      x[3 * i + d] = d < dim ? ((ej_real)(k % side) - half + jitter * (rng_uniform(&seed) - 0.5)) * dx : 0.0;
      if (d < dim) k /= side;
    }
    vol0[i] = vol;
    m[i] = rho * vol;
    r[i] = rho;
    ee[i] = e;
  }
  return n;
}

/* ------------------------------------------------------------------ tests */

START_TEST(test_params_and_ops)
{
  ufix f;
  fix_open(&f, 3, 1, false);
  const char *names[] = {"horizon", "variable_horizon", "delta_min", "delta_max", "C_q", "C_l",
                         "c_hg", "rcond_min", "regularization", "rho_min", "p_min", "density"};
  for (int k = 0; k < 12; ++k) ck_assert_str_eq(f.mops->params[k].name, names[k]);
  ck_assert_ptr_null(f.mops->params[12].name);
  ck_assert(*(ej_real *)((char *)f.mcfg + find_param(f.mops->params, "horizon")->offset) == 3.0);
  ck_assert(*(ej_real *)((char *)f.mcfg + find_param(f.mops->params, "C_q")->offset) == 8.0); /* 002 Eq 42 */
  ck_assert(*(ej_real *)((char *)f.mcfg + find_param(f.mops->params, "C_l")->offset) == 0.1);
  ck_assert_int_eq(f.mops->n_passes, 3); /* [summation density], families, forces */
  ck_assert_ptr_nonnull(f.mops->pass_count);
  ck_assert_ptr_nonnull(f.mops->counters);
  ck_assert_ptr_nonnull(f.mops->report);
  const ej_plugin_info *info = ej_plugin_ulpd_info();
  ck_assert_str_eq(info->name, "ulpd");
  ck_assert_str_eq(info->build_signature, EJ_BUILD_SIGNATURE);
  mfix_close(&f);
}
END_TEST

/* v = A x + b on a jittered lattice: L_i = A (dim x dim block) to round-off at every particle
 * whose family lies inside the lattice, and drho/dt = -rho tr(A). */
static void check_linear(int dim, bool variable)
{
  const int side = dim == 3 ? 11 : dim == 2 ? 17 : 31;
  const ej_real dx = 0.01;
  ufix f;
  const ej_idx n = lattice(&f, dim, side, dx, 1.3, 2.0, 0.3, false, 99u + (uint64_t)dim);
  *(bool *)((char *)f.mcfg + find_param(f.mops->params, "variable_horizon")->offset) = variable;
  uint64_t seed = 4242u + (uint64_t)dim;
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v");
  ej_real A[9] = {0}, b[3], tr = 0;
  for (int r = 0; r < dim; ++r) {
    b[r] = rng_uniform(&seed) - 0.5;
    for (int c = 0; c < dim; ++c) A[3 * r + c] = 200.0 * (rng_uniform(&seed) - 0.5);
    tr += A[4 * r];
  }
  for (ej_idx i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      v[3 * i + r] = r < dim ? b[r] : 0.0;
      if (r < dim)
        for (int c = 0; c < dim; ++c) v[3 * i + r] += A[3 * r + c] * x[3 * i + c];
    }
  mfix_start(&f);
  mfix_compute(&f, 2);
  const ej_real *L = ej_set_field(f.set, "vel_grad"), *delta = ej_set_field(f.set, "delta");
  const ej_real *rho_dot = ej_set_field(f.set, "rho_dot"), *rho = ej_set_field(f.set, "rho");
  const ej_real *wdot = ej_set_field(f.set, "w_visc_dot"), *q = ej_set_field(f.set, "q");
  const int32_t *fl = ej_set_field_int(f.set, "ulpd_flags");
  const ej_real R = 0.5 * (side - 1) * dx, Anorm = ej_m3_norm(A);
  int checked = 0;
  const ej_real *h = ej_set_field(f.set, "h");
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert_int_eq(fl[i] & 1, 0); /* no fallback anywhere, surface included */
    /* the smoothing length published for kernel couplings is half the horizon */
    ck_assert_msg(h[i] == 0.5 * delta[i] && h[i] > 0.0, "h %g, delta %g", h[i], delta[i]);
    bool interior = true;
    for (int d = 0; d < dim; ++d) interior &= fabs(x[3 * i + d]) < R - delta[i] - 0.5 * dx;
    if (!interior) continue;
    for (int k = 0; k < 9; ++k)
      ck_assert_msg(fabs(L[9 * i + k] - A[k]) < 1e-12 * Anorm, "dim %d: L[%d] = %.17g, expected %.17g", dim, k,
                    L[9 * i + k], A[k]);
    ck_assert_msg(fabs(rho_dot[i] / rho[i] + tr) < 1e-12 * Anorm, "dim %d: rho_dot/rho %.17g, -tr A %.17g", dim,
                  rho_dot[i] / rho[i], -tr);
    /* The zero-energy-mode control does nothing to a linear field; only q dissipates. */
    const ej_real wq = -q[i] * tr / rho[i];
    ck_assert_msg(fabs(wdot[i] - wq) < 1e-9 * (fabs(wq) + Anorm * 1e-3), "dim %d: w_visc_dot %.17g, q work %.17g",
                  dim, wdot[i], wq);
    ++checked;
  }
  ck_assert_msg(checked >= (dim == 3 ? 8 : 20), "dim %d: only %d interior particles", dim, checked);
  mfix_close(&f);
}

START_TEST(test_linear_field)
{
  for (int dim = 1; dim <= 3; ++dim) {
    check_linear(dim, true);
    check_linear(dim, false);
  }
}
END_TEST

/* Random blob with random rho, e, v and masses: sum m a = 0 and sum m (v.a + e_dot) = 0 to
 * round-off for the right-hand side, then a few velocity-Verlet steps (neighbour list rebuilt
 * every step) keep the total momentum to round-off. */
static void check_conservation(int dim)
{
  const ej_idx n = dim == 3 ? 500 : dim == 2 ? 300 : 80;
  ufix f;
  fix_open(&f, dim, n, false);
  uint64_t seed = 2024u + (uint64_t)dim;
  mfix_random_gas(&f, dim, &seed);
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v"), *m = ej_set_field(f.set, "m");
  ej_real *rho = ej_set_field(f.set, "rho"), *e = ej_set_field(f.set, "e");
  mfix_start(&f);
  mfix_compute(&f, 2);
  const ej_real *a = ej_set_field(f.set, "a"), *edot = ej_set_field(f.set, "e_dot");
  const ej_real *wdot = ej_set_field(f.set, "w_visc_dot");
  const rate_sums rs = rate_sums_of(n, m, v, a, edot);
  const double *P = rs.P, Pabs = rs.Pabs, E = rs.E, Eabs = rs.Eabs;
  double W = 0;
  for (ej_idx i = 0; i < n; ++i) W += m[i] * wdot[i];
  ck_assert(Pabs > 0 && Eabs > 0);
  for (int d = 0; d < 3; ++d)
    ck_assert_msg(fabs(P[d]) < 1e-13 * Pabs, "dim %d: momentum rate %g (scale %g)", dim, P[d], Pabs);
  ck_assert_msg(fabs(E) < 1e-12 * Eabs, "dim %d: energy rate %g (scale %g)", dim, E, Eabs);
  ck_assert_msg(W > 0.0, "dim %d: viscous dissipation %g", dim, W);

  /* A few steps of velocity Verlet, as the core integrates (rates by the same trapezoid). */
  double P0[3] = {0, 0, 0};
  for (ej_idx i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) P0[d] += m[i] * v[3 * i + d];
  const ej_real dt = 2e-4;
  for (int step = 0; step < 5; ++step) {
    ej_real *re = ej_set_field(f.set, "rho_dot"), *ed = ej_set_field(f.set, "e_dot");
    for (ej_idx i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) {
        v[3 * i + d] += 0.5 * dt * a[3 * i + d];
        x[3 * i + d] += dt * v[3 * i + d];
      }
      rho[i] += dt * re[i];
      e[i] += dt * ed[i];
    }
    mfix_list(&f);
    mfix_compute(&f, 2);
    for (ej_idx i = 0; i < n; ++i)
      for (int d = 0; d < 3; ++d) v[3 * i + d] += 0.5 * dt * a[3 * i + d];
  }
  double P1[3] = {0, 0, 0}, Pscale = 0;
  for (ej_idx i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) P1[d] += m[i] * v[3 * i + d], Pscale += fabs(m[i] * v[3 * i + d]);
  for (int d = 0; d < 3; ++d)
    ck_assert_msg(fabs(P1[d] - P0[d]) < 1e-13 * Pscale, "dim %d: momentum %.17g -> %.17g", dim, P0[d], P1[d]);
  mfix_close(&f);
}

START_TEST(test_conservation)
{
  for (int dim = 1; dim <= 3; ++dim) check_conservation(dim);
}
END_TEST

/* Two particles alone in 3D: rank-1 shape tensors, both regularised and counted; the pair
 * repels, equal and opposite, along the bond. */
START_TEST(test_isolated_pair)
{
  ufix f;
  fix_open(&f, 3, 2, false);
  ej_real *x = ej_set_field(f.set, "x"), *m = ej_set_field(f.set, "m"), *vol0 = ej_set_field(f.set, "vol0");
  ej_real *rho = ej_set_field(f.set, "rho"), *e = ej_set_field(f.set, "e");
  for (int i = 0; i < 2; ++i) {
    x[3 * i] = 0.1 * i, x[3 * i + 1] = 0.05 * i, x[3 * i + 2] = 0;
    vol0[i] = 1e-3, rho[i] = 1.0, m[i] = 1e-3, e[i] = 2.5;
  }
  mfix_start(&f);
  mfix_compute(&f, 2);
  const ej_real *a = ej_set_field(f.set, "a");
  const int32_t *fb = ej_set_field_int(f.set, "shape_fallbacks");
  ck_assert_int_eq(fb[0], 1);
  ck_assert_int_eq(fb[1], 1);
  for (int d = 0; d < 3; ++d) {
    ck_assert(isfinite(a[d]) && isfinite(a[3 + d]));
    ck_assert_double_eq_tol(m[0] * a[d] + m[1] * a[3 + d], 0.0, 1e-14 * fabs(a[0]));
  }
  ck_assert(a[0] < 0 && a[1] < 0 && a[3] > 0 && a[4] > 0); /* apart */
  ck_assert_double_eq_tol(a[1] / a[0], 0.5, 1e-12);         /* along the bond */
  ej_counter c[4];
  int nc = 0;
  ck_assert_int_eq(f.mops->counters(f.mstate, c, 4, &nc), EJ_OK);
  ck_assert_int_ge(nc, 1);
  ck_assert_int_eq(c[0].value, 2);
  ej_series_value sv[EJ_MAX_SERIES];
  int ns = 0;
  ck_assert_int_eq(f.mops->report(f.mstate, f.set, sv, EJ_MAX_SERIES, &ns), EJ_OK);
  ck_assert_int_eq(ns, 4);
  ck_assert_str_eq(sv[0].name, "shape_fallbacks");
  ck_assert_double_eq(sv[0].value, 2.0);
  /* A particle with no bond at all: no force, counted, no NaN. */
  x[3] = 10.0;
  mfix_list(&f);
  mfix_compute(&f, 2);
  ck_assert(a[0] == 0.0 && a[3] == 0.0);
  ck_assert_int_eq(fb[0], 2);
  mfix_close(&f);
}
END_TEST

/* Density floor and pressure cutoff: no NaN, no negative density, both flagged. */
START_TEST(test_floors)
{
  ufix f;
  lattice(&f, 2, 7, 0.1, 2.0, 1.0, 0.0, false, 1u);
  set_real(&f, "rho_min", 1e-3);
  mfix_start(&f);
  ej_real *rho = ej_set_field(f.set, "rho"), *e = ej_set_field(f.set, "e");
  rho[3] = 0.0;
  rho[4] = -1e-9;
  e[10] = -5.0; /* overshoot of an expansion: ideal-gas p < 0 */
  mfix_compute(&f, 2);
  ck_assert_double_eq_tol(rho[3], 2e-3, 1e-15);
  ck_assert_double_eq_tol(rho[4], 2e-3, 1e-15);
  const ej_real *p = ej_set_field(f.set, "p"), *a = ej_set_field(f.set, "a");
  const int32_t *fl = ej_set_field_int(f.set, "ulpd_flags");
  ck_assert(p[10] == 0.0);
  ck_assert(fl[3] & 2);
  ck_assert(fl[10] & 4);
  for (ej_idx i = 0; i < 49; ++i) ck_assert(isfinite(a[3 * i]) && isfinite(a[3 * i + 1]) && isfinite(p[i]));
  /* Without a floor a non-positive density is a numeric error naming the particle. */
  set_real(&f, "rho_min", 0.0);
  f.mops->destroy(f.mstate);
  ck_assert_int_eq(f.mops->create(f.mcfg, f.set, &f.model, &f.mstate), EJ_OK);
  rho[7] = -1.0;
  ck_assert_int_eq(f.mops->compute(f.mstate, f.set, &f.list->pub, 0, (ej_range){0, 49}), EJ_ERR_NUMERIC);
  ck_assert_ptr_nonnull(strstr(ej_error_cause()->msg, "id 7"));
  ej_error_clear();
  mfix_close(&f);
}
END_TEST

/* Strength model (elastic, hypoelastic): a linear velocity field gives the stress increment
 * dt (lambda tr D I + 2 mu D) at interior particles; a rigid spin of a pre-stressed body
 * rotates the stress (Hughes-Winget) and keeps its invariants, with no stress power. */
START_TEST(test_elastic)
{
  const ej_real dx = 0.01, E = 2.5e9, nu = 0.25;
  const ej_real mu = E / (2 * (1 + nu)), lam = E * nu / ((1 + nu) * (1 - 2 * nu));
  ufix f;
  const ej_idx n = lattice(&f, 3, 11, dx, 1000.0, 0.0, 0.2, true, 5u);
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v"), *sg = ej_set_field(f.set, "stress");
  const ej_real A[9] = {1.0, 0.3, -0.2, 0.1, -0.5, 0.4, 0.0, 0.2, 0.7};
  for (ej_idx i = 0; i < n; ++i) ej_m3_apply(v + 3 * i, A, x + 3 * i);
  mfix_start(&f);
  f.dt = 1e-6;
  mfix_compute(&f, 2);
  const ej_real *delta = ej_set_field(f.set, "delta"), *c = ej_set_field(f.set, "c");
  const ej_real R = 0.5 * 10 * dx;
  ej_real D[6];
  ej_m3_sym(D, A);
  const ej_real trD = D[0] + D[1] + D[2];
  int checked = 0;
  for (ej_idx i = 0; i < n; ++i) {
    bool interior = true;
    for (int d = 0; d < 3; ++d) interior &= fabs(x[3 * i + d]) < R - delta[i] - 0.5 * dx;
    if (!interior) continue;
    for (int k = 0; k < 6; ++k) {
      const ej_real want = f.dt * ((k < 3 ? lam * trD : 0.0) + 2 * mu * D[k]);
      ck_assert_msg(fabs(sg[6 * i + k] - want) < 1e-9 * mu * f.dt, "stress[%d] = %g, expected %g", k, sg[6 * i + k],
                    want);
    }
    ck_assert_double_eq_tol(c[i], sqrt((lam + 2 * mu) / 1000.0), 1e-9);
    ++checked;
  }
  ck_assert_int_gt(checked, 0);

  /* Rigid spin about z with a pre-stress: d = 0, stress rotated by exactly the HW rotation. */
  const ej_real om = 50.0;
  const ej_real Wm[9] = {0, -om, 0, om, 0, 0, 0, 0, 0};
  for (ej_idx i = 0; i < n; ++i) {
    ej_m3_apply(v + 3 * i, Wm, x + 3 * i);
    const ej_real s0[6] = {-1e6, 2e5, 3e5, 4e5, 0, -1e5};
    memcpy(sg + 6 * i, s0, sizeof s0);
  }
  f.dt = 1e-4;
  mfix_compute(&f, 2);
  const ej_real *edot = ej_set_field(f.set, "e_dot");
  ej_real Q[9], want[6];
  ck_assert(ej_hughes_winget(Q, Wm, f.dt));
  const ej_real s0[6] = {-1e6, 2e5, 3e5, 4e5, 0, -1e5};
  ej_s6_rotate(want, Q, s0);
  checked = 0;
  for (ej_idx i = 0; i < n; ++i) {
    bool interior = true;
    for (int d = 0; d < 3; ++d) interior &= fabs(x[3 * i + d]) < R - delta[i] - 0.5 * dx;
    if (!interior) continue;
    for (int k = 0; k < 6; ++k) ck_assert_msg(fabs(sg[6 * i + k] - want[k]) < 1e-6, "spin: stress[%d] %.10g vs %.10g", k, sg[6 * i + k], want[k]);
    ck_assert_double_eq_tol(ej_s6_sqrt_j2(sg + 6 * i), ej_s6_sqrt_j2(s0), 1e-6);
    ck_assert_msg(fabs(edot[i]) < 1e-6, "spin: e_dot %g", edot[i]);
    ++checked;
  }
  ck_assert_int_gt(checked, 0);
  mfix_close(&f);
}
END_TEST

START_TEST(test_needs_model)
{
  ufix f;
  fix_open(&f, 3, 4, false);
  f.model.eos = NULL;
  void *st = NULL;
  ck_assert_int_eq(f.mops->create(f.mcfg, f.set, &f.model, &st), EJ_ERR_UNSUPPORTED);
  ck_assert_ptr_null(st);
  ck_assert_ptr_nonnull(strstr(ej_error_cause()->msg, "ulpd needs an equation of state"));
  ej_error_clear();
  mfix_close(&f);
}
END_TEST

/* Time step of a lattice particle at rest: spacing / (c (1 + C_l)). */
START_TEST(test_stable_dt)
{
  ufix f;
  const ej_idx n = lattice(&f, 3, 7, 0.02, 1.2, 2.0e5, 0.0, false, 3u);
  mfix_start(&f);
  mfix_compute(&f, 2);
  const ej_real *c = ej_set_field(f.set, "c");
  const ej_idx centre = n / 2;
  ej_real dt;
  ck_assert_int_eq(f.mops->stable_dt(f.mstate, f.set, (ej_range){centre, centre + 1}, &dt), EJ_OK);
  ck_assert_double_eq_tol(dt, 0.02 / (c[centre] * 1.1), 1e-12 * dt);
  ck_assert_double_eq_tol(c[centre], sqrt(1.4 * 0.4 * 2.0e5), 1e-9);
  mfix_close(&f);
}
END_TEST

/* ------------------------------------------------------------------ scene level */

static void urun_open(vrun *r, const char *scene_path, const ej_run_opts *opts)
{
  memset(r, 0, sizeof *r);
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_ulpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_ideal_gas_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene_path, r->reg, &r->scene);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  rc = ej_sim_create(r->scene, r->reg, opts, &r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

/* Scene of a uniform gas (1.2 kg/m^3, 1e5 Pa) filling a 0.1 m box periodic in x, y and z with
 * spacing 0.01; `extra` adds lines to the set (e.g. the density option). */
static void periodic_box_scene(const char *path, const char *output, const char *extra)
{
  char text[1024];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 3\ntime: {end: 0.05, cfl: 0.3}\n"
           "output: {file: %s, fields: [v, rho, p]}\n"
           "materials:\n  gas: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "sets:\n  gas:\n    method: ulpd\n    material: gas\n%s"
           "    shape: {box: {min: [0, 0, 0], max: [0.1, 0.1, 0.1]}}\n    spacing: 0.01\n"
           "    rho: 1.2\n    p: 1.0e5\n"
           "boundaries:\n  - periodic: {axis: x, min: 0, max: 0.1}\n"
           "  - periodic: {axis: y, min: 0, max: 0.1}\n  - periodic: {axis: z, min: 0, max: 0.1}\n",
           output, extra);
  vrun_write(path, text);
}

/* A uniform gas filling a box periodic in x, y and z (every family complete, through the ghost
 * images) stays exactly at rest: no spurious motion, density and energy unchanged. */
START_TEST(test_uniform_periodic)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "ulpd_uniform");
  snprintf(scene, sizeof scene, "%s/box.yaml", dir);
  snprintf(out, sizeof out, "%s/box.h5", dir);
  periodic_box_scene(scene, "box.h5", "");
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  vrun r;
  urun_open(&r, scene, &opts);
  r.scene->max_steps = 40;
  vrun_run(&r);
  ck_assert_int_eq(r.sim->step, 40);
  const ej_set *s = r.sim->sets[0];
  const ej_real *v = ej_set_field(s, "v"), *rho = ej_set_field(s, "rho"), *p = ej_set_field(s, "p");
  const ej_real c = sqrt(1.4 * 1.0e5 / 1.2);
  ck_assert_int_eq(ej_set_count(s), 1000);
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int d = 0; d < 3; ++d) ck_assert_msg(fabs(v[3 * i + d]) < 1e-10 * c, "v = %g", v[3 * i + d]);
    ck_assert_double_eq_tol(rho[i], 1.2, 1e-12);
    ck_assert_double_eq_tol(p[i], 1.0e5, 1e-12 * 1.0e5);
  }
  vrun_free(&r);
  const char *names[] = {"box.yaml", "box.h5", "box.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

/* M4 cubic spline of support 2h (the test's own copy, Monaghan & Lattanzio 1985). */
static double m4(int dim, double r, double h)
{
  const double q = r / h, pi = 3.14159265358979323846;
  const double sigma = dim == 1 ? 2.0 / 3.0 : dim == 2 ? 10.0 / (7.0 * pi) : 1.0 / pi;
  const double f = q < 1.0 ? 1.0 - 1.5 * q * q + 0.75 * q * q * q : q < 2.0 ? 0.25 * pow(2.0 - q, 3) : 0.0;
  return sigma * f / pow(h, dim);
}

/* density: summation. rho is no longer an integrated field (no rho_dot); after a step on a
 * jittered periodic 1D gas, rho_i is exactly sum_j m_j W(r_ij, delta_i / 2) over the images
 * (recomputed here independently), and a uniform periodic 3D lattice stays at rest with a
 * uniform rho within 0.3 % of the lattice density (M4 at h = 1.5 spacings sums to +0.18 %). */
START_TEST(test_summation_density)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "ulpd_summation");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/s.h5", dir);
  vrun_write(scene, "ejecta: 1\ndimension: 1\ntime: {end: 1.0e-3, cfl: 0.3}\n"
                    "output: {file: s.h5, fields: [v, rho, p]}\n"
                    "materials:\n  gas: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n  gas:\n    method: ulpd\n    material: gas\n    density: summation\n"
                    "    shape: {box: {min: [0], max: [1]}}\n    spacing: 0.02\n    jitter: 0.3\n    seed: 3\n"
                    "    rho: 1.2\n    p: 1.0e5\n"
                    "boundaries:\n  - periodic: {axis: x, min: 0, max: 1}\n");
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  vrun r;
  urun_open(&r, scene, &opts);
  r.scene->max_steps = 3;
  vrun_run(&r);
  const ej_set *s = r.sim->sets[0];
  ck_assert_int_lt(ej_set_find_field(s, "rho_dot"), 0);
  const ej_idx n = ej_set_count(s);
  ck_assert_int_eq(n, 50);
  const ej_real *x = ej_set_field(s, "x"), *m = ej_set_field(s, "m"), *rho = ej_set_field(s, "rho");
  const ej_real *delta = ej_set_field(s, "delta");
  double dev = 0.0;
  for (ej_idx i = 0; i < n; ++i) {
    double sum = 0.0;
    for (ej_idx j = 0; j < n; ++j) {
      double d = fabs(x[3 * j] - x[3 * i]);
      d = fmin(d, 1.0 - d);
      sum += m[j] * m4(1, d, 0.5 * delta[i]);
    }
    ck_assert_msg(fabs(rho[i] - sum) < 1e-12 * sum, "particle %d: rho %.15g, sum %.15g", (int)i, rho[i], sum);
    dev = fmax(dev, fabs(rho[i] / 1.2 - 1.0));
  }
  ck_assert_msg(dev > 1e-3, "the jittered cloud must show a density variation (%g)", dev);
  vrun_free(&r);
  periodic_box_scene(scene, "s.h5", "    density: summation\n");
  urun_open(&r, scene, &opts);
  r.scene->max_steps = 20;
  vrun_run(&r);
  s = r.sim->sets[0];
  const ej_real *v = ej_set_field(s, "v");
  rho = ej_set_field(s, "rho");
  const ej_real c = sqrt(1.4 * 1.0e5 / 1.2);
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int d = 0; d < 3; ++d) ck_assert_msg(fabs(v[3 * i + d]) < 1e-10 * c, "v = %g", v[3 * i + d]);
    ck_assert_double_eq_tol(rho[i], rho[0], 1e-12);
  }
  ck_assert_double_eq_tol(rho[0], 1.2, 3.6e-3);
  vrun_free(&r);
  const char *names[] = {"s.yaml", "s.h5", "s.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

/* The zero-energy-mode bond viscosity across a velocity jump (ulpd README, limitations): a
 * stress-free elastic 3D block, periodic in x and y, whose upper half moves at +dv/2 and lower half
 * at -dv/2 along x. After one tiny step the x force on the upper half from `c_hg` (run with c_hg 0.1
 * minus run with 0; the viscous pressure off in both) is a traction k c_hg rho c dv on the plane
 * z = 0 with k independent of the spacing: the non-affine part of the relative velocity is largest
 * across a shear jump, so the drag does not fade under refinement (the same test as sph's viscosity
 * and rkpm's stabilisation). Returns k. */
static double chg_traction_k(double spacing)
{
  double fx[2] = {0, 0}, c0 = 0;
  const double dv = 1e-3, dt = 1e-6, chg = 0.1;
  for (int run = 0; run < 2; ++run) {
    const ej_plugin_info *pl[] = {ej_plugin_ulpd_info(), ej_plugin_elastic_info()};
    fx[run] = shear_jump_run(
        "ulpdvisc", pl, 2, dv, dt, &c0,
        "ejecta: 1\ndimension: 3\ntime: {end: 1, dt: %g, max_steps: 1}\n"
        "output: {file: st.h5, every: 1, fields: [v]}\n"
        "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n"
        "sets:\n  block:\n    method: ulpd\n    material: m\n    c_hg: %g\n    C_q: 0\n    C_l: 0\n"
        "    shape: {box: {min: [0, 0, -1], max: [1, 1, 1]}}\n    spacing: %.17g\n"
        "    velocity: [%g, 0, 0]\n    initial:\n"
        "      - {region: {half_space: {point: [0, 0, 0], normal: [0, 0, -1]}}, velocity: [%g, 0, 0]}\n"
        "boundaries:\n  - periodic: {axis: x, min: 0, max: 1}\n  - periodic: {axis: y, min: 0, max: 1}\n",
        dt, run ? chg : 0.0, spacing, -0.5 * dv, 0.5 * dv);
  }
  const double k = -(fx[1] - fx[0]) / (chg * c0 * dv); /* face 1 x 1, rho = 1 */
  fprintf(stderr, "ulpd c_hg across a velocity jump, spacing %g: force without %.3e, with %.3e, k = %.4f\n", spacing,
          fx[0], fx[1], k);
  ck_assert_msg(fabs(fx[0]) < 1e-3 * fabs(fx[1]), "without c_hg the jump is not stress-free: %g vs %g", fx[0], fx[1]);
  return k;
}

START_TEST(test_chg_shear_traction)
{
  const double k8 = chg_traction_k(0.125), k16 = chg_traction_k(0.0625);
  ck_assert_msg(k8 > 0.0 && k16 > 0.0, "no drag across the jump: k = %g, %g", k8, k16);
  ck_assert_msg(fabs(k16 / k8 - 1) < 0.03, "k depends on the spacing: %g vs %g", k8, k16);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("ulpd");
  TCase *tm = tcase_create("method");
  tcase_set_timeout(tm, 60);
  tcase_add_test(tm, test_params_and_ops);
  tcase_add_test(tm, test_linear_field);
  tcase_add_test(tm, test_conservation);
  tcase_add_test(tm, test_isolated_pair);
  tcase_add_test(tm, test_floors);
  tcase_add_test(tm, test_elastic);
  tcase_add_test(tm, test_needs_model);
  tcase_add_test(tm, test_stable_dt);
  tcase_add_test(tm, test_uniform_periodic);
  tcase_add_test(tm, test_summation_density);
  tcase_add_test(tm, test_chg_shear_traction);
  suite_add_tcase(s, tm);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
