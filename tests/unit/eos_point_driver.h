/* EOS fixture for the EOS unit tests: registry with one statically linked EOS plugin, config
 * with defaults, parameters set by name (SI), evaluate at (rho, e). Header only. */
#ifndef EJ_TEST_EOS_POINT_DRIVER_H
#define EJ_TEST_EOS_POINT_DRIVER_H

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

typedef struct epd {
  ej_registry *reg;
  const ej_eos_ops *ops;
  void *config, *state;
} epd;

static inline void epd_open(epd *f, const ej_plugin_info *info, const char *name)
{
  memset(f, 0, sizeof *f);
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, info), EJ_OK);
  const void *ops = NULL;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_EOS, name, NULL, &ops), EJ_OK);
  f->ops = ops;
  f->config = ej_calloc(1, f->ops->config_size);
  ck_assert_ptr_nonnull(f->config);
  ck_assert_int_eq(ej_params_defaults(f->ops->params, f->config), EJ_OK);
}

static inline void epd_set(epd *f, const char *name, double v)
{
  for (const ej_param *p = f->ops->params; p && p->name; ++p)
    if (strcmp(p->name, name) == 0) {
      if (p->type == EJ_PT_BOOL) *(bool *)((char *)f->config + p->offset) = v != 0;
      else *(ej_real *)((char *)f->config + p->offset) = v;
      return;
    }
  ck_abort_msg("no parameter %s", name);
}

static inline void epd_create(epd *f) { ck_assert_int_eq(f->ops->create(f->config, &f->state), EJ_OK); }

static inline double epd_p(const epd *f, double rho, double e, double *c)
{
  ej_real p, cc;
  ck_assert_int_eq(f->ops->evaluate(f->state, 1, &rho, &e, &p, c ? &cc : NULL), EJ_OK);
  if (c) *c = cc;
  return p;
}

/* c^2 = dp/drho|_e + p/rho^2 dp/de|_rho by central differences */
static inline double epd_c2_fd(const epd *f, double rho, double e)
{
  const double hr = 1e-6 * rho, he = 1e-6 * (fabs(e) + 1e3);
  const double dpr = (epd_p(f, rho + hr, e, NULL) - epd_p(f, rho - hr, e, NULL)) / (2 * hr);
  const double dpe = (epd_p(f, rho, e + he, NULL) - epd_p(f, rho, e - he, NULL)) / (2 * he);
  return dpr + epd_p(f, rho, e, NULL) / (rho * rho) * dpe;
}

static inline void epd_close(epd *f)
{
  if (f->state) f->ops->destroy(f->state);
  ej_free(f->config);
  ej_registry_destroy(f->reg);
}

#endif
