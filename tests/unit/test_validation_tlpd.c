/* Short validations of the tlpd method (validation/tlpd_wave, 1D case), through the library API:
 * the speed of an elastic wave in a bar within 1 % of c = sqrt(E / rho) and the energy balance
 * within 0.1 % of the initial energy. The patch test (F exact for linear fields in 1, 2 and 3 D,
 * jittered clouds and surface particles included) is in test_tlpd.c.
 *
 * Scene: validation/tlpd_wave/check.py, 1D: bar L = 1 m, dx = 1 mm, E = 1 GPa, nu = 0,
 * rho = 2000 kg/m^3, a cos^2 velocity pulse of half-width w = 0.05 m in the middle. The initial
 * pulse splits into two halves; the centroid of v^2 over x > L/2 moves at c once they have
 * separated (t > 1.4 w / c = 0.1 ms). Speed = (centroid(t2) - centroid(t1)) / (t2 - t1) from two
 * runs to t1 = 0.2 ms and t2 = 0.4 ms (before the pulse reaches the end). check.py measured
 * -0.37 % (least squares over frames) and an energy error of 8.4e-5. */
#include "validation_common.h"

const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

#define TW_RHO 2000.0
#define TW_E 1.0e9
#define TW_L 1.0
#define TW_W 0.05
#define TW_DX 0.001
#define TW_TOL_C 0.01
#define TW_TOL_E 0.001

static char *tw_scene(double t_end, const char *out)
{
  ej_buf b = {0};
  ck_assert_int_eq(ej_buf_printf(&b,
                                 "ejecta: 1\ndimension: 1\ntime: {end: %.17g, cfl: 0.5}\n"
                                 "output: {file: %s, every: 1, fields: [v]}\n"
                                 "materials:\n  bar: {model: elastic, rho0: %g, E: %g, nu: 0.0}\n"
                                 "sets:\n  bar:\n    method: tlpd\n    material: bar\n    hourglass: zhu_zhao\n"
                                 "    shape: {box: {min: [0], max: [%g]}}\n    spacing: %g\n    initial:\n",
                                 t_end, out, TW_RHO, TW_E, TW_L, TW_DX),
                   EJ_OK);
  const int n = (int)lround(TW_L / TW_DX);
  for (int i = 0; i < n; ++i) {
    const double x = (i + 0.5) * TW_DX, xc = 0.5 * TW_L;
    if (fabs(x - xc) >= TW_W) continue;
    const double c = cos(M_PI * (x - xc) / (2 * TW_W)), v = c * c;
    ck_assert_int_eq(ej_buf_printf(&b, "      - {region: {box: {min: [%.9g], max: [%.9g]}}, velocity: [%.9g]}\n",
                                   x - TW_DX / 2, x + TW_DX / 2, v),
                     EJ_OK);
  }
  char *copy = strdup(b.data);
  ej_buf_free(&b);
  ck_assert_ptr_nonnull(copy);
  return copy;
}

/* runs to t_end; returns the centroid of v^2 over x > L/2 and the energy error */
static double tw_run(double t_end, double *eerr)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "tlpd_wave");
  snprintf(scene, sizeof scene, "%s/w.yaml", dir);
  snprintf(out, sizeof out, "%s/w.h5", dir);
  char *text = tw_scene(t_end, "w.h5");
  vrun_write(scene, text);
  free(text);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  const ej_plugin_info *plugins[] = {ej_plugin_tlpd_info(), ej_plugin_elastic_info()};
  vrun r;
  vrun_open_with(&r, scene, &opts, -1, plugins, 2);
  vrun_run(&r);
  ck_assert_double_eq_tol(r.sim->t, t_end, 1e-12);
  *eerr = fabs(r.sim->energy.balance) / r.sim->energy.total0;
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  double num = 0, den = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    ck_assert(isfinite(v[3 * i]));
    if (x[3 * i] <= 0.5 * TW_L) continue;
    const double k = v[3 * i] * v[3 * i];
    num += k * x[3 * i];
    den += k;
  }
  ck_assert(den > 0);
  vrun_free(&r);
  const char *names[] = {"w.yaml", "w.h5", "w.xdmf"};
  vrun_cleanup(dir, names, 3);
  return num / den;
}

START_TEST(test_tlpd_wave_speed_and_energy)
{
  const double t1 = 0.2e-3, t2 = 0.4e-3, c_ref = sqrt(TW_E / TW_RHO);
  double e1, e2;
  const double x1 = tw_run(t1, &e1), x2 = tw_run(t2, &e2);
  const double c = (x2 - x1) / (t2 - t1), err = c / c_ref - 1;
  fprintf(stderr, "tlpd wave 1D dx 1 mm: c = %.2f m/s (exact %.2f), error %+.3f %%; energy error %.1e, %.1e\n", c, c_ref,
          100 * err, e1, e2);
  ck_assert_msg(fabs(err) < TW_TOL_C, "wave speed %g m/s, exact %g (error %g, tolerance %g)", c, c_ref, err, TW_TOL_C);
  ck_assert_msg(e1 < TW_TOL_E && e2 < TW_TOL_E, "energy error %g, %g (tolerance %g)", e1, e2, TW_TOL_E);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_tlpd");
  TCase *tc = tcase_create("wave_1d");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_tlpd_wave_speed_and_energy);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
