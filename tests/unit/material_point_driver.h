/* Material-point driver for the strength-model unit tests: one point (or a small batch) driven
 * through ej_mat_batch exactly as a method calls it (stress in -> stress out, d given, dt),
 * with mixed strain/stress control for triaxial and uniaxial-stress paths.
 *
 * CSV output for validation/material_points/run.py: when EJ_MP_CSV_DIR is set, mpd_csv_open
 * writes <dir>/<name>.csv (header + rows); otherwise it returns NULL and nothing is written.
 * Header only, included by tests/unit/test_<material>.c. */
#ifndef EJ_TEST_MATERIAL_POINT_DRIVER_H
#define EJ_TEST_MATERIAL_POINT_DRIVER_H

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "ejecta/tensor.h"

#define MPD_MAX_HIST 16

typedef struct mpd {
  ej_registry *reg;
  const ej_material_ops *ops;
  void *config, *state;
  int nh;
  ej_real hbuf[MPD_MAX_HIST];
  ej_real *hist[MPD_MAX_HIST];
  ej_real stress[6];
  ej_real rho, e, p, c, wp, wp_total;
  int32_t failed;
  const ej_real *pext; /* pressure handed to a needs_eos material (NULL: b.p = NULL) */
} mpd;

static inline void mpd_open(mpd *m, const ej_plugin_info *info, const char *name)
{
  memset(m, 0, sizeof *m);
  ck_assert_int_eq(ej_registry_create(&m->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(m->reg, info), EJ_OK);
  const void *ops = NULL;
  ck_assert_int_eq(ej_registry_require(m->reg, EJ_KIND_MATERIAL, name, NULL, &ops), EJ_OK);
  m->ops = ops;
  m->config = ej_calloc(1, m->ops->config_size);
  ck_assert_ptr_nonnull(m->config);
  ck_assert_int_eq(ej_params_defaults(m->ops->params, m->config), EJ_OK);
  m->rho = 1000.0;
}

static inline const ej_param *mpd_param(const mpd *m, const char *name)
{
  for (const ej_param *p = m->ops->params; p && p->name; ++p)
    if (strcmp(p->name, name) == 0) return p;
  ck_abort_msg("no parameter '%s' in %s", name, m->ops->name);
  return NULL;
}

/* SI values (angles in radians). */
static inline void mpd_set(mpd *m, const char *name, double v)
{
  const ej_param *p = mpd_param(m, name);
  ck_assert_int_eq(p->type, EJ_PT_REAL);
  *(ej_real *)((char *)m->config + p->offset) = v;
}
static inline void mpd_set_bool(mpd *m, const char *name, bool v)
{
  const ej_param *p = mpd_param(m, name);
  ck_assert_int_eq(p->type, EJ_PT_BOOL);
  *(bool *)((char *)m->config + p->offset) = v;
}
static inline void mpd_set_enum(mpd *m, const char *name, const char *word)
{
  const ej_param *p = mpd_param(m, name);
  ck_assert_int_eq(p->type, EJ_PT_ENUM);
  for (int k = 0; p->choices[k]; ++k)
    if (strcmp(p->choices[k], word) == 0) {
      *(int *)((char *)m->config + p->offset) = k;
      return;
    }
  ck_abort_msg("'%s' is not a choice of %s", word, name);
}

/* check_config (must accept), create, init_hist; stress zero. */
static inline void mpd_create(mpd *m)
{
  if (m->ops->check_config) {
    ej_err rc = m->ops->check_config(m->config, NULL);
    if (rc != EJ_OK) ej_error_report("mpd_create");
    ck_assert_int_eq(rc, EJ_OK);
  }
  ck_assert_int_eq(m->ops->create(m->config, &m->state), EJ_OK);
  m->nh = m->ops->n_hist;
  ck_assert_int_le(m->nh, MPD_MAX_HIST);
  for (int k = 0; k < m->nh; ++k) m->hist[k] = &m->hbuf[k];
  if (m->ops->init_hist) ck_assert_int_eq(m->ops->init_hist(m->state, 1, m->hist), EJ_OK);
  memset(m->stress, 0, sizeof m->stress);
}

/* check_config must reject (error stack cleared). */
static inline void mpd_expect_reject(mpd *m)
{
  ck_assert_ptr_nonnull(m->ops->check_config);
  ck_assert_int_eq(m->ops->check_config(m->config, NULL), EJ_ERR_INPUT);
  ej_error_clear();
}

static inline void mpd_close(mpd *m)
{
  if (m->state) m->ops->destroy(m->state);
  ej_free(m->config);
  ej_registry_destroy(m->reg);
}

static inline int mpd_hist_index(const mpd *m, const char *name)
{
  for (int k = 0; k < m->nh; ++k)
    if (strcmp(m->ops->hist_names[k], name) == 0) return k;
  ck_abort_msg("no history variable '%s'", name);
  return -1;
}
static inline ej_real mpd_hist(const mpd *m, const char *name) { return m->hbuf[mpd_hist_index(m, name)]; }

/* One update with rate of deformation d over dt (updates stress, history, c, w_plastic). */
static inline ej_err mpd_step(mpd *m, const ej_real d[6], ej_real dt)
{
  ej_mat_batch b = {.n = 1, .dt = dt, .rho = &m->rho, .e = &m->e, .d = d, .F = NULL, .p = m->pext,
                    .stress = m->stress, .hist = m->hist, .c = &m->c, .w_plastic = &m->wp, .failed = &m->failed};
  m->wp = 0;
  ej_err rc = m->ops->update(m->state, &b);
  m->wp_total += m->wp;
  return rc;
}

/* A trial update on copies: stress after a step with d (state untouched). */
static inline void mpd_peek(const mpd *m, const ej_real d[6], ej_real dt, ej_real out[6])
{
  mpd c = *m;
  for (int k = 0; k < c.nh; ++k) c.hist[k] = &c.hbuf[k];
  ck_assert_int_eq(mpd_step(&c, d, dt), EJ_OK);
  memcpy(out, c.stress, sizeof c.stress);
}

/* Mixed control: components with ctrl[k] = 0 have the prescribed rate d[k]; components with
 * ctrl[k] = 1 are solved so that stress[k] at the end of the step equals target[k] (Newton with
 * a finite-difference Jacobian on the free components). d is overwritten with the rates used. */
static inline void mpd_step_mixed(mpd *m, ej_real d[6], const int ctrl[6], const ej_real target[6], ej_real dt,
                                  ej_real G_scale)
{
  int idx[6], nf = 0;
  for (int k = 0; k < 6; ++k)
    if (ctrl[k]) idx[nf++] = k;
  for (int it = 0; it < 60 && nf > 0; ++it) {
    ej_real s0[6], r[6], J[6][6], maxr = 0;
    mpd_peek(m, d, dt, s0);
    for (int a = 0; a < nf; ++a) {
      r[a] = s0[idx[a]] - target[idx[a]];
      maxr = fmax(maxr, fabs(r[a]));
    }
    if (maxr <= 1e-13 * G_scale) break;
    const ej_real h = 1e-7 * fmax(1e-6, fabs(d[0]) + fabs(d[1]) + fabs(d[2]) + fabs(d[3]));
    for (int bcol = 0; bcol < nf; ++bcol) {
      ej_real dd[6], s1[6];
      memcpy(dd, d, sizeof dd);
      dd[idx[bcol]] += h;
      mpd_peek(m, dd, dt, s1);
      for (int a = 0; a < nf; ++a) J[a][bcol] = (s1[idx[a]] - s0[idx[a]]) / h;
    }
    /* Gauss elimination with partial pivoting on J x = -r */
    ej_real x[6];
    for (int a = 0; a < nf; ++a) x[a] = -r[a];
    for (int col = 0; col < nf; ++col) {
      int piv = col;
      for (int a = col + 1; a < nf; ++a)
        if (fabs(J[a][col]) > fabs(J[piv][col])) piv = a;
      for (int bb = 0; bb < nf; ++bb) {
        ej_real t = J[col][bb];
        J[col][bb] = J[piv][bb], J[piv][bb] = t;
      }
      ej_real t = x[col];
      x[col] = x[piv], x[piv] = t;
      ck_assert(fabs(J[col][col]) > 0);
      for (int a = col + 1; a < nf; ++a) {
        const ej_real f = J[a][col] / J[col][col];
        for (int bb = col; bb < nf; ++bb) J[a][bb] -= f * J[col][bb];
        x[a] -= f * x[col];
      }
    }
    for (int a = nf - 1; a >= 0; --a) {
      for (int bb = a + 1; bb < nf; ++bb) x[a] -= J[a][bb] * x[bb];
      x[a] /= J[a][a];
    }
    for (int a = 0; a < nf; ++a) d[idx[a]] += x[a];
  }
  ck_assert_int_eq(mpd_step(m, d, dt), EJ_OK);
}

/* Tension-positive mean stress and ||s|| = sqrt(s:s). */
static inline ej_real mpd_mean(const ej_real s[6]) { return (s[0] + s[1] + s[2]) / 3; }
static inline ej_real mpd_snorm(const ej_real s[6])
{
  ej_real dv[6];
  ej_s6_dev(dv, s);
  return sqrt(ej_s6_ddot(dv, dv));
}

static inline FILE *mpd_csv_open(const char *name, const char *header)
{
  const char *dir = getenv("EJ_MP_CSV_DIR");
  if (!dir || !dir[0]) return NULL;
  char path[1024];
  snprintf(path, sizeof path, "%s/%s.csv", dir, name);
  FILE *f = fopen(path, "w");
  if (f) fprintf(f, "%s\n", header);
  return f;
}

static inline double mpd_relerr(double a, double b) { return fabs(a - b) / fmax(fabs(b), 1e-300); }

#endif /* EJ_TEST_MATERIAL_POINT_DRIVER_H */
