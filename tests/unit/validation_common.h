/* Helpers shared by the validation and determinism suites: write a scene into a temporary
 * directory, run it through the library API (registry with the statically linked sph and
 * ideal_gas plugins, scene, sim), and the exact Riemann solution of the Sod problem.
 * Header-only, included by test_validation_sod.c, test_validation_sedov.c, test_determinism.c. */
#ifndef EJ_TEST_VALIDATION_COMMON_H
#define EJ_TEST_VALIDATION_COMMON_H

#include <check.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_ideal_gas_info(void);

/* A loaded scene and its finished (or restarted) run. */
typedef struct vrun {
  ej_registry *reg;
  ej_scene *scene;
  ej_sim *sim;
} vrun;

static inline void vrun_dir(char *dir, size_t n, const char *tag)
{
  ej_test_tmpdir(dir, n, tag);
}

static inline void vrun_write(const char *path, const char *text)
{
  FILE *f = fopen(path, "w");
  ck_assert_ptr_nonnull(f);
  ck_assert_int_eq(fputs(text, f) >= 0, 1);
  fclose(f);
}

/* Loads scene_path with the np statically linked plugins; max_steps >= 0 overrides the scene's;
 * then creates the sim with the given options. The caller runs it (vrun_run) and frees it with
 * vrun_free. */
static inline void vrun_open_with(vrun *r, const char *scene_path, const ej_run_opts *opts, int64_t max_steps,
                                  const ej_plugin_info *const *plugins, int np)
{
  memset(r, 0, sizeof *r);
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  for (int k = 0; k < np; ++k) ck_assert_int_eq(ej_registry_add_static(r->reg, plugins[k]), EJ_OK);
  ej_err rc = ej_scene_load(scene_path, r->reg, &r->scene);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  if (max_steps >= 0) r->scene->max_steps = max_steps;
  rc = ej_sim_create(r->scene, r->reg, opts, &r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

/* vrun_open_with the sph and ideal_gas plugins. */
static inline void vrun_open(vrun *r, const char *scene_path, const ej_run_opts *opts, int64_t max_steps)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info()};
  vrun_open_with(r, scene_path, opts, max_steps, p, 2);
}

static inline void vrun_run(vrun *r)
{
  ej_err rc = ej_sim_run(r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static inline void vrun_free(vrun *r)
{
  ej_sim_destroy(r->sim);
  ej_scene_destroy(r->scene);
  ej_registry_destroy(r->reg);
  memset(r, 0, sizeof *r);
}

/* The set called name in a sim (aborts the test when there is none). */
static inline ej_set *vsim_set(const ej_sim *sim, const char *name)
{
  for (int k = 0; k < sim->n_sets; ++k)
    if (!strcmp(ej_set_name(sim->sets[k]), name)) return sim->sets[k];
  ck_abort_msg("no set %s", name);
  return NULL;
}

/* The scene at path (the np plugins p) loads, and `ejecta check` (ej_sim_create with check_only)
 * refuses it as bad input: a message containing msg, at line:col. */
static inline void vrun_check_refuses_with(const char *path, const ej_plugin_info *const *p, int np, const char *msg,
                                           int line, int col)
{
  ej_registry *reg = NULL;
  ej_scene *sc = NULL;
  ej_sim *sim = NULL;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  for (int k = 0; k < np; ++k) ck_assert_int_eq(ej_registry_add_static(reg, p[k]), EJ_OK);
  ck_assert_int_eq(ej_scene_load(path, reg, &sc), EJ_OK);
  ej_error_clear();
  ej_run_opts o = {.struct_size = sizeof o, .check_only = true};
  ck_assert_int_eq(ej_sim_create(sc, reg, &o, &sim), EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_msg(strstr(f->msg, msg) != NULL, "%s", f->msg);
  ck_assert_int_eq(f->where.line, line);
  ck_assert_int_eq(f->where.col, col);
  ej_error_clear();
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
}

/* The same with the sph and ideal_gas plugins. */
static inline void vrun_check_refuses(const char *path, const char *msg, int line, int col)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info()};
  vrun_check_refuses_with(path, p, 2, msg, line, col);
}

/* vrun_check_refuses_with on a scene given as text, written into a fresh temporary folder named after
 * tag (removed afterwards). */
static inline void vrun_refuses_text_with(const char *tag, const ej_plugin_info *const *p, int np, const char *text,
                                          const char *msg, int line, int col)
{
  char dir[64], scene[128];
  vrun_dir(dir, sizeof dir, tag);
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  vrun_write(scene, text);
  vrun_check_refuses_with(scene, p, np, msg, line, col);
  ej_test_rmtree(dir);
}

/* The same with the sph and ideal_gas plugins. */
static inline void vrun_refuses_text(const char *tag, const char *text, const char *msg, int line, int col)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info()};
  vrun_refuses_text_with(tag, p, 2, text, msg, line, col);
}

/* Two runs of one scene ended in the same state, bitwise: the named fields of set 0 (every
 * component) and the external work of the budget; what names the comparison in the messages. */
static inline void vrun_same_state(const ej_sim *a, const ej_sim *b, const char *const *fields, int n,
                                   const char *what)
{
  const ej_set *sa = a->sets[0], *sb = b->sets[0];
  ck_assert_int_eq(ej_set_count(sa), ej_set_count(sb));
  for (int k = 0; k < n; ++k) {
    const int f = ej_set_find_field(sa, fields[k]);
    ck_assert_msg(f >= 0, "no field %s", fields[k]);
    const size_t nb = (size_t)ej_set_count(sa) * (size_t)sa->fields[f].ncomp * sizeof(ej_real);
    ck_assert_msg(!memcmp(ej_set_field(sa, fields[k]), ej_set_field(sb, fields[k]), nb), "%s differs%s", fields[k],
                  what);
  }
  ck_assert_msg(!memcmp(&a->energy.external, &b->energy.external, sizeof(ej_real)), "external %.17g vs %.17g%s",
                a->energy.external, b->energy.external, what);
}

/* A scene given as text, in a fresh temporary directory: dir/s.yaml, output dir/out.h5. */
typedef struct vscene {
  char dir[64], scene[128], out[128];
  vrun r;
} vscene;

/* Writes the printf-formatted scene, registers the np static plugins, loads the scene and creates
 * its sim (threads threads, output dir/out.h5). Returns the first error; the caller asserts on it. */
static inline ej_err vscene_open_threads(vscene *c, const char *tag, const ej_plugin_info *const *plugins, int np,
                                         int threads, const char *fmt, va_list ap)
{
  memset(c, 0, sizeof *c);
  vrun_dir(c->dir, sizeof c->dir, tag);
  snprintf(c->scene, sizeof c->scene, "%s/s.yaml", c->dir);
  snprintf(c->out, sizeof c->out, "%s/out.h5", c->dir);
  FILE *f = fopen(c->scene, "w");
  ck_assert_ptr_nonnull(f);
  vfprintf(f, fmt, ap);
  fclose(f);
  ck_assert_int_eq(ej_registry_create(&c->r.reg), EJ_OK);
  for (int k = 0; k < np; ++k) ck_assert_int_eq(ej_registry_add_static(c->r.reg, plugins[k]), EJ_OK);
  ej_err rc = ej_scene_load(c->scene, c->r.reg, &c->r.scene);
  if (rc != EJ_OK) return rc;
  ej_run_opts o = {.threads = threads, .output = c->out};
  return ej_sim_create(c->r.scene, c->r.reg, &o, &c->r.sim);
}

/* vscene_open_threads on 1 thread. */
static inline ej_err vscene_open(vscene *c, const char *tag, const ej_plugin_info *const *plugins, int np,
                                 const char *fmt, va_list ap)
{
  return vscene_open_threads(c, tag, plugins, np, 1, fmt, ap);
}

static inline void vscene_free(vscene *c)
{
  vrun_free(&c->r);
  ej_test_rmtree(c->dir);
}

/* Removes the files a run left in dir (scene, outputs, XDMF sidecars), then dir. */
static inline void vrun_cleanup(const char *dir, const char *const *names, int n)
{
  char p[1024];
  for (int k = 0; k < n; ++k) {
    snprintf(p, sizeof p, "%s/%s", dir, names[k]);
    unlink(p);
  }
  rmdir(dir);
}

/* The shear-jump traction tests (test_rkpm.c test_stabilization_traction, test_sph_solid.c
 * test_visc_shear_traction, test_ulpd.c test_chg_shear_traction): runs the printf-formatted scene,
 * a 3D block whose upper half (z > 0) of set 0 started at +dv/2 along x, for its one step of dt
 * and returns the x force on that half, sum m (v_x - dv/2) / dt; *c0 gets the sound speed of the
 * first particle. */
static inline double shear_jump_run(const char *tag, const ej_plugin_info *const *plugins, int np, double dv,
                                    double dt, double *c0, const char *fmt, ...)
{
  vscene c;
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(&c, tag, plugins, np, fmt, ap);
  va_end(ap);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  vrun_run(&c.r);
  const ej_set *set = c.r.sim->sets[0];
  const ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *m = ej_set_field(set, "m");
  double fx = 0;
  for (ej_idx i = 0; i < ej_set_count(set); ++i)
    if (x[3 * i + 2] > 0) fx += m[i] * (v[3 * i] - 0.5 * dv) / dt;
  *c0 = ej_set_field(set, "c")[0];
  vscene_free(&c);
  return fx;
}

/* ------------------------------------------------------------------ smooth block velocity */

/* The `initial:` entries of the free 0.5 m block of the rkpm/tlpd stability and restart tests: a
 * smooth nonuniform velocity field (scale vscale) sampled on 4 x 4 columns of the block, one
 * YAML list item per column, written into buf. */
static inline void smooth_block_initial(char *buf, size_t n, double vscale)
{
  size_t o = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const double X = 0.125 * (i + 0.5), Y = 0.125 * (j + 0.5);
      o += (size_t)snprintf(buf + o, o < n ? n - o : 0,
                            "      - {region: {box: {min: [%g, %g, -1], max: [%g, %g, 1]}}, velocity: [%.12g, %.12g, "
                            "%.12g]}\n",
                            0.125 * i, 0.125 * j, 0.125 * (i + 1), 0.125 * (j + 1), vscale * sin(5 * X) * (1 + Y * Y),
                            vscale * sin(7 * Y) * (1 + 2 * X * X), vscale * cos(3 * X) * cos(4 * Y));
    }
  ck_assert(o < n);
}

/* ------------------------------------------------------------------ Sod scene and solution */

/* The Sod tube of validation/sod/check.py (sod_scene): one spacing on both sides, the jump
 * smoothed by (1 + tanh(x / w)) / 2 with w = 1.95 dx (Monaghan & Gingold 1983), one `initial`
 * strip per lattice column with |x| < 5 w. dim 1, or 3 with a periodic cross-section
 * [0, width]^2. set_extra: more keys of the tube set, each line indented by 4 (NULL: none).
 * Returns a malloc'ed scene text. */
static inline char *sod_scene_text(int dim, double dx, double t_end, double width, const char *out,
                                   const char *set_extra)
{
  ej_buf b = {0};
  const char *lo3 = dim == 3 ? ", 0, 0" : "";
  char hi3[64] = "";
  if (dim == 3) snprintf(hi3, sizeof hi3, ", %.17g, %.17g", width, width);
  ck_assert_int_eq(ej_buf_printf(&b,
                                 "ejecta: 1\ndimension: %d\ntime: {end: %.17g, cfl: 0.3}\n"
                                 "output: {file: %s, fields: [v, m, rho, p, e, h]}\n"
                                 "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                                 "sets:\n  tube:\n    method: sph\n%s    material: gas\n"
                                 "    shape: {box: {min: [-0.5%s], max: [0.5%s]}}\n    spacing: %.17g\n"
                                 "    rho: 1\n    p: 1\n    initial:\n"
                                 "      - {region: {box: {min: [0%s], max: [0.5%s]}}, rho: 0.125, p: 0.1}\n",
                                 dim, t_end, out, set_extra ? set_extra : "", lo3, hi3, dx, lo3, hi3),
                   EJ_OK);
  const double w = 1.5 * 1.3 * dx;
  const int n = (int)lround(1.0 / dx);
  for (int i = 0; i < n; ++i) {
    const double x = -0.5 + (i + 0.5) * dx;
    if (fabs(x) >= 5 * w) continue;
    const double f = 0.5 * (1.0 + tanh(x / w));
    ck_assert_int_eq(ej_buf_printf(&b,
                                   "      - {region: {box: {min: [%.17g%s], max: [%.17g%s]}}, rho: %.17g, p: %.17g}\n",
                                   x - dx / 2, lo3, x + dx / 2, hi3, 1.0 + (0.125 - 1.0) * f, 1.0 + (0.1 - 1.0) * f),
                     EJ_OK);
  }
  const char *z3 = dim == 3 ? ", 0, 0" : "";
  ck_assert_int_eq(ej_buf_printf(&b, "boundaries:\n  - symmetry: {point: [-0.5%s], normal: [1%s]}\n"
                                     "  - symmetry: {point: [0.5%s], normal: [-1%s]}\n",
                                 z3, z3, z3, z3),
                   EJ_OK);
  if (dim == 3)
    ck_assert_int_eq(ej_buf_printf(&b, "  - periodic: {axis: y, min: 0, max: %.17g}\n"
                                       "  - periodic: {axis: z, min: 0, max: %.17g}\n",
                                   width, width),
                     EJ_OK);
  char *text = b.data; /* ej_buf memory comes from ej_malloc */
  char *copy = strdup(text);
  ej_buf_free(&b);
  ck_assert_ptr_nonnull(copy);
  return copy;
}

/* Exact Riemann solver for the ideal gas: Toro, "Riemann Solvers and Numerical Methods for Fluid
 * Dynamics", 3rd ed., ch. 4 (Eqs 4.6-4.9, 4.44-4.46 Newton iteration, sampling section 4.5). */
typedef struct sod_state {
  double rho, u, p;
} sod_state;

static inline void toro_f(double p, const sod_state *k, double g, double *f, double *df)
{
  const double c = sqrt(g * k->p / k->rho);
  if (p > k->p) {
    const double A = 2 / ((g + 1) * k->rho), B = (g - 1) / (g + 1) * k->p, s = sqrt(A / (p + B));
    *f = (p - k->p) * s;
    *df = s * (1 - 0.5 * (p - k->p) / (p + B));
  } else {
    *f = 2 * c / (g - 1) * (pow(p / k->p, (g - 1) / (2 * g)) - 1);
    *df = 1 / (k->rho * c) * pow(p / k->p, -(g + 1) / (2 * g));
  }
}

static inline void toro_star(const sod_state *L, const sod_state *R, double g, double *ps, double *us)
{
  const double cl = sqrt(g * L->p / L->rho), cr = sqrt(g * R->p / R->rho), z = (g - 1) / (2 * g);
  double p = pow((cl + cr - 0.5 * (g - 1) * (R->u - L->u)) / (cl / pow(L->p, z) + cr / pow(R->p, z)), 1 / z);
  for (int it = 0; it < 100; ++it) {
    double fl, dl, fr, dr;
    toro_f(p, L, g, &fl, &dl);
    toro_f(p, R, g, &fr, &dr);
    double pn = p - (fl + fr + R->u - L->u) / (dl + dr);
    if (pn < 1e-12) pn = 1e-12;
    const double change = 2 * fabs(pn - p) / (pn + p);
    p = pn;
    if (change < 1e-13) break;
  }
  double fl, dl, fr, dr;
  toro_f(p, L, g, &fl, &dl);
  toro_f(p, R, g, &fr, &dr);
  *ps = p;
  *us = 0.5 * (L->u + R->u) + 0.5 * (fr - fl);
}

/* Density of the exact solution at x, t (diaphragm at 0). Sod: left rarefaction, right shock. */
static inline double toro_rho(const sod_state *L, const sod_state *R, double g, double ps, double us, double x, double t)
{
  const double s = x / t, gm = (g - 1) / (g + 1);
  const double cl = sqrt(g * L->p / L->rho), cr = sqrt(g * R->p / R->rho);
  if (s <= us) {
    if (ps > L->p) {
      const double sl = L->u - cl * sqrt((g + 1) / (2 * g) * ps / L->p + (g - 1) / (2 * g));
      return s <= sl ? L->rho : L->rho * (ps / L->p + gm) / (gm * ps / L->p + 1);
    }
    const double shl = L->u - cl, stl = us - cl * pow(ps / L->p, (g - 1) / (2 * g));
    if (s <= shl) return L->rho;
    if (s >= stl) return L->rho * pow(ps / L->p, 1 / g);
    const double c = 2 / (g + 1) * (cl + 0.5 * (g - 1) * (L->u - s));
    return L->rho * pow(c / cl, 2 / (g - 1));
  }
  if (ps > R->p) {
    const double sr = R->u + cr * sqrt((g + 1) / (2 * g) * ps / R->p + (g - 1) / (2 * g));
    return s >= sr ? R->rho : R->rho * (ps / R->p + gm) / (gm * ps / R->p + 1);
  }
  const double shr = R->u + cr, str = us + cr * pow(ps / R->p, (g - 1) / (2 * g));
  if (s >= shr) return R->rho;
  if (s <= str) return R->rho * pow(ps / R->p, 1 / g);
  const double c = 2 / (g + 1) * (cr - 0.5 * (g - 1) * (R->u - s));
  return R->rho * pow(c / cr, 2 / (g - 1));
}

#endif
