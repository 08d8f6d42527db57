/* tlpd method: patch test (a linear displacement field gives F exactly in 1, 2 and 3 D, also on
 * a jittered cloud and at surface particles), exact rigid rotation of a pre-stressed body by the
 * Hughes-Winget update (d = 0), momentum and energy conservation of the semi-discrete sum form
 * with hourglass control, zero force of the difference form under uniform stress, symmetric
 * irreversible bond breaking with damage, the spring fallback for a singular K, and the energy
 * correction of the core's rate predictor (energy_correction). */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_rng.h"
#include "ejecta/tensor.h"
#include "tlpd_trun.h"
#include "test_tmpdir.h"


static double rng_u(uint64_t *s) { return rng_uniform(s) - 0.5; }

#define MAT "materials: {m: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}}\n"

/* ------------------------------------------------------------------ patch test */

static void patch(int dim, double jitter, const char *extra)
{
  char y[1024];
  const char *box = dim == 1 ? "{min: [0], max: [0.2]}" : dim == 2 ? "{min: [0, 0], max: [0.1, 0.12]}"
                                                                  : "{min: [0, 0, 0], max: [0.06, 0.07, 0.08]}";
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: %d\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: %s}, spacing: 0.01, jitter: %g, %s}}\n",
           dim, box, jitter, extra);
  trun r;
  trun_open(&r, y);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev");
  const ej_real *x0 = ej_set_field(s, "x0");
  const ej_real A[9] = {1.01, 0.02, -0.03, 0.015, 0.98, 0.01, -0.02, 0.025, 1.03};
  const ej_real b[3] = {0.1, -0.2, 0.3};
  for (ej_idx i = 0; i < n; ++i) {
    for (int a = 0; a < dim; ++a) {
      x[3 * i + a] = b[a];
      for (int c = 0; c < dim; ++c) x[3 * i + a] += A[3 * a + c] * x0[3 * i + c];
    }
    memcpy(xp + 3 * i, x + 3 * i, 3 * sizeof *x);
  }
  trun_compute(&r);
  const ej_real *F = ej_set_field(s, "F");
  const int32_t *st = ej_set_field_int(s, "pd_status");
  double err = 0;
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert_int_eq(st[i], 0);
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) {
        const double want = (a < dim && c < dim) ? A[3 * a + c] : (a == c ? 1.0 : 0.0);
        err = fmax(err, fabs(F[9 * i + 3 * a + c] - want));
      }
  }
  ck_assert_msg(err < 1e-12, "dim %d jitter %g: max |F - A| = %g", dim, jitter, err);
  trun_close(&r);
}

START_TEST(test_patch_1d) { patch(1, 0, "horizon: 3"); }
END_TEST
START_TEST(test_patch_2d) { patch(2, 0, "influence: quadratic"); }
END_TEST
START_TEST(test_patch_3d) { patch(3, 0, "influence: gaussian"); }
END_TEST
START_TEST(test_patch_3d_jitter) { patch(3, 0.2, "horizon: 2.5"); }
END_TEST

/* ------------------------------------------------------------------ rigid rotation */

/* A pre-stressed block turned rigidly between x_prev = R0 x0 and x = R1 x0: the Hughes-Winget
 * increment is exactly dR = R1 R0^T and d = 0, so the stress is exactly dR sigma dR^T. */
static const double rot_th0 = 0.3, rot_th1 = 0.35;
static const ej_real rot_s0[6] = {-2e6, 1e6, 0.5e6, 0.7e6, -0.2e6, 0.1e6};

static void rot_about_z(ej_real R[9], double th)
{
  const ej_real Q[9] = {cos(th), -sin(th), 0, sin(th), cos(th), 0, 0, 0, 1};
  memcpy(R, Q, sizeof Q);
}

/* Opens a 5 cm block of tlpd with the extra set options, places it rigidly turned (x_prev =
 * R(th0) x0, x = R(th1) x0) with the stress rot_s0 everywhere, and computes one step; returns the
 * stress (the run stays open in r). */
static ej_real *rotated_block(trun *r, const char *opts)
{
  char text[1024];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, %sshape: {box: {min: [0, 0, 0], max: [0.05, 0.05, 0.05]}}, "
           "spacing: 0.01}}\n",
           opts);
  trun_open(r, text);
  ej_set *s = r->sim->sets[0];
  ck_assert(ej_set_dt(s) > 0);
  ej_real *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev"), *sig = ej_set_field(s, "stress");
  const ej_real *x0 = ej_set_field(s, "x0");
  ej_real R0[9], R1[9];
  rot_about_z(R0, rot_th0);
  rot_about_z(R1, rot_th1);
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    ej_m3_apply(xp + 3 * i, R0, x0 + 3 * i);
    ej_m3_apply(x + 3 * i, R1, x0 + 3 * i);
    memcpy(sig + 6 * i, rot_s0, sizeof rot_s0);
  }
  trun_compute(r);
  return sig;
}

START_TEST(test_rigid_rotation_exact)
{
  trun r;
  const ej_real *s0 = rot_s0;
  ej_real *sig = rotated_block(&r, "");
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real R1[9];
  rot_about_z(R1, rot_th1);
  const ej_real dR[9] = {cos(rot_th1 - rot_th0), -sin(rot_th1 - rot_th0), 0, sin(rot_th1 - rot_th0),
                         cos(rot_th1 - rot_th0), 0, 0, 0, 1};
  ej_real want[6];
  ej_s6_rotate(want, dR, s0);
  const ej_real *F = ej_set_field(s, "F");
  for (ej_idx i = 0; i < n; ++i) {
    for (int k = 0; k < 6; ++k) ck_assert_msg(fabs(sig[6 * i + k] - want[k]) < 1e-8 * 2e6, "i %d k %d: %g vs %g", (int)i, k, sig[6 * i + k], want[k]);
    for (int k = 0; k < 9; ++k) ck_assert(fabs(F[9 * i + k] - R1[k]) < 1e-12);
  }
  trun_close(&r);

  /* without the objective update the stress is left in the old orientation */
  sig = rotated_block(&r, "objective: false, ");
  s = r.sim->sets[0];
  ck_assert(fabs(sig[0] - want[0]) > 1e4);
  /* nonobjective: rate (default): d = sym(h) of a rigid rotation is zero, the stress stays s0 */
  for (ej_idx i = 0; i < ej_set_count(s); ++i)
    for (int k = 0; k < 6; ++k) ck_assert_msg(fabs(sig[6 * i + k] - s0[k]) < 1e-8 * 2e6, "rate: %g vs %g", sig[6 * i + k], s0[k]);
  trun_close(&r);

  /* nonobjective: small_strain: sym(R1 - R0) is not zero, the rigid rotation strains the body */
  sig = rotated_block(&r, "objective: false, nonobjective: small_strain, ");
  double dmax = 0;
  for (int k = 0; k < 6; ++k) dmax = fmax(dmax, fabs(sig[k] - s0[k]));
  ck_assert_msg(dmax > 1e-6 * 2e6, "small_strain: stress change %g", dmax);
  trun_close(&r);
}
END_TEST

/* ------------------------------------------------------------------ conservation */

/* Random deformation and velocity of a jittered block: the sum form (with hourglass forces
 * and partial volumes) conserves momentum, sum m a = 0, and energy, sum m (v.a + e_dot) = 0,
 * to round-off; the hourglass power is part of e_dot and recorded in w_hg_dot. */
static void conservation(const char *extra, bool expect_momentum)
{
  char y[1024];
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0, 0], max: [0.06, 0.05, 0.04]}}, "
           "spacing: 0.01, jitter: 0.2, %s}}\n",
           extra);
  trun r;
  trun_open(&r, y);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev"), *v = ej_set_field(s, "v");
  const ej_real *x0 = ej_set_field(s, "x0"), *m = ej_set_field(s, "m");
  uint64_t seed = 7;
  for (ej_idx i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      x[3 * i + a] = x0[3 * i + a] * (1 + 0.01 * a) + 2e-4 * rng_u(&seed);
      xp[3 * i + a] = x[3 * i + a] - 1e-6 * rng_u(&seed);
      v[3 * i + a] = rng_u(&seed);
    }
  trun_compute(&r);
  const ej_real *acc = ej_set_field(s, "a"), *ed = ej_set_field(s, "e_dot"), *wd = ej_set_field(s, "w_hg_dot");
  double p[3] = {0, 0, 0}, pscale = 0, pw = 0, pws = 0, hg = 0;
  for (ej_idx i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      p[a] += m[i] * acc[3 * i + a];
      pscale += fabs(m[i] * acc[3 * i + a]);
      pw += m[i] * v[3 * i + a] * acc[3 * i + a];
      pws += fabs(m[i] * v[3 * i + a] * acc[3 * i + a]);
    }
    pw += m[i] * ed[i];
    hg += m[i] * wd[i];
  }
  ck_assert(pscale > 0);
  if (expect_momentum) {
    for (int a = 0; a < 3; ++a) ck_assert_msg(fabs(p[a]) < 1e-12 * pscale, "momentum %d: %g of %g", a, p[a], pscale);
    ck_assert_msg(fabs(pw) < 1e-12 * pws, "power balance %g of %g", pw, pws);
  } else {
    double pm = fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2])));
    ck_assert_msg(pm > 1e-9 * pscale, "difference form unexpectedly conserves momentum");
  }
  if (strstr(extra, "zhu_zhao") || strstr(extra, "silling")) ck_assert(fabs(hg) > 0);
  trun_close(&r);
}

START_TEST(test_conservation_sum) { conservation("hourglass: zhu_zhao, hourglass_coefficient: 0.5", true); }
END_TEST
START_TEST(test_conservation_silling) { conservation("hourglass: silling, influence: quadratic", true); }
END_TEST
START_TEST(test_difference_not_conservative) { conservation("force_form: difference, hourglass: none", false); }
END_TEST

/* Objectivity of the force pass (validation/tlpd_rotation, README "Study"): a jittered block
 * with a non-affine deformation (hourglass modes present) and a random symmetric stress field,
 * then the same state turned rigidly, x -> Q x + b, sigma -> Q sigma Q^T (x_prev = x: no
 * increment): F -> Q F and every acceleration a -> Q a (round-off), with the zhu_zhao and silling
 * hourglass forces on; the total torque sum m x cross a is zero (no spurious spin-up); and a rigidly
 * turned stress-free body, x = Q x0, has F = Q and no force at all (hourglass force C w (Y - F X)
 * vanishes). Would catch an hourglass or stress force that is not frame-indifferent. */
static double objective_forces(const char *extra, bool torque_free)
{
  char y[1024];
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0, 0], max: [0.06, 0.05, 0.04]}}, "
           "spacing: 0.01, jitter: 0.2, %s}}\n",
           extra);
  const double th = 0.7, c = cos(th), sn = sin(th), q = 1 / sqrt(3.0);
  /* rotation by th about (1, 1, 1)/sqrt(3) (Rodrigues) */
  const double k[3] = {q, q, q};
  ej_real Q[9];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) Q[3 * a + b] = (a == b ? c : 0) + (1 - c) * k[a] * k[b];
  Q[1] -= sn * k[2], Q[2] += sn * k[1], Q[3] += sn * k[2], Q[5] -= sn * k[0], Q[6] -= sn * k[1], Q[7] += sn * k[0];
  const ej_real shift[3] = {0.3, -0.1, 0.2};
  ej_real *acc0 = NULL, *F0 = NULL;
  ej_idx n = 0;
  double torque = 0;
  for (int turned = 0; turned < 3; ++turned) {
    trun r;
    trun_open(&r, y);
    ej_set *s = r.sim->sets[0];
    n = ej_set_count(s);
    ej_real *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev"), *sig = ej_set_field(s, "stress");
    const ej_real *x0 = ej_set_field(s, "x0"), *m = ej_set_field(s, "m");
    uint64_t seed = 11;
    for (ej_idx i = 0; i < n; ++i) {
      ej_real xa[3], sa[6];
      for (int a = 0; a < 3; ++a) xa[a] = turned == 2 ? x0[3 * i + a] : x0[3 * i + a] * (1 + 0.01 * a) + 3e-4 * rng_u(&seed);
      for (int a = 0; a < 6; ++a) sa[a] = turned == 2 ? 0 : 2e6 * rng_u(&seed);
      if (turned) {
        ej_m3_apply(x + 3 * i, Q, xa);
        for (int a = 0; a < 3; ++a) x[3 * i + a] += shift[a];
        ej_s6_rotate(sig + 6 * i, Q, sa);
      } else {
        memcpy(x + 3 * i, xa, sizeof xa);
        memcpy(sig + 6 * i, sa, sizeof sa);
      }
      memcpy(xp + 3 * i, x + 3 * i, 3 * sizeof *x);
    }
    trun_compute(&r);
    const ej_real *acc = ej_set_field(s, "a"), *F = ej_set_field(s, "F");
    if (turned == 0) {
      acc0 = malloc(3 * (size_t)n * sizeof *acc0), F0 = malloc(9 * (size_t)n * sizeof *F0);
      memcpy(acc0, acc, 3 * (size_t)n * sizeof *acc0);
      memcpy(F0, F, 9 * (size_t)n * sizeof *F0);
      /* total torque about the origin */
      double L[3] = {0, 0, 0}, Ls = 0;
      for (ej_idx i = 0; i < n; ++i) {
        const ej_real *xi = x + 3 * i, *ai = acc + 3 * i;
        const double t[3] = {xi[1] * ai[2] - xi[2] * ai[1], xi[2] * ai[0] - xi[0] * ai[2], xi[0] * ai[1] - xi[1] * ai[0]};
        for (int a = 0; a < 3; ++a) L[a] += m[i] * t[a], Ls += fabs(m[i] * t[a]);
      }
      ck_assert(Ls > 0);
      torque = fmax(fabs(L[0]), fmax(fabs(L[1]), fabs(L[2]))) / Ls;
      if (torque_free)
        for (int a = 0; a < 3; ++a) ck_assert_msg(fabs(L[a]) < 1e-11 * Ls, "%s: torque %d = %g of %g", extra, a, L[a], Ls);
    } else if (turned == 1) {
      double err = 0, scale = 0, ferr = 0;
      for (ej_idx i = 0; i < n; ++i) {
        ej_real want[3], QF[9];
        ej_m3_apply(want, Q, acc0 + 3 * i);
        ej_m3_mul(QF, Q, F0 + 9 * i);
        for (int a = 0; a < 3; ++a) err = fmax(err, fabs(acc[3 * i + a] - want[a])), scale = fmax(scale, fabs(want[a]));
        for (int a = 0; a < 9; ++a) ferr = fmax(ferr, fabs(F[9 * i + a] - QF[a]));
      }
      ck_assert(scale > 1e3);
      ck_assert_msg(ferr < 1e-12, "%s: |F - Q F0| = %g", extra, ferr);
      ck_assert_msg(err < 1e-10 * scale, "%s: |a - Q a0| = %g of %g", extra, err, scale);
    } else {
      double amax = 0, ferr = 0;
      for (ej_idx i = 0; i < n; ++i) {
        for (int a = 0; a < 3; ++a) amax = fmax(amax, fabs(acc[3 * i + a]));
        for (int a = 0; a < 9; ++a) ferr = fmax(ferr, fabs(F[9 * i + a] - Q[a]));
      }
      ck_assert_msg(ferr < 1e-12, "%s: rigid |F - Q| = %g", extra, ferr);
      /* scale: E / (rho dx) = 1e9 / (2000 * 0.01) = 5e7 m/s^2 per unit strain */
      ck_assert_msg(amax < 1e-12 * 5e7, "%s: rigid rotation |a| = %g", extra, amax);
    }
    trun_close(&r);
  }
  free(acc0);
  free(F0);
  return torque;
}

/* The silling option is objective but not torque-free: its bond weight w/|X|^2 differs from the
 * weight w of the least-squares fit F, so sum_j w |X|^-2 (F X) x (Y - F X) != 0 on a non-affine
 * deformation (zhu_zhao's sum_j w (F X) x (Y - F X) = 0 by the normal equations of the fit).
 * Measured here: max_k |sum m (x cross a)_k| / sum |m (x cross a)_k| = 2.6e-3 (constant w), 1.5e-3
 * (quadratic w); the total angular momentum of a silling run drifts (1.5e-6 in 1 ms on the 2-D
 * spinning disc of validation/tlpd_rotation/study.py, 2 mm; zhu_zhao and none: 4e-16).
 * Asserted so that a fix shows up here. */
START_TEST(test_objective_forces)
{
  objective_forces("hourglass: zhu_zhao, hourglass_coefficient: 0.5", true);
  objective_forces("hourglass: none, influence: gaussian", true);
  const double t1 = objective_forces("hourglass: silling, hourglass_coefficient: 0.5", false);
  const double t2 = objective_forces("hourglass: silling, hourglass_coefficient: 0.5, influence: quadratic", false);
  printf("tlpd silling hourglass: relative torque %.3g (constant w), %.3g (quadratic w)\n", t1, t2);
  ck_assert_msg(t1 > 1e-4 && t2 > 1e-4, "silling torque %g %g: now torque-free, update the comment and README", t1, t2);
}
END_TEST

/* 000 digest section 1.1: the difference form exerts no force for a uniform stress, even at a
 * free surface; the sum form pushes surface particles (the traction of the stress). */
START_TEST(test_uniform_stress)
{
  for (int form = 0; form < 2; ++form) {
    char y[512];
    snprintf(y, sizeof y,
             "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
             "sets: {b: {method: tlpd, material: m, force_form: %s, shape: {box: {min: [0, 0, 0], max: [0.05, 0.05, 0.05]}}, "
             "spacing: 0.01}}\n",
             form ? "difference" : "sum");
    trun r;
    trun_open(&r, y);
    ej_set *s = r.sim->sets[0];
    const ej_idx n = ej_set_count(s);
    ej_real *sig = ej_set_field(s, "stress");
    for (ej_idx i = 0; i < n; ++i) sig[6 * i] = sig[6 * i + 1] = sig[6 * i + 2] = -1e6;
    trun_compute(&r);
    const ej_real *acc = ej_set_field(s, "a");
    double amax = 0;
    for (ej_idx i = 0; i < 3 * n; ++i) amax = fmax(amax, fabs(acc[i]));
    if (form) ck_assert_msg(amax < 1e-6, "difference form: |a| = %g", amax);
    else ck_assert_msg(amax > 1e3, "sum form: |a| = %g", amax);
    trun_close(&r);
  }
}
END_TEST

/* The 4 mm / 8 mm refine: scene of the interface tests: a 1-D bar (0.4 m, fine for x < 0.2) or a
 * 2-D plate (0.2 x 0.16 m, fine for x < 0.1), with the extra set options opts; opened in r. */
static void refine_open(trun *r, int dim, const char *opts)
{
  char y[1024];
  const char *box = dim == 1 ? "{min: [0], max: [0.4]}" : "{min: [0, 0], max: [0.2, 0.16]}";
  const char *rbox = dim == 1 ? "{min: [-1], max: [0.2]}" : "{min: [-1, -1], max: [0.1, 1]}";
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: %d\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: %s}, spacing: 0.008, "
           "refine: [{region: {box: %s}, spacing: 0.004}], %s}}\n",
           dim, box, rbox, opts);
  trun_open(r, y);
}

/* Patch test across a refine: interface (issue 4, item 3): a uniform strain (x = A x0) with a
 * uniform stress must give
 * zero force on every row farther than a coarse horizon from the free surfaces, also on the
 * dual-horizon rows of the 4 mm / 8 mm interface. Without ghost_force_correction these rows carry
 * the ghost force (about 0.25 P/dx in 1-D, asserted > 0.05 so that the test can fail). */
static double refine_ghost(int dim, bool corr, double hl, double grade)
{
  char opts[160];
  snprintf(opts, sizeof opts, "ghost_force_correction: %s, horizon_length: %g, horizon_grading: %g", corr ? "true" : "false",
           hl, grade);
  trun r;
  refine_open(&r, dim, opts);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *sig = ej_set_field(s, "stress"), *x = ej_set_field(s, "x"), *xp = ej_set_field(s, "x_prev");
  const ej_real *x0c = ej_set_field(s, "x0");
  const ej_real P = 1e6;
  /* uniform strain x = A x0 (F = A exactly, patch test) and a uniform Cauchy stress */
  const ej_real A[4] = {1.01, 0.02, -0.015, 0.99};
  for (ej_idx i = 0; i < n; ++i) {
    for (int a = 0; a < dim; ++a) {
      x[3 * i + a] = 0;
      for (int c = 0; c < dim; ++c) x[3 * i + a] += A[2 * a + c] * x0c[3 * i + c];
      xp[3 * i + a] = x[3 * i + a];
    }
    sig[6 * i] = -P, sig[6 * i + 1] = -0.5 * P, sig[6 * i + 2] = -0.3 * P;
    sig[6 * i + 5] = 0.2 * P; /* a shear component too (Voigt xy) */
  }
  trun_compute(&r);
  const ej_real *acc = ej_set_field(s, "a"), *x0 = ej_set_field(s, "x0"), *m = ej_set_field(s, "m");
  const ej_real *vol0 = ej_set_field(s, "vol0");
  const double hi[2] = {0.4, 0.2}, hi2 = 0.16, margin = 0.06; /* two coarse horizons (24 mm + dx/2): a row sees the surface through its neighbours' K */
  double worst = 0;
  int nin = 0, nfine = 0, ncoarse = 0;
  for (ej_idx i = 0; i < n; ++i) {
    bool in = x0[3 * i] > margin && x0[3 * i] < hi[dim - 1] - margin;
    if (dim == 2) in = in && x0[3 * i + 1] > margin && x0[3 * i + 1] < hi2 - margin;
    if (!in) continue;
    ++nin;
    const double dx = dim == 1 ? vol0[i] : sqrt(vol0[i]);
    nfine += dx < 0.006, ncoarse += dx > 0.006;
    const double rho0 = m[i] / vol0[i];
    for (int q = 0; q < dim; ++q) worst = fmax(worst, fabs(acc[3 * i + q]) * rho0 * dx / P); /* in units of P/dx */
  }
  ck_assert_int_gt(nfine, 10);
  ck_assert_int_gt(ncoarse, 10);
  ck_assert_int_gt(nin, 20);
  trun_close(&r);
  return worst;
}

/* horizon_grading (issue 4, item 5) on the same 4 mm / 8 mm bar and plate: (1) the graded
 * horizon pd_horizon equals the rule delta_i = max_j (3 dx_j - g max(0, |X_ij| - (dx_i + dx_j)/2))
 * evaluated by brute force over the set (24 mm at the interface, 12 mm beyond the ramp); (2) the
 * uniform-strain patch across the graded interface is exact with ghost_force_correction; (3) 1-D,
 * linear stress sigma_xx = -P (1 + x0/L) (F = I): the divergence on the rows away from the surfaces,
 * s_i = rho0 a_i / (d sigma/dx), is first-order consistent within 10 % with the grading
 * (0.95-1.08 in the numpy model of validation/tlpd_refine) and off by > 40 % without it
 * (0.55-1.47: the horizon jump 12 -> 24 mm). */
static double refine_linear(bool grade)
{
  char opts[96];
  snprintf(opts, sizeof opts, "ghost_force_correction: true, horizon_grading: %g", grade ? 0.125 : 0.0);
  trun r;
  refine_open(&r, 1, opts);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *sig = ej_set_field(s, "stress");
  const ej_real *x0 = ej_set_field(s, "x0"), *m = ej_set_field(s, "m"), *vol0 = ej_set_field(s, "vol0");
  const ej_real P = 1e6, L = 0.4;
  for (ej_idx i = 0; i < n; ++i) sig[6 * i] = -P * (1 + x0[3 * i] / L);
  trun_compute(&r);
  const ej_real *acc = ej_set_field(s, "a");
  double worst = 0;
  int nin = 0;
  for (ej_idx i = 0; i < n; ++i) {
    if (!(x0[3 * i] > 0.06 && x0[3 * i] < 0.34)) continue;
    ++nin;
    worst = fmax(worst, fabs(acc[3 * i] * m[i] / vol0[i] / (-P / L) - 1));
  }
  ck_assert_int_gt(nin, 40);
  trun_close(&r);
  return worst;
}

START_TEST(test_refine_graded_horizon)
{
  const double g = 0.125;
  for (int dim = 1; dim <= 2; ++dim) {
    char opts[64];
    snprintf(opts, sizeof opts, "horizon_grading: %g", g);
    trun r;
    refine_open(&r, dim, opts);
    ej_set *s = r.sim->sets[0];
    const ej_idx n = ej_set_count(s);
    trun_compute(&r);
    const ej_real *x0 = ej_set_field(s, "x0"), *vol0 = ej_set_field(s, "vol0"), *hz = ej_set_field(s, "pd_horizon");
    ck_assert_msg(hz != NULL, "horizon_grading: field pd_horizon missing");
    double err = 0, dfmax = 0;
    int n24 = 0, n12 = 0;
    for (ej_idx i = 0; i < n; ++i) {
      const double dxi = dim == 1 ? vol0[i] : sqrt(vol0[i]);
      double want = 3 * dxi;
      for (ej_idx j = 0; j < n; ++j) {
        const double dxj = dim == 1 ? vol0[j] : sqrt(vol0[j]);
        const double a0 = x0[3 * j] - x0[3 * i], a1 = x0[3 * j + 1] - x0[3 * i + 1];
        want = fmax(want, 3 * dxj - g * fmax(0, sqrt(a0 * a0 + a1 * a1) - 0.5 * (dxi + dxj)));
      }
      err = fmax(err, fabs(hz[i] - want));
      if (dxi < 0.006) {
        dfmax = fmax(dfmax, hz[i]);
        n24 += fabs(hz[i] - 0.024) < 1e-12;
        n12 += fabs(hz[i] - 0.012) < 1e-12;
      } else {
        ck_assert_msg(fabs(hz[i] - 0.024) < 1e-15, "coarse particle with horizon %g", hz[i]);
      }
    }
    fprintf(stderr, "tlpd graded horizon, %d-D: max |delta - rule| %.2e m, fine rows at 24 mm: %d, at 12 mm: %d\n", dim, err,
            n24, n12);
    ck_assert_msg(err < 1e-15, "%d-D: graded horizon differs from the rule by %g m", dim, err);
    /* the fine row next to the interface has (nearly: in 2-D the lattices are offset) the coarse horizon */
    ck_assert(n12 > 0 && dfmax > 0.023 && dfmax <= 0.024 + 1e-15);
    trun_close(&r);
  }
  const double lin_off = refine_linear(false), lin_on = refine_linear(true);
  fprintf(stderr, "tlpd refine interface, 1-D linear stress: max |s_i - 1| %.3f with 3 dx_i, %.3f graded (0.125)\n", lin_off, lin_on);
  ck_assert_msg(lin_off > 0.4, "3 dx_i: the horizon jump should make the divergence inconsistent (%g)", lin_off);
  ck_assert_msg(lin_on < 0.1, "graded: first-order error %g of the divergence", lin_on);
  for (int dim = 1; dim <= 2; ++dim) {
    const double off = refine_ghost(dim, false, 0, g), on = refine_ghost(dim, true, 0, g);
    fprintf(stderr, "tlpd refine interface, %d-D, horizon_grading %g: %.3e P/dx without, %.3e with ghost_force_correction\n",
            dim, g, off, on);
    ck_assert_msg(on < 1e-9, "%d-D, graded: ghost force %g P/dx with the correction", dim, on);
  }
}
END_TEST

START_TEST(test_patch_refine_interface)
{
  for (int dim = 1; dim <= 2; ++dim) {
    const double off = refine_ghost(dim, false, 0, 0), on = refine_ghost(dim, true, 0, 0);
    const double hoff = refine_ghost(dim, false, 0.024, 0), hon = refine_ghost(dim, true, 0.024, 0);
    fprintf(stderr, "tlpd refine interface, %d-D, horizon_length 24 mm: %.3e P/dx without, %.3e with ghost_force_correction\n",
            dim, hoff, hon);
    fprintf(stderr, "tlpd refine interface, %d-D: ghost force of a uniform stress %.3e P/dx without, %.3e with ghost_force_correction\n",
            dim, off, on);
    ck_assert_msg(off > 0.05, "%d-D: the uncorrected interface should carry a ghost force (%g P/dx)", dim, off);
    /* 1-D: every interior interface row is corrected. 2-D: the free-surface test of the rows
     * (their neighbours' cells cover >= 0.85 of the horizon disc) misses some interface rows
     * (0.58-0.82 of the disc with 8 mm cells in a 12 mm horizon), which keep their ghost force:
     * only "no worse" is asserted there (issue 4, item 3, open) */
    /* one absolute horizon across the interface (horizon_length): the ball test accepts the
     * interface rows in 2-D as well, and the corrected patch is exact (issue 4: 2-D patch) */
    ck_assert_msg(hoff > 1e-3, "%d-D, horizon_length: the uncorrected interface should carry a ghost force (%g P/dx)", dim, hoff);
    ck_assert_msg(hon < 1e-9, "%d-D, horizon_length: ghost force %g P/dx with the correction", dim, hon);
    /* 2-D passes since the core's refine tiles the shape without the half-cell gap (geometry.c). */
    ck_assert_msg(on < 1e-9, "%d-D: ghost force %g P/dx with the correction", dim, on);
  }
}
END_TEST

/* ------------------------------------------------------------------ bonds */

START_TEST(test_bond_breaking)
{
  trun r;
  trun_open(&r, "ejecta: 1\ndimension: 3\ntime: {end: 1e-6}\n" MAT
                "sets: {b: {method: tlpd, material: m, failure: {critical_stretch: 0.01}, "
                "shape: {box: {min: [0, 0, 0], max: [0.08, 0.04, 0.04]}}, spacing: 0.01}}\n");
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *x = ej_set_field(s, "x");
  const ej_real *x0 = ej_set_field(s, "x0");
  /* open a gap of 2 mm at x = 0.04: every bond crossing the plane is stretched */
  for (ej_idx i = 0; i < n; ++i)
    if (x0[3 * i] > 0.04) x[3 * i] += 0.002;
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){0, n / 2}), EJ_OK);
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){n / 2, n}), EJ_OK);
  const uint8_t *fl = ej_set_bond_flags(s);
  const ej_nbr *nb = &s->list->pub;
  int64_t broken = 0;
  for (ej_idx i = 0; i < n; ++i)
    for (ej_off k = nb->off[i]; k < nb->off[i + 1]; ++k) {
      const ej_idx j = nb->idx[k];
      const bool cross = (x0[3 * i] > 0.04) != (x0[3 * j] > 0.04);
      ck_assert_int_eq((fl[k] & 1) != 0, cross);
      broken += (fl[k] & 1);
      /* symmetric: the reverse bond has the same status */
      bool found = false;
      for (ej_off q = nb->off[j]; q < nb->off[j + 1]; ++q)
        if (nb->idx[q] == i) {
          found = true;
          ck_assert_int_eq(fl[q] & 1, fl[k] & 1);
        }
      ck_assert(found);
    }
  ck_assert(broken > 0);
  const ej_real *dmg = ej_set_field(s, "damage");
  for (ej_idx i = 0; i < n; ++i) {
    const bool near = fabs(x0[3 * i] - 0.04) < 0.03;
    if (near) ck_assert(dmg[i] > 0 && dmg[i] < 1);
    else ck_assert(dmg[i] == 0);
  }
  /* irreversible: closing the gap heals nothing */
  for (ej_idx i = 0; i < n; ++i) x[3 * i] = x0[3 * i];
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){0, n}), EJ_OK);
  int64_t broken2 = 0;
  for (ej_off k = 0; k < nb->off[n]; ++k) broken2 += fl[k] & 1;
  ck_assert_int_eq(broken2, broken);
  /* the halves are still well conditioned (K over intact bonds): F = I after the gap closes */
  trun_compute(&r);
  const ej_real *F = ej_set_field(s, "F");
  for (ej_idx i = 0; i < n; ++i)
    for (int k = 0; k < 9; ++k) ck_assert(fabs(F[9 * i + k] - ((k % 4 == 0) ? 1 : 0)) < 1e-12);
  trun_close(&r);
}
END_TEST

/* The particle at (x, y) of a 2-D set, flagged failed (as if the material had set it), then one
 * force evaluation (pass 0 sees the flag) and post_step, which breaks the bonds. */
static ej_idx fail_at(trun *r, double x, double y)
{
  ej_set *s = r->sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_real *x0 = ej_set_field(s, "x0");
  ej_idx pa = -1;
  for (ej_idx i = 0; i < n; ++i)
    if (fabs(x0[3 * i] - x) < 1e-9 && fabs(x0[3 * i + 1] - y) < 1e-9) pa = i;
  ck_assert(pa >= 0);
  ej_set_field_int(s, "failed")[pa] = 1;
  trun_compute(r);
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){0, n}), EJ_OK);
  return pa;
}

/* A failed point loses all its bonds and becomes detached (F = I, P = 0, damage 1, 000
 * section 5), and its neighbours lose the bonds to it. */
START_TEST(test_point_failure_detached)
{
  trun r;
  trun_open(&r, "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
                "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0], max: [0.05, 0.05]}}, spacing: 0.01}}\n");
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_nbr *nb = &s->list->pub;
  const ej_idx pa = fail_at(&r, 0.025, 0.025);
  const int32_t *st = ej_set_field_int(s, "pd_status");
  ck_assert_int_eq(st[pa], 2);
  ck_assert(ej_set_field(s, "damage")[pa] == 1);
  const uint8_t *fl = ej_set_bond_flags(s);
  for (ej_idx i = 0; i < n; ++i)
    for (ej_off k = nb->off[i]; k < nb->off[i + 1]; ++k) ck_assert_int_eq(fl[k] & 1, i == pa || nb->idx[k] == pa);
  trun_compute(&r);
  const ej_real *F = ej_set_field(s, "F"), *PK = ej_set_field(s, "PK"), *acc = ej_set_field(s, "a");
  for (int k = 0; k < 9; ++k) ck_assert(F[9 * pa + k] == ((k % 4 == 0) ? 1 : 0) && PK[9 * pa + k] == 0);
  for (int k = 0; k < 3; ++k) ck_assert(acc[3 * pa + k] == 0);
  int64_t nfb = 0;
  for (ej_idx i = 0; i < n; ++i) nfb += st[i] == 1;
  ck_assert_int_eq(nfb, 0);
  trun_close(&r);
}
END_TEST

/* failure.cut_distance (seed 002 Sec. 2.4 (b)): a failed point also breaks the intact bonds whose
 * reference segment passes within cut_distance dx of it. 2-D block, spacing 10 mm, horizon 3,
 * partial volumes (families to 3.5 dx), one failed particle in the middle: every bond flag equals
 * the rule evaluated here by projection (a different formula from the plugin's cross product), the
 * flags are symmetric, and the cut breaks bonds beyond the failed particle's own. Returns the
 * number of broken row entries. */
static int64_t cut_case(double cut)
{
  trun r;
  char yaml[512];
  snprintf(yaml, sizeof yaml,
           "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0], max: [0.11, 0.11]}}, spacing: 0.01, "
           "failure: {cut_distance: %g}}}\n",
           cut);
  trun_open(&r, yaml);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_nbr *nb = &s->list->pub;
  const ej_real *x0 = ej_set_field(s, "x0");
  const ej_idx pa = fail_at(&r, 0.055, 0.055);
  const uint8_t *fl = ej_set_bond_flags(s);
  const double dx = 0.01, R = 3 * dx, rc = cut * dx;
  int64_t broken = 0, cut_only = 0;
  const double *P = x0 + 3 * pa;
  for (ej_idx i = 0; i < n; ++i)
    for (ej_off k = nb->off[i]; k < nb->off[i + 1]; ++k) {
      const ej_idx j = nb->idx[k];
      const double *A = x0 + 3 * i, *B = x0 + 3 * j;
      bool want = i == pa || j == pa;
      if (!want && cut > 0) {
        const double dpa = hypot(P[0] - A[0], P[1] - A[1]), dpb = hypot(P[0] - B[0], P[1] - B[1]);
        const double ex = B[0] - A[0], ey = B[1] - A[1], L2 = ex * ex + ey * ey;
        double t = ((P[0] - A[0]) * ex + (P[1] - A[1]) * ey) / L2;
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        const double d = hypot(A[0] + t * ex - P[0], A[1] + t * ey - P[1]);
        want = dpa < R * (1 - 1e-6) && dpb < R * (1 - 1e-6) && d < rc;
        cut_only += want;
      }
      ck_assert_msg((fl[k] & 1) == want, "bond %d-%d: flag %d, rule %d", (int)i, (int)j, fl[k] & 1, (int)want);
      broken += fl[k] & 1;
      /* symmetric: the reverse entry carries the same flag */
      ej_off kr = nb->off[j];
      while (kr < nb->off[j + 1] && nb->idx[kr] != i) ++kr;
      ck_assert(kr < nb->off[j + 1]);
      ck_assert_int_eq(fl[kr] & 1, fl[k] & 1);
    }
  if (cut > 0) ck_assert_msg(cut_only >= 20, "only %lld row entries cut", (long long)cut_only);
  trun_close(&r);
  return broken;
}

START_TEST(test_failure_cut)
{
  const int64_t own = cut_case(0), half = cut_case(0.5);
  /* the failed particle's own bonds (both row entries), then the cut on top: the bonds through its
   * lattice neighbours' pairs across it, e.g. (i-1, i+1), and the diagonals passing by */
  ck_assert_int_gt(own, 40);
  ck_assert_int_gt(half, own + 20);
  printf("failure cut: %lld broken row entries without the cut, %lld with cut_distance 0.5\n", (long long)own,
         (long long)half);
}
END_TEST

/* One row of particles in 2D: every K is singular (collinear bonds), so every particle uses
 * the bond-based spring fallback; a uniform stretch pulls only the ends, and the power
 * balance still closes. */
START_TEST(test_spring_fallback)
{
  trun r;
  trun_open(&r, "ejecta: 1\ndimension: 2\ntime: {end: 1e-6}\n" MAT
                "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0], max: [0.2, 0.01]}}, spacing: 0.01}}\n");
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const int32_t *st = ej_set_field_int(s, "pd_status");
  for (ej_idx i = 0; i < n; ++i) ck_assert_int_eq(st[i], 1);
  ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  const ej_real *x0 = ej_set_field(s, "x0"), *m = ej_set_field(s, "m");
  for (ej_idx i = 0; i < n; ++i) {
    x[3 * i] = 1.001 * x0[3 * i];
    v[3 * i] = x0[3 * i];
  }
  trun_compute(&r);
  const ej_real *acc = ej_set_field(s, "a"), *ed = ej_set_field(s, "e_dot");
  double amax = 0, pw = 0, pws = 0, mom = 0;
  for (ej_idx i = 0; i < n; ++i) {
    amax = fmax(amax, fabs(acc[3 * i]));
    pw += m[i] * (v[3 * i] * acc[3 * i] + ed[i]);
    pws += fabs(m[i] * v[3 * i] * acc[3 * i]);
    mom += m[i] * acc[3 * i];
  }
  ck_assert(amax > 0);
  ck_assert_msg(fabs(pw) < 1e-12 * pws, "power %g of %g", pw, pws);
  ck_assert(fabs(mom) < 1e-12 * amax * m[0] * n);
  /* the left end is pulled to +x (tension), the middle particle feels nothing */
  ej_idx left = 0, mid = 0;
  for (ej_idx i = 0; i < n; ++i) {
    if (x0[3 * i] < x0[3 * left]) left = i;
    if (fabs(x0[3 * i] - 0.105) < 1e-9) mid = i;
  }
  ck_assert(acc[3 * left] > 0);
  ck_assert(fabs(acc[3 * mid]) < 1e-9 * amax);
  trun_close(&r);
}
END_TEST

/* ------------------------------------------------------------------ thread-count determinism */

/* x, v, stress and damage of the set's owned particles into buf (13 n values); returns the end */
static ej_real *copy_state(const ej_set *s, ej_real *buf)
{
  const char *names[] = {"x", "v", "stress", "damage"};
  const int nc[] = {3, 3, 6, 1};
  const ej_idx n = ej_set_count(s);
  for (int k = 0; k < 4; ++k) {
    memcpy(buf, ej_set_field(s, names[k]), (size_t)n * nc[k] * sizeof *buf);
    buf += (size_t)n * nc[k];
  }
  return buf;
}

/* 25 steps of a jittered, compressed and sheared block with bond breaking (about 1300 particles:
 * three chunks of 512) on 1 and on 2 threads: positions, velocities, stress and damage must be
 * bitwise identical (gather form, per-row sums, the F_n reuse of pass 0 included). */
static void det_run(int threads, const char *dir, ej_real **out, ej_idx *n_out)
{
  char path[256], h5[256];
  snprintf(path, sizeof path, "%s/d%d.yaml", dir, threads);
  snprintf(h5, sizeof h5, "%s/d%d.h5", dir, threads);
  FILE *f = fopen(path, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "ejecta: 1\ndimension: 3\ntime: {end: 1, cfl: 0.5, max_steps: 25}\n" MAT
             "output: {file: %s}\n"
             "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0, 0], max: [0.11, 0.11, 0.11]}}, "
             "spacing: 0.01, jitter: 0.2, failure: {critical_stretch: 0.002}, "
             "initial: [{region: {box: {min: [0, 0, 0.06], max: [1, 1, 1]}}, velocity: [3, 0, -5]}]}}\n",
          h5);
  fclose(f);
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_tlpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_scene_load(path, reg, &sc), EJ_OK);
  ej_run_opts o = {.struct_size = sizeof o, .threads = threads};
  ck_assert_int_eq(ej_sim_create(sc, reg, &o, &sim), EJ_OK);
  ej_err rc = ej_sim_run(sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set *s = sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ej_real *buf = malloc((size_t)n * 13 * sizeof *buf);
  ck_assert_ptr_nonnull(buf);
  copy_state(s, buf);
  const ej_real *dmg = ej_set_field(s, "damage");
  double dsum = 0;
  for (ej_idx i = 0; i < n; ++i) dsum += dmg[i];
  ck_assert_msg(dsum > 0, "no bond broke: the test would not exercise breaking");
  *out = buf;
  *n_out = n;
  ej_sim_destroy(sim);
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
  unlink(path);
  unlink(h5);
  snprintf(h5, sizeof h5, "%s/d%d.xdmf", dir, threads);
  unlink(h5);
}

/* break_skip (tlpd_post_step's bond-break skip): a 40 x 8 x 6 bar whose end is pulled off at 2 m/s
 * (critical stretch 0.002: the bonds across the pull break over several steps, longest last), a
 * symmetry plane y = 0 (mirror ghosts in the families), a corner particle failed from the start,
 * and at step 30 one particle far from the pull, still nearly at rest, marked failed (its
 * neighbours must break their bonds to it although their sweeps are being skipped). With the skip on and off, after
 * 60 steps: positions, velocities, stress, damage, failed flags and every bond flag bitwise equal;
 * the skip skipped sweeps and the pull broke bonds. */
static void skip_run(bool skip, double cut, ej_real **out, uint8_t **flags_out, ej_idx *n_out, ej_off *nb_out,
                     int64_t *skipped)
{
  trun r;
  char yaml[1024];
  snprintf(yaml, sizeof yaml,
           "ejecta: 1\ndimension: 3\ntime: {end: 1, cfl: 0.5, max_steps: 30}\n" MAT
           "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0, 0, 0], max: [0.4, 0.08, 0.06]}}, "
           "spacing: 0.01, failure: {critical_stretch: 0.002, cut_distance: %g}, break_skip: %s, "
           "initial: [{region: {box: {min: [-1, -1, -1], max: [0.03, 1, 1]}}, velocity: [-2, 0, 0]}]}}\n"
           "boundaries: [{symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}}]\n",
           cut, skip ? "true" : "false");
  trun_open(&r, yaml);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const ej_real *x0 = ej_set_field(s, "x0");
  ej_idx pf = -1, p0 = -1;
  for (ej_idx i = 0; i < n; ++i) {
    if (fabs(x0[3 * i] - 0.305) < 1e-9 && fabs(x0[3 * i + 1] - 0.005) < 1e-9 && fabs(x0[3 * i + 2] - 0.025) < 1e-9) pf = i;
    if (fabs(x0[3 * i] - 0.395) < 1e-9 && fabs(x0[3 * i + 1] - 0.075) < 1e-9 && fabs(x0[3 * i + 2] - 0.055) < 1e-9) p0 = i;
  }
  ck_assert_int_ge(pf, 0);
  ck_assert_int_ge(p0, 0);
  /* a corner particle failed from the start: failed ends break bonds (check_fail) from the first
   * step on, so the failure at step 30 has to be found by the skip's failure counts */
  ej_set_field_int(s, "failed")[p0] = 1;
  ej_err rc = ej_sim_run(r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set_field_int(s, "failed")[pf] = 1;
  r.scene->max_steps = 60;
  char o2[256]; /* the first run closed its output: a second file for the rest */
  snprintf(o2, sizeof o2, "%s/o2.h5", r.dir);
  ck_assert_int_eq(ej_output_open(&r.sim->out, r.sim, o2), EJ_OK);
  rc = ej_sim_run(r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_real *buf = malloc((size_t)n * 14 * sizeof *buf);
  ck_assert_ptr_nonnull(buf);
  ej_real *p = copy_state(s, buf);
  const int32_t *failed = ej_set_field_int(s, "failed");
  for (ej_idx i = 0; i < n; ++i) p[i] = failed[i];
  const ej_nbr *nb = &s->list->pub;
  const ej_off nbonds = nb->off[n];
  uint8_t *fl = malloc((size_t)nbonds);
  ck_assert_ptr_nonnull(fl);
  memcpy(fl, ej_set_bond_flags(s), (size_t)nbonds);
  /* the bonds of the failed particle are broken from both ends */
  for (ej_idx i = 0; i < n; ++i)
    for (ej_off k = nb->off[i]; k < nb->off[i + 1]; ++k)
      if (i == pf || nb->idx[k] == pf) ck_assert_int_eq(fl[k] & 1, 1);
  ej_counter c[8];
  int nc_out = 0;
  ck_assert_int_eq(s->mops->counters(s->mstate, c, 8, &nc_out), EJ_OK);
  *skipped = -1;
  for (int k = 0; k < nc_out; ++k)
    if (strstr(c[k].name, "skipped")) *skipped = c[k].value;
  *out = buf, *flags_out = fl, *n_out = n, *nb_out = nbonds;
  trun_close(&r);
}

START_TEST(test_break_skip)
{
  int64_t broken_by_cut[2];
  for (int c = 0; c < 2; ++c) { /* without and with failure.cut_distance (its rows must not be skipped) */
    const double cut = c ? 0.5 : 0;
    ej_real *a, *b;
    uint8_t *fa, *fb;
    ej_idx na, nb;
    ej_off ba, bb;
    int64_t sa, sb;
    skip_run(true, cut, &a, &fa, &na, &ba, &sa);
    skip_run(false, cut, &b, &fb, &nb, &bb, &sb);
    ck_assert_int_eq(na, nb);
    ck_assert_int_eq(ba, bb);
    ck_assert_msg(memcmp(a, b, (size_t)na * 14 * sizeof *a) == 0, "fields differ with and without break_skip (cut %g)", cut);
    ck_assert_msg(memcmp(fa, fb, (size_t)ba) == 0, "bond flags differ with and without break_skip (cut %g)", cut);
    int64_t broken = 0;
    for (ej_off k = 0; k < ba; ++k) broken += fa[k] & 1;
    broken_by_cut[c] = broken;
    /* the pull broke bonds beyond those of the two failed particles (~70 and ~30 each way) */
    ck_assert_msg(broken > 400, "only %lld broken bonds: the test would not exercise breaking", (long long)broken);
    ck_assert_int_eq(sb, -1); /* off: no counter */
    ck_assert_msg(sa > (int64_t)na * 10, "%lld sweeps skipped of %lld row-steps", (long long)sa, (long long)na * 60);
    ck_assert_msg(sa < (int64_t)na * 60, "every sweep skipped: the pull's rows must sweep");
    free(a), free(b), free(fa), free(fb);
  }
  /* the cut around the two failed particles (one beside the symmetry plane) breaks more bonds */
  ck_assert_msg(broken_by_cut[1] > broken_by_cut[0] + 100, "broken row entries %lld without the cut, %lld with",
                (long long)broken_by_cut[0], (long long)broken_by_cut[1]);
  printf("break_skip with failure cut: %lld broken row entries without the cut, %lld with cut_distance 0.5\n",
         (long long)broken_by_cut[0], (long long)broken_by_cut[1]);
}
END_TEST

/* ------------------------------------------------------------------ stable step of the family */

/* The 40-particle chain of the two family-step tests below. */
static const char *const dt_family_chain =
    "ejecta: 1\ndimension: 1\ntime: {end: 1e-6}\n"
    "materials: {m: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0}}\n"
    "sets: {b: {method: tlpd, material: m, shape: {box: {min: [0], max: [0.4]}}, spacing: 0.01, "
    "horizon: 1.5, partial_volume: false, hourglass: zhu_zhao, hourglass_coefficient: 0.5, "
    "failure: {critical_stretch: 0.01}}}\n";

/* 1-D chain, horizon 1.5 dx (one neighbour each side), no partial volumes, nu = 0 (M = E),
 * zhu_zhao hourglass c_h = 0.5. Gershgorin bound of tlpd_stable_dt by hand, interior particle:
 * correspondence rows i-1, i+1 give 2 dx M (1/2dx)(1/dx) = M/dx; hourglass springs (C = c_h E /
 * dx^3 per row) 2 V_i sum (A C_i + B C_j) = 8 c_h E / dx: lambda = E (1 + 8 c_h) / (rho dx^2),
 * dt = 2 dx / (c sqrt(5)). After the bond (i, i+1) breaks: own row K = dx^3, |K^-1 m1| = 1/dx,
 * H = 2/dx gives 2 M/dx, row i-1 0.5 M/dx, springs (C_i = 2 c_h E/dx^3) 6 c_h E/dx:
 * dt = 2 dx / (c sqrt(5.5)). Both below dx/c, so the family bound is what stable_dt returns. */
START_TEST(test_stable_dt_family)
{
  trun r;
  trun_open(&r, dt_family_chain);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  ck_assert_int_eq(n, 40);
  trun_compute(&r);
  const double dx = 0.01, c = sqrt(1e9 / 2000.0);
  const ej_real *x0 = ej_set_field(s, "x0");
  ej_idx i = -1;
  for (ej_idx k = 0; k < n; ++k)
    if (fabs(x0[3 * k] - 0.205) < 1e-9) i = k;
  ck_assert_int_ge(i, 0);
  ej_real dt = 0;
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){i, i + 1}, &dt), EJ_OK);
  ck_assert_msg(fabs(dt / (2 * dx / (c * sqrt(5.0))) - 1) < 1e-6, "intact: dt %g, expected %g", dt, 2 * dx / (c * sqrt(5.0)));
  /* break the bond to the right neighbour: shift everything right of x = 0.21 by 0.02 dx */
  ej_real *x = ej_set_field(s, "x");
  for (ej_idx k = 0; k < n; ++k)
    if (x0[3 * k] > 0.21) x[3 * k] += 0.02 * dx;
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){0, n}), EJ_OK);
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){i, i + 1}, &dt), EJ_OK);
  ck_assert_msg(fabs(dt / (2 * dx / (c * sqrt(5.5))) - 1) < 1e-6, "broken: dt %g, expected %g", dt, 2 * dx / (c * sqrt(5.5)));
  /* a particle whose families did not change keeps the intact value (x = 0.105) */
  for (ej_idx k = 0; k < n; ++k)
    if (fabs(x0[3 * k] - 0.105) < 1e-9) i = k;
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){i, i + 1}, &dt), EJ_OK);
  ck_assert_msg(fabs(dt / (2 * dx / (c * sqrt(5.0))) - 1) < 1e-6, "far: dt %g", dt);
  trun_close(&r);
}
END_TEST

/* The cached family step is recomputed only where a family changed: after a bond breaks at
 * x = 0.21 (rows 0.205 and 0.215), exactly the particles whose family holds one of those rows
 * (0.195 .. 0.225 at horizon 1.5 dx) get a new pd_dt_fam_t, every other keeps its time, and every
 * cached value equals a computation from scratch. */
START_TEST(test_stable_dt_family_cache)
{
  trun r;
  trun_open(&r, dt_family_chain);
  ej_set *s = r.sim->sets[0];
  const ej_idx n = ej_set_count(s);
  trun_compute(&r);
  const double dx = 0.01;
  const ej_real *x0 = ej_set_field(s, "x0");
  ej_real *dt_fam = ej_set_field(s, "pd_dt_fam"), *dt_fam_t = ej_set_field(s, "pd_dt_fam_t");
  ck_assert(s->t == &r.sim->t);
  ej_real dt = 0;
  r.sim->t = 1e-6;
  for (ej_idx k = 0; k < n; ++k) dt_fam[k] = 0;
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){0, n}, &dt), EJ_OK);
  for (ej_idx k = 0; k < n; ++k) ck_assert(dt_fam_t[k] == 1e-6 && dt_fam[k] > 0);
  r.sim->t = 2e-6;
  ej_real *x = ej_set_field(s, "x");
  for (ej_idx k = 0; k < n; ++k)
    if (x0[3 * k] > 0.21) x[3 * k] += 0.02 * dx;
  ck_assert_int_eq(s->mops->post_step(s->mstate, s, (ej_range){0, n}), EJ_OK);
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){0, n}, &dt), EJ_OK);
  int fresh = 0;
  for (ej_idx k = 0; k < n; ++k) {
    const bool near = fabs(x0[3 * k] - 0.21) < 2 * dx;
    ck_assert_msg(dt_fam_t[k] == (near ? 2e-6 : 1e-6), "x0 %g: cached at %g", x0[3 * k], dt_fam_t[k]);
    fresh += near;
  }
  ck_assert_int_eq(fresh, 4);
  ej_real *keep = malloc((size_t)n * sizeof *keep);
  ck_assert_ptr_nonnull(keep);
  memcpy(keep, dt_fam, (size_t)n * sizeof *keep);
  for (ej_idx k = 0; k < n; ++k) dt_fam[k] = 0;
  ck_assert_int_eq(s->mops->stable_dt(s->mstate, s, (ej_range){0, n}, &dt), EJ_OK);
  for (ej_idx k = 0; k < n; ++k) ck_assert_msg(keep[k] == dt_fam[k], "x0 %g: cached %g, fresh %g", x0[3 * k], keep[k], dt_fam[k]);
  free(keep);
  trun_close(&r);
}
END_TEST

/* ------------------------------------------------------------------ energy of the rate predictor */

/* The core evaluates e_dot with the predicted velocity v_n + dt a_n; summed over the run this
 * creates (dt^2/4) sum m |a_n+1 - a_n|^2 of energy, large when broken families rattle. tlpd's
 * energy_correction re-evaluates the rate at the final velocity (exact in total). A jittered
 * block with a velocity jump and bond breaking at cfl 0.5, 120 steps: the final energy balance
 * relative to the initial kinetic energy with and without the correction. */
static double ecorr_run(const char *dir, bool corr)
{
  char path[256], h5[256];
  snprintf(path, sizeof path, "%s/e%d.yaml", dir, (int)corr);
  snprintf(h5, sizeof h5, "%s/e%d.h5", dir, (int)corr);
  FILE *f = fopen(path, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "ejecta: 1\ndimension: 3\ntime: {end: 1, cfl: 0.5, max_steps: 120}\n" MAT
             "output: {file: %s}\n"
             "sets: {b: {method: tlpd, material: m, energy_correction: %s, shape: {box: {min: [0, 0, 0], max: [0.09, 0.09, 0.09]}}, "
             "spacing: 0.01, jitter: 0.2, failure: {critical_stretch: 0.003}, "
             "initial: [{region: {box: {min: [0, 0, 0.05], max: [1, 1, 1]}}, velocity: [0, 0, 20]}]}}\n",
          h5, corr ? "true" : "false");
  fclose(f);
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_tlpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_scene_load(path, reg, &sc), EJ_OK);
  ej_run_opts o = {.struct_size = sizeof o, .threads = 1};
  ck_assert_int_eq(ej_sim_create(sc, reg, &o, &sim), EJ_OK);
  ej_set *s = sim->sets[0];
  const ej_real *v = ej_set_field(s, "v"), *m = ej_set_field(s, "m");
  double k0 = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) k0 += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  ej_err rc = ej_sim_run(sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  const ej_real *dmg = ej_set_field(s, "damage");
  double dsum = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) dsum += dmg[i];
  ck_assert_msg(dsum > 0, "no bond broke");
  const double rel = fabs(sim->energy.balance) / k0;
  ej_sim_destroy(sim);
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
  unlink(path);
  unlink(h5);
  snprintf(h5, sizeof h5, "%s/e%d.xdmf", dir, (int)corr);
  unlink(h5);
  return rel;
}

START_TEST(test_energy_correction)
{
  char dir[64];
  ej_test_tmpdir(dir, sizeof dir, "tlpd_ec");
  const double off = ecorr_run(dir, false), on = ecorr_run(dir, true);
  rmdir(dir);
  fprintf(stderr, "tlpd energy balance / initial kinetic energy: %.3e without, %.3e with energy_correction\n", off, on);
  ck_assert_msg(on < 0.2 * off, "correction %.3e vs %.3e", on, off);
  ck_assert_msg(on < 2e-3, "balance %.3e", on);
}
END_TEST

START_TEST(test_thread_determinism)
{
  char dir[64];
  ej_test_tmpdir(dir, sizeof dir, "tlpd_det");
  ej_real *a, *b;
  ej_idx na, nb;
  det_run(1, dir, &a, &na);
  det_run(2, dir, &b, &nb);
  rmdir(dir);
  ck_assert_int_gt(na, 1024);
  ck_assert_int_eq(na, nb);
  ck_assert_msg(memcmp(a, b, (size_t)na * 13 * sizeof *a) == 0, "1 and 2 threads differ");
  free(a);
  free(b);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("tlpd");
  TCase *tc = tcase_create("method");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_patch_1d);
  tcase_add_test(tc, test_patch_2d);
  tcase_add_test(tc, test_patch_3d);
  tcase_add_test(tc, test_patch_3d_jitter);
  tcase_add_test(tc, test_rigid_rotation_exact);
  tcase_add_test(tc, test_conservation_sum);
  tcase_add_test(tc, test_conservation_silling);
  tcase_add_test(tc, test_difference_not_conservative);
  tcase_add_test(tc, test_uniform_stress);
  tcase_add_test(tc, test_objective_forces);
  tcase_add_test(tc, test_patch_refine_interface);
  tcase_add_test(tc, test_refine_graded_horizon);
  tcase_add_test(tc, test_bond_breaking);
  tcase_add_test(tc, test_point_failure_detached);
  tcase_add_test(tc, test_failure_cut);
  tcase_add_test(tc, test_break_skip);
  tcase_add_test(tc, test_spring_fallback);
  tcase_add_test(tc, test_thread_determinism);
  tcase_add_test(tc, test_stable_dt_family);
  tcase_add_test(tc, test_stable_dt_family_cache);
  tcase_add_test(tc, test_energy_correction);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
