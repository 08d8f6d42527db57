/* Interface impedance test of pd_sph (issue "coupled blast"), the 1D case of
 * validation/pd_sph_impedance/check.py as a unit test (about 5 s): a cos^2 velocity pulse in a
 * tlpd bar (E = 1 GPa, rho 2000, nu 0) crosses into an sph fluid (linear polynomial EOS,
 * renormalize: false) through pd_sph (form pairwise, pair_stress owned, the default).
 * Linear acoustics: transmitted T = 2 Z2/(Z1 + Z2), reflected R = (Z2 - Z1)/(Z1 + Z2) times the
 * incident stress -Z1 v0/2; tolerance 3 % on both, for Z2/Z1 = 0.354 and 2.83. The forms
 * pair_stress fluid and both are run too and must fail it (the reason `owned` exists). */
#include <check.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_pd_sph_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);

static ej_err imp_open(vscene *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(),  ej_plugin_ideal_gas_info(), ej_plugin_pd_sph_info(),
                               ej_plugin_tlpd_info(), ej_plugin_elastic_info(),   ej_plugin_polynomial_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "pdsph_imp", p, 6, fmt, ap);
  va_end(ap);
  return rc;
}

static ej_set *imp_set(vscene *c, const char *name) { return vsim_set(c->r.sim, name); }

/* Runs one case; returns T and R relative to the exact incident stress -Z1 v0 / 2. */
static void imp_case_dx(double rho2, double K2, const char *pair_stress, double dx, double fluid_h, double hg_coef,
                        double *T, double *R)
{
  const double v0 = 1.0, W = 0.1, xc = 0.35;
  const double c1 = sqrt(1e9 / 2000.0), c2 = sqrt(K2 / rho2), Z1 = sqrt(1e9 * 2000.0);
  const double t_hit = 0.15 / c1, t_end = fmin(t_hit + 0.2 / c2, t_hit + 0.12 / c1);
  static char init[16384];
  size_t len = 0;
  const int n = (int)lround(W / dx);
  for (int k = 0; k < n; ++k) {
    const double a = xc - W / 2 + k * dx, b = a + dx, xm = 0.5 * (a + b);
    const double v = v0 * pow(cos(M_PI * (xm - xc) / W), 2);
    len += (size_t)snprintf(init + len, sizeof init - len,
                            "      - {region: {box: {min: [%.9g], max: [%.9g]}}, velocity: [%.9g]}\n", a, b, v);
    ck_assert_uint_lt(len, sizeof init);
  }
  vscene c;
  ej_err rc = imp_open(&c,
                       "ejecta: 1\ndimension: 1\ntime: {end: %.6g, cfl: 0.4}\noutput: {file: out.h5}\n"
                       "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.0}\n"
                       "  fluid: {rho0: %g, eos: {model: polynomial, rho0: %g, C1: %g}}\n"
                       "sets:\n  bar:\n    method: tlpd\n    material: rock\n    shape: {box: {min: [0], max: [0.5]}}\n"
                       "    hourglass_coefficient: %g\n    spacing: %g\n    initial:\n%s"
                       "  fluid:\n    method: sph\n    material: fluid\n    alpha: 0\n    beta: 0\n"
                       "    renormalize: false\n    h_factor: %g\n    shape: {box: {min: [0.5], max: [1.0]}}\n"
                       "    spacing: %g\n"
                       "interactions:\n  - {model: pd_sph, sets: [bar, fluid], alpha: 0, beta: 0, pair_stress: %s}\n",
                       t_end, rho2, rho2, K2, hg_coef, dx, init, fluid_h, dx, pair_stress);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  vrun_run(&c.r);
  ej_set *bar = imp_set(&c, "bar"), *fl = imp_set(&c, "fluid");
  const ej_real *xb = ej_set_field(bar, "x"), *sb = ej_set_field(bar, "stress");
  const ej_real *xf = ej_set_field(fl, "x"), *pf = ej_set_field(fl, "p");
  double sr = 0, st = 0;
  for (ej_idx i = 0; i < bar->n; ++i) /* reflected: between the free-end echo and the interface */
    if (xb[3 * i] > 0.15 && xb[3 * i] < 0.48 && fabs(sb[6 * i]) > fabs(sr)) sr = sb[6 * i];
  for (ej_idx i = 0; i < fl->n; ++i) /* transmitted: away from the interface */
    if (xf[3 * i] > 0.52 && fabs(pf[i]) > fabs(st)) st = -pf[i];
  const double sig_i = -Z1 * v0 / 2;
  *T = st / sig_i;
  *R = sr / sig_i;
  const double Z2 = sqrt(K2 * rho2), Te = 2 * Z2 / (Z1 + Z2), Re = (Z2 - Z1) / (Z1 + Z2);
  fprintf(stderr,
          "pair_stress %-27s dx %g mm, fluid h %g dx: Z2/Z1 = %.3f: T = %.4f (exact %.4f, %+.2f %%), R = %.4f (exact "
          "%.4f, %+.2f %%)\n",
          pair_stress, 1e3 * dx, fluid_h > 0 ? fluid_h : 2.0, Z2 / Z1, *T, Te, 100 * (*T / Te - 1), *R, Re,
          100 * (*R / Re - 1));
  *T /= Te;
  *R /= Re;
  vscene_free(&c);
}

/* the 1 mm case with the sph default h (2 dx in 1D) */
static void imp_case(double rho2, double K2, const char *pair_stress, double *T, double *R)
{
  imp_case_dx(rho2, K2, pair_stress, 1e-3, 0.0, 0.01, T, R);
}

/* The 3D slab's failure at 2 mm (validation README: R -6.17 % at Z2/Z1 = 2.83, 50 spacings per
 * pulse width) in 1D: it is the fluid's smoothing length at the interface (the sph 3D default
 * 1.3 dx), not the dimension. With the former pair weight (pair_weight: kernel, the SPH kernel
 * gradient at the fluid's h) the reactions load the solid's surface layer alone when h < 2 dx,
 * against the PD sum form's own free-surface profile, and drive the PD surface layers'
 * zero-energy modes: h = 1.3 dx fails on the reflected peak (measured -7.48 %), a 5x stiffer
 * hourglass penalty (diagnostic only: 002's reference is 0.01) brings it within 3 %.
 * pair_weight bond (default, issue 8 fourth pass) spreads the reactions over the solid's horizon
 * with its own bond weight K^-1 X and passes at h = 1.3 and 2 dx (plugin README). */
START_TEST(test_impedance_fluid_h_2mm)
{
  double T, R;
  const double hs[] = {1.3, 2.0};
  for (int k = 0; k < 2; ++k) {
    imp_case_dx(4000.0, 4e9, "owned", 2e-3, hs[k], 0.01, &T, &R);
    ck_assert_double_lt(fabs(T - 1), 0.03);
    ck_assert_double_lt(fabs(R - 1), 0.03);
  }
  /* the former weight at h 1.3 dx: fails (measured -7.48 %; check.py, against the measured incident: -6.96 %) */
  imp_case_dx(4000.0, 4e9, "owned, pair_weight: kernel", 2e-3, 1.3, 0.01, &T, &R);
  ck_assert_double_lt(R - 1, -0.05);
  ck_assert_double_gt(R - 1, -0.09);
  /* ... and its mechanism: with 5x 002's hourglass penalty within 3 % (measured T -1.17 %, R +0.22 %) */
  imp_case_dx(4000.0, 4e9, "owned, pair_weight: kernel", 2e-3, 1.3, 0.05, &T, &R);
  ck_assert_double_lt(fabs(T - 1), 0.03);
  ck_assert_double_lt(fabs(R - 1), 0.03);
}
END_TEST

START_TEST(test_impedance_owned)
{
  const double cases[2][2] = {{1000.0, 2.5e8}, {4000.0, 4e9}};
  for (int k = 0; k < 2; ++k) {
    double T, R;
    imp_case(cases[k][0], cases[k][1], "owned", &T, &R);
    ck_assert_double_lt(fabs(T - 1), 0.03);
    ck_assert_double_lt(fabs(R - 1), 0.03);
  }
}
END_TEST

START_TEST(test_impedance_other_weights_fail)
{
  const char *ps[] = {"fluid", "both"};
  for (int k = 0; k < 2; ++k) {
    double T, R;
    imp_case(1000.0, 2.5e8, ps[k], &T, &R);
    ck_assert(fabs(T - 1) > 0.03 || fabs(R - 1) > 0.03);
  }
}
END_TEST

static Suite *imp_suite(void)
{
  Suite *s = suite_create("pd_sph_impedance");
  TCase *tc = tcase_create("impedance");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_impedance_owned);
  tcase_add_test(tc, test_impedance_other_weights_fail);
  tcase_add_test(tc, test_impedance_fluid_h_2mm);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(imp_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
