/* C4 products expanding into air in 1D (validation/c4_air, short version): the hard case of the
 * explosives issue, density ratio 1601 / 1.2 = 1334. A 10 mm C4 slab (JWL, digest 001 Table 1,
 * programmed burn lit at x = 0, symmetry plane there) against air (ideal gas, gamma 1.4,
 * 101325 Pa) in two sets coupled by `continuum` (volume pair form), both sph (kernel gradient with
 * renormalize_interfaces, or the shape tensor) or both ulpd,
 * dx = 0.1 mm, 6 us (the front at 0.2 mm is too smeared for the 10 % velocity check:
 * check.py measured -11.9 % there, -0.2 % at 0.1 mm).
 *
 * Checks: no NaN/inf, density > 0 everywhere, max |balance| over all steps below 1 % of the
 * initial total energy (/series/energy/balance), and the air shock right after the detonation
 * reaches the interface: peak air pressure over 1.25..3 us within 15 % of p* = 84.28 MPa, peak
 * air velocity within 10 % of u* = 7640 m/s. p*, u*: Riemann problem between the CJ state of these
 * JWL parameters and air at rest (validation/c4_air/riemann.py: JWL isentrope through the CJ point
 * against an ideal-gas shock, Toro ch. 4). Measured: see validation/c4_air/README.md. */
#include <hdf5.h>

#include "validation_common.h"

const ej_plugin_info *ej_plugin_jwl_info(void);
const ej_plugin_info *ej_plugin_ulpd_info(void);
const ej_plugin_info *ej_plugin_continuum_info(void);

#define C4AIR_P_STAR 84.28e6
#define C4AIR_U_STAR 7640.0

static const char C4AIR_SCENE[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 6 us, cfl: 0.3}\n"
    "output: {file: c4air.h5, every: 0.25 us, fields: [v, rho, p, e]}\n"
    "materials:\n  c4:\n    rho0: 1601\n    eos: {model: jwl, A: 6.098e11, B: 1.3e10, R1: 4.5, R2: 1.4, omega: 0.25,\n"
    "          rho0: 1601, e0: 5.621e6, detonation: {point: [0, 0, 0], speed: 8193}}\n"
    "  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  charge: {method: %s, material: c4, shape: {box: {min: [0], max: [0.01]}}, spacing: 0.1 mm}\n"
    "  air: {method: %s, material: air, shape: {box: {min: [0.01], max: [0.08]}}, spacing: 0.1 mm, p: 101325}\n"
    "interactions:\n  - {model: continuum, sets: [charge, air]}\n"
    "boundaries:\n  - symmetry: {point: [0], normal: [1]}\n  - symmetry: {point: [0.08], normal: [-1]}\n";

static double c4air_attr(hid_t f, const char *path, const char *name)
{
  hid_t g = H5Oopen(f, path, H5P_DEFAULT);
  ck_assert_int_ge(g, 0);
  hid_t a = H5Aopen(g, name, H5P_DEFAULT);
  double t = 0;
  ck_assert_int_ge(H5Aread(a, H5T_NATIVE_DOUBLE, &t), 0);
  H5Aclose(a);
  H5Oclose(g);
  return t;
}

/* Reads a 1-D or 2-D double dataset into buf (at most cap doubles); returns the row count. */
static int c4air_read(hid_t f, const char *path, double *buf, int cap)
{
  hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
  ck_assert_int_ge(d, 0);
  hid_t sp = H5Dget_space(d);
  hsize_t dims[2] = {0, 1};
  const int nd = H5Sget_simple_extent_dims(sp, dims, NULL);
  ck_assert_int_le((int)(dims[0] * (nd > 1 ? dims[1] : 1)), cap);
  ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf), 0);
  H5Sclose(sp);
  H5Dclose(d);
  return (int)dims[0];
}

/* Loads and runs the scene file into out with every plugin these tests use, one thread; returns the
 * initial total energy. */
static double c4air_sim(const char *scene, const char *out)
{
  vrun r;
  memset(&r, 0, sizeof r);
  ck_assert_int_eq(ej_registry_create(&r.reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_ulpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_ideal_gas_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_jwl_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_continuum_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene, r.reg, &r.scene);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 1};
  rc = ej_sim_create(r.scene, r.reg, &opts, &r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  vrun_run(&r);
  const double total0 = r.sim->energy.total0;
  vrun_free(&r);
  return total0;
}

/* method: the method and its options as they go into the set's flow mapping ("sph, ..."). */
static void c4air_run(const char *method, bool check_peak_p, bool check_peak_u)
{
  char dir[64], scene[128], out[128], text[2048];
  vrun_dir(dir, sizeof dir, "c4air");
  snprintf(scene, sizeof scene, "%s/c4air.yaml", dir);
  snprintf(out, sizeof out, "%s/c4air.h5", dir);
  snprintf(text, sizeof text, C4AIR_SCENE, method, method);
  vrun_write(scene, text);
  const double total0 = c4air_sim(scene, out);

  enum { CAP = 1 << 20 };
  double *buf = malloc(CAP * sizeof *buf);
  ck_assert_ptr_nonnull(buf);
  hid_t f = H5Fopen(out, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  /* energy balance over every step */
  const int nsteps = c4air_read(f, "/series/energy/balance", buf, CAP);
  double bal = 0;
  for (int k = 0; k < nsteps; ++k) bal = fmax(bal, fabs(buf[k]) / total0);
  /* frames: robustness everywhere, air peak in the window after arrival (t = 1.22 us) */
  double rho_min = INFINITY, p_air = 0, u_air = 0;
  int nonfinite = 0, nframes = 0;
  for (int k = 0; k < 1000; ++k) {
    char fp[64], path[128];
    snprintf(fp, sizeof fp, "/frames/%06d", k);
    if (H5Lexists(f, fp, H5P_DEFAULT) <= 0) break;
    ++nframes;
    const double t = c4air_attr(f, fp, "time");
    const bool in_win = t >= 1.25e-6 - 1e-12 && t <= 3e-6 + 1e-12;
    static const char *const sets[] = {"charge", "air"};
    for (int s = 0; s < 2; ++s) {
      snprintf(path, sizeof path, "%s/%s/rho", fp, sets[s]);
      const int n = c4air_read(f, path, buf, CAP);
      for (int i = 0; i < n; ++i) nonfinite += !isfinite(buf[i]), rho_min = fmin(rho_min, buf[i]);
      snprintf(path, sizeof path, "%s/%s/p", fp, sets[s]);
      c4air_read(f, path, buf, CAP);
      for (int i = 0; i < n; ++i) {
        nonfinite += !isfinite(buf[i]);
        if (s == 1 && in_win) p_air = fmax(p_air, buf[i]);
      }
      snprintf(path, sizeof path, "%s/%s/v", fp, sets[s]);
      c4air_read(f, path, buf, CAP);
      for (int i = 0; i < 3 * n; ++i) nonfinite += !isfinite(buf[i]);
      if (s == 1 && in_win)
        for (int i = 0; i < n; ++i) u_air = fmax(u_air, buf[3 * i]);
    }
  }
  H5Fclose(f);
  free(buf);
  fprintf(stderr,
          "c4 into air (%s, dx 0.1 mm, 6 us, %d steps): non-finite %d, min rho %.4g kg/m^3, max |balance|/total0 "
          "%.3e, air peak p %.2f MPa (p* 84.28), air peak v %.0f m/s (u* 7640)\n",
          method, nsteps, nonfinite, rho_min, bal, p_air / 1e6, u_air);
  ck_assert_int_ge(nframes, 24);
  ck_assert_int_eq(nonfinite, 0);
  ck_assert(rho_min > 0);
  ck_assert_msg(bal < 0.01, "energy balance %g", bal);
  if (check_peak_p) ck_assert_msg(fabs(p_air / C4AIR_P_STAR - 1) <= 0.15, "air peak pressure %g Pa", p_air);
  if (check_peak_u) ck_assert_msg(fabs(u_air / C4AIR_U_STAR - 1) <= 0.10, "air peak velocity %g m/s", u_air);
  const char *names[] = {"c4air.yaml", "c4air.h5", "c4air.xdmf"};
  vrun_cleanup(dir, names, 3);
}

/* sph as examples/c4_air_1d.yaml: both sets renormalise their continuity across the interface */
START_TEST(test_c4_air_sph) { c4air_run("sph, renormalize_interfaces: true", true, true); }
END_TEST

START_TEST(test_c4_air_ulpd) { c4air_run("ulpd", true, true); }
END_TEST

/* The shape-tensor gradient on both sets: the hard case's criteria (no NaN, rho > 0, balance
 * < 1 %); its first air shock overshoots the Riemann state (+81.7 % in pressure, +29.1 % in
 * velocity, here and in validation/c4_air's 30 us run), so the peaks are printed, not asserted.
 * The cause is the density contact: a start-up offset at ratio 1334, and with the default
 * symmetric continuity a steady +10 % at ratio 133 (validation/c4_air README "The shape tensor at
 * a density contact"; test_shape_density_contact below). */
START_TEST(test_c4_air_shape_tensor) { c4air_run("sph, gradient: shape_tensor", false, false); }
END_TEST

/* The recommendation of that README section, checked: an ideal-gas tube 1601 kg/m^3 at 1 GPa | 12 kg/m^3
 * at 101325 Pa (density ratio 133, gamma 1.4), two sph sets with the shape tensor and
 * shape_continuity: own, coupled by continuum, spacing 0.5 mm. Exact (validation/sod/exact.py): p* =
 * 41.983 MPa, shock speed U_s = 2049.39 m/s. Shock = the largest x where p > (p* + p_R)/2; its speed
 * between the first output (t_end/4) and the last, which leaves out the start-up of the sharp jump,
 * within 3 % of U_s. Measured (validation/c4_air/shape_ratio.py's scene at 0.5 mm): +0.9 %; the
 * default shape_continuity: symmetric gives +14.7 % here. */
#define C4AIR_GAS_SCENE                                                                                              \
  "ejecta: 1\ndimension: 1\ntime: {end: 19.518 us, cfl: 0.3}\n"                                                  \
  "output: {file: gas.h5, every: 4.8795 us, fields: [v, rho, p, e]}\n"                                             \
  "materials:\n  heavy: {rho0: 1601, eos: {model: ideal_gas, gamma: 1.4}}\n"                                       \
  "  light: {rho0: 12, eos: {model: ideal_gas, gamma: 1.4}}\n"                                                      \
  "sets:\n"                                                                                                         \
  "  hp: {method: sph, gradient: shape_tensor, shape_continuity: own, material: heavy,\n"                          \
  "       shape: {box: {min: [-0.05], max: [0]}}, spacing: 0.5 mm, p: 1 GPa}\n"                                    \
  "  air: {method: sph, gradient: shape_tensor, shape_continuity: own, material: light,\n"                         \
  "        shape: {box: {min: [0], max: [0.15]}}, spacing: 0.5 mm, p: 101325}\n"                                   \
  "interactions:\n  - {model: continuum, sets: [hp, air]}\n"                                                       \
  "boundaries:\n  - symmetry: {point: [-0.05], normal: [1]}\n  - symmetry: {point: [0.15], normal: [-1]}\n"

START_TEST(test_shape_density_contact)
{
  const double p_star = 41.983e6, u_s = 2049.39, p_half = 0.5 * (p_star + 101325.0);
  char dir[64], scene[128], out[128];
  vrun_dir(dir, sizeof dir, "c4gas");
  snprintf(scene, sizeof scene, "%s/gas.yaml", dir);
  snprintf(out, sizeof out, "%s/gas.h5", dir);
  vrun_write(scene, C4AIR_GAS_SCENE);
  c4air_sim(scene, out);

  enum { CAP = 1 << 16 };
  double *xb = malloc(3 * CAP * sizeof *xb), *pb = malloc(CAP * sizeof *pb);
  ck_assert(xb && pb);
  hid_t f = H5Fopen(out, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  double t[5] = {0}, xs[5] = {0};
  for (int k = 1; k <= 4; ++k) {
    char fp[64], path[128];
    snprintf(fp, sizeof fp, "/frames/%06d", k);
    ck_assert_int_gt(H5Lexists(f, fp, H5P_DEFAULT), 0);
    t[k] = c4air_attr(f, fp, "time");
    xs[k] = -INFINITY;
    static const char *const sets[] = {"hp", "air"};
    for (int s = 0; s < 2; ++s) {
      snprintf(path, sizeof path, "%s/%s/x", fp, sets[s]);
      const int n = c4air_read(f, path, xb, 3 * CAP);
      snprintf(path, sizeof path, "%s/%s/p", fp, sets[s]);
      ck_assert_int_eq(c4air_read(f, path, pb, CAP), n);
      for (int i = 0; i < n; ++i)
        if (pb[i] > p_half) xs[k] = fmax(xs[k], xb[3 * i]);
    }
  }
  H5Fclose(f);
  free(xb);
  free(pb);
  const double speed = (xs[4] - xs[1]) / (t[4] - t[1]);
  fprintf(stderr,
          "ideal gas 1601 | 12 kg/m^3, shape tensor with shape_continuity: own, dx 0.5 mm: shock at %.2f / %.2f mm "
          "(t %.3f / %.3f us), speed %.1f m/s (exact %.1f, %+.2f %%)\n",
          1e3 * xs[1], 1e3 * xs[4], 1e6 * t[1], 1e6 * t[4], speed, u_s, 100 * (speed / u_s - 1));
  ck_assert_msg(fabs(speed / u_s - 1) <= 0.03, "steady shock speed %g m/s against %g", speed, u_s);
  const char *names[] = {"gas.yaml", "gas.h5", "gas.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("validation_c4air");
  TCase *tc = tcase_create("c4_air_1d");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_c4_air_sph);
  tcase_add_test(tc, test_c4_air_ulpd);
  tcase_add_test(tc, test_c4_air_shape_tensor);
  tcase_add_test(tc, test_shape_density_contact);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
