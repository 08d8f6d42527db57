/* sph with geometry: spherical (1D, x = r): plugins/methods/sph/README.md "Spherical symmetry".
 *  - a uniform gas at rest stays at rest to round-off (uniform line mass, mirror ghosts at r = 0 and
 *    at the outer wall), and the shell masses are rho 4 pi r^2 dx;
 *  - a Sedov-Taylor point blast follows R = xi0 (E t^2/rho)^(1/5), xi0 = 1.0328 for gamma = 1.4 (the
 *    3D constant of validation/sedov, sedov_exact.py), within 3 %, and the total energy
 *    sum m (v^2/2 + e) stated (the viscous terms conserve it exactly, the local geometric pdV term
 *    -2 (p/rho) v/r does not: README);
 *  - with spherical_energy: pair (sph pairs and continuum's cross-set pairs in the exact pair form
 *    away from the axis) a hot shell between two coupled sets conserves sum m (v^2/2 + e) to the
 *    time integration's error, 30x better than the local form;
 *  - the jwl programmed burn lights a TNT sphere at r/D from the centre and holds m e0;
 *  - dimension != 1 and unsupported options are rejected with a located message. */
#include "validation_common.h"

const ej_plugin_info *ej_plugin_jwl_info(void);
const ej_plugin_info *ej_plugin_continuum_info(void);

#define SPH_PI 3.14159265358979323846

static ej_err sc_open(vscene *c, const char *tag, const char *fmt, ...)
{
  const ej_plugin_info *pl[3] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info(), ej_plugin_jwl_info()};
  va_list ap;
  va_start(ap, fmt);
  const ej_err rc = vscene_open(c, tag, pl, 3, fmt, ap);
  va_end(ap);
  return rc;
}

static ej_err sc_open_pl(vscene *c, const char *tag, const ej_plugin_info *const *pl, int np, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  const ej_err rc = vscene_open(c, tag, pl, np, fmt, ap);
  va_end(ap);
  return rc;
}

/* ------------------------------------------------------------------ uniform gas at rest */

START_TEST(test_static)
{
  vscene c;
  const double dx = 0.01, R = 1.0, rho0 = 1.225, p0 = 101325.0;
  ej_err rc = sc_open(&c, "sphsph_static",
                      "ejecta: 1\ndimension: 1\ntime: {end: 0.01, cfl: 0.3}\n"
                      "output: {file: o.h5, every: 1}\n"
                      "materials:\n  air: {rho0: 1.225, eos: {model: ideal_gas, gamma: 1.4}}\n"
                      "sets:\n  air: {method: sph, material: air, geometry: spherical,\n"
                      "        shape: {box: {min: [0], max: [%g]}}, spacing: %g, p: %g}\n"
                      "boundaries:\n  - symmetry: {point: [0], normal: [1]}\n"
                      "  - symmetry: {point: [%g], normal: [-1]}\n",
                      R, dx, p0, R);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const ej_set *s = c.r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ck_assert_int_eq(n, 100);
  const ej_real *x = ej_set_field(s, "x"), *m = ej_set_field(s, "m");
  double M = 0;
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert_double_eq_tol(m[i], rho0 * dx * 4 * SPH_PI * x[3 * i] * x[3 * i], 1e-12 * m[i]);
    M += m[i];
  }
  /* midpoint shells: 1/(4 N^2) less than the sphere */
  const double Ms = rho0 * 4.0 / 3.0 * SPH_PI * R * R * R;
  ck_assert_double_eq_tol(M / Ms, 1.0 - 1.0 / (4.0 * n * n), 1e-12);
  vrun_run(&c.r);
  s = c.r.sim->sets[0];
  x = ej_set_field(s, "x");
  const ej_real *v = ej_set_field(s, "v"), *rho = ej_set_field(s, "rho"), *mu = ej_set_field(s, "m_line");
  const double cs = sqrt(1.4 * p0 / rho0);
  double vmax = 0, drho = 0, dmu = 0;
  for (ej_idx i = 0; i < n; ++i) {
    vmax = fmax(vmax, fabs(v[3 * i]));
    drho = fmax(drho, fabs(rho[i] - rho0) / rho0);
    dmu = fmax(dmu, fabs(mu[i] - rho0 * dx) / (rho0 * dx));
  }
  fprintf(stderr, "spherical static: %lld steps, max |v|/c = %.3g, max |drho|/rho = %.3g, line mass spread %.3g\n",
          (long long)c.r.sim->step, vmax / cs, drho, dmu);
  ck_assert_int_gt(c.r.sim->step, 100);
  ck_assert_msg(vmax / cs < 1e-12, "uniform gas moved: max |v|/c = %g", vmax / cs);
  /* the round-off of the -2 rho v / r term, accumulated over the steps (measured 2.4e-12) */
  ck_assert_msg(drho < 1e-10, "uniform gas density changed by %g", drho);
  vscene_free(&c);
}
END_TEST

/* ------------------------------------------------------------------ Sedov-Taylor */

#define SEDOV_XI0 1.03278 /* gamma = 1.4, validation/sedov/sedov_exact.py */

/* Runs the 1D spherical Sedov blast at spacing dx to t_end; returns the shock radius error
 * (leading-edge mid-height of the density, as validation/sedov) and the energy errors. */
static void sedov_run(double dx, double t_end, double *err_R, double *bal, double *e_err)
{
  vscene c;
  const double L = 0.5;
  /* energy 1 J in the 8 particles within 8 dx of the centre (as validation/sedov deposits over a
   * few spacings): e per unit mass of their shells */
  const double r_dep = 8.0 * dx;
  double m_dep = 0;
  for (int i = 0; i < 8; ++i) m_dep += 4 * SPH_PI * ((i + 0.5) * dx) * ((i + 0.5) * dx) * dx;
  const double e_dep = 1.0 / m_dep;
  ej_err rc = sc_open(&c, "sphsph_sedov",
                      "ejecta: 1\ndimension: 1\ntime: {end: %.17g, cfl: 0.3}\n"
                      "output: {file: o.h5, every: 1}\n"
                      "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                      "sets:\n  gas:\n    method: sph\n    material: gas\n    geometry: spherical\n"
                      "    shape: {box: {min: [0], max: [%g]}}\n    spacing: %.17g\n    rho: 1\n    e: 2.5e-6\n"
                      "    initial: [{region: {box: {min: [0], max: [%.17g]}}, e: %.17g}]\n"
                      "boundaries:\n  - symmetry: {point: [0], normal: [1]}\n"
                      "  - symmetry: {point: [%g], normal: [-1]}\n",
                      t_end, L, dx, r_dep, e_dep, L);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const double total0 = c.r.sim->energy.total0;
  vrun_run(&c.r);
  const ej_set *s = c.r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_real *x = ej_set_field(s, "x"), *rho = ej_set_field(s, "rho"), *v = ej_set_field(s, "v");
  const ej_real *e = ej_set_field(s, "e"), *m = ej_set_field(s, "m");
  /* particles in radial order (the core keeps cell order, which in 1D is x order, but do not rely on it) */
  double *rx = calloc((size_t)n + 1, sizeof(double)), *rr = calloc((size_t)n + 1, sizeof(double));
  ck_assert_ptr_nonnull(rx);
  ck_assert_ptr_nonnull(rr);
  double E = 0;
  for (ej_idx i = 0; i < n; ++i) {
    rx[i] = x[3 * i], rr[i] = rho[i];
    E += m[i] * (0.5 * v[3 * i] * v[3 * i] + e[i]);
  }
  for (ej_idx i = 1; i < n; ++i) /* insertion sort: nearly sorted */
    for (ej_idx j = i; j > 0 && rx[j - 1] > rx[j]; --j) {
      double t = rx[j]; rx[j] = rx[j - 1]; rx[j - 1] = t;
      t = rr[j]; rr[j] = rr[j - 1]; rr[j - 1] = t;
    }
  ej_idx ip = 0;
  for (ej_idx i = 0; i < n; ++i)
    if (rr[i] > rr[ip]) ip = i;
  const double half = 0.5 * (rr[ip] + 1.0);
  double R = rx[ip];
  for (ej_idx i = ip + 1; i < n; ++i)
    if (rr[i] <= half) {
      R = rx[i - 1] + (rr[i - 1] - half) / (rr[i - 1] - rr[i]) * (rx[i] - rx[i - 1]);
      break;
    }
  const double Eb = total0; /* 1 J deposit + background */
  const double Re = SEDOV_XI0 * pow(Eb * t_end * t_end / 1.0, 0.2);
  *err_R = (R - Re) / Re;
  *bal = fabs(c.r.sim->energy.balance) / total0;
  *e_err = fabs(E - total0) / total0;
  fprintf(stderr,
          "spherical sedov dx %g: %lld steps, E0 %.6f J, R = %.4f m (peak %.3f at %.4f), exact %.4f m: %+.2f %%; "
          "|balance|/total0 %.2e, |sum m (v^2/2 + e) - E0|/E0 %.2e\n",
          dx, (long long)c.r.sim->step, total0, R, rr[ip], rx[ip], Re, 100 * *err_R, *bal, *e_err);
  free(rx), free(rr);
  vscene_free(&c);
}

START_TEST(test_sedov)
{
  double eR, bal, eE;
  sedov_run(0.001, 0.05, &eR, &bal, &eE);
  ck_assert_msg(fabs(eR) <= 0.03, "shock radius error %+.2f %% (tolerance 3 %%)", 100 * eR);
  /* The local geometric pdV term is not exactly conservative next to r = 0 (README "Spherical
   * symmetry"): measured |balance|/E0 1.5e-2 at t = 0.05 s (6.1e-2 at its largest, t = 1 ms, while
   * the blast is a few h wide). Regression guard on the end value. */
  ck_assert_msg(eE <= 0.025 && bal <= 0.025, "energy error %g, balance %g (guard 2.5e-2)", eE, bal);
}
END_TEST

/* ------------------------------------------------------------------ spherical_energy: pair */

/* A hot layer r in [0.65, 0.75] m in a spherical shell [0.3, 1.2] m, cut at r = 0.7 into two sets
 * coupled by `continuum` (each set geometry: spherical); no particle is near the axis, the waves do
 * not reach the walls by t_end. Returns |sum m (v^2/2 + e) - E0| over the energy of the hot layer
 * above the cold gas. With `pair` the pdV work of sph's pairs and of continuum's cross-set pairs
 * is the exact pair form: only the time integration error remains; `local` is not conservative. */
static double shell_energy_error(const char *form)
{
  vscene c;
  const ej_plugin_info *pl[3] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info(), ej_plugin_continuum_info()};
  const char *fmt =
      "ejecta: 1\ndimension: 1\ntime: {end: 0.06, cfl: 0.3}\n"
      "output: {file: o.h5, every: 1}\n"
      "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
      "sets:\n"
      "  inner: {method: sph, material: gas, geometry: spherical, spherical_energy: %s, renormalize: false,\n"
      "          shape: {box: {min: [0.3], max: [0.7]}}, spacing: 0.0025, rho: 1, e: 2.5,\n"
      "          initial: [{region: {box: {min: [0.65], max: [0.71]}}, e: 25}]}\n"
      "  outer: {method: sph, material: gas, geometry: spherical, spherical_energy: %s, renormalize: false,\n"
      "          shape: {box: {min: [0.7], max: [1.2]}}, spacing: 0.0025, rho: 1, e: 2.5,\n"
      "          initial: [{region: {box: {min: [0.69], max: [0.75]}}, e: 25}]}\n"
      "interactions:\n  - {model: continuum, sets: [inner, outer]}\n"
      "boundaries:\n  - symmetry: {point: [0.3], normal: [1]}\n  - symmetry: {point: [1.2], normal: [-1]}\n";
  ej_err rc = sc_open_pl(&c, "sphsph_shell", pl, 3, fmt, form, form);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const double total0 = c.r.sim->energy.total0;
  const double ehot = 4 * SPH_PI / 3 * (0.75 * 0.75 * 0.75 - 0.65 * 0.65 * 0.65) * (25 - 2.5);
  vrun_run(&c.r);
  double E = 0, vmax_wall = 0;
  for (int k = 0; k < 2; ++k) {
    const ej_set *s = c.r.sim->sets[k];
    const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v"), *e = ej_set_field(s, "e");
    const ej_real *m = ej_set_field(s, "m");
    for (ej_idx i = 0; i < ej_set_count(s); ++i) {
      E += m[i] * (0.5 * v[3 * i] * v[3 * i] + e[i]);
      if (x[3 * i] < 0.35 || x[3 * i] > 1.15) vmax_wall = fmax(vmax_wall, fabs(v[3 * i]));
    }
  }
  const double err = fabs(E - total0) / ehot;
  fprintf(stderr, "spherical shell, spherical_energy %s: %lld steps, |E - E0| / E_hot = %.2e (hot layer %.4f J), "
          "max |v| near the walls %.2e\n", form, (long long)c.r.sim->step, err, ehot, vmax_wall);
  ck_assert_msg(vmax_wall < 1e-6, "waves reached the walls: |v| %g", vmax_wall);
  vscene_free(&c);
  return err;
}

START_TEST(test_pair_energy)
{
  const double e_pair = shell_energy_error("pair"), e_local = shell_energy_error("local");
  /* measured (dx 2.5 mm, 0.06 s, 501 steps): pair 1.06e-5 (the time integration's error), local
   * 3.12e-4 of the hot layer's energy; guard 5e-5 on pair */
  ck_assert_msg(e_pair < 5e-5, "pair form energy error %g", e_pair);
  ck_assert_msg(e_local > 10 * e_pair, "local form %g not worse than the pair form %g", e_local, e_pair);
}
END_TEST

/* ------------------------------------------------------------------ jwl burn in 1D spherical */

START_TEST(test_jwl_burn)
{
  vscene c;
  const double r0 = 0.0527, dx = r0 / 40, D = 6930.0, t_end = 4e-6;
  ej_err rc = sc_open(&c, "sphsph_jwl",
                      "ejecta: 1\ndimension: 1\ntime: {end: %.17g, cfl: 0.3}\n"
                      "output: {file: o.h5, every: 1}\n"
                      "materials:\n  tnt:\n    rho0: 1630\n"
                      "    eos: {model: jwl, A: 3.712e11, B: 3.231e9, R1: 4.15, R2: 0.95, omega: 0.30, rho0: 1630,\n"
                      "          e0: 4.29e6, detonation: {point: [0, 0, 0], speed: %g}}\n"
                      "sets:\n  charge: {method: sph, material: tnt, geometry: spherical, h_max: 4, rho_min: 1e-4,\n"
                      "           shape: {box: {min: [0], max: [%.17g]}}, spacing: %.17g}\n"
                      "boundaries:\n  - symmetry: {point: [0], normal: [1]}\n",
                      t_end, D, r0, dx);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const ej_set *s = c.r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_real *x = ej_set_field(s, "x"), *tl = ej_set_field(s, "t_light"), *m = ej_set_field(s, "m");
  double M = 0;
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert_double_eq_tol(tl[i], x[3 * i] / D, 1e-15);
    M += m[i];
  }
  const double Ms = 1630.0 * 4.0 / 3.0 * SPH_PI * r0 * r0 * r0;
  ck_assert_double_eq_tol(M / Ms, 1.0 - 1.0 / (4.0 * n * n), 1e-12);
  ck_assert_double_eq_tol(c.r.sim->energy.total0, M * 4.29e6, 1e-9 * M * 4.29e6);
  vrun_run(&c.r);
  s = c.r.sim->sets[0];
  x = ej_set_field(s, "x");
  const ej_real *burn = ej_set_field(s, "burn"), *v = ej_set_field(s, "v"), *p = ej_set_field(s, "p");
  tl = ej_set_field(s, "t_light");
  int burnt = 0, lit_wrong = 0, ahead_moving = 0;
  double pmax = 0, bmax_ahead = 0;
  for (ej_idx i = 0; i < n; ++i) {
    if (burn[i] >= 1.0) ++burnt;
    /* lighting times are set once from the initial radius: the front is at D t. The volume burn
     * (jwl README) ignites explosive compressed by the viscous precursor of the front (measured
     * 0.9 % burnt 4 spacings ahead); 8 spacings ahead (almost) nothing burns and nothing moves */
    if (tl[i] > t_end + 8 * dx / D && burn[i] > 1e-3) ++lit_wrong;
    if (tl[i] > t_end + 8 * dx / D) bmax_ahead = fmax(bmax_ahead, burn[i]);
    if (tl[i] > t_end + 8 * dx / D && fabs(v[3 * i]) > 1.0) ++ahead_moving;
    pmax = fmax(pmax, p[i]);
  }
  const double bal = fabs(c.r.sim->energy.balance) / c.r.sim->energy.total0;
  fprintf(stderr, "spherical jwl: %d of %d burnt at t = %g (front at %.1f of %d spacings), p max %.3g GPa, "
                  "balance %.2e, largest burn fraction 8+ spacings ahead of the front %.2e\n", burnt, (int)n, t_end, D * t_end / dx,
          (int)n, pmax / 1e9, bal, bmax_ahead);
  ck_assert_int_eq(lit_wrong, 0);
  ck_assert_int_eq(ahead_moving, 0);
  /* D t / dx = 21 spacings, burn ramp 2 spacings (jwl burn_width default): 18-21 fully burnt */
  ck_assert_msg(burnt >= 17 && burnt <= 21, "burnt %d", burnt);
  ck_assert_msg(pmax > 5e9 && pmax < 40e9, "peak pressure %g (CJ 21 GPa)", pmax);
  /* measured 8.0e-4 (the local geometric pdV term is not exactly conservative: README) */
  ck_assert_msg(bal < 2e-3, "energy balance %g", bal);
  vscene_free(&c);
}
END_TEST

/* ------------------------------------------------------------------ rejections */

START_TEST(test_reject)
{
  vscene c;
  /* dimension 2: refused by create, located at the set */
  ej_err rc = sc_open(&c, "sphsph_rej",
                      "ejecta: 1\ndimension: 2\ntime: {end: 0.01}\n"
                      "materials:\n  air: {rho0: 1.225, eos: {model: ideal_gas, gamma: 1.4}}\n"
                      "sets:\n  air: {method: sph, material: air, geometry: spherical,\n"
                      "        shape: {box: {min: [0, 0], max: [0.1, 0.1]}}, spacing: 0.02, p: 1e5}\n");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_ptr_nonnull(strstr(f->msg, "geometry: spherical needs dimension: 1"));
  ck_assert_ptr_nonnull(f->where.file);
  ck_assert_int_eq(f->where.line, 7);
  ej_error_clear();
  vscene_free(&c);
  /* density: summation with spherical: refused by check_config (the set block) */
  rc = sc_open(&c, "sphsph_rej2",
               "ejecta: 1\ndimension: 1\ntime: {end: 0.01}\n"
               "materials:\n  air: {rho0: 1.225, eos: {model: ideal_gas, gamma: 1.4}}\n"
               "sets:\n  air: {method: sph, material: air, geometry: spherical, density: summation,\n"
               "        shape: {box: {min: [0], max: [0.1]}}, spacing: 0.02, p: 1e5}\n");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_ptr_nonnull(strstr(f->msg, "density: continuity only"));
  ck_assert_int_eq(f->where.line, 7);
  ej_error_clear();
  vscene_free(&c);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("sph_spherical");
  TCase *tc = tcase_create("spherical");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_static);
  tcase_add_test(tc, test_reject);
  tcase_add_test(tc, test_jwl_burn);
  tcase_add_test(tc, test_sedov);
  tcase_add_test(tc, test_pair_energy);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
