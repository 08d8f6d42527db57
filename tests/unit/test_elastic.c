/* elastic strength model: closed-form uniaxial-strain and pure-shear paths (hypoelastic and
 * neo-Hookean), objectivity under a rigid rotation of a loaded point with the Hughes-Winget
 * update of tensor.h, the Hughes-Winget rotation itself, moduli and sound speed. */
#include <check.h>
#include <math.h>
#include <stdlib.h>

#include "core_impl.h"
#include "ejecta/tensor.h"

const ej_plugin_info *ej_plugin_elastic_info(void);

typedef struct mat_fix {
  ej_registry *reg;
  const ej_material_ops *ops;
  void *config;
  void *state;
} mat_fix;

static const ej_param *find_param(const ej_param *t, const char *name)
{
  for (; t->name; ++t)
    if (!strcmp(t->name, name)) return t;
  return NULL;
}

static void mat_open(mat_fix *f, double E, double nu, int formulation)
{
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_elastic_info()), EJ_OK);
  const void *ops = NULL;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_MATERIAL, "elastic", NULL, &ops), EJ_OK);
  f->ops = ops;
  f->config = ej_calloc(1, f->ops->config_size);
  ck_assert_ptr_nonnull(f->config);
  ck_assert_int_eq(ej_params_defaults(f->ops->params, f->config), EJ_OK);
  *(ej_real *)((char *)f->config + find_param(f->ops->params, "E")->offset) = E;
  *(ej_real *)((char *)f->config + find_param(f->ops->params, "nu")->offset) = nu;
  *(int *)((char *)f->config + find_param(f->ops->params, "formulation")->offset) = formulation;
  ck_assert_int_eq(f->ops->create(f->config, &f->state), EJ_OK);
}

static void mat_close(mat_fix *f)
{
  f->ops->destroy(f->state);
  ej_free(f->config);
  ej_registry_destroy(f->reg);
}

/* One point, one call. */
static void mat_step(mat_fix *f, ej_real dt, const ej_real d[6], const ej_real *F, ej_real sig[6], ej_real *c)
{
  ej_real rho = 2000, e = 0, wp = -1;
  int32_t failed = 0;
  ej_mat_batch b = {.n = 1, .dt = dt, .rho = &rho, .e = &e, .d = d, .F = F, .stress = sig, .c = c,
                    .w_plastic = &wp, .failed = &failed};
  ck_assert_int_eq(f->ops->update(f->state, &b), EJ_OK);
  ck_assert(wp == 0);
  ck_assert_int_eq(failed, 0);
}

static const double E0 = 98.5e6, NU0 = 0.25;

START_TEST(test_params_moduli_sound_speed)
{
  mat_fix f;
  mat_open(&f, E0, NU0, 0);
  const ej_param *E = find_param(f.ops->params, "E"), *nu = find_param(f.ops->params, "nu");
  ck_assert(E && (E->flags & EJ_PF_REQUIRED) && !strcmp(E->unit, "Pa"));
  ck_assert(nu && nu->min == -1 && nu->max == 0.5 && (nu->flags & EJ_PF_MAX_OPEN));
  ej_real K, G;
  ck_assert_int_eq(f.ops->moduli(f.state, &K, &G), EJ_OK);
  /* 000 Table 2 soil: lambda = mu = 39.4 MPa, K = 65.67 MPa, lambda + 2 mu = 118.2 MPa */
  ck_assert_double_eq_tol(G, 39.4e6, 1e-9 * G);
  ck_assert_double_eq_tol(K, 98.5e6 / 1.5, 1e-9 * K);
  const ej_real d[6] = {0};
  ej_real sig[6] = {0}, c = 0;
  mat_step(&f, 1e-6, d, NULL, sig, &c);
  ck_assert_double_eq_tol(c, sqrt(118.2e6 / 2000), 1e-9 * c);
  mat_close(&f);
  /* bad input through create */
  mat_fix g;
  ck_assert_int_eq(ej_registry_create(&g.reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(g.reg, ej_plugin_elastic_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(g.reg, EJ_KIND_MATERIAL, "elastic", NULL, &ops), EJ_OK);
  g.ops = ops;
  g.config = ej_calloc(1, g.ops->config_size);
  ck_assert_int_eq(ej_params_defaults(g.ops->params, g.config), EJ_OK);
  void *st = NULL;
  ck_assert_int_eq(g.ops->create(g.config, &st), EJ_ERR_ARG); /* E = 0 */
  ck_assert_ptr_null(st);
  ej_error_clear();
  ej_free(g.config);
  ej_registry_destroy(g.reg);
}
END_TEST

/* Uniaxial strain eps along x: sigma_xx = (lambda + 2 mu) eps, sigma_yy = sigma_zz = lambda eps. */
START_TEST(test_uniaxial_strain)
{
  const double lam = NU0 * E0 / ((1 + NU0) * (1 - 2 * NU0)), mu = E0 / (2 * (1 + NU0));
  mat_fix f;
  mat_open(&f, E0, NU0, 0);
  ej_real sig[6] = {0}, c;
  const int n = 1000;
  const double eps = -1e-3, dt = 1e-5;
  const ej_real d[6] = {eps / (n * dt), 0, 0, 0, 0, 0};
  for (int k = 0; k < n; ++k) mat_step(&f, dt, d, NULL, sig, &c);
  ck_assert_double_eq_tol(sig[0], (lam + 2 * mu) * eps, 1e-10 * fabs(lam * eps));
  ck_assert_double_eq_tol(sig[1], lam * eps, 1e-10 * fabs(lam * eps));
  ck_assert_double_eq_tol(sig[2], lam * eps, 1e-10 * fabs(lam * eps));
  for (int k = 3; k < 6; ++k) ck_assert(sig[k] == 0);
  mat_close(&f);

  /* neo-Hookean, F = diag(1 + eps, 1, 1): J = 1 + eps, b_xx = J^2 */
  mat_open(&f, E0, NU0, 1);
  for (int s = 0; s < 3; ++s) {
    const double e2 = s == 0 ? -1e-6 : s == 1 ? 0.2 : -0.3;
    const ej_real F[9] = {1 + e2, 0, 0, 0, 1, 0, 0, 0, 1};
    ej_real sn[6] = {7, 7, 7, 7, 7, 7};
    mat_step(&f, 1e-6, (const ej_real[6]){0}, F, sn, &c);
    const double J = 1 + e2;
    const double sxx = mu / J * (J * J - 1) + lam * log(J) / J, syy = lam * log(J) / J;
    ck_assert_double_eq_tol(sn[0], sxx, 1e-12 * fabs(sxx));
    ck_assert_double_eq_tol(sn[1], syy, 1e-12 * fabs(syy));
    ck_assert_double_eq_tol(sn[2], syy, 1e-12 * fabs(syy));
    for (int k = 3; k < 6; ++k) ck_assert(sn[k] == 0);
    if (s == 0) /* small strain: the linear law */
      ck_assert_double_eq_tol(sn[0], (lam + 2 * mu) * e2, 1e-5 * fabs((lam + 2 * mu) * e2));
  }
  mat_close(&f);
}
END_TEST

/* Pure (simple) shear gamma: sigma_xy = mu gamma; neo-Hookean adds sigma_xx = mu gamma^2. */
START_TEST(test_pure_shear)
{
  const double mu = E0 / (2 * (1 + NU0));
  mat_fix f;
  mat_open(&f, E0, NU0, 0);
  ej_real sig[6] = {0}, c;
  const double gam = 2e-3, dt = 1e-5;
  const int n = 400;
  const ej_real d[6] = {0, 0, 0, 0.5 * gam / (n * dt), 0, 0}; /* d_xy = gamma_dot / 2 */
  for (int k = 0; k < n; ++k) mat_step(&f, dt, d, NULL, sig, &c);
  ck_assert_double_eq_tol(sig[3], mu * gam, 1e-10 * mu * gam);
  for (int k = 0; k < 6; ++k)
    if (k != 3) ck_assert(sig[k] == 0);
  /* mean stress zero: pressure unaffected by shear */
  ck_assert(ej_s6_trace(sig) == 0);
  mat_close(&f);

  mat_open(&f, E0, NU0, 1);
  const double g2 = 0.3;
  const ej_real F[9] = {1, g2, 0, 0, 1, 0, 0, 0, 1};
  ej_real sn[6] = {0};
  mat_step(&f, 1e-6, (const ej_real[6]){0}, F, sn, &c);
  ck_assert_double_eq_tol(sn[3], mu * g2, 1e-12 * mu);
  ck_assert_double_eq_tol(sn[0], mu * g2 * g2, 1e-12 * mu);
  ck_assert_double_eq_tol(sn[1], 0, 1e-12 * mu);
  ck_assert_double_eq_tol(sn[2], 0, 1e-12 * mu);
  mat_close(&f);
}
END_TEST

/* Hughes-Winget (tensor.h): Cayley transform of dt w; orthogonal, det 1, rotation angle
 * 2 atan(omega dt / 2) about the axis of w. */
START_TEST(test_hughes_winget)
{
  const double axis[3] = {1 / sqrt(14.0), 2 / sqrt(14.0), 3 / sqrt(14.0)};
  const double om = 1000, dt = 1e-4;
  /* w = omega [axis]x : w v = omega axis x v */
  const ej_real w[9] = {0, -om * axis[2], om * axis[1], om * axis[2], 0, -om * axis[0], -om * axis[1], om * axis[0], 0};
  ej_real Q[9], QtQ[9];
  ck_assert_int_eq(ej_hughes_winget(Q, w, dt), 1);
  ej_m3_mul_at(QtQ, Q, Q);
  for (int k = 0; k < 9; ++k) ck_assert_double_eq_tol(QtQ[k], (k % 4 == 0) ? 1.0 : 0.0, 1e-15);
  ck_assert_double_eq_tol(ej_m3_det(Q), 1.0, 1e-15);
  /* axis is fixed, the angle is 2 atan(om dt / 2) */
  ej_real qa[3];
  ej_m3_apply(qa, Q, axis);
  for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(qa[k], axis[k], 1e-15);
  const double th = 2 * atan(0.5 * om * dt);
  ck_assert_double_eq_tol((ej_m3_trace(Q) - 1) / 2, cos(th), 1e-15);
  /* sense: rotating e_perp moves it along axis x e_perp (positive spin) */
  const double ep[3] = {2 / sqrt(5.0), -1 / sqrt(5.0), 0}; /* perpendicular to axis */
  const double cr[3] = {axis[1] * ep[2] - axis[2] * ep[1], axis[2] * ep[0] - axis[0] * ep[2], axis[0] * ep[1] - axis[1] * ep[0]};
  ej_real qe[3];
  ej_m3_apply(qe, Q, ep);
  for (int k = 0; k < 3; ++k) ck_assert_double_eq_tol(qe[k], cos(th) * ep[k] + sin(th) * cr[k], 1e-14);
  /* zero spin: identity */
  ej_real Z[9] = {0}, Q0[9];
  ck_assert_int_eq(ej_hughes_winget(Q0, Z, dt), 1);
  for (int k = 0; k < 9; ++k) ck_assert(Q0[k] == ((k % 4 == 0) ? 1.0 : 0.0));
}
END_TEST

/* Objectivity: a point loaded in uniaxial strain, then spun rigidly (L = W, d = 0) with the
 * stress rotated each step as Q sigma Q^T (Hughes-Winget, 000 Eq 93 with the transpose
 * erratum) and the material called with d = 0. The stress must equal R sigma0 R^T, R the
 * accumulated rotation, and keep its invariants; the rotated-back stress R^T sigma R is
 * unchanged. The printed form Q^T sigma Q rotates it backwards (checked to differ). */
START_TEST(test_objectivity)
{
  mat_fix f;
  mat_open(&f, E0, NU0, 0);
  ej_real sig[6] = {0}, c;
  const ej_real dload[6] = {-1.0, 0.2, 0, 0.3, 0, 0};
  mat_step(&f, 1e-3, dload, NULL, sig, &c);
  ej_real sig0[6];
  for (int k = 0; k < 6; ++k) sig0[k] = sig[k];
  const double om = 1000, dt = 1e-5;
  const int n = 79; /* about pi/4 (omega dt = 0.01): +-pi/2 would give the same tensor */
  const ej_real w[9] = {0, -om, 0, om, 0, 0, 0, 0, 0}; /* spin about z */
  ej_real Q[9], R[9], T[9];
  ej_m3_identity(R);
  ck_assert_int_eq(ej_hughes_winget(Q, w, dt), 1);
  ej_real sig_wrong[6];
  for (int k = 0; k < 6; ++k) sig_wrong[k] = sig[k];
  ej_real Qt[9];
  ej_m3_transpose(Qt, Q);
  const ej_real dzero[6] = {0};
  for (int s = 0; s < n; ++s) {
    ej_s6_rotate(sig, Q, sig);
    mat_step(&f, dt, dzero, NULL, sig, &c);
    ej_s6_rotate(sig_wrong, Qt, sig_wrong);
    ej_m3_mul(T, Q, R);
    ej_m3_copy(R, T);
  }
  ej_real expect[6], back[6], Rt[9];
  ej_s6_rotate(expect, R, sig0);
  const double scale = fabs(sig0[0]);
  for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(sig[k], expect[k], 1e-11 * scale);
  ej_m3_transpose(Rt, R);
  ej_s6_rotate(back, Rt, sig);
  for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(back[k], sig0[k], 1e-11 * scale);
  /* invariants */
  ck_assert_double_eq_tol(ej_s6_trace(sig), ej_s6_trace(sig0), 1e-11 * scale);
  ck_assert_double_eq_tol(ej_s6_sqrt_j2(sig), ej_s6_sqrt_j2(sig0), 1e-11 * scale);
  /* the material axis (x) has turned by the HW angle: sigma_yy now carries sigma0_xx */
  const double th = n * 2 * atan(0.5 * om * dt);
  ck_assert_double_eq_tol(R[0], cos(th), 1e-12);
  ck_assert_double_eq_tol(R[3], sin(th), 1e-12);
  /* the transposed (printed Eq 93) update turns the stress the other way */
  double diff = 0;
  for (int k = 0; k < 6; ++k) diff = fmax(diff, fabs(sig_wrong[k] - expect[k]));
  ck_assert(diff > 0.1 * scale);
  mat_close(&f);

  /* neo-Hookean is objective by construction: F -> R F gives sigma -> R sigma R^T */
  mat_open(&f, E0, NU0, 1);
  const ej_real F[9] = {1.1, 0.2, 0.05, -0.03, 0.95, 0.1, 0.02, 0.0, 1.02};
  ej_real RF[9], s1[6], s2[6];
  mat_step(&f, 1e-6, dzero, F, s1, &c);
  ej_m3_mul(RF, R, F);
  mat_step(&f, 1e-6, dzero, RF, s2, &c);
  ej_s6_rotate(expect, R, s1);
  for (int k = 0; k < 6; ++k) ck_assert_double_eq_tol(s2[k], expect[k], 1e-9 * fabs(s1[0]));
  mat_close(&f);
}
END_TEST

START_TEST(test_neo_hookean_needs_F)
{
  mat_fix f;
  mat_open(&f, E0, NU0, 1);
  ej_real rho = 2000, e = 0, sig[6] = {0}, c;
  const ej_real d[6] = {0};
  ej_mat_batch b = {.n = 1, .dt = 1e-6, .rho = &rho, .e = &e, .d = d, .F = NULL, .stress = sig, .c = &c};
  ck_assert_int_eq(f.ops->update(f.state, &b), EJ_ERR_ARG);
  ej_error_clear();
  const ej_real Fbad[9] = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
  b.F = Fbad;
  ck_assert_int_eq(f.ops->update(f.state, &b), EJ_ERR_NUMERIC);
  ej_error_clear();
  mat_close(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("elastic");
  TCase *tc = tcase_create("material");
  tcase_add_test(tc, test_params_moduli_sound_speed);
  tcase_add_test(tc, test_uniaxial_strain);
  tcase_add_test(tc, test_pure_shear);
  tcase_add_test(tc, test_hughes_winget);
  tcase_add_test(tc, test_objectivity);
  tcase_add_test(tc, test_neo_hookean_needs_F);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
