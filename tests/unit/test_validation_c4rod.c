/* Short C4 rod (validation/c4_rod, 1D, coarse): SPH + JWL programmed burn against Chen et al.
 * Case 1 (digest 001 section 3.1): front speed 8193 m/s and arrival at the far end of the
 * 0.1 m rod at 12.21 us, both within 1 %; peak pressure within 10 % of the JWL CJ pressure
 * 28.0 GPa; energy balance below 1e-3 of the initial total. Then a C4 slab expanding into
 * vacuum: no NaN, positive density, pressure >= 0 and energy balance below 1 %.
 *
 * Front position: the largest x at which p crosses half its maximum, at each frame
 * (every 0.5 us) from 2 to 12 us; speed = least-squares slope. check.py at dx = 0.2 mm measured
 * 8196.8 m/s, arrival 12.237 us, peak 27.02 GPa (validation/c4_rod/README.md). */
#include <hdf5.h>

#include "validation_common.h"

const ej_plugin_info *ej_plugin_jwl_info(void);

#define C4_L 0.1
#define C4_D 8193.0
#define C4_T_ARR 12.21e-6
#define C4_P_CJ 28.0e9

static const char *const C4_MATERIAL =
    "materials:\n  c4:\n    rho0: 1601\n    eos: {model: jwl, A: 6.098e11, B: 1.3e10, R1: 4.5, R2: 1.4, omega: 0.25,\n"
    "          rho0: 1601, e0: 5.621e6, detonation: {point: [0, 0, 0], speed: 8193}}\n";

static void c4_open(vrun *r, const char *scene_path, const char *out)
{
  memset(r, 0, sizeof *r);
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_jwl_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene_path, r->reg, &r->scene);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  rc = ej_sim_create(r->scene, r->reg, &opts, &r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

/* Reads /frames/<name>/<set>/<field> (n doubles x ncomp) into buf; returns n. */
static int h5_field(hid_t f, const char *frame, const char *set, const char *field, double *buf, int cap, int ncomp)
{
  char path[256];
  snprintf(path, sizeof path, "/frames/%s/%s/%s", frame, set, field);
  hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
  ck_assert_int_ge(d, 0);
  hid_t sp = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(sp, dims, NULL);
  ck_assert_int_le((int)dims[0] * ncomp, cap);
  ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf), 0);
  H5Sclose(sp);
  H5Dclose(d);
  return (int)dims[0];
}

static double h5_frame_time(hid_t f, const char *frame)
{
  char path[64];
  snprintf(path, sizeof path, "/frames/%s", frame);
  hid_t g = H5Gopen2(f, path, H5P_DEFAULT);
  ck_assert_int_ge(g, 0);
  hid_t a = H5Aopen(g, "time", H5P_DEFAULT);
  double t = 0;
  ck_assert_int_ge(H5Aread(a, H5T_NATIVE_DOUBLE, &t), 0);
  H5Aclose(a);
  H5Gclose(g);
  return t;
}

/* Largest x where p crosses half its maximum, interpolated (particles sorted by x first). */
static double leading_edge(int n, const double *x3, const double *p, double *pmax_out)
{
  double pmax = 0;
  for (int i = 0; i < n; ++i) pmax = fmax(pmax, p[i]);
  /* the particle with the largest x at or above half maximum, and its right-hand neighbour */
  double xa = -INFINITY, pa = 0, xb = INFINITY, pb = 0;
  for (int i = 0; i < n; ++i)
    if (p[i] >= 0.5 * pmax && x3[3 * i] > xa) xa = x3[3 * i], pa = p[i];
  for (int i = 0; i < n; ++i)
    if (x3[3 * i] > xa && x3[3 * i] < xb) xb = x3[3 * i], pb = p[i];
  *pmax_out = pmax;
  if (!isfinite(xb)) return xa;
  return xa + (0.5 * pmax - pa) * (xb - xa) / (pb - pa);
}

START_TEST(test_c4_rod_front)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "c4rod");
  snprintf(scene, sizeof scene, "%s/rod.yaml", dir);
  snprintf(out, sizeof out, "%s/rod.h5", dir);
  char text[2048];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 1\ntime: {end: 12 us, cfl: 0.3}\n"
           "output: {file: rod.h5, every: 0.5 us, fields: [rho, p, burn]}\n%s"
           "sets:\n  rod: {method: sph, material: c4, shape: {box: {min: [0], max: [0.1]}}, spacing: 0.2 mm}\n",
           C4_MATERIAL);
  vrun_write(scene, text);
  vrun r;
  c4_open(&r, scene, out);
  vrun_run(&r);
  const double balance = fabs(r.sim->energy.balance) / r.sim->energy.total0;
  vrun_free(&r);

  hid_t f = H5Fopen(out, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  enum { CAP = 4096 };
  static double x[3 * CAP], p[CAP];
  double st = 0, sx = 0, stt = 0, stx = 0, peak = 0;
  int nfit = 0;
  for (int k = 0; k < 64; ++k) {
    char frame[16];
    snprintf(frame, sizeof frame, "%06d", k);
    char path[32];
    snprintf(path, sizeof path, "/frames/%s", frame);
    if (H5Lexists(f, path, H5P_DEFAULT) <= 0) break;
    const double t = h5_frame_time(f, frame);
    const int n = h5_field(f, frame, "rod", "x", x, 3 * CAP, 3);
    ck_assert_int_eq(h5_field(f, frame, "rod", "p", p, CAP, 1), n);
    if (t < 2e-6 - 1e-12) continue;
    double pmax;
    const double xf = leading_edge(n, x, p, &pmax);
    if (t >= 6e-6 - 1e-12) peak = fmax(peak, pmax);
    st += t, sx += xf, stt += t * t, stx += t * xf;
    ++nfit;
  }
  H5Fclose(f);
  ck_assert_int_ge(nfit, 15);
  const double speed = (nfit * stx - st * sx) / (nfit * stt - st * st);
  const double x0 = (sx - speed * st) / nfit;
  const double t_arr = (C4_L - x0) / speed;
  fprintf(stderr,
          "c4 rod 1D, dx 0.2 mm: front %.1f m/s (ref 8193), arrival %.3f us (ref 12.21), peak p %.2f GPa "
          "(p_CJ 28.0), energy balance %.2e\n",
          speed, t_arr * 1e6, peak / 1e9, balance);
  ck_assert_msg(fabs(speed / C4_D - 1) < 0.01, "front speed %g m/s", speed);
  ck_assert_msg(fabs(t_arr / C4_T_ARR - 1) < 0.01, "arrival %g s", t_arr);
  ck_assert_msg(fabs(peak / C4_P_CJ - 1) < 0.10, "peak pressure %g Pa", peak);
  ck_assert_msg(balance < 1e-3, "energy balance %g", balance);
  const char *names[] = {"rod.yaml", "rod.h5", "rod.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

/* A 10 mm C4 slab lit at one face, free on both sides, for 30 us: the products expand about
 * 35-fold into vacuum (the cutoffs of the EOS at low density, and no NaN anywhere). */
START_TEST(test_c4_slab_vacuum)
{
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "c4vac");
  snprintf(scene, sizeof scene, "%s/slab.yaml", dir);
  snprintf(out, sizeof out, "%s/slab.h5", dir);
  char text[2048];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 1\ntime: {end: 30 us, cfl: 0.3}\noutput: {file: slab.h5}\n%s"
           "sets:\n  slab: {method: sph, material: c4, shape: {box: {min: [0], max: [0.01]}}, spacing: 0.1 mm}\n",
           C4_MATERIAL);
  vrun_write(scene, text);
  vrun r;
  c4_open(&r, scene, out);
  vrun_run(&r);
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho"), *p = ej_set_field(s, "p");
  const ej_real *e = ej_set_field(s, "e"), *burn = ej_set_field(s, "burn");
  double xmin = INFINITY, xmax = -INFINITY, rmin = INFINITY;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    ck_assert(isfinite(x[3 * i]) && isfinite(rho[i]) && isfinite(p[i]) && isfinite(e[i]));
    ck_assert(rho[i] > 0 && p[i] >= 0);
    ck_assert(burn[i] == 1.0);
    xmin = fmin(xmin, x[3 * i]), xmax = fmax(xmax, x[3 * i]), rmin = fmin(rmin, rho[i]);
  }
  const double balance = fabs(r.sim->energy.balance) / r.sim->energy.total0;
  fprintf(stderr, "c4 slab in vacuum: extent %.4f m (initial 0.01), min rho %.1f kg/m^3, energy balance %.2e\n",
          xmax - xmin, rmin, balance);
  ck_assert(xmax - xmin > 0.2);
  ck_assert_msg(balance < 0.01, "energy balance %g", balance);
  vrun_free(&r);
  const char *names[] = {"slab.yaml", "slab.h5", "slab.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_c4rod");
  TCase *tc = tcase_create("c4_rod_1d");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_c4_rod_front);
  tcase_add_test(tc, test_c4_slab_vacuum);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
