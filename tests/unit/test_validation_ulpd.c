/* Short Sod shock tube with the ulpd method (validation/ulpd, 1D): L1 density error against the
 * exact Riemann solution at t = 0.2 s, its decrease under refinement, and the energy balance.
 * Runs through the library API.
 *
 * Tolerances come from validation/ulpd/check_sod.py runs (Release, same scene): L1(rho) over
 * |x| <= 0.4 was 0.00756 at dx = 0.005 and 0.00390 at dx = 0.0025; the bounds are those values
 * x 1.5. Refinement must cut the error by at least 25 % (first order expected: 50 %). The energy
 * balance measured 4e-7 of the initial total; the bound is 1e-5. */
#include "validation_common.h"

const ej_plugin_info *ej_plugin_ulpd_info(void);

#define SOD_T_END 0.2
#define SOD_TOL_L1_COARSE (1.5 * 0.00756) /* dx = 0.005  */
#define SOD_TOL_L1_FINE (1.5 * 0.00390)   /* dx = 0.0025 */
#define SOD_TOL_RATIO 0.75
#define SOD_TOL_BALANCE 1e-5

/* The scene of validation/ulpd/check_sod.py (ulpd_scene, dim 1): jump smoothed over one
 * spacing, (1 + tanh(x / dx)) / 2, one `initial` strip per column with |x| < 5 dx. */
static char *ulpd_sod_text(double dx, const char *out)
{
  ej_buf b = {0};
  ck_assert_int_eq(ej_buf_printf(&b,
                                 "ejecta: 1\ndimension: 1\ntime: {end: %.17g, cfl: 0.3}\n"
                                 "output: {file: %s, fields: [v, m, rho, p, e, delta]}\n"
                                 "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                                 "sets:\n  tube:\n    method: ulpd\n    material: gas\n"
                                 "    shape: {box: {min: [-0.5], max: [0.5]}}\n    spacing: %.17g\n"
                                 "    rho: 1\n    p: 1\n    initial:\n"
                                 "      - {region: {box: {min: [0], max: [0.5]}}, rho: 0.125, p: 0.1}\n",
                                 SOD_T_END, out, dx),
                   EJ_OK);
  const int n = (int)lround(1.0 / dx);
  for (int i = 0; i < n; ++i) {
    const double x = -0.5 + (i + 0.5) * dx;
    if (fabs(x) >= 5 * dx) continue;
    const double f = 0.5 * (1.0 + tanh(x / dx));
    ck_assert_int_eq(ej_buf_printf(&b, "      - {region: {box: {min: [%.17g], max: [%.17g]}}, rho: %.17g, p: %.17g}\n",
                                   x - dx / 2, x + dx / 2, 1.0 + (0.125 - 1.0) * f, 1.0 + (0.1 - 1.0) * f),
                     EJ_OK);
  }
  ck_assert_int_eq(ej_buf_printf(&b, "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n"
                                     "  - symmetry: {point: [0.5], normal: [-1]}\n"),
                   EJ_OK);
  char *copy = strdup(b.data);
  ej_buf_free(&b);
  ck_assert_ptr_nonnull(copy);
  return copy;
}

static double sod_l1(double dx, double *balance)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "ulpd_sod");
  snprintf(scene, sizeof scene, "%s/sod.yaml", dir);
  snprintf(out, sizeof out, "%s/sod.h5", dir);
  char *text = ulpd_sod_text(dx, "sod.h5");
  vrun_write(scene, text);
  free(text);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  const ej_plugin_info *plugins[] = {ej_plugin_ulpd_info(), ej_plugin_ideal_gas_info()};
  vrun r;
  vrun_open_with(&r, scene, &opts, -1, plugins, 2);
  vrun_run(&r);
  ck_assert_double_eq_tol(r.sim->t, SOD_T_END, 1e-12);
  *balance = fabs(r.sim->energy.balance) / r.sim->energy.total0;
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho"), *m = ej_set_field(s, "m");
  ck_assert_ptr_nonnull(x);
  const sod_state L = {1.0, 0.0, 1.0}, R = {0.125, 0.0, 0.1};
  double ps, us;
  toro_star(&L, &R, 1.4, &ps, &us);
  double num = 0, den = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    ck_assert(isfinite(rho[i]) && rho[i] > 0);
    if (fabs(x[3 * i]) > 0.4) continue;
    const double V = m[i] / rho[i];
    num += V * fabs(rho[i] - toro_rho(&L, &R, 1.4, ps, us, x[3 * i], r.sim->t));
    den += V;
  }
  ck_assert(den > 0);
  vrun_free(&r);
  const char *names[] = {"sod.yaml", "sod.h5", "sod.xdmf"};
  vrun_cleanup(dir, names, 3);
  return num / den;
}

START_TEST(test_ulpd_sod_l1_and_convergence)
{
  double b1, b2;
  const double e1 = sod_l1(0.005, &b1), e2 = sod_l1(0.0025, &b2);
  fprintf(stderr, "ulpd sod 1D: L1(rho) = %.5f (dx 0.005), %.5f (dx 0.0025), order %.2f; balance %.1e, %.1e\n", e1,
          e2, log(e1 / e2) / log(2.0), b1, b2);
  ck_assert_msg(e1 < SOD_TOL_L1_COARSE, "L1(rho) = %g at dx 0.005, tolerance %g", e1, SOD_TOL_L1_COARSE);
  ck_assert_msg(e2 < SOD_TOL_L1_FINE, "L1(rho) = %g at dx 0.0025, tolerance %g", e2, SOD_TOL_L1_FINE);
  ck_assert_msg(e2 < SOD_TOL_RATIO * e1, "refinement cut L1(rho) only from %g to %g", e1, e2);
  ck_assert_msg(b1 < SOD_TOL_BALANCE && b2 < SOD_TOL_BALANCE, "energy balance %g, %g", b1, b2);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_ulpd");
  TCase *tc = tcase_create("sod_1d");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_ulpd_sod_l1_and_convergence);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
