/* rigid_body method: free fall (exact for velocity Verlet under a constant force), a spinning
 * asymmetric body stays rigid and keeps its angular momentum, and momentum exchange with an
 * elastic RKPM block through kernel_contact conserves total momentum to round-off and closes
 * the energy budget; kernel_contact's normal damping gives the restitution of a clipped linear
 * dashpot. */
#include <check.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_rigid_body_info(void);
const ej_plugin_info *ej_plugin_rkpm_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_kernel_contact_info(void);

/* A scene run through the shared harness (validation_common.h: vscene). */
typedef struct rb_run {
  vscene v;
  ej_sim *sim;
} rb_run;

static ej_err rb_vopen(vscene *c, const ej_plugin_info *const *p, int np, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "rb", p, np, fmt, ap);
  va_end(ap);
  return rc;
}

static void rb_open(rb_run *R, const char *text)
{
  const ej_plugin_info *p[] = {ej_plugin_rigid_body_info(), ej_plugin_rkpm_info(), ej_plugin_elastic_info(), ej_plugin_kernel_contact_info()};
  ej_err rc = rb_vopen(&R->v, p, (int)(sizeof p / sizeof *p), "%s", text);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  R->sim = R->v.r.sim;
}

static void rb_go(rb_run *R)
{
  ej_err rc = ej_sim_run(R->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static void rb_close(rb_run *R)
{
  vscene_free(&R->v);
}

static ej_set *rb_set(const rb_run *R, const char *name) { return vsim_set(R->sim, name); }

/* Max over pairs (i, j) of | |x_i - x_j| - |x0_i - x0_j| |, pairs matched by id. */
static double rb_pair_dist_err(const ej_set *s, const double *x0, const int32_t *id0)
{
  const ej_idx n = ej_set_count(s);
  const ej_real *x = ej_set_field(s, "x");
  const int32_t *id = ej_set_field_int(s, "id");
  double *xs = malloc(sizeof(double) * 3 * (size_t)n);
  for (ej_idx i = 0; i < n; ++i)
    for (ej_idx k = 0; k < n; ++k)
      if (id0[k] == id[i]) memcpy(&xs[3 * k], &x[3 * i], 3 * sizeof(double));
  double err = 0;
  for (ej_idx i = 0; i < n; ++i)
    for (ej_idx j = i + 1; j < n; ++j) {
      double d0 = 0, d1 = 0;
      for (int c = 0; c < 3; ++c) {
        d0 += (x0[3 * i + c] - x0[3 * j + c]) * (x0[3 * i + c] - x0[3 * j + c]);
        d1 += (xs[3 * i + c] - xs[3 * j + c]) * (xs[3 * i + c] - xs[3 * j + c]);
      }
      err = fmax(err, fabs(sqrt(d1) - sqrt(d0)));
    }
  free(xs);
  return err;
}

static void rb_snapshot(const ej_set *s, double **x0, int32_t **id0)
{
  const ej_idx n = ej_set_count(s);
  *x0 = malloc(sizeof(double) * 3 * (size_t)n);
  *id0 = malloc(sizeof(int32_t) * (size_t)n);
  memcpy(*x0, ej_set_field(s, "x"), sizeof(double) * 3 * (size_t)n);
  memcpy(*id0, ej_set_field_int(s, "id"), sizeof(int32_t) * (size_t)n);
}

static void rb_moments(const ej_set *s, double X[3], double P[3], double L[3], double *ke)
{
  const ej_idx n = ej_set_count(s);
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v"), *m = ej_set_field(s, "m");
  double M = 0;
  *ke = 0;
  for (int d = 0; d < 3; ++d) X[d] = P[d] = L[d] = 0;
  for (ej_idx i = 0; i < n; ++i) {
    M += m[i];
    for (int d = 0; d < 3; ++d) X[d] += m[i] * x[3 * i + d], P[d] += m[i] * v[3 * i + d];
    *ke += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  }
  for (int d = 0; d < 3; ++d) X[d] /= M;
  for (ej_idx i = 0; i < n; ++i) {
    const double r[3] = {x[3 * i] - X[0], x[3 * i + 1] - X[1], x[3 * i + 2] - X[2]};
    const ej_real *vi = &v[3 * i];
    L[0] += m[i] * (r[1] * vi[2] - r[2] * vi[1]);
    L[1] += m[i] * (r[2] * vi[0] - r[0] * vi[2]);
    L[2] += m[i] * (r[0] * vi[1] - r[1] * vi[0]);
  }
}

/* Free fall with an initial velocity: velocity Verlet is exact for a constant force, so the
 * centre follows z0 + v0 t - g t^2 / 2 to round-off, and the body does not deform or spin. */
START_TEST(test_free_fall)
{
  rb_run R;
  rb_open(&R, "ejecta: 1\ndimension: 3\ntime: {end: 0.2, dt: 1.0e-3}\noutput: {file: rb.h5, fields: [v]}\n"
              "gravity: [0, 0, -9.81]\n"
              "materials:\n  steel: {rho0: 7800}\n"
              "sets:\n  ball: {method: rigid_body, material: steel, shape: {sphere: {center: [0, 0, 1], radius: 0.05}},"
              " spacing: 0.02, velocity: [1.5, 0, 2]}\n");
  ej_set *b = rb_set(&R, "ball");
  double X0[3], P0[3], L0[3], ke0, *x0;
  int32_t *id0;
  rb_moments(b, X0, P0, L0, &ke0);
  rb_snapshot(b, &x0, &id0);
  rb_go(&R);
  double X[3], P[3], L[3], ke;
  rb_moments(b, X, P, L, &ke);
  const double t = R.sim->t; /* 0.2 up to the core's landing step */
  const double ex = X0[0] + 1.5 * t, ez = X0[2] + 2 * t - 0.5 * 9.81 * t * t;
  const ej_real *v = ej_set_field(b, "v");
  double dv = 0;
  for (ej_idx i = 0; i < ej_set_count(b); ++i)
    dv = fmax(dv, fabs(v[3 * i] - 1.5) + fabs(v[3 * i + 1]) + fabs(v[3 * i + 2] - (2 - 9.81 * t)));
  const double derr = rb_pair_dist_err(b, x0, id0);
  fprintf(stderr, "rigid_body free fall: |X - exact| %.3g %.3g m, max |v - exact| %.3g m/s, pair distance error %.3g m\n",
          fabs(X[0] - ex), fabs(X[2] - ez), dv, derr);
  ck_assert(fabs(X[0] - ex) < 1e-12 && fabs(X[2] - ez) < 1e-12 && fabs(X[1]) < 1e-12);
  ck_assert(dv < 1e-10); /* 6e-12 of g t: round-off of 200 steps (positions are exact to 3e-13 m) */
  ck_assert(derr < 1e-13);
  free(x0);
  free(id0);
  rb_close(&R);
}
END_TEST

/* An asymmetric box spinning about a non-principal axis (torque-free precession): positions stay
 * rigid to round-off, the world angular momentum is conserved (the drift conserves sum m x x v
 * exactly and no torque acts), the kinetic energy drifts only at O(dt^2). */
START_TEST(test_spin_rigid)
{
  rb_run R;
  rb_open(&R, "ejecta: 1\ndimension: 3\ntime: {end: 2.0, dt: 2.0e-3}\noutput: {file: rb.h5, fields: [v]}\n"
              "materials:\n  al: {rho0: 2700}\n"
              "sets:\n  box: {method: rigid_body, material: al, shape: {box: {min: [0, 0, 0], max: [0.3, 0.2, 0.1]}},"
              " spacing: 0.05, velocity: [0.1, 0, 0], omega: [3, 1, 2]}\n");
  ej_set *b = rb_set(&R, "box");
  double X0[3], P0[3], L0[3], ke0, *x0;
  int32_t *id0;
  rb_moments(b, X0, P0, L0, &ke0);
  rb_snapshot(b, &x0, &id0);
  rb_go(&R);
  double X[3], P[3], L[3], ke;
  rb_moments(b, X, P, L, &ke);
  const double derr = rb_pair_dist_err(b, x0, id0);
  const double nL = sqrt(L0[0] * L0[0] + L0[1] * L0[1] + L0[2] * L0[2]);
  const double dL = sqrt((L[0] - L0[0]) * (L[0] - L0[0]) + (L[1] - L0[1]) * (L[1] - L0[1]) + (L[2] - L0[2]) * (L[2] - L0[2]));
  fprintf(stderr,
          "rigid_body spin (1000 steps, dt |W| = 7.5e-3): pair distance error %.3g m, |dL|/|L| %.3g, dKE/KE %.3g, "
          "|X - X0 - V t| %.3g m\n",
          derr, dL / nL, (ke - ke0) / ke0, fabs(X[0] - X0[0] - 0.2));
  ck_assert(derr < 1e-12);
  ck_assert(dL < 1e-12 * nL);
  ck_assert(fabs(ke - ke0) < 1e-3 * ke0);
  ck_assert(fabs(X[0] - X0[0] - 0.2) < 1e-12);
  /* Precession really happened: the angular velocity is not constant for this body. */
  ck_assert(ke0 > 0);
  free(x0);
  free(id0);
  rb_close(&R);
}
END_TEST

/* A rigid disc hits an elastic RKPM block through kernel_contact (2D, oblique, with spin and
 * friction): total momentum of both sets is conserved to round-off, momentum is exchanged, and
 * the energy budget (kinetic + internal + reported penalty work and dissipation) closes. */
START_TEST(test_contact_exchange)
{
  rb_run R;
  rb_open(&R, "ejecta: 1\ndimension: 2\ntime: {end: 5.0, cfl: 0.25}\noutput: {file: rb.h5, fields: [v]}\n"
              "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n  hard: {rho0: 3}\n"
              "sets:\n"
              "  block: {method: rkpm, material: m, shape: {box: {min: [0, 0], max: [0.8, 0.6]}}, spacing: 0.1}\n"
              "  disc: {method: rigid_body, material: hard, modulus: 3, shape: {sphere: {center: [0.4, 0.95], radius: 0.25}},"
              " spacing: 0.1, velocity: [0.03, -0.05], omega: [0, 0, 0.2]}\n"
              "interactions:\n  - {model: kernel_contact, sets: [block, disc], mu: 0.3}\n");
  ej_set *blk = rb_set(&R, "block"), *disc = rb_set(&R, "disc");
  double Xa[3], Pa0[3], La[3], ka, Xb[3], Pb0[3], Lb[3], kb;
  rb_moments(blk, Xa, Pa0, La, &ka);
  rb_moments(disc, Xb, Pb0, Lb, &kb);
  double *x0;
  int32_t *id0;
  rb_snapshot(disc, &x0, &id0);
  const double e0 = R.sim->energy.kinetic + R.sim->energy.internal;
  rb_go(&R);
  double Pa1[3], Pb1[3];
  rb_moments(blk, Xa, Pa1, La, &ka);
  rb_moments(disc, Xb, Pb1, Lb, &kb);
  const double scale = fabs(Pb0[0]) + fabs(Pb0[1]);
  double dP = 0, dPb = 0;
  for (int d = 0; d < 2; ++d) dP = fmax(dP, fabs(Pa1[d] + Pb1[d] - Pa0[d] - Pb0[d])), dPb = fmax(dPb, fabs(Pb1[d] - Pb0[d]));
  const double derr = rb_pair_dist_err(disc, x0, id0);
  fprintf(stderr,
          "rigid_body + kernel_contact: |dP_total| %.3g (scale %.3g), |dP_disc| %.3g, disc pair distance error %.3g, "
          "energy balance %.3g of E0 %.3g (%.2f %%), steps %lld, disc P_y %.3g -> %.3g\n",
          dP, scale, dPb, derr, R.sim->energy.balance, e0, 100 * fabs(R.sim->energy.balance) / e0, (long long)R.sim->step, Pb0[1], Pb1[1]);
  ck_assert_msg(dP < 1e-12 * scale, "total momentum changed by %g", dP);
  ck_assert_msg(Pb1[1] - Pb0[1] > 0.5 * fabs(Pb0[1]), "disc's downward momentum %g -> %g: no collision?", Pb0[1], Pb1[1]);
  ck_assert(derr < 1e-12);
  ck_assert_msg(fabs(R.sim->energy.balance) < 0.02 * e0, "energy balance %g of %g", R.sim->energy.balance, e0);
  free(x0);
  free(id0);
  rb_close(&R);
}
END_TEST

/* rigid_body normals: true. A 3D box lattice: every point inside a face (not on an edge) has
 * the face's outward axis as its normal to round-off and depth 0; the interior has the depth of
 * one spacing and unit normals. A quarter ball on two symmetry planes (the sphere drop's ball):
 * the surface normals are radial within the lattice's staircase (10 deg on average), and the points
 * on the symmetry planes are no surface (their mirror images count in the colour function): the
 * surface points next to x = 0 are those of the sphere, |n_x| small; without the planes the cut
 * face is a surface, |n_x| = 1. */
static void rb_normal_stats(const ej_set *s, const double c[3], double sp, double *ang_mean,
                            double *ang_max, double *nx_plane, int *n_surf)
{
  const ej_real *x = ej_set_field(s, "x"), *n = ej_set_field(s, "rb_n"), *dep = ej_set_field(s, "rb_depth");
  ck_assert(x && n && dep);
  double sum = 0, mx = 0, npl = 0;
  int ns = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    const double *p = x + 3 * i, *u = n + 3 * i;
    ck_assert(fabs(sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) - 1) < 1e-12);
    double r[3], rr = 0;
    for (int k = 0; k < 3; ++k) r[k] = p[k] - c[k], rr += r[k] * r[k];
    rr = sqrt(rr);
    if (dep[i] != 0) continue;
    if (p[0] < sp) npl = fmax(npl, fabs(u[0])); /* surface points next to the x = 0 plane */
    const double cs = (r[0] * u[0] + r[1] * u[1] + r[2] * u[2]) / rr;
    const double a = acos(fmin(1, cs)) * 180 / M_PI;
    sum += a, mx = fmax(mx, a), ++ns;
  }
  *ang_mean = ns ? sum / ns : NAN, *ang_max = mx, *nx_plane = npl, *n_surf = ns;
}

START_TEST(test_surface_normals)
{
  rb_run R;
  rb_open(&R, "ejecta: 1\ndimension: 3\ntime: {end: 0.002, dt: 0.001}\noutput: {file: rb.h5, fields: [v]}\n"
              "materials:\n  hard: {rho0: 3}\n"
              "sets:\n  box: {method: rigid_body, material: hard, normals: true, fix_translation: [1, 1, 1],"
              " fix_rotation: [1, 1, 1], shape: {box: {min: [0, 0, 0], max: [0.6, 0.4, 0.4]}}, spacing: 0.1}\n");
  const ej_set *b = rb_set(&R, "box");
  const ej_real *x = ej_set_field(b, "x"), *n = ej_set_field(b, "rb_n"), *dep = ej_set_field(b, "rb_depth");
  ck_assert(x && n && dep);
  const double lo[3] = {0.05, 0.05, 0.05}, hi[3] = {0.55, 0.35, 0.35};
  int faces = 0, inner = 0;
  for (ej_idx i = 0; i < ej_set_count(b); ++i) {
    int on = 0, axis = -1, sign = 0;
    for (int k = 0; k < 3; ++k) {
      if (fabs(x[3 * i + k] - lo[k]) < 1e-9) ++on, axis = k, sign = -1;
      if (fabs(x[3 * i + k] - hi[k]) < 1e-9) ++on, axis = k, sign = 1;
    }
    if (on == 1) { /* inside a face */
      for (int k = 0; k < 3; ++k) ck_assert_msg(fabs(n[3 * i + k] - (k == axis ? sign : 0)) < 1e-12, "face normal");
      ck_assert(dep[i] == 0);
      ++faces;
    } else if (on == 0) {
      ck_assert_msg(dep[i] > 0.0999 && dep[i] < 0.1001, "interior depth %g", dep[i]); /* one spacing in */
      ++inner;
    }
  }
  fprintf(stderr, "rigid_body normals, 6x4x4 box: %d face points exact, %d interior points at depth 0.1\n", faces,
          inner);
  ck_assert_int_eq(faces, 2 * (4 * 2 + 4 * 2 + 2 * 2));
  ck_assert_int_eq(inner, 4 * 2 * 2);
  rb_close(&R);

  static const char ball[] =
      "ejecta: 1\ndimension: 3\ntime: {end: 0.002, dt: 0.001}\noutput: {file: rb.h5, fields: [v]}\n"
      "materials:\n  hard: {rho0: 3}\n"
      "sets:\n  ball: {method: rigid_body, material: hard, normals: true, fix_translation: [1, 1, 1],"
      " fix_rotation: [1, 1, 1], spacing: 0.002375, shape: {sphere: {center: [0, 0, 0.02], radius: 0.0095},"
      " minus: [{half_space: {point: [0, 0, 0], normal: [1, 0, 0]}}, {half_space: {point: [0, 0, 0], normal: [0, 1, "
      "0]}}]}}\n";
  const double c[3] = {0, 0, 0.02};
  double am[2], ax[2], npl[2];
  int ns[2];
  for (int planes = 1; planes >= 0; --planes) {
    char text[2048];
    snprintf(text, sizeof text, "%s%s", ball,
             planes ? "boundaries:\n  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n"
                      "  - symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}\n"
                    : "");
    rb_open(&R, text);
    rb_normal_stats(rb_set(&R, "ball"), c, 0.002375, &am[planes], &ax[planes], &npl[planes], &ns[planes]);
    rb_close(&R);
  }
  fprintf(stderr,
          "rigid_body normals, quarter ball d/8: with the symmetry planes %d surface points, angle to the radius "
          "mean %.2f, max %.2f deg, |n_x| of the surface points next to x = 0 <= %.3f; without them %d surface "
          "points, |n_x| %.3f\n",
          ns[1], am[1], ax[1], npl[1], ns[0], npl[0]);
  /* a ball of 4 spacings radius is a staircase: 10.1 deg on average, 17.6 at most (measured) */
  ck_assert_msg(am[1] < 12, "mean angle %g deg", am[1]);
  ck_assert_msg(ax[1] < 25, "max angle %g deg", ax[1]);
  ck_assert_msg(npl[1] < 0.5, "surface points at the symmetry plane point out of it (%g)", npl[1]);
  ck_assert_msg(npl[0] > 0.99, "without the plane its cut face should be a surface (%g)", npl[0]);
}
END_TEST

/* kernel_contact normal: body against the pair form. A 20 x 20 mm rigid block of 2 mm points hits
 * a fixed row of points 10 mm apart at 150 m/s (2D, penalty modulus 0.2 GPa for both). With the pair
 * direction the block's points slip between the row's points and the block goes through; with the
 * block's level-set normal and depth (rigid_body normals: true) the row pushes it back out of the
 * side it entered: it bounces, and the energy budget closes within 1 % of E0. */
static void pierce(const char *mode, double *v_end, double *low_min, double *bal)
{
  rb_run R;
  char text[2048];
  const bool body = !strcmp(mode, "body");
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 2\ntime: {end: 0.4 ms, cfl: 0.3}\noutput: {file: rb.h5, fields: [v]}\n"
           "materials:\n  steel: {rho0: 7800}\n"
           "sets:\n"
           "  row: {method: rigid_body, material: steel, modulus: 0.2 GPa, fix_translation: [1, 1, 1],"
           " fix_rotation: [1, 1, 1], shape: {box: {min: [-0.05, -0.005], max: [0.05, 0.005]}}, spacing: 0.01}\n"
           "  block: {method: rigid_body, material: steel, modulus: 0.2 GPa, fix_rotation: [1, 1, 1],%s"
           " shape: {box: {min: [-0.011, 0.007], max: [0.009, 0.027]}}, spacing: 0.002, velocity: [0, -150]}\n"
           "interactions:\n  - {model: kernel_contact, sets: [row, block], normal: %s}\n",
           body ? " normals: true," : "", mode);
  rb_open(&R, text);
  const double e0 = R.sim->energy.kinetic;
  const ej_set *b = rb_set(&R, "block");
  rb_go(&R);
  double lmin = INFINITY; /* the block's lowest point at the end */
  const ej_real *x = ej_set_field(b, "x");
  for (ej_idx i = 0; i < ej_set_count(b); ++i) lmin = fmin(lmin, x[3 * i + 1]);
  double X[3], P[3], L[3], ke, m = 0;
  rb_moments(b, X, P, L, &ke);
  const ej_real *mm = ej_set_field(b, "m");
  for (ej_idx i = 0; i < ej_set_count(b); ++i) m += mm[i];
  *v_end = P[1] / m, *low_min = lmin, *bal = fabs(R.sim->energy.balance) / e0;
  rb_close(&R);
}

START_TEST(test_body_normal_holds)
{
  double vp, lp, bp, vb, lb, bb;
  pierce("pair", &vp, &lp, &bp);
  pierce("body", &vb, &lb, &bb);
  fprintf(stderr,
          "block at 150 m/s into a row of fixed points at 0.4 ms: pair normal v %.1f m/s, lowest point %.2f mm, "
          "balance %.2e E0; body normal v %.1f m/s, lowest point %.2f mm, balance %.2e E0\n",
          vp, lp * 1e3, bp, vb, lb * 1e3, bb);
  ck_assert_msg(vp < 0 && lp < -0.005, "the pair form was expected to let the block through (v %g, low %g)", vp, lp);
  ck_assert_msg(vb > 100, "the body normal should send the block back (v %g)", vb);
  ck_assert_msg(lb > 0.005, "the block's points are not back above the row (low %g)", lb);
  ck_assert_msg(bb < 0.01, "energy balance %g of E0", bb);
  /* normal: body without a set that has normals: bad input at the interaction's line */
  rb_run R;
  const ej_plugin_info *p[] = {ej_plugin_rigid_body_info(), ej_plugin_kernel_contact_info()};
  ej_error_clear();
  ej_err rc = rb_vopen(&R.v, p, 2, "%s",
                       "ejecta: 1\ndimension: 2\ntime: {end: 0.4 ms, cfl: 0.3}\noutput: {file: rb.h5}\n"
                       "materials:\n  steel: {rho0: 7800}\n"
                       "sets:\n"
                       "  row: {method: rigid_body, material: steel, shape: {box: {min: [0, 0], max: [0.1, 0.01]}},"
                       " spacing: 0.01}\n"
                       "  block: {method: rigid_body, material: steel, shape: {box: {min: [0, 0.02], max: [0.02, "
                       "0.04]}}, spacing: 0.002}\n"
                       "interactions:\n  - {model: kernel_contact, sets: [row, block], normal: body}\n");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  const ej_error_frame *e = ej_error_cause();
  ck_assert_ptr_nonnull(e);
  ck_assert_msg(strstr(e->msg, "normal: body needs a rigid_body set with normals: true") != NULL, "%s", e->msg);
  ck_assert_int_eq(e->where.line, 11);
  ck_assert_int_eq(e->where.col, 5);
  ej_error_clear();
  vscene_free(&R.v);
}
END_TEST

/* normal: body between a rigid disc with normals and a free rkpm block, oblique, with friction: the
 * pair forces stay antisymmetric bitwise (total momentum to round-off) and the budget closes. */
START_TEST(test_body_normal_momentum)
{
  rb_run R;
  rb_open(&R, "ejecta: 1\ndimension: 2\ntime: {end: 5.0, cfl: 0.25}\noutput: {file: rb.h5, fields: [v]}\n"
              "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n  hard: {rho0: 3}\n"
              "sets:\n"
              "  block: {method: rkpm, material: m, shape: {box: {min: [0, 0], max: [0.8, 0.6]}}, spacing: 0.1}\n"
              "  disc: {method: rigid_body, material: hard, modulus: 3, normals: true,"
              " shape: {sphere: {center: [0.4, 0.95], radius: 0.25}}, spacing: 0.1, velocity: [0.03, -0.05]}\n"
              "interactions:\n  - {model: kernel_contact, sets: [block, disc], mu: 0.3, normal: body}\n");
  ej_set *blk = rb_set(&R, "block"), *disc = rb_set(&R, "disc");
  double X[3], Pa0[3], Pb0[3], Pa1[3], Pb1[3], L[3], k;
  rb_moments(blk, X, Pa0, L, &k);
  rb_moments(disc, X, Pb0, L, &k);
  const double e0 = R.sim->energy.kinetic + R.sim->energy.internal;
  rb_go(&R);
  rb_moments(blk, X, Pa1, L, &k);
  rb_moments(disc, X, Pb1, L, &k);
  const double scale = fabs(Pb0[0]) + fabs(Pb0[1]);
  double dP = 0;
  for (int d = 0; d < 2; ++d) dP = fmax(dP, fabs(Pa1[d] + Pb1[d] - Pa0[d] - Pb0[d]));
  fprintf(stderr,
          "normal: body, disc on an rkpm block: |dP_total| %.3g (scale %.3g), disc P_y %.3g -> %.3g, balance "
          "%.2f %% of E0\n",
          dP, scale, Pb0[1], Pb1[1], 100 * fabs(R.sim->energy.balance) / e0);
  ck_assert_msg(dP < 1e-12 * scale, "total momentum changed by %g", dP);
  ck_assert_msg(Pb1[1] - Pb0[1] > 0.5 * fabs(Pb0[1]), "no collision? %g -> %g", Pb0[1], Pb1[1]);
  ck_assert_msg(fabs(R.sim->energy.balance) < 0.02 * e0, "energy balance %g of %g", R.sim->energy.balance, e0);
  rb_close(&R);
}
END_TEST

/* A rigid body without normals (no neighbour list of its own) in contact next to a symmetry plane:
 * kernel_contact asks for both sets' images (ABI 1.9 needs_images), so the half model (plane x = 0,
 * body's x translation and rotation locked) is the full model's half: the body's y momentum equals
 * half the full model's, and total y momentum (parallel to the plane) is conserved. Before the body
 * had images the block's rows never met them: one-sided contact at the plane. Measured (contact
 * distance 1.5, penalty 0.05, impact at 0.3 m/s): with images |dP_y| 6e-16 of 0.081, body P_y half x 2
 * against full 2.9e-14 relative; without them (needs_images false) |dP_y| 1.6e-3 and 1.7e-2. */
static void rb_half_full(bool half, double Pb[3], double *dP, double *scale, double *ghosts, double *Py0)
{
  rb_run R;
  char text[1024];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 2\ntime: {end: 5.0, cfl: 0.25}\noutput: {file: rb.h5, fields: [v]}\n"
           "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n  hard: {rho0: 3}\n"
           "sets:\n"
           "  block: {method: rkpm, material: m, shape: {box: {min: [%s, 0], max: [0.8, 0.6]}}, spacing: 0.1}\n"
           "  body: {method: rigid_body, material: hard, modulus: 3, %s"
           " shape: {box: {min: [%s, 0.7], max: [0.3, 1.0]}}, lattice_origin: [0, 0, 0], spacing: 0.1,"
           " velocity: [0, -0.3]}\n"
           "interactions:\n  - {model: kernel_contact, sets: [block, body], mu: 0.3, distance: 1.5, penalty: 0.05}\n%s",
           half ? "0" : "-0.8", half ? "fix_translation: [1, 0, 0], fix_rotation: [0, 0, 1]," : "",
           half ? "0" : "-0.3", half ? "boundaries:\n  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n" : "");
  rb_open(&R, text);
  ej_set *blk = rb_set(&R, "block"), *body = rb_set(&R, "body");
  double X[3], Pa0[3], Pb0[3], Pa1[3], L[3], k;
  rb_moments(blk, X, Pa0, L, &k);
  rb_moments(body, X, Pb0, L, &k);
  rb_go(&R);
  rb_moments(blk, X, Pa1, L, &k);
  rb_moments(body, X, Pb, L, &k);
  *dP = fabs(Pa1[1] + Pb[1] - Pa0[1] - Pb0[1]);
  *scale = fabs(Pb0[1]), *Py0 = Pb0[1];
  *ghosts = (double)(ej_set_count_all(body) - ej_set_count(body));
  rb_close(&R);
}

START_TEST(test_bad_body_at_check)
{
  /* what the method's setup refuses (points on a line: singular inertia) is found by `ejecta check`
   * (check_only runs the methods' setup and the first force evaluation) and placed at the set (line 8,
   * column 3) */
  const ej_plugin_info *p[] = {ej_plugin_rigid_body_info()};
  vrun_refuses_text_with("rb_line", p, 1,
                         "ejecta: 1\ndimension: 3\ntime: {end: 1e-5}\noutput: {file: o.h5}\n"
                         "materials:\n  steel: {rho0: 7800}\nsets:\n  rod: {method: rigid_body, material: steel, "
                         "shape: {box: {min: [0, 0, 0], max: [0.1, 0.01, 0.01]}}, spacing: 0.01}\n",
                         "has a singular inertia tensor", 8, 3);
  /* what the first force evaluation refuses (normals: true on a lone point: no surface normal) too,
   * also placed at the set */
  vrun_refuses_text_with("rb_lone", p, 1,
                         "ejecta: 1\ndimension: 3\ntime: {end: 1e-5}\noutput: {file: o.h5}\n"
                         "materials:\n  steel: {rho0: 7800}\nsets:\n  dot: {method: rigid_body, material: steel, "
                         "normals: true, fix_rotation: [1, 1, 1], shape: {box: {min: [0, 0, 0], max: [0.01, 0.01, "
                         "0.01]}}, spacing: 0.01}\n",
                         "has no surface point with a normal", 8, 3);
}
END_TEST

START_TEST(test_contact_symmetry_plane)
{
  double Ph[3], Pf[3], dPh, dPf, sh, sf, gh, gf, p0h, p0f;
  rb_half_full(true, Ph, &dPh, &sh, &gh, &p0h);
  rb_half_full(false, Pf, &dPf, &sf, &gf, &p0f);
  const double rel = fabs(2 * Ph[1] - Pf[1]) / sf;
  fprintf(stderr,
          "rigid body without normals at a symmetry plane: half model %g body images, |dP_y| %.3g of %.3g; "
          "body P_y half x 2 %.10g, full %.10g (relative difference %.3g)\n",
          gh, dPh, sh, 2 * Ph[1], Pf[1], rel);
  ck_assert_msg(gh > 0, "the body has no images at the plane");
  ck_assert_msg(Pf[1] - p0f > 0.5 * sf, "no collision in the full model: body P_y %g -> %g", p0f, Pf[1]);
  ck_assert_msg(dPh < 1e-12 * sh, "half model: y momentum changed by %g of %g", dPh, sh);
  ck_assert_msg(dPf < 1e-12 * sf, "full model: y momentum changed by %g of %g", dPf, sf);
  ck_assert_msg(rel < 1e-9, "half model's body P_y x 2 = %g, full model's %g", 2 * Ph[1], Pf[1]);
}
END_TEST

/* Restitution of kernel_contact's normal law N = max(0, k g - c v_n), c = 2 damping sqrt(k m_ij):
 * two one-point rigid bodies (mass 1, k = modulus h = 10, reduced mass 1/2, omega dt = cfl = 0.025;
 * the overlap stays below 0.45 of the contact distance) meet head-on at relative speed 2. In units of the pair's contact time the overlap obeys
 * G'' = -max(0, G + 2 zeta G'), G(0) = 0, G'(0) = 1 with zeta = damping; the coefficient of
 * restitution is -G' where the force first vanishes (1 for zeta = 0; e^-2 = 0.135 for zeta = 1: a
 * clipped dashpot never stops a rebound). The reference is that ODE integrated here by RK4.
 * Measured: restitution 1.00005 / 0.50372 / 0.13261 against 1 / 0.50628 / 0.13534 for damping
 * 0 / 0.25 / 1; first order in dt (-5.9e-3 and -6.4e-3 at cfl 0.05), hence the bound 5e-3. */
static double clipped_dashpot_restitution(double zeta)
{
  const double dt = 1e-5;
  double g = 0, v = 1;
#define EJ_ACC(G, V) (-fmax(0.0, (G) + 2 * zeta * (V)))
  for (long k = 0; k < 10000000; ++k) {
    const double k1g = v, k1v = EJ_ACC(g, v);
    const double k2g = v + 0.5 * dt * k1v, k2v = EJ_ACC(g + 0.5 * dt * k1g, v + 0.5 * dt * k1v);
    const double k3g = v + 0.5 * dt * k2v, k3v = EJ_ACC(g + 0.5 * dt * k2g, v + 0.5 * dt * k2v);
    const double k4g = v + dt * k3v, k4v = EJ_ACC(g + dt * k3g, v + dt * k3v);
    g += dt * (k1g + 2 * k2g + 2 * k3g + k4g) / 6;
    v += dt * (k1v + 2 * k2v + 2 * k3v + k4v) / 6;
    if (v < 0 && (g <= 0 || g + 2 * zeta * v <= 0)) return -v;
  }
#undef EJ_ACC
  ck_abort_msg("no separation");
  return NAN;
}

START_TEST(test_contact_damping_restitution)
{
  const double zetas[] = {0.0, 0.25, 1.0};
  for (int q = 0; q < 3; ++q) {
    char text[1536];
    snprintf(text, sizeof text,
             "ejecta: 1\ndimension: 3\ntime: {end: 4.0, cfl: 0.025}\noutput: {file: rb.h5, fields: [v]}\n"
             "materials:\n  hard: {rho0: 1}\n"
             "sets:\n"
             "  a: {method: rigid_body, material: hard, modulus: 10, shape: {box: {min: [-0.5, -0.5, -0.5], max: [0.5, 0.5, 0.5]}},"
             " spacing: 1, velocity: [1, 0, 0], fix_rotation: [1, 1, 1]}\n"
             "  b: {method: rigid_body, material: hard, modulus: 10, shape: {box: {min: [0.7, -0.5, -0.5], max: [1.7, 0.5, 0.5]}},"
             " spacing: 1, velocity: [-1, 0, 0], fix_rotation: [1, 1, 1]}\n"
             "interactions:\n  - {model: kernel_contact, sets: [a, b], damping: %g}\n",
             zetas[q]);
    rb_run R;
    rb_open(&R, text);
    ej_set *a = rb_set(&R, "a"), *b = rb_set(&R, "b");
    ck_assert_int_eq(ej_set_count(a), 1);
    ck_assert_int_eq(ej_set_count(b), 1);
    rb_go(&R);
    const ej_real *va = ej_set_field(a, "v"), *vb = ej_set_field(b, "v");
    const double e = (vb[0] - va[0]) / 2, ref = clipped_dashpot_restitution(zetas[q]);
    const ej_real *xa = ej_set_field(a, "x"), *xb = ej_set_field(b, "x");
    fprintf(stderr, "kernel_contact damping %.2f: restitution %.5f (clipped dashpot %.5f, %+.2e), separation %.3f, "
                    "total momentum %.2e, dissipated %.4f of 1\n",
            zetas[q], e, ref, e - ref, xb[0] - xa[0], va[0] + vb[0], 1 - e * e);
    ck_assert_msg(xb[0] - xa[0] > 1.0, "bodies still in contact at the end");
    ck_assert_msg(fabs(va[0] + vb[0]) < 1e-14, "momentum %g", va[0] + vb[0]);
    ck_assert_msg(fabs(e - ref) < 5e-3, "restitution %g against %g", e, ref);
    rb_close(&R);
  }
}
END_TEST

int main(void)
{
  Suite *s = suite_create("rigid_body");
  TCase *tc = tcase_create("rigid_body");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_free_fall);
  tcase_add_test(tc, test_spin_rigid);
  tcase_add_test(tc, test_contact_exchange);
  tcase_add_test(tc, test_contact_damping_restitution);
  tcase_add_test(tc, test_surface_normals);
  tcase_add_test(tc, test_body_normal_holds);
  tcase_add_test(tc, test_body_normal_momentum);
  tcase_add_test(tc, test_contact_symmetry_plane);
  tcase_add_test(tc, test_bad_body_at_check);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
