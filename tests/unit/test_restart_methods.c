/* Restart of the solid methods (DESIGN.md "Determinism"; test_determinism covers sph gas): a run
 * restarted from the output of a run stopped at step N/2 continues bitwise identically to an
 * uninterrupted run of N steps. Scenes: a free, jittered 3D elastic block with a smooth
 * nonuniform velocity field, as semi-Lagrangian rkpm with MSNNI (its face data live in plugin
 * arrays that the method's setup allocates: a restart used to stop with "rkpm particle id outside
 * the setup range" because the core did not call setup on a restart). */
#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_rkpm_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);

#define RS_STEPS 24

typedef struct rs_snap {
  ej_idx n;
  double *x, *v; /* ordered by particle id */
} rs_snap;

static void rs_scene(const char *path, const char *method_lines)
{
  char init[4096];
  smooth_block_initial(init, sizeof init, 0.01);
  char text[8192];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 3\ntime: {end: 100, cfl: 0.3}\n"
           "output: {file: out.h5, every: 100, fields: [v]}\n"
           "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n"
           "sets:\n  block:\n%s"
           "    material: m\n    shape: {box: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}}\n"
           "    spacing: 0.0625\n    jitter: 0.3\n    initial:\n%s",
           method_lines, init);
  vrun_write(path, text);
}

static void rs_run(const char *dir, const char *out_name, int64_t steps, const char *restart, rs_snap *sn)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/%s", dir, out_name);
  ej_registry *reg = NULL;
  ej_scene *sc = NULL;
  ej_sim *sim = NULL;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_rkpm_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_tlpd_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene, reg, &sc);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  sc->max_steps = steps;
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = restart, .threads = 1};
  rc = ej_sim_create(sc, reg, &opts, &sim);
  if (rc == EJ_OK) rc = ej_sim_run(sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_int_eq(sim->step, steps);
  const ej_set *s = sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const int32_t *id = ej_set_field_int(s, "id");
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  ck_assert(id && x && v);
  sn->n = n;
  sn->x = calloc((size_t)n * 3, sizeof(double));
  sn->v = calloc((size_t)n * 3, sizeof(double));
  ck_assert(sn->x && sn->v);
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert(id[i] >= 0 && id[i] < n);
    memcpy(sn->x + 3 * id[i], x + 3 * i, 3 * sizeof(double));
    memcpy(sn->v + 3 * id[i], v + 3 * i, 3 * sizeof(double));
  }
  ej_sim_destroy(sim);
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
}

static void rs_case(const char *tag, const char *method_lines)
{
  char dir[64], half[128];
  vrun_dir(dir, sizeof dir, tag);
  char scene[128];
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  rs_scene(scene, method_lines);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  rs_snap full, first, cont;
  rs_run(dir, "full.h5", RS_STEPS, NULL, &full);
  rs_run(dir, "half.h5", RS_STEPS / 2, NULL, &first);
  rs_run(dir, "cont.h5", RS_STEPS, half, &cont);
  ck_assert_int_eq(full.n, cont.n);
  double dv = 0, vmax = 0;
  for (ej_idx k = 0; k < 3 * full.n; ++k) {
    dv = fmax(dv, fabs(full.v[k] - cont.v[k]));
    vmax = fmax(vmax, fabs(full.v[k]));
  }
  printf("%s restart: %ld particles, max |v_full - v_restarted| %.3g (max |v| %.3g)\n", tag, (long)full.n, dv, vmax);
  fflush(stdout);
  ck_assert_msg(memcmp(full.x, cont.x, (size_t)full.n * 3 * sizeof(double)) == 0, "%s: x differs", tag);
  ck_assert_msg(memcmp(full.v, cont.v, (size_t)full.n * 3 * sizeof(double)) == 0, "%s: v differs", tag);
  ck_assert(vmax > 0); /* the block moves: the comparison is not of two resting blocks */
  free(full.x), free(full.v), free(first.x), free(first.v), free(cont.x), free(cont.v);
  const char *names[] = {"s.yaml", "full.h5", "full.xdmf", "half.h5", "half.xdmf", "cont.h5", "cont.xdmf"};
  vrun_cleanup(dir, names, 7);
}

START_TEST(test_rkpm_msnni_restart)
{
  rs_case("rsrk", "    method: rkpm\n    integration: msnni\n");
}
END_TEST

/* tlpd: its family stable-step cache (dt per family, valid until a bond breaks), the flag that F
 * of the previous step may be differenced (grad du = F_n+1 - F_n) and F itself must survive a
 * restart; the critical stretch breaks bonds in the second half, so the cache is invalidated
 * after the restart too. */
START_TEST(test_tlpd_restart)
{
  rs_case("rstl", "    method: tlpd\n");
}
END_TEST

START_TEST(test_tlpd_restart_breaking)
{
  rs_case("rstb", "    method: tlpd\n    failure: {critical_stretch: 0.004}\n");
}
END_TEST

int main(void)
{
  Suite *s = suite_create("restart_methods");
  TCase *tc = tcase_create("bitwise");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_rkpm_msnni_restart);
  tcase_add_test(tc, test_tlpd_restart);
  tcase_add_test(tc, test_tlpd_restart_breaking);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
