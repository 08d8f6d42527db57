/* repulsive_wall interaction (Monaghan's boundary force, PySPH's MonaghanBoundaryForce form):
 * - one SPH particle at rest above a row of boundary particles, one step of 1e-9 s: the
 *   acceleration matches the closed form m_w/(m_i + m_w) Gamma(y/h) chi(t) 0.02 c^2 / y summed over
 *   the boundary particles (and, inside the reach, 0.5 Gamma 0.02 c^2 / y: the hats sum to one),
 *   zero from q = 2 and at or behind the wall line, finite (the guard) at y = 1e-7 h;
 * - the same particle thrown at a wall that is free to move along the normal: it is repelled
 *   (never reaches the wall line), the total momentum of particle and wall is conserved to
 *   round-off, the force has no tangential part, and the energy budget with the reported `work`
 *   closes (the work returns to ~0 once the particle has left the range: a conservative force);
 * - a zero normal is refused. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hdf5.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_repulsive_wall_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);
const ej_plugin_info *ej_plugin_rigid_body_info(void);

#define DP 0.01  /* spacing of both sets, m */
#define HF 2.0   /* h = HF DP */
#define CS 20.0  /* sound_speed of the wall force, m/s */
#define DT1 1e-9 /* the one-step runs */

static ej_err rw_open(vscene *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_polynomial_info(), ej_plugin_rigid_body_info(),
                               ej_plugin_repulsive_wall_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "rwall", p, 4, fmt, ap);
  va_end(ap);
  return rc;
}

static ej_set *rw_set(vscene *c, const char *name) { return vsim_set(c->r.sim, name); }

/* One SPH particle at (x0, y0), rho0 1000, h = 2 DP, a row of 11 boundary particles at y = 0,
 * x = -5 DP ... 5 DP (rho0 1000: m_w = m_i). */
static const char scene_fmt[] =
    "ejecta: 1\ndimension: 2\ntime: {end: %.17g, %s}\noutput: {file: out.h5, every: %g}\n"
    "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 1e5}}\n"
    "  wallmat: {rho0: 1000}\n"
    "sets:\n  p: {method: sph, material: water, kernel: wendland_c2, h_factor: %g, variable_h: false,\n"
    "       shape: {box: {min: [%.17g, %.17g], max: [%.17g, %.17g]}}, spacing: %g, velocity: [%g, %g]}\n"
    "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, %d, 1], fix_rotation: [1, 1, 1],\n"
    "         shape: {box: {min: [%g, %g], max: [%g, %g]}}, spacing: %g}\n"
    "interactions:\n  - {model: repulsive_wall, sets: [p, wall], normal: [0, 1, 0], sound_speed: %g}\n";

static double gamma_q(double q)
{
  if (q <= 0 || q >= 2) return 0;
  if (q <= 2.0 / 3.0) return 2.0 / 3.0;
  if (q <= 1) return 2 * q * (1 - 0.75 * q);
  return 0.5 * (2 - q) * (2 - q);
}

/* a_y after one step of the particle at rest at (x0, y0); *ref the closed form over the boundary
 * particles closer than 2h (the plugin cuts there, whatever the list's skin holds), *ideal 0.5 Gamma 0.02 c^2 / max(y, 0.01 h). */
static double one_step(double x0, double y0, double *ax, double *ref, double *ideal)
{
  char tm[64];
  snprintf(tm, sizeof tm, "dt: %.17g", DT1);
  vscene c;
  ej_err rc = rw_open(&c, scene_fmt, DT1, tm, 1.0, HF, x0 - DP / 2, y0 - DP / 2, x0 + DP / 2, y0 + DP / 2, DP, 0.0, 0.0,
                      1, -5.5 * DP, -DP / 2, 5.5 * DP, DP / 2, DP, CS);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  rc = ej_sim_run(c.r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_int_eq((int)c.r.sim->step, 1);
  ej_set *p = rw_set(&c, "p"), *w = rw_set(&c, "wall");
  ck_assert_int_eq((int)p->n, 1);
  ck_assert_int_eq((int)w->n, 11);
  const ej_real *v = ej_set_field(p, "v"), *h = ej_set_field(p, "h"), *m = ej_set_field(p, "m");
  const ej_real *xw = ej_set_field(w, "x"), *mw = ej_set_field(w, "m");
  ck_assert_double_eq_tol(h[0], HF * DP, 1e-15);
  const double hh = h[0], ye = fmax(y0, 0.01 * hh), beta = 0.02 * CS * CS / ye;
  *ref = 0;
  for (ej_idx k = 0; k < w->n; ++k) {
    const double dx = x0 - xw[3 * k], dy = y0 - xw[3 * k + 1];
    if (dx * dx + dy * dy >= 4 * hh * hh || !(y0 > 0)) continue;
    const double chi = fabs(dx) < DP ? 1 - fabs(dx) / DP : 0;
    *ref += mw[k] / (m[0] + mw[k]) * gamma_q(y0 / hh) * chi * beta;
  }
  *ideal = y0 > 0 ? 0.5 * gamma_q(y0 / hh) * beta : 0;
  *ax = v[0] / DT1;
  const double ay = v[1] / DT1;
  vscene_free(&c);
  return ay;
}

START_TEST(test_closed_form)
{
  const double h = HF * DP;
  const struct {
    double x0, q;
    int full; /* every boundary particle with chi > 0 within the reach 2h */
  } cases[] = {{0.3 * DP, 0.5, 1},  {0.3 * DP, 0.8, 1}, {0.3 * DP, 1.5, 1}, {0.0, 1.99, 1},   {0.3 * DP, 1.99, 0},
               {0.3 * DP, 2.0, 1},  {0.3 * DP, 2.5, 1}, {0.3 * DP, 1e-7, 1}, {0.3 * DP, 0.0, 1}, {0.3 * DP, -0.3, 1}};
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    double ax, ref, ideal;
    const double ay = one_step(cases[k].x0, cases[k].q * h, &ax, &ref, &ideal);
    fprintf(stderr, "repulsive_wall: x0 %.2f dp, q %-6g a_y %.10g m/s^2, closed form %.10g, 0.5 Gamma beta %.10g\n",
            cases[k].x0 / DP, cases[k].q, ay, ref, ideal);
    ck_assert_msg(isfinite(ay) && isfinite(ax), "q %g: not finite", cases[k].q);
    ck_assert_msg(fabs(ay - ref) <= 1e-9 * fabs(ref) + 1e-9, "q %g: %.12g vs %.12g", cases[k].q, ay, ref);
    ck_assert_msg(fabs(ax) <= 1e-12 * fabs(ref) + 1e-9, "q %g: a_x %g", cases[k].q, ax);
    if (cases[k].full) ck_assert_msg(fabs(ref - ideal) <= 1e-12 * ideal, "q %g: hats %.12g vs %.12g", cases[k].q, ref, ideal);
    if (cases[k].q > 0 && cases[k].q < 2) ck_assert_double_gt(ay, 0); /* repelled */
    else ck_assert(ay == 0);
  }
}
END_TEST

static void momentum(vscene *c, double P[3])
{
  P[0] = P[1] = P[2] = 0;
  for (int s = 0; s < c->r.sim->n_sets; ++s) {
    const ej_set *t = c->r.sim->sets[s];
    const ej_real *v = ej_set_field(t, "v"), *m = ej_set_field(t, "m");
    for (ej_idx i = 0; i < t->n; ++i)
      for (int q = 0; q < 3; ++q) P[q] += m[i] * v[3 * i + q];
  }
}

/* y of particle 0 of a set in frame k of an output file (NAN when the frame does not exist). */
static double frame_y0(hid_t f, int k, const char *set)
{
  char path[128];
  snprintf(path, sizeof path, "/frames/%06d", k);
  if (H5Lexists(f, path, H5P_DEFAULT) <= 0) return NAN;
  snprintf(path, sizeof path, "/frames/%06d/%s/x", k, set);
  hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
  ck_assert_int_ge(d, 0);
  hid_t sp = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(sp, dims, NULL);
  double *x = malloc(dims[0] * dims[1] * sizeof *x);
  ck_assert_ptr_nonnull(x);
  ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, x), 0);
  const double y = x[1];
  free(x);
  H5Sclose(sp);
  H5Dclose(d);
  return y;
}

START_TEST(test_bounce_energy_momentum)
{
  const double h = HF * DP, y0 = 2.2 * h, v0[2] = {0.3, -1.0};
  vscene c;
  ej_err rc = rw_open(&c, scene_fmt, 0.08, "cfl: 0.2", 2e-4, HF, -DP / 2, y0 - DP / 2, DP / 2, y0 + DP / 2, DP, v0[0], v0[1],
                      0, -5.5 * DP, -DP / 2, 5.5 * DP, DP / 2, DP, CS);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  double P0[3], P1[3];
  momentum(&c, P0);
  rc = ej_sim_run(c.r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set *p = rw_set(&c, "p"), *w = rw_set(&c, "wall");
  const ej_real *v = ej_set_field(p, "v");
  /* closest approach to the (moving) wall line over the frames: particle y - wall particle y */
  double ymin = INFINITY;
  int nf = 0;
  hid_t f = H5Fopen(c.out, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  for (int k = 0;; ++k, ++nf) {
    const double yp = frame_y0(f, k, "p");
    if (isnan(yp)) break;
    ymin = fmin(ymin, yp - frame_y0(f, k, "wall"));
  }
  H5Fclose(f);
  ck_assert_int_gt(nf, 100);
  momentum(&c, P1);
  const ej_energy E = c.r.sim->energy;
  const double m = ej_set_field(p, "m")[0], ke0 = 0.5 * m * (v0[0] * v0[0] + v0[1] * v0[1]);
  double work = NAN;
  for (int k = 0; k < c.r.sim->reports.n; ++k)
    if (strstr(c.r.sim->reports.names[k], "work")) work = c.r.sim->reports.values[k];
  const ej_real *vw = ej_set_field(w, "v");
  fprintf(stderr,
          "repulsive_wall bounce: %lld steps, %d frames, closest approach y = %.4g h, particle v (%.6f, %.6f) m/s (initial "
          "(%.1f, %.1f)), wall vy %.3g m/s; momentum change (%.3g, %.3g) of %.3g; KE0 %.6g J, KE %.6g, internal "
          "%.3g, work %.3g, balance %.3g J\n",
          (long long)c.r.sim->step, nf, ymin / h, v[0], v[1], v0[0], v0[1], vw[1], P1[0] - P0[0], P1[1] - P0[1],
          m * hypot(v0[0], v0[1]), ke0, E.kinetic, E.internal, work, E.balance);
  ck_assert_double_gt(ymin, 0.2 * h);       /* repelled well before the wall line */
  ck_assert_double_gt(v[1], 0.0);           /* bounced */
  ck_assert_double_lt(vw[1], 0.0);          /* the reaction pushed the free wall down */
  ck_assert(v[0] == v0[0]);                  /* no tangential force */
  const double pscale = m * hypot(v0[0], v0[1]);
  for (int q = 0; q < 3; ++q) ck_assert_double_lt(fabs(P1[q] - P0[q]), 1e-12 * pscale);
  ck_assert_double_lt(fabs(E.kinetic - ke0), 1e-3 * ke0); /* elastic: the potential is back to zero */
  ck_assert_double_lt(fabs(work), 1e-3 * ke0);
  ck_assert_double_lt(fabs(E.balance), 1e-3 * ke0);
  vscene_free(&c);
}
END_TEST

START_TEST(test_zero_normal_refused)
{
  vscene c;
  ej_err rc = rw_open(&c,
                      "ejecta: 1\ndimension: 2\ntime: {end: 1e-9, dt: 1e-9}\noutput: {file: out.h5}\n"
                      "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 1e5}}\n"
                      "  wallmat: {rho0: 1000}\n"
                      "sets:\n  p: {method: sph, material: water, shape: {box: {min: [0, 0.005], max: [0.01, 0.015]}},"
                      " spacing: 0.01}\n"
                      "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: [1, 1, 1],"
                      " shape: {box: {min: [0, -0.005], max: [0.01, 0.005]}}, spacing: 0.01}\n"
                      "interactions:\n  - {model: repulsive_wall, sets: [p, wall], normal: [0, 0, 0]}\n");
  ck_assert_int_ne(rc, EJ_OK);
  ej_error_clear();
  vscene_free(&c);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("repulsive_wall");
  TCase *tc = tcase_create("wall");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_closed_form);
  tcase_add_test(tc, test_bounce_energy_momentum);
  tcase_add_test(tc, test_zero_normal_refused);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  const int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
