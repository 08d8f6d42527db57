/* A one-set fixture for the unit tests of the method plugins (test_sph, test_sph_solid, test_ulpd,
 * test_rkpm): a registry, the method's configuration, an optional EOS and strength model, a set of n
 * particles carrying the method's fields, and a current-configuration neighbour list (no skin, no
 * ghosts). Each suite registers its plugins and sets its parameters in its own fix_open; the steps
 * shared by all of them are here. The right-hand side is evaluated as the core does it
 * (core/src/sim.c): the acceleration and every rate field zeroed, then the method's passes, each over
 * several ranges (to exercise range handling). Header only. */
#ifndef EJ_TEST_METHOD_FIX_H
#define EJ_TEST_METHOD_FIX_H

#include <check.h>
#include <string.h>

#include "core_impl.h"
#include "test_rng.h"

typedef struct method_fix {
  ej_registry *reg;
  const ej_method_ops *mops;
  const ej_eos_ops *eops;        /* NULL: no EOS */
  const ej_material_ops *matops; /* NULL: no strength model */
  void *mcfg, *ecfg, *matcfg;
  void *mstate, *estate, *matstate;
  struct ej_eos eos;
  struct ej_material mat;
  struct ej_model model;
  ej_set *set;
  ej_nbrlist *list;
  int dim;
  ej_real t, dt;
} method_fix;

static inline const ej_param *find_param(const ej_param *t, const char *name)
{
  for (; t && t->name; ++t)
    if (!strcmp(t->name, name)) return t;
  ck_abort_msg("no parameter '%s'", name);
  return NULL;
}

/* The method's support radii and its neighbour list over the set's current positions. */
static inline void mfix_list(method_fix *f)
{
  const ej_idx n = ej_set_count(f->set);
  ck_assert_int_eq(f->mops->support(f->mstate, f->set, (ej_range){0, n}, f->set->radius), EJ_OK);
  const ej_real *x = ej_set_field(f->set, "x");
  ck_assert_int_eq(ej_nbrlist_build(f->list, f->dim, x, f->set->radius, n, x, f->set->radius, n, 0.0, true), EJ_OK);
}

/* create + setup + support + neighbour list. */
static inline void mfix_start(method_fix *f)
{
  ck_assert_int_eq(f->mops->create(f->mcfg, f->set, &f->model, &f->mstate), EJ_OK);
  ck_assert_int_eq(f->mops->setup(f->mstate, f->set), EJ_OK);
  mfix_list(f);
}

/* One right-hand side: a and the rate fields zeroed (as ej_zero_chunk), then every pass of the
 * method over nr ranges [n h / nr, n (h + 1) / nr). */
static inline void mfix_compute(method_fix *f, int nr)
{
  ej_set *s = f->set;
  const ej_idx n = ej_set_count(s);
  for (int k = 0; k < s->n_fields; ++k)
    if (k == s->f_a || s->fields[k].rate_of >= 0)
      memset(s->fields[k].data, 0, (size_t)n * (size_t)s->fields[k].ncomp * sizeof(ej_real));
  const int np = f->mops->pass_count ? f->mops->pass_count(f->mstate) : f->mops->n_passes;
  for (int pass = 0; pass < np; ++pass)
    for (int h = 0; h < nr; ++h) {
      const ej_range rg = {n * h / nr, n * (h + 1) / nr};
      ck_assert_int_eq(f->mops->compute(f->mstate, s, &f->list->pub, pass, rg), EJ_OK);
    }
}

/* A random gas state for the conservation tests: the set's n particles uniform in the unit box of
 * the first dim axes, v uniform in [-1, 1), rho in [0.5, 1.5), e in [1, 3), volumes (0.8 ... 1.2) / n
 * and m = rho vol0, drawn from *seed in that order, particle by particle. */
static inline void mfix_random_gas(method_fix *f, int dim, uint64_t *seed)
{
  const ej_idx n = ej_set_count(f->set);
  ej_real *x = ej_set_field(f->set, "x"), *v = ej_set_field(f->set, "v"), *m = ej_set_field(f->set, "m");
  ej_real *vol0 = ej_set_field(f->set, "vol0"), *rho = ej_set_field(f->set, "rho"), *e = ej_set_field(f->set, "e");
  const ej_real vol = 1.0 / n;
  for (ej_idx i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      x[3 * i + d] = d < dim ? rng_uniform(seed) : 0.0;
      v[3 * i + d] = d < dim ? 2.0 * rng_uniform(seed) - 1.0 : 0.0;
    }
    rho[i] = 0.5 + rng_uniform(seed);
    e[i] = 1.0 + 2.0 * rng_uniform(seed);
    vol0[i] = vol * (0.8 + 0.4 * rng_uniform(seed));
    m[i] = rho[i] * vol0[i];
  }
}

static inline void mfix_close(method_fix *f)
{
  if (f->mstate) f->mops->destroy(f->mstate);
  ej_nbrlist_destroy(f->list);
  ej_set_destroy(f->set);
  if (f->estate) f->eops->destroy(f->estate);
  if (f->matstate) f->matops->destroy(f->matstate);
  ej_free(f->mcfg);
  ej_free(f->ecfg);
  ej_free(f->matcfg);
  ej_registry_destroy(f->reg);
}

#endif
