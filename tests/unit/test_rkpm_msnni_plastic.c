/* rkpm MSNNI sub-box stabilisation through the strength model (`msnni_stress: material`,
 * plugins/methods/rkpm/README.md): (1) for a linear elastic material it is the incremental
 * 003 Eq 46 of `msnni_stress: elastic` (same velocities to round-off on a jittered 3D block);
 * (2) for a cohesionless Drucker-Prager bed (dp_damage, damage off) every sub-box stress
 * sigma_L + D_xi stays on or inside the yield surface, whereas the elastic stabilisation stress
 * pushes the sub-box stress far outside it (the failure mode of validation/sphere_drop). */
#include <check.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_rkpm_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_dp_damage_info(void);

static ej_err mp_vopen(vscene *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_rkpm_info(), ej_plugin_elastic_info(), ej_plugin_dp_damage_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "rkmp", p, 3, fmt, ap);
  va_end(ap);
  if (rc != EJ_OK) ej_error_report("test");
  return rc;
}

/* A free jittered 8^3 block with a smooth nonuniform velocity field (as test_rkpm's stability
 * case), `steps` steps; mat is the materials entry, stab the msnni_stress value. */
static void mp_run_part(vscene *c, const char *mat, const char *stab, const char *part, int steps, double vscale)
{
  char init[4096];
  smooth_block_initial(init, sizeof init, vscale);
  ej_err rc = mp_vopen(c,
                       "ejecta: 1\ndimension: 3\ntime: {end: 100, cfl: 0.3, max_steps: %d}\n"
                       "output: {file: out.h5, every: 100, fields: [v]}\n"
                       "materials:\n  m: %s\n"
                       "sets:\n  block:\n    method: rkpm\n    integration: msnni\n    msnni_stress: %s\n    msnni_part: %s\n"
                       "    material: m\n    shape: {box: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}}\n"
                       "    spacing: 0.0625\n    jitter: 0.3\n    initial:\n%s",
                       steps, mat, stab, part, init);
  ck_assert_int_eq(rc, EJ_OK);
  rc = ej_sim_run(c->r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static void mp_run(vscene *c, const char *mat, const char *stab, int steps, double vscale)
{
  mp_run_part(c, mat, stab, "full", steps, vscale);
}

static ej_set *mp_set(vscene *c) { return c->r.sim->sets[0]; }

START_TEST(test_elastic_equivalence)
{
  const char *mat = "{model: elastic, rho0: 1, E: 1, nu: 0.25}";
  vscene a, b;
  mp_run(&a, mat, "material", 40, 0.01);
  mp_run(&b, mat, "elastic", 40, 0.01);
  ej_set *sa = mp_set(&a), *sb = mp_set(&b);
  const ej_idx n = ej_set_count(sa);
  ck_assert_int_eq(n, ej_set_count(sb));
  const ej_real *va = ej_set_field(sa, "v"), *vb = ej_set_field(sb, "v");
  const ej_real *wa = ej_set_field(sa, "w_hg"), *wb = ej_set_field(sb, "w_hg");
  double dv = 0, vmax = 0, dw = 0, wmax = 0;
  for (ej_idx i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      dv = fmax(dv, fabs(va[3 * i + c] - vb[3 * i + c]));
      vmax = fmax(vmax, fabs(vb[3 * i + c]));
    }
    dw = fmax(dw, fabs(wa[i] - wb[i]));
    wmax = fmax(wmax, fabs(wb[i]));
  }
  fprintf(stderr, "rkpm msnni_stress material vs elastic (elastic material, 40 steps): max |dv| / max |v| = %.2e, "
          "max |dw_hg| / max |w_hg| = %.2e\n", dv / vmax, dw / wmax);
  ck_assert(wmax > 0); /* the stabilisation did work */
  ck_assert_msg(dv <= 1e-10 * vmax, "velocities differ: %g of %g", dv, vmax);
  ck_assert_msg(dw <= 1e-8 * wmax, "stabilisation work differs: %g of %g", dw, wmax);
  vscene_free(&a);
  vscene_free(&b);
}
END_TEST

/* Largest Drucker-Prager yield-function value f = ||s|| + beta p - A (p = tr/3, tension
 * positive; 003 Eq 50) over all sub-box stresses sigma_L + D_xi (material) or sigma_L +
 * sigma_s,xi / w (elastic: the sub-box stress the stabilisation represents), relative to the
 * largest ||sigma_L||. */
static double mp_max_yield(ej_set *s, double beta, bool material, double w, double *node_f)
{
  static const char *const ssn[] = {"rk_ss0", "rk_ss1", "rk_ss2", "rk_ss3", "rk_ss4", "rk_ss5"};
  const ej_real *sg = ej_set_field(s, "stress");
  const ej_real *ss[6];
  for (int k = 0; k < 6; ++k) ss[k] = ej_set_field(s, ssn[k]);
  const ej_idx n = ej_set_count(s);
  double fmax_sub = -INFINITY, fmax_node = -INFINITY, smax = 0;
  for (ej_idx i = 0; i < n; ++i) {
    for (int xi = -1; xi < 8; ++xi) {
      double t[6];
      for (int k = 0; k < 6; ++k) {
        t[k] = sg[6 * i + k];
        if (xi >= 0) {
          const int e = 6 * xi + k;
          t[k] += ss[e / 9][9 * i + e % 9] / (material ? 1.0 : w);
        }
      }
      const double p = (t[0] + t[1] + t[2]) / 3;
      const double s0 = t[0] - p, s1 = t[1] - p, s2 = t[2] - p;
      const double sn = sqrt(s0 * s0 + s1 * s1 + s2 * s2 + 2 * (t[3] * t[3] + t[4] * t[4] + t[5] * t[5]));
      const double f = sn + beta * p;
      if (xi < 0) {
        fmax_node = fmax(fmax_node, f);
        smax = fmax(smax, sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) + sn);
      } else {
        fmax_sub = fmax(fmax_sub, f);
      }
    }
  }
  *node_f = fmax_node / smax;
  return fmax_sub / smax;
}

START_TEST(test_subbox_yield_bound)
{
  /* Cohesionless DP (phi 24 deg, the sphere-drop beads), soft enough that the velocity field
   * drives it well into plastic flow in 60 steps. */
  const double phi = 24.0 * M_PI / 180.0, beta = 2 * sqrt(6.0) * sin(phi) / (3 - sin(phi));
  const char *mat = "{model: dp_damage, rho0: 1, E: 1, nu: 0.3, friction_angle: 24 deg, dilation_angle: 0 deg, "
                    "cohesion: 0, damage: false}";
  vscene a, b;
  mp_run(&a, mat, "material", 60, 0.05);
  mp_run(&b, mat, "elastic", 60, 0.05);
  double fna, fnb;
  const double fa = mp_max_yield(mp_set(&a), beta, true, 0.5, &fna);
  const double fb = mp_max_yield(mp_set(&b), beta, false, 0.5, &fnb);
  const ej_real *wpa = ej_set_field(mp_set(&a), "w_plastic");
  double wp = 0;
  for (ej_idx i = 0; i < ej_set_count(mp_set(&a)); ++i) wp += wpa[i];
  const double bal = fabs(a.r.sim->energy.balance) / (a.r.sim->energy.kinetic + a.r.sim->energy.internal + 1e-300);
  fprintf(stderr, "rkpm msnni cohesionless DP block: max f/|sigma| nodes %.2e, sub-boxes: material %.2e, "
          "elastic %.2e; sum w_plastic %.3g, |balance| %.2e\n", fna, fa, fb, wp, bal);
  ck_assert_msg(wp > 0, "no plastic flow: the test does not test the yield limit");
  ck_assert_msg(fna < 1e-8, "node stress outside the yield surface: %g", fna);
  ck_assert_msg(fa < 1e-8, "sub-box stress outside the yield surface: %g", fa);
  /* the elastic stabilisation is not limited (measured 2e-1 and more): shows the check can fail */
  ck_assert_msg(fb > 1e-3, "elastic sub-box stress unexpectedly inside the yield surface: %g", fb);
  vscene_free(&a);
  vscene_free(&b);
}
END_TEST

/* Largest |tr D_xi| / 3 over all stored sub-box stresses, relative to the largest |D_xi| entry. */
static double mp_max_trace(ej_set *s)
{
  static const char *const ssn[] = {"rk_ss0", "rk_ss1", "rk_ss2", "rk_ss3", "rk_ss4", "rk_ss5"};
  const ej_real *ss[6];
  for (int k = 0; k < 6; ++k) ss[k] = ej_set_field(s, ssn[k]);
  double tmax = 0, dmax = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i)
    for (int xi = 0; xi < 8; ++xi) {
      double t[6];
      for (int k = 0; k < 6; ++k) {
        const int e = 6 * xi + k;
        t[k] = ss[e / 9][9 * i + e % 9];
        dmax = fmax(dmax, fabs(t[k]));
      }
      tmax = fmax(tmax, fabs(t[0] + t[1] + t[2]) / 3);
    }
  return dmax > 0 ? tmax / dmax : INFINITY;
}

/* msnni_part: deviatoric (B-bar-like: the sub-boxes take the node's volumetric rate, the
 * stabilisation stress is deviatoric). (1) The stored sub-box stresses are trace-free for both
 * sub-box stress forms; (2) elastic material: material = elastic form as with `full`; (3) on the
 * cohesionless DP block the sub-box stresses stay on the yield surface, the energy balance holds,
 * and the stabilisation does less work than the full form (its volumetric part is gone). */
START_TEST(test_deviatoric_part)
{
  const char *el = "{model: elastic, rho0: 1, E: 1, nu: 0.25}";
  vscene a, b;
  mp_run_part(&a, el, "material", "deviatoric", 40, 0.01);
  mp_run_part(&b, el, "elastic", "deviatoric", 40, 0.01);
  const ej_idx n = ej_set_count(mp_set(&a));
  const ej_real *va = ej_set_field(mp_set(&a), "v"), *vb = ej_set_field(mp_set(&b), "v");
  double dv = 0, vmax = 0;
  for (ej_idx i = 0; i < 3 * n; ++i) dv = fmax(dv, fabs(va[i] - vb[i])), vmax = fmax(vmax, fabs(vb[i]));
  const double ta = mp_max_trace(mp_set(&a)), tb = mp_max_trace(mp_set(&b));
  fprintf(stderr, "rkpm msnni_part deviatoric (elastic material): material vs elastic max |dv|/|v| %.2e; "
          "max |tr D|/3 / max |D|: material %.2e, elastic %.2e\n", dv / vmax, ta, tb);
  ck_assert_msg(dv <= 1e-10 * vmax, "velocities differ: %g of %g", dv, vmax);
  ck_assert_msg(ta < 1e-12 && tb < 1e-12, "sub-box stresses not trace-free: %g %g", ta, tb);
  vscene_free(&a);
  vscene_free(&b);
  const double phi = 24.0 * M_PI / 180.0, beta = 2 * sqrt(6.0) * sin(phi) / (3 - sin(phi));
  const char *dp = "{model: dp_damage, rho0: 1, E: 1, nu: 0.3, friction_angle: 24 deg, dilation_angle: 0 deg, "
                   "cohesion: 0, damage: false}";
  vscene d, f;
  mp_run_part(&d, dp, "material", "deviatoric", 60, 0.05);
  mp_run_part(&f, dp, "material", "full", 60, 0.05);
  double fnd;
  const double fd = mp_max_yield(mp_set(&d), beta, true, 0.5, &fnd);
  const double td = mp_max_trace(mp_set(&d));
  double whd = 0, whf = 0;
  const ej_real *wd = ej_set_field(mp_set(&d), "w_hg"), *wf = ej_set_field(mp_set(&f), "w_hg");
  const ej_real *md = ej_set_field(mp_set(&d), "m"), *mf = ej_set_field(mp_set(&f), "m");
  for (ej_idx i = 0; i < ej_set_count(mp_set(&d)); ++i) whd += md[i] * wd[i], whf += mf[i] * wf[i];
  const double bal = fabs(d.r.sim->energy.balance) / (d.r.sim->energy.kinetic + d.r.sim->energy.internal + 1e-300);
  fprintf(stderr, "rkpm msnni_part deviatoric, cohesionless DP block: max f/|sigma| sub-boxes %.2e, max |tr D|/3 / "
          "max |D| %.2e, stabilisation work %.3g (full: %.3g), |balance| %.2e\n", fd, td, whd, whf, bal);
  ck_assert_msg(fd < 1e-8, "sub-box stress outside the yield surface: %g", fd);
  ck_assert_msg(td < 1e-12, "sub-box stresses not trace-free: %g", td);
  ck_assert_msg(whd > 0 && whd < whf, "deviatoric stabilisation work %g not in (0, full %g)", whd, whf);
  ck_assert_msg(bal < 1e-2, "energy balance %g", bal);
  vscene_free(&d);
  vscene_free(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("rkpm_msnni_plastic");
  TCase *tc = tcase_create("rkpm_msnni_plastic");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_elastic_equivalence);
  tcase_add_test(tc, test_subbox_yield_bound);
  tcase_add_test(tc, test_deviatoric_part);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
