/* Short Sod shock tube (validation/sod, 1D): L1 density error against the exact Riemann
 * solution at t = 0.2 s, and its decrease under refinement. Runs through the library API.
 *
 * Tolerances come from validation/sod/check.py runs (Release, same scene): L1(rho) over
 * |x| <= 0.4 was 0.00965 at dx = 0.005 and 0.00856 at dx = 0.0025; the bounds below are those
 * values x 1.5. Refinement must cut the error by at least 25 % (first order expected: 50 %). */
#include "validation_common.h"

#define SOD_T_END 0.2
#define SOD_TOL_L1_COARSE (1.5 * 0.00965) /* dx = 0.005  */
#define SOD_TOL_L1_FINE (1.5 * 0.00856)   /* dx = 0.0025 */
#define SOD_TOL_RATIO 0.75

/* L1 = sum V_i |rho_i - rho_exact(x_i)| / sum V_i over |x_i| <= 0.4, V_i = m_i / rho_i; `extra`:
 * more keys of the tube set (sod_scene_text's set_extra; NULL: none). */
static double sod_l1_with(double dx, const char *extra)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "sod");
  snprintf(scene, sizeof scene, "%s/sod.yaml", dir);
  snprintf(out, sizeof out, "%s/sod.h5", dir);
  char *text = sod_scene_text(1, dx, SOD_T_END, 0, "sod.h5", extra);
  vrun_write(scene, text);
  free(text);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  vrun r;
  vrun_open(&r, scene, &opts, -1);
  vrun_run(&r);
  ck_assert_double_eq_tol(r.sim->t, SOD_T_END, 1e-12);
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho"), *m = ej_set_field(s, "m");
  ck_assert_ptr_nonnull(x);
  ck_assert_ptr_nonnull(rho);
  ck_assert_ptr_nonnull(m);
  const sod_state L = {1.0, 0.0, 1.0}, R = {0.125, 0.0, 0.1};
  double ps, us;
  toro_star(&L, &R, 1.4, &ps, &us);
  ck_assert_double_eq_tol(ps, 0.30313, 1e-5); /* Toro table 4.3, test 1 */
  ck_assert_double_eq_tol(us, 0.92745, 1e-5);
  double num = 0, den = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
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

static double sod_l1(double dx) { return sod_l1_with(dx, NULL); }

/* Strong shock tube (validation/strong_shock, short version): rho 1 | 1, p 1 | 1e-3, dx 0.005, run
 * until the shock is near x = 0.3. Mean density and pressure over the middle 40 % of the shocked
 * region (between the exact contact and the exact shock) against the exact post-shock state;
 * `set_extra`: more keys of the tube set. */
static void strong_plateau(const char *set_extra, double *err_rho, double *err_p)
{
  const sod_state L = {1.0, 0.0, 1.0}, R = {1.0, 0.0, 1e-3};
  double ps, us;
  toro_star(&L, &R, 1.4, &ps, &us);
  const double t_end = 0.3 / (1.2 * us);
  char dir[64], scene[128], out[128], text[1024];
  vrun_dir(dir, sizeof dir, "strong");
  snprintf(scene, sizeof scene, "%s/strong.yaml", dir);
  snprintf(out, sizeof out, "%s/strong.h5", dir);
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 1\ntime: {end: %.9g, cfl: 0.3}\noutput: {file: strong.h5, every: %.9g}\n"
           "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "sets:\n  tube: {method: sph, material: g, %sshape: {box: {min: [-0.5], max: [0.5]}}, spacing: 0.005, p: 1,\n"
           "         initial: [{region: {box: {min: [0], max: [0.5]}}, rho: 1, p: 1e-3}]}\n"
           "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n",
           t_end, t_end, set_extra);
  vrun_write(scene, text);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  vrun r;
  vrun_open(&r, scene, &opts, -1);
  vrun_run(&r);
  const double t = r.sim->t;
  /* exact post-shock density (just right of the contact) and shock position */
  const double xc = us * t, rho2 = toro_rho(&L, &R, 1.4, ps, us, xc + 1e-9, t);
  double xs = xc + 1e-9;
  while (xs < 0.5 && toro_rho(&L, &R, 1.4, ps, us, xs, t) > 1.0 + 1e-9) xs += 1e-5;
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho"), *p = ej_set_field(s, "p");
  double sr = 0, sp = 0;
  int n = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    if (x[3 * i] < xc + 0.3 * (xs - xc) || x[3 * i] > xc + 0.7 * (xs - xc)) continue;
    sr += rho[i], sp += p[i], ++n;
  }
  ck_assert_int_gt(n, 5);
  *err_rho = sr / n / rho2 - 1, *err_p = sp / n / ps - 1;
  vrun_free(&r);
  const char *names[] = {"strong.yaml", "strong.h5", "strong.xdmf"};
  vrun_cleanup(dir, names, 3);
}

/* The default continuity (auto: the number form for the kernel gradient) keeps the strong-shock jump:
 * plateau within 2 % (validation/strong_shock: -0.14 % at dx 0.0025). The former default, continuity:
 * volume, is printed for comparison (+17 %: plugins/methods/sph/README.md "Continuity form"). */
START_TEST(test_strong_shock_plateau)
{
  double er, ep, evr, evp;
  strong_plateau("", &er, &ep);
  strong_plateau("continuity: volume, ", &evr, &evp);
  fprintf(stderr,
          "strong shock (p ratio 1000, dx 0.005): plateau rho %+.2f %%, p %+.2f %% (default); continuity: volume "
          "%+.2f %%, %+.2f %%\n",
          100 * er, 100 * ep, 100 * evr, 100 * evp);
  ck_assert_double_lt(fabs(er), 0.02);
  ck_assert_double_lt(fabs(ep), 0.02);
}
END_TEST

START_TEST(test_sod_l1_and_convergence)
{
  const double e1 = sod_l1(0.005), e2 = sod_l1(0.0025);
  fprintf(stderr, "sod 1D: L1(rho) = %.5f (dx 0.005), %.5f (dx 0.0025), ratio %.3f, order %.2f\n", e1, e2,
          e2 / e1, log(e1 / e2) / log(2.0));
  ck_assert_msg(e1 < SOD_TOL_L1_COARSE, "L1(rho) = %g at dx 0.005, tolerance %g", e1, SOD_TOL_L1_COARSE);
  ck_assert_msg(e2 < SOD_TOL_L1_FINE, "L1(rho) = %g at dx 0.0025, tolerance %g", e2, SOD_TOL_L1_FINE);
  ck_assert_msg(e2 < SOD_TOL_RATIO * e1, "refinement cut L1(rho) only from %g to %g (need < %g x)", e1, e2,
                SOD_TOL_RATIO);
}
END_TEST

/* Hard case of issue 3 (validation/sod README, "Hard case: jittered lattice"): the shape-tensor
 * gradient on the lattice jittered by 30 % of the spacing, with the particles' volumes from the
 * arrangement (jitter_volume: kernel), keeps L1(rho) under 2 x the regular lattice's at both
 * spacings of check.py; with the lattice cells' volumes (the default) the ratio is larger. The
 * scene is validation_common.h's (jump smoothed over 1.95 dx; check.py's 1D tube: 3 dx): measured
 * 1.27 / 1.80 here, 1.30 / 1.79 in check.py; cell volumes 2.42 / 3.39. */
START_TEST(test_sod_jitter_shape_tensor)
{
  static const char *const shape = "    gradient: shape_tensor\n";
  static const char *const jit_kernel = "    gradient: shape_tensor\n    jitter: 0.3\n    seed: 7\n"
                                        "    jitter_volume: kernel\n";
  static const char *const jit_cell = "    gradient: shape_tensor\n    jitter: 0.3\n    seed: 7\n";
  const double dxs[2] = {0.0025, 0.00125};
  for (int k = 0; k < 2; ++k) {
    const double e0 = sod_l1_with(dxs[k], shape), e1 = sod_l1_with(dxs[k], jit_kernel);
    const double e2 = sod_l1_with(dxs[k], jit_cell);
    fprintf(stderr, "sod 1D shape tensor, dx %g: L1(rho) regular %.5f, jittered %.5f (ratio %.2f; cell volumes %.5f, "
            "ratio %.2f)\n", dxs[k], e0, e1, e1 / e0, e2, e2 / e0);
    ck_assert_msg(e1 < 2.0 * e0, "jittered / regular L1(rho) = %.3f at dx %g (hard case: < 2)", e1 / e0, dxs[k]);
    ck_assert_msg(e2 > e1, "cell volumes gave %g, kernel volumes %g: the option made no difference", e2, e1);
  }
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_sod");
  TCase *tc = tcase_create("sod_1d");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_sod_l1_and_convergence);
  tcase_add_test(tc, test_sod_jitter_shape_tensor);
  tcase_add_test(tc, test_strong_shock_plateau);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
