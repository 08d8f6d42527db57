/* tlpd initial_stress (a prescribed Cauchy stress at t = 0): a uniform initial stress in a block
 * periodic in x, y and z (every family complete) is in equilibrium, so the block stays at rest and
 * the stress unchanged to round-off, while the same stress in a free block pushes its surfaces
 * (the check can fail); the initial stress of a rigidly turned block is turned exactly by the
 * Hughes-Winget update (left in place by objective: false); the per-particle CSV file gives each
 * particle the row at its position, and a file without a particle's row, or both uniform and
 * file, is an input error. */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "ejecta/tensor.h"
#include "tlpd_trun.h"

#define MAT "materials: {m: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}}\n"
static const ej_real is_s0[6] = {-2e6, 1e6, 0.5e6, 0.7e6, -0.2e6, 0.1e6};
#define S0 "initial_stress: {uniform: [-2e6, 1e6, 0.5e6, 0.7e6, -0.2e6, 0.1e6]}"

/* ------------------------------------------------------------------ equilibrium */

/* 20 steps of a 8 cm block (spacing 1 cm) with the uniform stress S0; returns max |v| / (a_ref t),
 * a_ref = |S0| / (rho dx), and the max stress change relative to |S0|. */
static void block_run(bool periodic, double *vrel, double *srel)
{
  char y[1024];
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 3\ntime: {end: 1}\n" MAT
           "sets: {b: {method: tlpd, material: m, " S0 ", shape: {box: {min: [0, 0, 0], max: [0.08, 0.08, 0.08]}}, "
           "spacing: 0.01}}\n%s",
           periodic ? "boundaries:\n  - periodic: {axis: x, min: 0, max: 0.08}\n"
                      "  - periodic: {axis: y, min: 0, max: 0.08}\n  - periodic: {axis: z, min: 0, max: 0.08}\n"
                    : "");
  trun r;
  trun_open(&r, y);
  const ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ck_assert_int_eq(n, 512);
  const ej_real *sig = ej_set_field(s, "stress");
  for (ej_idx i = 0; i < n; ++i) /* the option set the stress */
    for (int k = 0; k < 6; ++k) ck_assert(sig[6 * i + k] == is_s0[k]);
  r.scene->max_steps = 20;
  ej_err rc = ej_sim_run(r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_int_eq(r.sim->step, 20);
  s = r.sim->sets[0];
  sig = ej_set_field(s, "stress");
  const ej_real *v = ej_set_field(s, "v");
  const double smax = 2e6, aref = smax / (2000 * 0.01);
  double vm = 0, ds = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int d = 0; d < 3; ++d) vm = fmax(vm, fabs(v[3 * i + d]));
    for (int k = 0; k < 6; ++k) ds = fmax(ds, fabs(sig[6 * i + k] - is_s0[k]));
  }
  *vrel = vm / (aref * r.sim->t);
  *srel = ds / smax;
  trun_close(&r);
}

START_TEST(test_uniform_periodic_equilibrium)
{
  double vrel, srel;
  block_run(true, &vrel, &srel);
  ck_assert_msg(vrel < 1e-12, "periodic block: max |v| / (a_ref t) = %g", vrel);
  ck_assert_msg(srel < 1e-12, "periodic block: stress change %g of |S0|", srel);
  /* the same stress in a free block is not in equilibrium (surface traction S0 n): it moves */
  block_run(false, &vrel, &srel);
  ck_assert_msg(vrel > 1e-2, "free block: max |v| / (a_ref t) = %g", vrel);
}
END_TEST

/* ------------------------------------------------------------------ rigid rotation */

START_TEST(test_initial_stress_rotated)
{
  const double th0 = 0.3, th1 = 0.35;
  for (int obj = 1; obj >= 0; --obj) {
    char y[1024];
    snprintf(y, sizeof y,
             "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
             "sets: {b: {method: tlpd, material: m, objective: %s, " S0
             ", shape: {box: {min: [0, 0, 0], max: [0.05, 0.05, 0.05]}}, spacing: 0.01}}\n",
             obj ? "true" : "false");
    trun r;
    trun_open(&r, y);
    ej_set *s = r.sim->sets[0];
    ej_real *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev"), *sig = ej_set_field(s, "stress");
    const ej_real *x0 = ej_set_field(s, "x0");
    const ej_real R0[9] = {cos(th0), -sin(th0), 0, sin(th0), cos(th0), 0, 0, 0, 1};
    const ej_real R1[9] = {cos(th1), -sin(th1), 0, sin(th1), cos(th1), 0, 0, 0, 1};
    const ej_real dR[9] = {cos(th1 - th0), -sin(th1 - th0), 0, sin(th1 - th0), cos(th1 - th0), 0, 0, 0, 1};
    for (ej_idx i = 0; i < ej_set_count(s); ++i) {
      ej_m3_apply(xp + 3 * i, R0, x0 + 3 * i);
      ej_m3_apply(x + 3 * i, R1, x0 + 3 * i);
    }
    trun_compute(&r);
    ej_real want[6];
    if (obj) ej_s6_rotate(want, dR, is_s0);
    else memcpy(want, is_s0, sizeof want);
    for (ej_idx i = 0; i < ej_set_count(s); ++i)
      for (int k = 0; k < 6; ++k)
        ck_assert_msg(fabs(sig[6 * i + k] - want[k]) < 1e-8 * 2e6, "objective %d, i %d k %d: %g vs %g", obj, (int)i, k,
                      sig[6 * i + k], want[k]);
    if (obj) ck_assert(fabs(want[0] - is_s0[0]) > 1e4); /* the turn changes the components */
    trun_close(&r);
  }
}
END_TEST

/* ------------------------------------------------------------------ file */

/* the CSV's stress at grid point (gx, gy) */
static void is_field(double gx, double gy, ej_real s[6])
{
  s[0] = 1e6 * (1 + 20 * gx);
  s[1] = -3e5 * gy;
  s[2] = 0;
  s[3] = 2e5 * gx * gy / 1e-4;
  s[4] = 0;
  s[5] = 7;
}

/* Writes a CSV on a 2.5 mm grid over [0, 0.1] x [0, 0.12] (columns in a shuffled order, szz and
 * syz absent). */
static void is_write(const trun *r)
{
  char p[160];
  snprintf(p, sizeof p, "%s/s.csv", r->dir);
  FILE *f = fopen(p, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "sxy, y, sxx,syy ,x,szx\n");
  for (int a = 0; a <= 40; ++a)
    for (int b = 0; b <= 48; ++b) {
      const double gx = 0.0025 * a, gy = 0.0025 * b;
      ej_real s[6];
      is_field(gx, gy, s);
      fprintf(f, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", s[3], gy, s[0], s[1], gx, s[5]);
    }
  fclose(f);
}

START_TEST(test_initial_stress_file)
{
  trun r;
  trun_dir(&r);
  is_write(&r);
  char y[1024];
  /* a relative path is taken from the scene file's directory (the scene is r.dir/s.yaml), not from
   * the working directory */
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, initial_stress: {file: s.csv}, "
           "shape: {box: {min: [0, 0], max: [0.1, 0.12]}}, spacing: 0.01}}\n");
  ej_err rc = trun_try(&r, y);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const ej_set *s = r.sim->sets[0];
  const ej_real *x = ej_set_field(s, "x"), *sig = ej_set_field(s, "stress");
  ck_assert_int_eq(ej_set_count(s), 120);
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    const double gx = 0.0025 * round(x[3 * i] / 0.0025), gy = 0.0025 * round(x[3 * i + 1] / 0.0025);
    ej_real want[6];
    is_field(gx, gy, want);
    for (int k = 0; k < 6; ++k)
      ck_assert_msg(sig[6 * i + k] == want[k], "i %d k %d: %.17g vs %.17g", (int)i, k, sig[6 * i + k], want[k]);
  }
  trun_close(&r);

  /* a particle (the one at (0.055, 0.055)) 3.5 mm from the nearest row: more than dx/4 */
  trun_dir(&r);
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, initial_stress: {file: %s/s.csv}, "
           "shape: {box: {min: [0, 0], max: [0.1, 0.12]}}, spacing: 0.01}}\n",
           r.dir);
  /* particle-centred rows except the one at (0.055, 0.055), replaced by a row 3.5 mm away */
  {
    char p[160];
    snprintf(p, sizeof p, "%s/s.csv", r.dir);
    FILE *f = fopen(p, "w");
    ck_assert_ptr_nonnull(f);
    fprintf(f, "x,y,sxx\n");
    for (int a = 0; a < 10; ++a)
      for (int b = 0; b < 12; ++b)
        if (!(a == 5 && b == 5)) fprintf(f, "%.17g,%.17g,1\n", 0.005 + 0.01 * a, 0.005 + 0.01 * b);
    fprintf(f, "0.0585,0.0555,1\n"); /* 3.5 mm from (0.055, 0.055): too far */
    fclose(f);
  }
  rc = trun_try(&r, y);
  ck_assert_int_ne(rc, EJ_OK);
  ej_error_clear();
  trun_close(&r);

  /* uniform and file together: an input error */
  trun_dir(&r);
  is_write(&r);
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, initial_stress: {file: s.csv, uniform: [1, 0, 0, 0, 0, 0]}, "
           "shape: {box: {min: [0, 0], max: [0.1, 0.12]}}, spacing: 0.01}}\n");
  rc = trun_try(&r, y);
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  ck_assert_ptr_nonnull(strstr(ej_error_cause()->msg, "give one of"));
  ej_error_clear();
  trun_close(&r);

  /* a file that cannot be read: refused when the scene is loaded (ejecta check), at the value */
  trun_dir(&r);
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, initial_stress: {file: none.csv}, "
           "shape: {box: {min: [0, 0], max: [0.1, 0.12]}}, spacing: 0.01}}\n");
  rc = trun_try(&r, y);
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  ck_assert_ptr_null(r.scene); /* the scene load itself refused it */
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(strstr(f->msg, "cannot read file"));
  ck_assert_ptr_nonnull(strstr(f->msg, "none.csv"));
  {
    int line = 1;
    for (const char *c = y; *c && strncmp(c, "sets:", 5) != 0; ++c) line += *c == '\n';
    ck_assert_int_eq(f->where.line, line);
    ck_assert_ptr_nonnull(strstr(y, "{file: none.csv}"));
    ck_assert_int_eq(f->where.col, (int)(strstr(y, "none.csv") - strstr(y, "sets:")) + 1);
  }
  ej_error_clear();
  trun_close(&r);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("tlpd_initial_stress");
  TCase *tc = tcase_create("core");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_uniform_periodic_equilibrium);
  tcase_add_test(tc, test_initial_stress_rotated);
  tcase_add_test(tc, test_initial_stress_file);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
