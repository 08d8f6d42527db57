/* Shared by the tlpd unit tests: a scene written into a fresh temporary folder, loaded with the
 * tlpd and elastic plugins linked in, and the method's two passes run directly (as the core runs
 * them, over two ranges, without ghosts). */
#ifndef EJ_TEST_TLPD_TRUN_H
#define EJ_TEST_TLPD_TRUN_H

#include <check.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

typedef struct trun {
  ej_registry *reg;
  ej_scene *scene;
  ej_sim *sim;
  char dir[64], path[128];
} trun;

static inline void trun_dir(trun *r)
{
  memset(r, 0, sizeof *r);
  ej_test_tmpdir(r->dir, sizeof r->dir, "tlpd");
  snprintf(r->path, sizeof r->path, "%s/s.yaml", r->dir);
}

/* writes the scene text (output into r->dir) and creates the run; returns the error code */
static inline ej_err trun_try(trun *r, const char *yaml)
{
  FILE *f = fopen(r->path, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "%s\noutput: {file: %s/o.h5}\n", yaml, r->dir);
  fclose(f);
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_tlpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_elastic_info()), EJ_OK);
  ej_err rc = ej_scene_load(r->path, r->reg, &r->scene);
  if (rc != EJ_OK) return rc;
  ej_run_opts o = {.struct_size = sizeof o, .threads = 1};
  return ej_sim_create(r->scene, r->reg, &o, &r->sim);
}

static inline void trun_open(trun *r, const char *yaml)
{
  trun_dir(r);
  ej_err rc = trun_try(r, yaml);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static inline void trun_close(trun *r)
{
  if (r->sim) ej_sim_destroy(r->sim);
  if (r->scene) ej_scene_destroy(r->scene);
  if (r->reg) ej_registry_destroy(r->reg);
  ej_test_rmtree(r->dir);
}

/* zero a and rates, then both passes over two ranges (as the core does, without ghosts) */
static inline void trun_compute(trun *r)
{
  ej_set *s = r->sim->sets[0];
  const ej_idx n = ej_set_count(s);
  for (int k = 0; k < s->n_fields; ++k)
    if (k == s->f_a || s->fields[k].rate_of >= 0)
      memset(s->fields[k].data, 0, (size_t)n * s->fields[k].ncomp * sizeof(ej_real));
  const ej_range halves[2] = {{0, n / 2}, {n / 2, n}};
  for (int pass = 0; pass < 2; ++pass)
    for (int h = 0; h < 2; ++h)
      ck_assert_int_eq(s->mops->compute(s->mstate, s, &s->list->pub, pass, halves[h]), EJ_OK);
}

#endif
