/* Non-reflecting boundaries (scene `boundaries: [{non_reflecting: ...}]`, core/src/sim.c
 * ej_nonreflect_force, docs/core.md "Non-reflecting boundaries"): the dashpot force of Lysmer and
 * Kuhlemeyer (1969) on each boundary particle, with the impedances taken from the strength model's
 * moduli or given; a pulse in an elastic bar leaves through the ends and the absorbed energy is the
 * external work of the budget; 1 and 2 threads and a restart give the same run bitwise. */
#include <hdf5.h>

#include "validation_common.h"

const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

#define RHO 2000.0
#define YOUNG 1.0e9

/* A run of the scene with the tlpd and elastic plugins (validation_common.h's vrun). */
static void nrun_open(vrun *r, const char *scene, const char *out, int threads, const char *restart)
{
  const ej_plugin_info *p[] = {ej_plugin_tlpd_info(), ej_plugin_elastic_info()};
  ej_run_opts o = {.struct_size = sizeof o, .output = out, .threads = threads, .restart = restart};
  vrun_open_with(r, scene, &o, -1, p, 2);
}

/* ------------------------------------------------------------------ the dashpot force */

/* A block in uniform motion (no deformation, so the method's forces are zero at t = 0): the
 * acceleration of the force evaluation at t = 0 is the dashpots' alone. Two boundaries overlap on
 * an edge: a plane one (normal [1, 1, 0], impedances from the elastic moduli) and a spherical one
 * with given c_p, c_s and rho. */
static const char force_scene[] = "ejecta: 1\n"
                                  "dimension: 3\n"
                                  "time: {end: 1 ms}\n"
                                  "materials:\n"
                                  "  rock: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}\n"
                                  "sets:\n"
                                  "  b:\n"
                                  "    method: tlpd\n"
                                  "    material: rock\n"
                                  "    shape: {box: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}}\n"
                                  "    spacing: 0.05\n"
                                  "    initial: [{velocity: [3, -2, 1]}]\n"
                                  "boundaries:\n"
                                  "  - {set: b, region: {box: {min: [0.45, 0, 0], max: [1, 1, 1]}}, non_reflecting: "
                                  "{normal: [1, 1, 0]}}\n"
                                  "  - {region: {box: {min: [0, 0.45, 0], max: [1, 1, 1]}}, non_reflecting: {center: "
                                  "[0.1, 0.2, 0.3], cp: 100, cs: 50 m/s, rho: 1000}}\n";

START_TEST(test_dashpot_force)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "nr_force");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/o.h5", dir);
  vrun_write(scene, force_scene);
  vrun r;
  nrun_open(&r, scene, out, 1, NULL);
  const ej_set *s = r.sim->sets[0];
  const double nu = 0.25, K = YOUNG / (3 * (1 - 2 * nu)), G = YOUNG / (2 * (1 + nu));
  const double zp0 = RHO * sqrt((K + 4 * G / 3) / RHO), zs0 = RHO * sqrt(G / RHO);
  ck_assert_msg(fabs(s->nr_zp[0] / zp0 - 1) < 1e-14 && fabs(s->nr_zs[0] / zs0 - 1) < 1e-14, "%g %g vs %g %g",
                s->nr_zp[0], s->nr_zs[0], zp0, zs0);
  ck_assert(s->nr_zp[1] == 1e5 && s->nr_zs[1] == 5e4);
  const ej_real *x = ej_set_field(s, "x"), *a = ej_set_field(s, "a"), *m = ej_set_field(s, "m");
  const ej_real *vol0 = ej_set_field(s, "vol0");
  const double v[3] = {3, -2, 1}, c[3] = {0.1, 0.2, 0.3};
  int n_plane = 0, n_sphere = 0, n_free = 0;
  double err = 0, amax = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    const double A = pow(vol0[i], 2.0 / 3.0);
    double f[3] = {0, 0, 0};
    const bool plane = x[3 * i] > 0.45, sphere = x[3 * i + 1] > 0.45;
    for (int b = 0; b < 2; ++b) {
      if (!(b ? sphere : plane)) continue;
      double n[3] = {M_SQRT1_2, M_SQRT1_2, 0};
      if (b) {
        double l = 0;
        for (int k = 0; k < 3; ++k) n[k] = x[3 * i + k] - c[k], l += n[k] * n[k];
        for (int k = 0; k < 3; ++k) n[k] /= sqrt(l);
      }
      const double vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
      const double zp = b ? 1e5 : zp0, zs = b ? 5e4 : zs0;
      for (int k = 0; k < 3; ++k) f[k] -= A * (zp * vn * n[k] + zs * (v[k] - vn * n[k]));
    }
    n_plane += plane, n_sphere += sphere, n_free += !plane && !sphere;
    for (int k = 0; k < 3; ++k) {
      err = fmax(err, fabs(a[3 * i + k] - f[k] / m[i]));
      amax = fmax(amax, fabs(f[k] / m[i]));
    }
  }
  ck_assert_int_eq(n_plane, 100);
  ck_assert_int_eq(n_sphere, 100);
  ck_assert_int_eq(n_free, 1000 - 190);
  ck_assert_msg(amax > 1e3 && err < 1e-12 * amax, "max |a - F/m| %g of %g", err, amax);
  vrun_free(&r);
  ej_test_rmtree(dir);
}
END_TEST

/* The dashpots are implicit in the second half kick (trapezoidal rule): boundaries about 20 times
 * stiffer than the material's (rate c_p / dx times the step 4.9 on the faces, 9.7 on the edge
 * where the two meet; an explicit dashpot diverges above 1, by about that factor per step) damp the
 * block's motion without growing, and the budget stays closed. */
static const char stiff_fmt[] = "ejecta: 1\n"
                                  "dimension: 3\n"
                                  "time: {end: 1 ms, max_steps: 40}\n"
                                  "materials:\n"
                                  "  rock: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}\n"
                                  "sets:\n"
                                  "  b:\n"
                                  "    method: tlpd\n"
                                  "    material: rock\n"
                                  "    shape: {box: {%s}}\n"
                                  "    spacing: 0.05\n"
                                  "    initial: [{velocity: [3, -2, 1]}]\n"
                                  "boundaries:\n"
                                  "  - {region: {box: {min: [0.45, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: "
                                  "[1, 0, 0], cp: 15 km/s, cs: 10 km/s}}\n"
                                  "  - {region: {box: {min: [0, 0.45, 0], max: [1, 1, 1]}}, non_reflecting: {center: "
                                  "[0.1, 0.2, 0.3], cp: 15 km/s, cs: 10 km/s}}\n";

START_TEST(test_stiff_dashpot)
{
  char dir[64], scene[128], out[128], text[2048];
  vrun_dir(dir, sizeof dir, "nr_stiff");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/o.h5", dir);
  snprintf(text, sizeof text, stiff_fmt, "min: [0, 0, 0], max: [0.5, 0.5, 0.5]");
  vrun_write(scene, text);
  vrun r;
  nrun_open(&r, scene, out, 1, NULL);
  const double ke0 = r.sim->energy.kinetic, rate_dt = 15000 / 0.05 * r.sim->dt;
  ck_assert_msg(rate_dt > 2, "c_p dt / dx = %g: not a stiff boundary", rate_dt);
  vrun_run(&r);
  ck_assert_int_eq((int)r.sim->step, 40);
  const ej_set *s = r.sim->sets[0];
  const ej_real *v = ej_set_field(s, "v");
  double vmax = 0;
  for (ej_idx i = 0; i < 3 * ej_set_count(s); ++i) vmax = fmax(vmax, fabs(v[i]));
  ck_assert_msg(vmax < 10, "max |v| %g m/s (initially 3)", vmax);
  ck_assert_msg(r.sim->energy.kinetic < ke0, "kinetic %g, initially %g", r.sim->energy.kinetic, ke0);
  ck_assert_msg(-r.sim->energy.external > 0.01 * ke0, "absorbed %g of %g", -r.sim->energy.external, ke0);
  /* tlpd books its internal energy from the step's velocities, which the stiff dashpots change
   * strongly at the boundary: measured 3.8e-4 of KE0; the dashpots' own work is exact (below) */
  ck_assert_msg(fabs(r.sim->energy.balance) < 1e-3 * ke0, "balance %g of %g", r.sim->energy.balance, ke0);
  vrun_free(&r);
  /* one particle (no bonds: the dashpots alone, on both boundaries): the budget to round-off */
  snprintf(text, sizeof text, stiff_fmt, "min: [0.45, 0.45, 0], max: [0.5, 0.5, 0.05]");
  vrun_write(scene, text);
  nrun_open(&r, scene, out, 1, NULL);
  ck_assert_int_eq((int)ej_set_count(r.sim->sets[0]), 1);
  vrun_run(&r);
  ck_assert_msg(-r.sim->energy.external > 0.5 * ke0 / 1000, "absorbed %g", -r.sim->energy.external);
  ck_assert_msg(fabs(r.sim->energy.balance) < 1e-12 * r.sim->energy.total0, "one particle: balance %g of %g",
                r.sim->energy.balance, r.sim->energy.total0);
  vrun_free(&r);
  ej_test_rmtree(dir);
}
END_TEST

/* ------------------------------------------------------------------ a pulse leaves a bar */

/* A 0.5 m elastic bar (1D, nu 0: c = sqrt(E / rho) = 707 m/s, dx 1 mm) with a cos^2 velocity pulse of
 * half-width w = 50 spacings in the middle; both ends non-reflecting or free. */
static void bar_scene(char *buf, size_t n, bool absorbing, const char *out)
{
  size_t o = (size_t)snprintf(buf, n,
                              "ejecta: 1\n"
                              "dimension: 1\n"
                              "time: {end: 0.6 ms, cfl: 0.5}\n"
                              "output: {file: %s}\n"
                              "materials:\n"
                              "  bar: {model: elastic, rho0: %g, E: %g, nu: 0}\n"
                              "sets:\n"
                              "  bar:\n"
                              "    method: tlpd\n"
                              "    material: bar\n"
                              "    hourglass: zhu_zhao\n"
                              "    shape: {box: {min: [0], max: [0.5]}}\n"
                              "    spacing: 0.001\n"
                              "    initial:\n",
                              out, RHO, YOUNG);
  const double dx = 0.001, w = 0.05;
  for (int i = 0; i < 500; ++i) {
    const double x = (i + 0.5) * dx, d = x - 0.25;
    if (fabs(d) >= w) continue;
    const double c = cos(M_PI * d / (2 * w));
    o += (size_t)snprintf(buf + o, n - o, "      - {region: {box: {min: [%.9g], max: [%.9g]}}, velocity: [%.12g]}\n",
                          x - dx / 2, x + dx / 2, c * c);
  }
  if (absorbing)
    snprintf(buf + o, n - o,
             "boundaries:\n"
             "  - {set: bar, region: {box: {min: [-1], max: [0.001]}}, non_reflecting: {normal: [-1]}}\n"
             "  - {set: bar, region: {box: {min: [0.499], max: [1]}}, non_reflecting: {normal: [1]}}\n");
}

/* max |/series/energy/balance| of a finished run's file */
static double max_abs_balance(const char *path)
{
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_msg(f >= 0, "cannot open %s", path);
  hid_t d = H5Dopen2(f, "/series/energy/balance", H5P_DEFAULT);
  ck_assert(d >= 0);
  hid_t sp = H5Dget_space(d);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(sp, &n, NULL);
  double *b = malloc((size_t)n * sizeof *b), m = 0;
  ck_assert_ptr_nonnull(b);
  ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, b), 0);
  for (hsize_t k = 0; k < n; ++k) m = fmax(m, fabs(b[k]));
  ck_assert(n > 100);
  free(b);
  H5Sclose(sp);
  H5Dclose(d);
  H5Fclose(f);
  return m;
}

START_TEST(test_bar_absorbs)
{
  char dir[64], scene[128], out[128], text[16384];
  vrun_dir(dir, sizeof dir, "nr_bar");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/o.h5", dir);
  double left[2];
  for (int absorbing = 0; absorbing < 2; ++absorbing) {
    bar_scene(text, sizeof text, absorbing, out);
    vrun_write(scene, text);
    vrun r;
    nrun_open(&r, scene, out, 1, NULL);
    const double e0 = r.sim->energy.total0;
    vrun_run(&r);
    const double bal = max_abs_balance(out);
    const ej_energy *en = &r.sim->energy;
    left[absorbing] = (en->kinetic + en->internal) / e0;
    ck_assert_msg(bal < 1e-4 * e0, "max |balance| %g of E0 %g", bal, e0);
    if (absorbing) /* what left the bar is the dashpots' (negative) work */
      ck_assert_msg(fabs(-en->external / e0 - (1 - left[1])) < 1e-4, "absorbed %g, left %g", -en->external / e0, left[1]);
    else
      ck_assert(en->external == 0);
    vrun_free(&r);
  }
  ck_assert_msg(left[0] > 0.999, "free ends: %g of E0 left", left[0]);
  ck_assert_msg(left[1] < 0.01, "non-reflecting ends: %g of E0 left", left[1]);
  ej_test_rmtree(dir);
}
END_TEST

/* ------------------------------------------------------------------ determinism */

/* A 2D strip, periodic across, with a plane S pulse leaving through both ends. */
static const char strip_head[] = "ejecta: 1\n"
                                 "dimension: 2\n"
                                 "time: {end: 1 ms, cfl: 0.5, max_steps: %d}\n"
                                 "materials:\n"
                                 "  rock: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}\n"
                                 "sets:\n"
                                 "  s:\n"
                                 "    method: tlpd\n"
                                 "    material: rock\n"
                                 "    shape: {box: {min: [0, 0], max: [0.4, 0.04]}}\n"
                                 "    spacing: 0.01\n"
                                 "    initial:\n"
                                 "      - {region: {box: {min: [0.15, -1], max: [0.25, 1]}}, velocity: [0.3, 1]}\n"
                                 "      - {region: {box: {min: [0.17, -1], max: [0.23, 1]}}, velocity: [0.6, 2]}\n"
                                 "boundaries:\n"
                                 "  - {periodic: {axis: y, min: 0, max: 0.04}}\n"
                                 "  - {set: s, region: {box: {min: [-1, -1], max: [0.01, 1]}}, non_reflecting: {normal: "
                                 "[-1, 0]}}\n"
                                 "  - {set: s, region: {box: {min: [0.39, -1], max: [1, 1]}}, non_reflecting: {normal: "
                                 "[1, 0]}}\n";

static void same_state(const ej_sim *a, const ej_sim *b, const char *what)
{
  static const char *const f[] = {"x", "v", "nr_force", "nr_power"};
  vrun_same_state(a, b, f, 4, what);
}

START_TEST(test_threads_and_restart)
{
  char dir[64], full[128], half[128], text[2048], o[4][160];
  vrun_dir(dir, sizeof dir, "nr_rs");
  snprintf(full, sizeof full, "%s/full.yaml", dir);
  snprintf(half, sizeof half, "%s/half.yaml", dir);
  snprintf(text, sizeof text, strip_head, 120);
  vrun_write(full, text);
  snprintf(text, sizeof text, strip_head, 60);
  vrun_write(half, text);
  for (int k = 0; k < 4; ++k) snprintf(o[k], sizeof o[k], "%s/o%d.h5", dir, k);
  vrun a, b, c, d;
  nrun_open(&a, full, o[0], 1, NULL);
  vrun_run(&a);
  ck_assert_int_eq((int)a.sim->step, 120);
  ck_assert_msg(-a.sim->energy.external > 0.3 * a.sim->energy.total0, "absorbed %g of %g", -a.sim->energy.external,
                a.sim->energy.total0);
  nrun_open(&b, full, o[1], 2, NULL);
  vrun_run(&b);
  same_state(a.sim, b.sim, " between 1 and 2 threads");
  nrun_open(&c, half, o[2], 1, NULL);
  vrun_run(&c);
  nrun_open(&d, full, o[3], 1, o[2]);
  vrun_run(&d);
  ck_assert_int_eq((int)d.sim->step, 120);
  same_state(a.sim, d.sim, " after a restart at step 60");
  vrun_free(&a);
  vrun_free(&b);
  vrun_free(&c);
  vrun_free(&d);
  ej_test_rmtree(dir);
}
END_TEST

/* ------------------------------------------------------------------ a fluid without strength */

START_TEST(test_needs_speeds)
{
  vrun_refuses_text("nr_gas",
                    "ejecta: 1\n"
                    "time: {end: 1 ms}\n"
                    "materials:\n"
                    "  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n"
                    "  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 0.1, p: 1e5}\n"
                    "boundaries:\n"
                    "  - {region: {box: {min: [0.9, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [1, 0, 0]}}\n",
                    "non_reflecting on set 'gas': material 'air' has no strength model", 8, 5);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("nonreflecting");
  TCase *tc = tcase_create("nonreflecting");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_dashpot_force);
  tcase_add_test(tc, test_stiff_dashpot);
  tcase_add_test(tc, test_bar_absorbs);
  tcase_add_test(tc, test_threads_and_restart);
  tcase_add_test(tc, test_needs_speeds);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
