/* Determinism (DESIGN.md "Determinism"): the same scene gives bitwise identical x, v, rho and e
 * with 1 and 2 OpenMP threads, and a run restarted from a checkpoint continues bitwise
 * identically to an uninterrupted one. Scene: the 3D periodic Sod tube of validation/sod at
 * spacing 0.01 (1600 particles: several chunks, symmetry and periodic ghosts), 40 steps.
 *
 * The restart is cut by steps (scene max_steps), not by time: a run to an end time shortens
 * its last step to land on it, so stopping at T/2 would change the step sequence itself. */
#include "validation_common.h"

#define DET_STEPS 40

typedef struct snap {
  ej_idx n;
  int64_t step;
  double t;
  double *x, *v, *rho, *e; /* ordered by particle id */
} snap;

static void snap_take(snap *sn, const ej_sim *sim)
{
  const ej_set *s = sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const int32_t *id = ej_set_field_int(s, "id");
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  const ej_real *rho = ej_set_field(s, "rho"), *e = ej_set_field(s, "e");
  ck_assert(id && x && v && rho && e);
  sn->n = n;
  sn->step = sim->step;
  sn->t = sim->t;
  sn->x = calloc((size_t)n * 3, sizeof(double));
  sn->v = calloc((size_t)n * 3, sizeof(double));
  sn->rho = calloc((size_t)n, sizeof(double));
  sn->e = calloc((size_t)n, sizeof(double));
  ck_assert(sn->x && sn->v && sn->rho && sn->e);
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert(id[i] >= 0 && id[i] < n);
    const ej_idx k = id[i];
    memcpy(sn->x + 3 * k, x + 3 * i, 3 * sizeof(double));
    memcpy(sn->v + 3 * k, v + 3 * i, 3 * sizeof(double));
    sn->rho[k] = rho[i];
    sn->e[k] = e[i];
  }
}

static void snap_free(snap *sn)
{
  free(sn->x);
  free(sn->v);
  free(sn->rho);
  free(sn->e);
}

static void snap_assert_equal(const snap *a, const snap *b, const char *what)
{
  ck_assert_int_eq(a->n, b->n);
  ck_assert_int_eq(a->step, b->step);
  ck_assert_msg(memcmp(&a->t, &b->t, sizeof a->t) == 0, "%s: t %.17g vs %.17g", what, a->t, b->t);
  const size_t n = (size_t)a->n;
  ck_assert_msg(memcmp(a->x, b->x, 3 * n * sizeof(double)) == 0, "%s: x differs", what);
  ck_assert_msg(memcmp(a->v, b->v, 3 * n * sizeof(double)) == 0, "%s: v differs", what);
  ck_assert_msg(memcmp(a->rho, b->rho, n * sizeof(double)) == 0, "%s: rho differs", what);
  ck_assert_msg(memcmp(a->e, b->e, n * sizeof(double)) == 0, "%s: e differs", what);
}

/* Runs the tube for `steps` steps (from restart if not NULL) into dir/out_name. */
static void det_run(const char *dir, const char *out_name, int threads, int64_t steps, const char *restart, snap *sn)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/tube.yaml", dir);
  snprintf(out, sizeof out, "%s/%s", dir, out_name);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = restart, .threads = threads};
  vrun r;
  vrun_open(&r, scene, &opts, steps);
  vrun_run(&r);
  ck_assert_int_eq(r.sim->step, steps);
  snap_take(sn, r.sim);
  vrun_free(&r);
}

static void det_scene(char *dir, size_t n)
{
  vrun_dir(dir, n, "det");
  char scene[128];
  snprintf(scene, sizeof scene, "%s/tube.yaml", dir);
  char *text = sod_scene_text(3, 0.01, 0.2, 0.04, "tube.h5", NULL);
  vrun_write(scene, text);
  free(text);
}

START_TEST(test_threads_bitwise)
{
  char dir[64];
  det_scene(dir, sizeof dir);
  snap a, b;
  det_run(dir, "t1.h5", 1, DET_STEPS, NULL, &a);
  det_run(dir, "t2.h5", 2, DET_STEPS, NULL, &b);
  ck_assert_int_gt(a.n, 1024); /* more than one chunk of particles per thread */
  snap_assert_equal(&a, &b, "1 vs 2 threads");
  /* the chunk-to-thread schedule (OMP_SCHEDULE, read when the run starts; unset: the core's
   * affinity schedule with stealing) changes nothing, nor does a thread count that does not
   * divide the chunks evenly (3 threads: blocks of unequal size) */
  snap c, d, e;
  ck_assert_int_eq(setenv("OMP_SCHEDULE", "static", 1), 0);
  det_run(dir, "t3.h5", 2, DET_STEPS, NULL, &c);
  ck_assert_int_eq(setenv("OMP_SCHEDULE", "dynamic,1", 1), 0);
  det_run(dir, "t4.h5", 2, DET_STEPS, NULL, &d);
  ck_assert_int_eq(unsetenv("OMP_SCHEDULE"), 0);
  det_run(dir, "t5.h5", 3, DET_STEPS, NULL, &e);
  snap_assert_equal(&a, &c, "1 thread vs 2 threads with OMP_SCHEDULE=static");
  snap_assert_equal(&a, &d, "1 thread vs 2 threads with OMP_SCHEDULE=dynamic,1");
  snap_assert_equal(&a, &e, "1 thread vs 3 threads");
  snap_free(&a);
  snap_free(&b);
  snap_free(&c);
  snap_free(&d);
  snap_free(&e);
  const char *names[] = {"tube.yaml", "t1.h5", "t1.xdmf", "t2.h5", "t2.xdmf", "t3.h5", "t3.xdmf",
                         "t4.h5", "t4.xdmf", "t5.h5", "t5.xdmf"};
  vrun_cleanup(dir, names, 11);
}
END_TEST

/* The end-of-step fusion (ABI 1.4 post_step_local: kick, post_step and the diagnostics of a
 * chunk in one parallel region) gives what separate regions give: the same run with the method's
 * table copied and the flag cleared, so that post_step and the diagnostics get regions of their
 * own, must agree bitwise in the state and in the energy budget. */
START_TEST(test_fused_end_of_step)
{
  char dir[64], scene[128], out[128];
  det_scene(dir, sizeof dir);
  snprintf(scene, sizeof scene, "%s/tube.yaml", dir);
  snap a, b;
  ej_energy ea, eb;
  det_run(dir, "f1.h5", 2, DET_STEPS, NULL, &a);
  {
    snprintf(out, sizeof out, "%s/f2.h5", dir);
    ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 2};
    vrun r;
    vrun_open(&r, scene, &opts, DET_STEPS);
    ej_set *s = r.sim->sets[0];
    ck_assert_ptr_nonnull(s->mops->post_step);
    ck_assert(s->mops->post_step_local); /* sph declares it: the fused path is the one tested above */
    ej_method_ops unfused = *s->mops;
    unfused.post_step_local = false;
    s->mops = &unfused;
    vrun_run(&r);
    ck_assert_int_eq(r.sim->step, DET_STEPS);
    snap_take(&b, r.sim);
    eb = r.sim->energy;
    vrun_free(&r);
  }
  {
    snprintf(out, sizeof out, "%s/f3.h5", dir);
    ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 2};
    vrun r;
    vrun_open(&r, scene, &opts, DET_STEPS);
    vrun_run(&r);
    ea = r.sim->energy;
    vrun_free(&r);
  }
  snap_assert_equal(&a, &b, "fused vs separate end-of-step regions");
  ck_assert_msg(memcmp(&ea.kinetic, &eb.kinetic, sizeof ea.kinetic) == 0 &&
                    memcmp(&ea.internal, &eb.internal, sizeof ea.internal) == 0 &&
                    memcmp(&ea.balance, &eb.balance, sizeof ea.balance) == 0 &&
                    memcmp(ea.momentum, eb.momentum, sizeof ea.momentum) == 0,
                "energy budget differs: kinetic %.17g vs %.17g, balance %.17g vs %.17g", ea.kinetic, eb.kinetic,
                ea.balance, eb.balance);
  snap_free(&a);
  snap_free(&b);
  const char *names[] = {"tube.yaml", "f1.h5", "f1.xdmf", "f2.h5", "f2.xdmf", "f3.h5", "f3.xdmf"};
  vrun_cleanup(dir, names, 7);
}
END_TEST

START_TEST(test_restart_bitwise)
{
  char dir[64], half[128];
  det_scene(dir, sizeof dir);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  snap full, first, cont;
  det_run(dir, "full.h5", 2, DET_STEPS, NULL, &full);
  det_run(dir, "half.h5", 2, DET_STEPS / 2, NULL, &first);
  det_run(dir, "cont.h5", 2, DET_STEPS, half, &cont);
  ck_assert(first.t < full.t);
  snap_assert_equal(&full, &cont, "uninterrupted vs restarted");
  snap_free(&full);
  snap_free(&first);
  snap_free(&cont);
  const char *names[] = {"tube.yaml", "full.h5", "full.xdmf", "half.h5", "half.xdmf", "cont.h5", "cont.xdmf"};
  vrun_cleanup(dir, names, 7);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("determinism");
  TCase *tc = tcase_create("bitwise");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_threads_bitwise);
  tcase_add_test(tc, test_restart_bitwise);
  tcase_add_test(tc, test_fused_end_of_step);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
