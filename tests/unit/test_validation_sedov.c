/* Short Sedov-Taylor blast (validation/sedov, coarse): octant [0, 0.48]^3 at spacing 0.03
 * (4096 particles), E = 0.125 J in the octant (1 J in full space), rho = 1, run to 0.05 s.
 * The shock position (leading-edge mid-height of the radially binned density) must lie within 8 % of
 * R = xi0 (E t^2 / rho)^(1/5), xi0 = 1.0328 for gamma = 1.4 (Sedov 1959; Taylor 1950; computed
 * by validation/sedov/sedov_exact.py), and the energy balance within 0.5 % of the initial total. */
#include "validation_common.h"

#define SEDOV_DX 0.03
#define SEDOV_T_END 0.05
#define SEDOV_XI0 1.03278
/* Regression guard at a coarse spacing (ten particles from the centre to the shock): measured
 * +1.1 % here at t = 0.05 s. The 3 % accuracy claim is tested at spacings 0.02 and 0.01 by
 * validation/sedov/check.py (make validate), not by this test. */
#define SEDOV_TOL_R 0.08
#define SEDOV_TOL_E 0.005

static const char sedov_scene[] =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 0.05, cfl: 0.3}\n"
    "output: {file: sedov.h5, fields: [v, rho, p, e]}\n"
    "materials:\n"
    "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  gas:\n"
    "    method: sph\n"
    "    material: gas\n"
    "    shape: {box: {min: [0, 0, 0], max: [0.48, 0.48, 0.48]}}\n"
    "    spacing: 0.03\n"
    "    rho: 1\n"
    "    e: 2.5e-6\n"
    "    initial: [{region: {sphere: {center: [0, 0, 0], radius: 0.06}}, energy_total: 0.125}]\n"
    "boundaries:\n"
    "  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n"
    "  - symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}\n"
    "  - symmetry: {point: [0, 0, 0], normal: [0, 0, 1]}\n";

START_TEST(test_sedov_radius_and_energy)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "sedov");
  snprintf(scene, sizeof scene, "%s/sedov.yaml", dir);
  snprintf(out, sizeof out, "%s/sedov.h5", dir);
  vrun_write(scene, sedov_scene);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 2};
  vrun r;
  vrun_open(&r, scene, &opts, -1);
  const double total0 = r.sim->energy.total0;
  ck_assert_double_eq_tol(total0, 0.125, 1e-3); /* the deposit, plus 4e-6 J of background */
  vrun_run(&r);
  ck_assert_double_eq_tol(r.sim->t, SEDOV_T_END, 1e-12);
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho");
  /* Mean density in radial bins of half a spacing, inside r < 0.44 (complete shells). */
  enum { NB = 22 };
  const double wbin = 0.5 * SEDOV_DX;
  double sum[NB] = {0}, cnt[NB] = {0};
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    const double rr = sqrt(x[3 * i] * x[3 * i] + x[3 * i + 1] * x[3 * i + 1] + x[3 * i + 2] * x[3 * i + 2]);
    const int k = (int)(rr / wbin);
    if (k < NB) sum[k] += rho[i], cnt[k] += 1;
  }
  int best = -1;
  double best_rho = -1;
  for (int k = 0; k < NB; ++k)
    if (cnt[k] >= 3 && sum[k] / cnt[k] > best_rho) best_rho = sum[k] / cnt[k], best = k;
  ck_assert_int_gt(best, 0);
  /* The captured shock's position: where the binned density falls, ahead of its peak, to
   * half way between the peak and the ambient density (the peak lags the front). */
  double R = (best + 0.5) * wbin;
  const double half = 0.5 * (best_rho + 1.0);
  for (int k = best + 1; k < NB; ++k)
    if (cnt[k] >= 3 && sum[k] / cnt[k] <= half) {
      const double y0 = sum[k - 1] / cnt[k - 1], y1 = sum[k] / cnt[k];
      R = (k - 0.5 + (y0 - half) / (y0 - y1)) * wbin;
      break;
    }
  const double Re = SEDOV_XI0 * pow(1.0 * SEDOV_T_END * SEDOV_T_END / 1.0, 0.2);
  const double balance = fabs(r.sim->energy.balance) / total0;
  fprintf(stderr, "sedov: R = %.4f m, exact %.4f m (error %+.2f %%), peak rho %.3f; |balance|/total0 = %.3e\n", R,
          Re, 100 * (R - Re) / Re, best_rho, balance);
  ck_assert_msg(fabs(R - Re) <= SEDOV_TOL_R * Re, "shock radius %g m, exact %g m (tolerance %g %%)", R, Re,
                100 * SEDOV_TOL_R);
  ck_assert_msg(balance <= SEDOV_TOL_E, "energy balance %g of the initial total (tolerance %g)", balance,
                SEDOV_TOL_E);
  vrun_free(&r);
  const char *names[] = {"sedov.yaml", "sedov.h5", "sedov.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_sedov");
  TCase *tc = tcase_create("sedov_octant");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_sedov_radius_and_energy);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
