/* Interaction `sph_wall` (Adami, Hu & Adams 2012 dummy-particle walls):
 * - hydrostatic water column (2D, weakly compressible, started from the hydrostatic density) in
 *   a wall box stays at rest and keeps p = rho g (H - y) within 1 % of rho g H;
 * - a liquid slab sliding along a floor keeps its momentum on a free-slip wall and is slowed by
 *   a no-slip wall;
 * - an elastic SPH block dropped at 3 m/s on the floor does not penetrate it and bounces;
 * - an elastic block set on a no-slip floor under gravity rests on it, its bottom row carrying the
 *   weight, with the wall in the velocity gradient (wall_gradient; without it the block sinks);
 * - a Drucker-Prager block sliding on a no-slip floor under gravity and settling: the energy budget
 *   closes with the plastic work booked by sph (one material update per step, the wall's L_wall in
 *   it), and the run is bitwise identical on 1 and 2 threads;
 * - a wall set under a symmetry plane is refused at create, at the interaction's line;
 * - with correction: true the wall particles enter B_i as they enter L_i, so a linear velocity
 *   field over the block and the wall rows gives the exact gradient next to the wall;
 * - viscosity_velocity: wall: the wall pairs' Monaghan viscosity of a liquid block driven onto
 *   the floor equals the sum on v_i - v_w (the wall's own velocity) for free and no slip; the
 *   default (extrapolated) gives no viscous wall term for free slip and the larger Adami Eq 23
 *   term (v_i - (2 v_w - v~_w)) for no slip; a slab sliding on a free-slip floor keeps its speed
 *   with wall_normal (normal part only) and is slowed by wall (the oblique pairs act as friction). */
#include <check.h>
#include <hdf5.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "../../plugins/methods/sph/sph_kernels.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_sph_wall_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);
const ej_plugin_info *ej_plugin_rigid_body_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_drucker_prager_info(void);

typedef vscene wrun;

static ej_err wrun_open(wrun *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_polynomial_info(), ej_plugin_rigid_body_info(),
                               ej_plugin_sph_wall_info(), ej_plugin_elastic_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "wall", p, 5, fmt, ap);
  va_end(ap);
  return rc;
}

/* As wrun_open with a thread count (vscene_open runs on 1 thread) and the drucker_prager plugin. */
static ej_err wrun_open_threads(wrun *c, int threads, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(),       ej_plugin_polynomial_info(),
                               ej_plugin_rigid_body_info(), ej_plugin_sph_wall_info(),
                               ej_plugin_elastic_info(),    ej_plugin_drucker_prager_info()};
  memset(c, 0, sizeof *c);
  vrun_dir(c->dir, sizeof c->dir, "wallt");
  snprintf(c->scene, sizeof c->scene, "%s/s.yaml", c->dir);
  snprintf(c->out, sizeof c->out, "%s/out.h5", c->dir);
  FILE *f = fopen(c->scene, "w");
  ck_assert_ptr_nonnull(f);
  va_list ap;
  va_start(ap, fmt);
  vfprintf(f, fmt, ap);
  va_end(ap);
  fclose(f);
  ck_assert_int_eq(ej_registry_create(&c->r.reg), EJ_OK);
  for (int k = 0; k < 6; ++k) ck_assert_int_eq(ej_registry_add_static(c->r.reg, p[k]), EJ_OK);
  ej_err rc = ej_scene_load(c->scene, c->r.reg, &c->r.scene);
  if (rc != EJ_OK) return rc;
  ej_run_opts o = {.struct_size = sizeof o, .threads = threads, .output = c->out};
  return ej_sim_create(c->r.scene, c->r.reg, &o, &c->r.sim);
}

static void wrun_go(wrun *c)
{
  ej_err rc = ej_sim_run(c->r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static ej_set *wrun_set(wrun *c, const char *name) { return vsim_set(c->r.sim, name); }

/* Water-like liquid: rho0 1000, p = K (rho/rho0 - 1), K = 2e5 Pa (c = 14 m/s, 10 sqrt(g H)). */
#define W_RHO0 1000.0
#define W_K 2.0e5
#define W_G 9.81
#define W_H 0.2

static const char wall_box[] =
    "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: [1, 1, 1],\n"
    "         shape: {box: {min: [-0.03, -0.03], max: [%g, 0.3]}, minus: [{box: {min: [0, 0], max: [%g, 0.31]}}]},"
    " spacing: 0.01}\n";

START_TEST(test_hydrostatic_column)
{
  /* 20 x 20 particles, dx = 0.01, Wendland C2; initial density layered to the hydrostatic profile
   * (rows of 1 dx). Adami's test (JCP 2012 §4.1) with a linear EOS. 0.5 s = 3500 steps. */
  char layers[4096] = "", *q = layers;
  for (int k = 0; k < 20; ++k) {
    const double yc = 0.005 + 0.01 * k, rho = W_RHO0 * (1 + W_RHO0 * W_G * (W_H - yc) / W_K);
    q += snprintf(q, sizeof layers - (size_t)(q - layers), "%s{region: {box: {min: [-1, %.3f], max: [1, %.3f]}}, rho: %.9g}",
                  k ? ", " : "", 0.01 * k, 0.01 * (k + 1), rho);
  }
  char box[512];
  snprintf(box, sizeof box, wall_box, 0.23, 0.2);
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 0.5, cfl: 0.3}\noutput: {file: %s}\n"
                        "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: %g}}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  fluid: {method: sph, material: water, kernel: wendland_c2, renormalize: false,\n"
                        "         shape: {box: {min: [0, 0], max: [0.2, 0.2]}}, spacing: 0.01, initial: [%s]}\n"
                        "%s"
                        "interactions:\n  - {model: sph_wall, sets: [fluid, wall], kernel: wendland_c2, gravity: [0, "
                        "-9.81, 0]}\ngravity: [0, -9.81]\n",
                        "out.h5", W_K, layers, box);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  wrun_go(&c);
  ej_set *f = wrun_set(&c, "fluid");
  const ej_real *x = ej_set_field(f, "x"), *v = ej_set_field(f, "v"), *p = ej_set_field(f, "p");
  const double scale = W_RHO0 * W_G * W_H;
  double emax = 0, emax_low = 0, esum = 0, vmax = 0, ymin = 1;
  for (ej_idx i = 0; i < f->n; ++i) {
    const double e = fabs(p[i] - W_RHO0 * W_G * (W_H - x[3 * i + 1])) / scale;
    emax = fmax(emax, e), esum += e;
    if (x[3 * i + 1] < W_H - 0.03) emax_low = fmax(emax_low, e); /* below the free surface's 2h */
    vmax = fmax(vmax, hypot(v[3 * i], v[3 * i + 1]));
    ymin = fmin(ymin, x[3 * i + 1]);
  }
  fprintf(stderr,
          "hydrostatic column, %lld steps: |p - rho g (H - y)| / (rho g H): mean %.4f, max %.4f (max %.4f below "
          "H - 2h); max |v| %.2e m/s (sqrt(g H) = %.2f); lowest particle y = %.5f\n",
          (long long)c.r.sim->step, esum / f->n, emax, emax_low, vmax, sqrt(W_G * W_H), ymin);
  ck_assert_double_lt(esum / f->n, 0.01);
  ck_assert_double_lt(emax_low, 0.01);
  ck_assert_double_lt(emax, 0.02);
  ck_assert_double_lt(vmax, 1e-3 * sqrt(W_G * W_H));
  ck_assert_double_gt(ymin, 0.0045); /* the bottom row (y0 = 0.005) stays off the wall */
  vscene_free(&c);
}
END_TEST

/* A liquid slab (0.3 x 0.04) sliding at 1 m/s on a long floor for 0.1 s; returns the mean vx. */
static double slab_mean_vx(const char *slip)
{
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 0.1, cfl: 0.3}\noutput: {file: %s}\n"
                        "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2e5}}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  fluid: {method: sph, material: water, kernel: wendland_c2, renormalize: false,\n"
                        "         shape: {box: {min: [0, 0], max: [0.3, 0.04]}}, spacing: 0.01, velocity: [1, 0]}\n"
                        "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: "
                        "[1, 1, 1],\n         shape: {box: {min: [-0.1, -0.03], max: [0.6, 0]}}, spacing: 0.01}\n"
                        "interactions:\n  - {model: sph_wall, sets: [fluid, wall], kernel: wendland_c2, slip: %s, "
                        "gravity: [0, -9.81, 0]}\ngravity: [0, -9.81]\n",
                        "out.h5", slip);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  wrun_go(&c);
  ej_set *f = wrun_set(&c, "fluid");
  const ej_real *v = ej_set_field(f, "v"), *x = ej_set_field(f, "x"), *m = ej_set_field(f, "m");
  double px = 0, M = 0, ymin = 1;
  for (ej_idx i = 0; i < f->n; ++i) px += m[i] * v[3 * i], M += m[i], ymin = fmin(ymin, x[3 * i + 1]);
  fprintf(stderr, "slab on a %s floor: mean vx %.4f m/s after 0.1 s (initial 1), lowest y %.5f\n", slip, px / M, ymin);
  ck_assert_double_gt(ymin, 0.0);
  vscene_free(&c);
  return px / M;
}

START_TEST(test_free_vs_no_slip)
{
  const double free = slab_mean_vx("free_slip"), none = slab_mean_vx("no_slip");
  /* free slip: no tangential force, the momentum is kept (the wall's normal forces are vertical) */
  ck_assert_double_lt(fabs(free - 1.0), 0.01);
  /* no slip: the wall's viscous term drags the slab measurably */
  ck_assert_double_lt(none, free - 0.05);
}
END_TEST

/* Lowest y of set `set` over the frames of an output file. */
static double frames_ymin(const char *file, const char *set, int *n_frames)
{
  hid_t f = H5Fopen(file, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  double ymin = INFINITY;
  *n_frames = 0;
  for (int k = 0; k < 100000; ++k) {
    char path[128];
    snprintf(path, sizeof path, "/frames/%06d", k);
    if (H5Lexists(f, path, H5P_DEFAULT) <= 0) break;
    snprintf(path, sizeof path, "/frames/%06d/%s/x", k, set);
    hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
    ck_assert_int_ge(d, 0);
    hid_t sp = H5Dget_space(d);
    hsize_t dims[2] = {0, 0};
    H5Sget_simple_extent_dims(sp, dims, NULL);
    double *x = malloc(dims[0] * dims[1] * sizeof *x);
    ck_assert_ptr_nonnull(x);
    ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, x), 0);
    for (hsize_t i = 0; i < dims[0]; ++i) ymin = fmin(ymin, x[i * dims[1] + 1]);
    free(x);
    H5Sclose(sp);
    H5Dclose(d);
    ++*n_frames;
  }
  H5Fclose(f);
  return ymin;
}

START_TEST(test_dropped_block)
{
  /* elastic block (E 10 MPa, nu 0.3, rho 1000: P-wave speed 116 m/s) 0.1 x 0.05 starting 4 dx
   * above the floor at 3 m/s downwards; 20 ms (the contact lasts about 2 H / c = 1 ms), frames
   * every 0.1 ms. */
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 0.02, cfl: 0.3}\noutput: {file: %s, every: 1e-4}\n"
                        "materials:\n  rubber: {model: elastic, rho0: 1000, E: 10 MPa, nu: 0.3}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  block: {method: sph, strength: true, material: rubber, kernel: wendland_c2,\n"
                        "         shape: {box: {min: [0, 0.02], max: [0.1, 0.07]}}, spacing: 0.005, velocity: [0, -3]}\n"
                        "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: "
                        "[1, 1, 1],\n         shape: {box: {min: [-0.05, -0.015], max: [0.15, 0]}}, spacing: 0.005}\n"
                        "interactions:\n  - {model: sph_wall, sets: [block, wall], kernel: wendland_c2}\n",
                        "out.h5");
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  wrun_go(&c);
  ej_set *b = wrun_set(&c, "block");
  const ej_real *v = ej_set_field(b, "v"), *m = ej_set_field(b, "m");
  double py = 0, M = 0;
  for (ej_idx i = 0; i < b->n; ++i) py += m[i] * v[3 * i + 1], M += m[i];
  int nf = 0;
  const double ymin = frames_ymin(c.out, "block", &nf);
  fprintf(stderr,
          "dropped block: lowest particle y over %d frames %.5f m (floor surface 0, first row at dx/2 = 0.0025), "
          "mean vy after %.3f s: %+.3f m/s (initial -3)\n",
          nf, ymin, c.r.sim->t, py / M);
  /* energy: kinetic + internal - external (the wall's share of the pair work, series `work`) */
  const ej_energy *E = &c.r.sim->energy;
  fprintf(stderr, "dropped block energy: KE0 %.3f J, KE %.3f J, internal %.3f J, wall work %.3f J, balance %.2e J\n",
          E->total0, E->kinetic, E->internal, E->external, E->balance);
  ck_assert_double_lt(fabs(E->balance), 1e-4 * E->total0);
  ck_assert_double_lt(E->external, 0.0); /* the wall creates no energy over the impact */
  ck_assert_int_gt(nf, 100);
  ck_assert_double_gt(ymin, 0.0);   /* never inside the wall */
  ck_assert_double_gt(py / M, 0.0); /* bounced */
  vscene_free(&c);
}
END_TEST

/* Elastic block (E 2 MPa, nu 0.3, rho 1000, H 0.05 m) set on a floor under gravity from rest and
 * stress free, 0.1 s. Returns the block's mean y displacement (m) and the mean sigma_yy of its bottom
 * row against -rho g H in *bottom. */
static double resting_block(const char *slip, const char *gradient, double *bottom, double *ymin)
{
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 0.1, cfl: 0.3}\noutput: {file: %s, every: 0.005}\n"
                        "materials:\n  rubber: {model: elastic, rho0: 1000, E: 2 MPa, nu: 0.3}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  block: {method: sph, strength: true, material: rubber, kernel: wendland_c2, alpha: 1,\n"
                        "         shape: {box: {min: [0, 0], max: [0.1, 0.05]}}, spacing: 0.005}\n"
                        "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: "
                        "[1, 1, 1],\n         shape: {box: {min: [-0.05, -0.015], max: [0.15, 0]}}, spacing: 0.005}\n"
                        "interactions:\n  - {model: sph_wall, sets: [block, wall], kernel: wendland_c2, alpha: 1, "
                        "slip: %s, wall_gradient: %s, gravity: [0, -9.81, 0]}\n"
                        "gravity: [0, -9.81]\n",
                        "out.h5", slip, gradient);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set *b = wrun_set(&c, "block");
  const ej_idx n = b->n;
  double y0 = 0;
  const ej_real *x = ej_set_field(b, "x");
  for (ej_idx i = 0; i < n; ++i) y0 += x[3 * i + 1] / n;
  wrun_go(&c);
  x = ej_set_field(b, "x");
  const ej_real *sg = ej_set_field(b, "stress");
  double y1 = 0, syy = 0;
  int nb = 0;
  for (ej_idx i = 0; i < n; ++i) {
    y1 += x[3 * i + 1] / n;
    if (x[3 * i + 1] < 0.005) syy += sg[6 * i + 1], ++nb;
  }
  *bottom = nb ? syy / nb / (-1000.0 * 9.81 * 0.05) : 0.0;
  int nf = 0;
  *ymin = frames_ymin(c.out, "block", &nf);
  vscene_free(&c);
  return y1 - y0;
}

START_TEST(test_wall_velocity_gradient)
{
  /* with the wall in the velocity gradient the block rests on the floor and its bottom row carries
   * the weight (sigma_yy -> -rho g H); without it the wall only pushes through the hydrostatic term of
   * Eq 27 and (no slip) the artificial viscosity of the wall pairs, so the block sinks into the floor */
  /* free_slip: with the former lagged second material update the step collapsed at 15 ms; with
   * L_wall in sph's own update (pre-pass) the block rests on a frictionless floor too (the
   * wall_gradient: false run is printed for no_slip only: on free slip it sinks and the step
   * collapses at 15 ms) */
  const char *slips[] = {"no_slip", "free_slip"};
  for (int k = 0; k < 2; ++k) {
    double b1, b0 = 0, m1, m0 = 0, d0 = 0;
    const double d1 = resting_block(slips[k], "true", &b1, &m1);
    /* without the wall gradient the block sinks; on a free-slip floor its step then collapses */
    if (k == 0) d0 = resting_block(slips[k], "false", &b0, &m0);
    fprintf(stderr,
            "block resting on a %s floor, 0.1 s: wall_gradient true: mean dy %+.2e m, lowest y %.4f, bottom "
            "sigma_yy / (-rho g H) %.3f",
            slips[k], d1, m1, b1);
    if (k == 0) fprintf(stderr, "; false: dy %+.2e m, lowest y %.4f, bottom %.3f", d0, m0, b0);
    fprintf(stderr, "\n");
    ck_assert_double_gt(m1, 0.0);           /* never inside the wall */
    ck_assert_double_lt(fabs(d1), 1.0e-3); /* rests: elastic settlement rho g H^2 / (2 M) ~ 0.5 mm */
    ck_assert_double_gt(b1, 0.5);
    ck_assert_double_lt(b1, 1.5);
  }
}
END_TEST

/* Cohesionless Drucker-Prager block (phi 30 deg, E 5 MPa, rho 1500) 0.1 x 0.04 m sliding at 1 m/s
 * on a no-slip floor under gravity, 0.025 s: the floor shears the bottom rows plastically through
 * L_wall. Copies x, v, stress (n particles) into out[] when out != NULL. */
static void dp_slide(int threads, ej_energy *E, double *vx_mean, double *ymin, double **out, ej_idx *n_out)
{
  wrun c;
  ej_err rc = wrun_open_threads(&c, threads,
                                "ejecta: 1\ndimension: 2\ntime: {end: 0.025, cfl: 0.3}\noutput: {file: %s, every: 0.002}\n"
                                "materials:\n  sand: {model: drucker_prager, rho0: 1500, E: 5 MPa, nu: 0.3, "
                                "friction_angle: 30 deg, dilation_angle: 0 deg, cohesion: 0 Pa, beta: 1}\n"
                                "  wallmat: {rho0: 1500}\n"
                                "sets:\n  block: {method: sph, strength: true, material: sand, kernel: wendland_c2, "
                                "alpha: 1,\n         shape: {box: {min: [0, 0], max: [0.1, 0.04]}}, spacing: 0.005, "
                                "velocity: [1, 0]}\n"
                                "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], "
                                "fix_rotation: [1, 1, 1],\n         shape: {box: {min: [-0.05, -0.015], max: [0.25, 0]}}, "
                                "spacing: 0.005}\n"
                                "interactions:\n  - {model: sph_wall, sets: [block, wall], kernel: wendland_c2, alpha: 1, "
                                "slip: no_slip, gravity: [0, -9.81, 0]}\n"
                                "gravity: [0, -9.81]\n",
                                "out.h5");
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  wrun_go(&c);
  ej_set *b = wrun_set(&c, "block");
  const ej_real *x = ej_set_field(b, "x"), *v = ej_set_field(b, "v"), *m = ej_set_field(b, "m");
  const ej_real *sg = ej_set_field(b, "stress");
  double px = 0, M = 0;
  for (ej_idx i = 0; i < b->n; ++i) px += m[i] * v[3 * i], M += m[i];
  *vx_mean = px / M;
  *E = c.r.sim->energy;
  int nf = 0;
  *ymin = frames_ymin(c.out, "block", &nf);
  if (out) {
    const ej_idx n = b->n;
    *out = malloc((size_t)n * 12 * sizeof(double));
    ck_assert_ptr_nonnull(*out);
    memcpy(*out, x, (size_t)n * 3 * sizeof(double));
    memcpy(*out + 3 * n, v, (size_t)n * 3 * sizeof(double));
    memcpy(*out + 6 * n, sg, (size_t)n * 6 * sizeof(double));
    *n_out = n;
  }
  vscene_free(&c);
}

START_TEST(test_dp_block_energy_threads)
{
  ej_energy E1, E2;
  double vx1, vx2, y1, y2, *s1 = NULL, *s2 = NULL;
  ej_idx n1 = 0, n2 = 0;
  dp_slide(1, &E1, &vx1, &y1, &s1, &n1);
  dp_slide(2, &E2, &vx2, &y2, &s2, &n2);
  const double scale = E1.total0 + fabs(E1.work_gravity);
  fprintf(stderr,
          "DP block sliding on a no-slip floor, 0.025 s: mean vx %.4f m/s (initial 1), lowest y %.5f; energy KE0 "
          "%.4f J, KE %.4f, internal %.4f (plastic %.4f, viscous %.4f), external %.4f (gravity %.4f), balance %.2e J "
          "(%.1e of KE0 + |W_g|); 2 threads bitwise identical: %s\n",
          vx1, y1, E1.total0, E1.kinetic, E1.internal, E1.plastic, E1.viscous, E1.external, E1.work_gravity,
          E1.balance, fabs(E1.balance) / scale,
          (n1 == n2 && !memcmp(s1, s2, (size_t)n1 * 12 * sizeof(double))) ? "yes" : "NO");
  ck_assert_double_lt(vx1, 0.9);                /* the floor's friction slows the block */
  ck_assert_double_gt(y1, 0.0);                 /* never inside the wall */
  ck_assert_double_gt(E1.plastic, 1e-3 * E1.total0); /* the floor shears it plastically, booked by sph */
  ck_assert_double_lt(fabs(E1.balance), 1e-3 * scale);
  ck_assert_int_eq(n1, n2);
  ck_assert_int_eq(memcmp(s1, s2, (size_t)n1 * 12 * sizeof(double)), 0);
  ck_assert(E1.balance == E2.balance);
  free(s1), free(s2);
}
END_TEST

/* The wall's share of a corrected velocity gradient (correction: true with wall_gradient, no slip):
 * fluid and wall rows move with the linear field v = (A y, -E y), so every particle's L_i must be
 * the exact G = [[0, A], [0, -E]] once the wall particles are in B_i as they are in the sum of L_i
 * (sph's B_wall, sph README "Walls in the corrected gradient"). Evaluated at t = 0 (sph_create's
 * first force evaluation): d_rate = sym L_i, rho_dot = -rho tr L_i. Returns the largest error of
 * d_rate over the block's particles relative to |G| and of the first row only in *first. */
#define CG_A 10.0
#define CG_E 5.0
static double corrected_wall_gradient(const char *kernel, bool split, double quad, double *first, int *fallbacks,
                                      double **d_out, ej_idx *n_out)
{
  char rows[8192];
  size_t len = 0;
  for (int k = -3; k < 10; ++k) { /* rows of the wall (k < 0) and of the block, dx 5 mm */
    const double y = (k + 0.5) * 0.005;
    len += (size_t)snprintf(rows + len, sizeof rows - len,
                            "      - {region: {box: {min: [-1, %.4f], max: [1, %.4f]}}, velocity: [%.17g, %.17g]}\n",
                            y - 0.0025, y + 0.0025, CG_A * y + quad * y * y, -CG_E * y);
  }
  ck_assert_uint_lt(len, sizeof rows - 1);
  /* split: the same wall as two sets, x < 0.05 and x > 0.05, each with its own sph_wall (their
   * shares of L_i and B_i must add up) */
  char walls[2 * sizeof rows + 1024];
  if (split)
    snprintf(walls, sizeof walls,
             "  wall:\n    method: sph\n    strength: true\n    material: rubber\n    kernel: %s\n"
             "    shape: {box: {min: [-0.03, -0.015], max: [0.05, 0]}}\n    spacing: 0.005\n    initial:\n%s"
             "  wall2:\n    method: sph\n    strength: true\n    material: rubber\n    kernel: %s\n"
             "    shape: {box: {min: [0.05, -0.015], max: [0.13, 0]}}\n    spacing: 0.005\n    initial:\n%s"
             "interactions:\n  - {model: sph_wall, sets: [block, wall], kernel: %s, slip: no_slip}\n"
             "  - {model: sph_wall, sets: [block, wall2], kernel: %s, slip: no_slip}\n",
             kernel, rows, kernel, rows, kernel, kernel);
  else
    snprintf(walls, sizeof walls,
             "  wall:\n    method: sph\n    strength: true\n    material: rubber\n    kernel: %s\n"
             "    shape: {box: {min: [-0.03, -0.015], max: [0.13, 0]}}\n    spacing: 0.005\n    initial:\n%s"
             "interactions:\n  - {model: sph_wall, sets: [block, wall], kernel: %s, slip: no_slip}\n",
             kernel, rows, kernel);
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 1e-4, cfl: 0.3}\noutput: {file: %s}\n"
                        "materials:\n  rubber: {model: elastic, rho0: 1000, E: 2 MPa, nu: 0.3}\n"
                        "sets:\n  block:\n    method: sph\n    strength: true\n    correction: true\n"
                        "    material: rubber\n    kernel: %s\n"
                        "    shape: {box: {min: [0, 0], max: [0.1, 0.05]}}\n    spacing: 0.005\n    initial:\n%s%s",
                        "out.h5", kernel, rows, walls);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set *b = wrun_set(&c, "block");
  const ej_real *x = ej_set_field(b, "x"), *d = ej_set_field(b, "d_rate"), *rho = ej_set_field(b, "rho");
  const ej_real *rd = ej_set_field(b, "rho_dot");
  const int32_t *fb = ej_set_field_int(b, "corr_fallbacks");
  ck_assert(x && d && rho && rd && fb);
  const double exact[6] = {0, -CG_E, 0, 0.5 * CG_A, 0, 0}, gn = sqrt(CG_A * CG_A + CG_E * CG_E);
  double worst = 0, worst1 = 0;
  *fallbacks = 0;
  for (ej_idx i = 0; i < b->n; ++i) {
    double e = fabs(rd[i] - rho[i] * CG_E); /* -rho tr G = rho E */
    e /= rho[i];
    for (int q = 0; q < 6; ++q) e = fmax(e, fabs(d[6 * i + q] - exact[q]));
    worst = fmax(worst, e / gn);
    if (x[3 * i + 1] < 0.005) worst1 = fmax(worst1, e / gn);
    *fallbacks += fb[i];
  }
  *first = worst1;
  if (d_out) {
    *n_out = b->n;
    *d_out = malloc((size_t)b->n * 6 * sizeof(double));
    ck_assert_ptr_nonnull(*d_out);
    memcpy(*d_out, d, (size_t)b->n * 6 * sizeof(double));
  }
  vscene_free(&c);
  return worst;
}

START_TEST(test_wall_gradient_corrected)
{
  for (int k = 0; k < 3; ++k) {
    const char *kernel = k == 1 ? "wendland_c2" : "cubic_spline";
    double first;
    int fb;
    const double worst = corrected_wall_gradient(kernel, k == 2, 0.0, &first, &fb, NULL, NULL);
    fprintf(stderr,
            "corrected gradient next to a no-slip wall%s (%s, v = (%g y, -%g y)): largest error of sym L over the "
            "block %.2e of |G| (first row %.2e), %d correction fallbacks\n",
            k == 2 ? " of two sets, two sph_wall" : "", kernel, CG_A, CG_E, worst, first, fb);
    ck_assert_int_eq(fb, 0);
    ck_assert_double_lt(worst, 1e-10);
  }
  /* any consistent subset of the wall is exact for a linear field, so the two interactions' shares
   * adding up is checked on a quadratic one: v_x += 400 y^2 (d_rate next to the wall then depends on
   * which wall particles enter), one wall set against the same wall as two sets */
  double first, *d1 = NULL, *d2 = NULL;
  int fb;
  ej_idx n1 = 0, n2 = 0;
  corrected_wall_gradient("cubic_spline", false, 400.0, &first, &fb, &d1, &n1);
  corrected_wall_gradient("cubic_spline", true, 400.0, &first, &fb, &d2, &n2);
  ck_assert_int_eq(n1, n2);
  double diff = 0, dmax = 0;
  for (ej_idx i = 0; i < 6 * n1; ++i) diff = fmax(diff, fabs(d1[i] - d2[i])), dmax = fmax(dmax, fabs(d1[i]));
  fprintf(stderr, "quadratic field, one wall set against two (two sph_wall): max |d_rate difference| %.2e of max %.3g 1/s\n",
          diff, dmax);
  ck_assert_double_lt(diff, 1e-12 * dmax);
  free(d1), free(d2);
}
END_TEST

START_TEST(test_wall_ghosts_refused)
{
  /* an SPH wall set (fixed by a boundary condition) under a symmetry plane gets images: refused by
   * the interaction's create (so `ejecta check` finds it) at the interaction's line (12) */
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: 0.001, cfl: 0.3}\noutput: {file: %s}\n"
                        "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2e5}}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  fluid: {method: sph, material: water, shape: {box: {min: [0, 0], max: [0.1, 0.1]}}, "
                        "spacing: 0.01}\n"
                        "  wall: {method: sph, material: water, shape: {box: {min: [0, -0.03], max: [0.2, 0]}}, "
                        "spacing: 0.01}\n"
                        "interactions:\n  - {model: sph_wall, sets: [fluid, wall]}\n"
                        "boundaries:\n  - symmetry: {point: [0, 0], normal: [1, 0]}\n  - {fix: [x, y], set: wall}\n",
                        "out.h5");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  ck_assert_ptr_nonnull(ej_error_cause());
  ck_assert_ptr_nonnull(strstr(ej_error_cause()->msg, "wall set 'wall' gets mirror or periodic images"));
  ck_assert_int_eq(ej_error_cause()->where.line, 12);
  ej_error_clear();
  vscene_free(&c);
  /* the same boundary restricted to the SPH set: accepted, and the wall set has no images */
  rc = wrun_open(&c,
                 "ejecta: 1\ndimension: 2\ntime: {end: 0.0002, cfl: 0.3}\noutput: {file: %s}\n"
                 "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2e5}}\n"
                 "sets:\n  fluid: {method: sph, material: water, shape: {box: {min: [0, 0], max: [0.1, 0.1]}}, "
                 "spacing: 0.01}\n"
                 "  wall: {method: sph, material: water, shape: {box: {min: [-0.03, -0.03], max: [0.2, 0]}}, "
                 "spacing: 0.01}\n"
                 "interactions:\n  - {model: sph_wall, sets: [fluid, wall]}\n"
                 "boundaries:\n  - symmetry: {point: [0, 0], normal: [1, 0]}\n    set: fluid\n"
                 "  - {fix: [x, y], set: wall}\n",
                 "out.h5");
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_int_eq(ej_sim_run(c.r.sim), EJ_OK);
  vscene_free(&c);
}
END_TEST

/* One step (fixed dt 1e-7 s) of a 5 x 5 liquid block moving at -1 m/s onto a floor at rest;
 * returns the set's velocities (n x 3, caller frees) and fills the fields of the expected
 * viscous acceleration on v_i - v_w (wall at rest: v_i) when ref != NULL. */
#define VV_DT 1e-7
static double *visc_step(const char *slip, const char *vvel, double alpha, double beta, ej_idx *n, double **ref)
{
  wrun c;
  ej_err rc = wrun_open(&c,
                        "ejecta: 1\ndimension: 2\ntime: {end: %g, dt: %g}\noutput: {file: %s}\n"
                        "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2e5}}\n"
                        "  wallmat: {rho0: 1000}\n"
                        "sets:\n  fluid: {method: sph, material: water, kernel: wendland_c2, renormalize: false, "
                        "alpha: 0, beta: 0,\n         shape: {box: {min: [0, 0], max: [0.05, 0.05]}}, spacing: 0.01, "
                        "velocity: [0, -1]}\n"
                        "  wall: {method: rigid_body, material: wallmat, fix_translation: [1, 1, 1], fix_rotation: "
                        "[1, 1, 1],\n         shape: {box: {min: [-0.05, -0.03], max: [0.1, 0]}}, spacing: 0.01}\n"
                        "interactions:\n  - {model: sph_wall, sets: [fluid, wall], kernel: wendland_c2, slip: %s, "
                        "density: rest, alpha: %g, beta: %g, eta: 0.1, viscosity_velocity: %s}\n",
                        VV_DT, VV_DT, "out.h5", slip, alpha, beta, vvel);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  wrun_go(&c);
  ck_assert_int_eq((int)c.r.sim->step, 1);
  ej_set *f = wrun_set(&c, "fluid"), *w = wrun_set(&c, "wall");
  *n = f->n;
  double *v = malloc(3 * sizeof(double) * (size_t)f->n);
  ck_assert_ptr_nonnull(v);
  const ej_real *vf = ej_set_field(f, "v");
  for (ej_idx i = 0; i < 3 * f->n; ++i) v[i] = vf[i];
  if (ref) {
    /* a_i = -sum_w m_w Pi_iw grad_i W, Pi = (-alpha c_i mu + beta mu^2) / ((rho_i + rho_w)/2),
     * mu = h_i (v_i - v_w) . (x_i - x_w) / (r^2 + eta^2 h_i^2) when negative; m_w = rho0 vol0_w */
    const ej_real *x = ej_set_field(f, "x"), *h = ej_set_field(f, "h"), *rho = ej_set_field(f, "rho");
    const ej_real *cs = ej_set_field(f, "c"), *xw = ej_set_field(w, "x"), *vol = ej_set_field(w, "vol0");
    *ref = calloc(3 * (size_t)f->n, sizeof(double));
    ck_assert_ptr_nonnull(*ref);
    for (ej_idx i = 0; i < f->n; ++i)
      for (ej_idx k = 0; k < w->n; ++k) {
        const double d[2] = {x[3 * i] - xw[3 * k], x[3 * i + 1] - xw[3 * k + 1]}, r = hypot(d[0], d[1]);
        if (r >= 2 * h[i]) continue;
        const double vx = vf[3 * i] * d[0] + vf[3 * i + 1] * d[1];
        if (vx >= 0) continue;
        const double mu = h[i] * vx / (r * r + 0.01 * h[i] * h[i]);
        const double pi = (-alpha * cs[i] * mu + beta * mu * mu) / (0.5 * (rho[i] + 1000.0));
        const double dwdr = sph_kernel_dw(SPH_KERNEL_WENDLAND_C2, 2, r, h[i]);
        for (int q = 0; q < 2; ++q) (*ref)[3 * i + q] -= 1000.0 * vol[k] * pi * dwdr * d[q] / r;
      }
  }
  vscene_free(&c);
  return v;
}

START_TEST(test_viscosity_velocity)
{
  ej_idx n = 0;
  double *ref = NULL;
  double *v_free0 = visc_step("free_slip", "extrapolated", 1, 10, &n, NULL);
  double *v_none = visc_step("free_slip", "extrapolated", 0, 0, &n, NULL);
  double *v_free = visc_step("free_slip", "wall", 1, 10, &n, &ref);
  double *v_no = visc_step("no_slip", "wall", 1, 10, &n, NULL);
  double *v_no0 = visc_step("no_slip", "extrapolated", 1, 10, &n, NULL);
  double amax = 0, err = 0, err_slip = 0, d_free0 = 0, a_no0 = 0, a_free = 0;
  for (ej_idx i = 0; i < n; ++i)
    for (int q = 0; q < 2; ++q) {
      const ej_idx j = 3 * i + q;
      const double a = (v_free[j] - v_none[j]) / VV_DT; /* velocity Verlet: mean of the step's two evaluations */
      amax = fmax(amax, fabs(ref[j]));
      err = fmax(err, fabs(a - ref[j]));
      err_slip = fmax(err_slip, fabs(v_no[j] - v_free[j]) / VV_DT);
      d_free0 = fmax(d_free0, fabs(v_free0[j] - v_none[j]) / VV_DT);
      if (q == 1) a_no0 = fmax(a_no0, (v_no0[j] - v_none[j]) / VV_DT), a_free = fmax(a_free, a);
    }
  fprintf(stderr,
          "wall viscosity, liquid block at -1 m/s onto the floor: |a_visc| max %.4g m/s^2 (expected on v_i - v_w); "
          "error %.3g; no_slip - free_slip (wall) %.3g; free_slip extrapolated %.3g; no_slip extrapolated "
          "max a_y %.4g vs wall %.4g\n",
          amax, err, err_slip, d_free0, a_no0, a_free);
  ck_assert_double_gt(amax, 1.0);
  ck_assert_double_lt(err, 1e-3 * amax);      /* the term on v_i - v_w, both slips */
  ck_assert_double_lt(err_slip, 1e-6 * amax);  /* a liquid: the mirrored stress is the same pressure */
  ck_assert_double_lt(d_free0, 1e-6 * amax);   /* default free slip: no viscous wall term */
  ck_assert_double_gt(a_no0, 1.5 * a_free);     /* Adami Eq 23 velocity: twice the relative velocity */
  free(v_free0), free(v_none), free(v_free), free(v_no), free(v_no0), free(ref);
  /* tangential sliding on a free-slip floor: the viscosity on v_i - v_w acts as friction (oblique
   * pairs ahead of each particle approach it), wall_normal damps only n.(v_i - v_w): no friction */
  const double vt_normal = slab_mean_vx("free_slip, viscosity_velocity: wall_normal");
  const double vt_wall = slab_mean_vx("free_slip, viscosity_velocity: wall");
  ck_assert_double_lt(fabs(vt_normal - 1.0), 0.01);
  ck_assert_double_lt(vt_wall, vt_normal - 0.05);
}
END_TEST

static Suite *sph_wall_suite(void)
{
  Suite *s = suite_create("sph_wall");
  TCase *tc = tcase_create("walls");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_hydrostatic_column);
  tcase_add_test(tc, test_free_vs_no_slip);
  tcase_add_test(tc, test_dropped_block);
  tcase_add_test(tc, test_wall_velocity_gradient);
  tcase_add_test(tc, test_dp_block_energy_threads);
  tcase_add_test(tc, test_wall_ghosts_refused);
  tcase_add_test(tc, test_wall_gradient_corrected);
  tcase_add_test(tc, test_viscosity_velocity);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(sph_wall_suite());
  srunner_run_all(sr, CK_NORMAL);
  const int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
