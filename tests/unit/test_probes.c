/* Probes (scene `probes:`, core/src/sim.c "Probes", docs/core.md "Probes"): a gauge fixed in space
 * reads the Shepard average of its set's fields, recomputed here from the final particle state; a
 * constant field comes out exactly; a point no particle covers reads NaN with count 0; a tracer
 * follows the particle nearest to its point at t = 0 through the re-sorts of the rebuilds; the
 * columns do not depend on the thread count and a restart continues them bitwise; a field the set
 * does not have is an input error at its line and column. */
#include "validation_common.h"

/* A jittered gas block (cell volumes: every particle has the same mass) with a hot corner, so that
 * the gas moves, the lists are rebuilt and the particles re-sorted within the run. */
static const char probe_scene[] =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1, cfl: 0.3, max_steps: 30}\n"
    "output: {file: out.h5, fields: [v, rho, p]}\n"
    "materials:\n"
    "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  gas:\n"
    "    method: sph\n"
    "    material: gas\n"
    "    shape: {box: {min: [0, 0, 0], max: [0.6, 0.6, 0.6]}}\n"
    "    spacing: 0.05\n"
    "    jitter: 0.3\n"
    "    rho: 1\n"
    "    p: 1\n"
    "    initial: [{region: {sphere: {center: [0, 0, 0], radius: 0.2}}, p: 100}]\n"
    "probes:\n"
    "  - {name: g, set: gas, point: [0.31, 0.27, 0.29], fields: [p, rho, v, m]}\n"
    "  - {name: far, set: gas, point: [5, 5, 5], fields: [p]}\n"
    "  - {name: t, set: gas, point: [0.1, 0.1, 0.1], follow: true, fields: [v, id]}\n"
    "  - {name: r, set: gas, point: [0.3, 0.3, 0.3], radius: 0.12, fields: [rho]}\n";

/* The value the series holds for "probe/<name>/<col>" after the last step. */
static double series(const ej_sim *sim, const char *name)
{
  for (int k = 0; k < sim->reports.n; ++k)
    if (!strcmp(sim->reports.names[k], name)) return sim->reports.values[k];
  ck_abort_msg("no series '%s'", name);
  return 0;
}

static double spline(double q) { return q < 1 ? 1 - 1.5 * q * q + 0.75 * q * q * q : q < 2 ? 0.25 * pow(2 - q, 3) : 0; }

/* The Shepard average of field f (component c) at p, from the set's final fields. */
static double shepard(const ej_set *s, const double p[3], double radius, const char *f, int c, int ncomp, int *count)
{
  const ej_real *x = ej_set_field(s, "x"), *m = ej_set_field(s, "m"), *rho = ej_set_field(s, "rho");
  const ej_real *v = ej_set_field(s, f);
  double ws = 0, fs = 0;
  *count = 0;
  for (ej_idx j = 0; j < ej_set_count(s); ++j) {
    const double dx = x[3 * j] - p[0], dy = x[3 * j + 1] - p[1], dz = x[3 * j + 2] - p[2];
    const double r = sqrt(dx * dx + dy * dy + dz * dz), R = radius > 0 ? radius : s->radius[j];
    if (!(r < R)) continue;
    const double h = 0.5 * R, w = m[j] / rho[j] * spline(r / h) / (h * h * h);
    if (!(w > 0)) continue;
    ws += w, fs += w * v[(size_t)ncomp * j + (size_t)c];
    ++*count;
  }
  return fs / ws;
}

static void open_run(vrun *r, const char *dir, const char *scene, const char *out, int threads, const char *restart)
{
  char path[160];
  snprintf(path, sizeof path, "%s/%s", dir, out);
  ej_run_opts o = {.struct_size = sizeof o, .output = path, .threads = threads, .restart = restart};
  vrun_open(r, scene, &o, -1);
}

START_TEST(test_gauge_and_tracer)
{
  char dir[64], scene[128];
  vrun_dir(dir, sizeof dir, "probes");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  vrun_write(scene, probe_scene);
  vrun r;
  open_run(&r, dir, scene, "a.h5", 1, NULL);
  const ej_set *s = r.sim->sets[0];
  /* the tracer's particle: the one nearest to its point in the generated (unsorted) set */
  const ej_real *x0 = ej_set_field(s, "x");
  const int32_t *id0 = ej_set_field_int((ej_set *)s, "id");
  double best = INFINITY;
  int32_t want = -1;
  for (ej_idx j = 0; j < ej_set_count(s); ++j) {
    const double d2 = pow(x0[3 * j] - 0.1, 2) + pow(x0[3 * j + 1] - 0.1, 2) + pow(x0[3 * j + 2] - 0.1, 2);
    if (d2 < best) best = d2, want = id0[j];
  }
  ck_assert(best < 0.05 * 0.05); /* within a spacing of its point */
  ck_assert_int_eq(r.sim->n_probes, 4);
  ck_assert_int_eq(r.sim->probes[2].id, want);
  vrun_run(&r);
  ck_assert_int_eq((int)r.sim->step, 30);
  ck_assert_int_ge((int)r.sim->n_rebuilds, 3); /* the particles were re-sorted within the run */

  /* gauge: the Shepard average of the final state */
  const double pg[3] = {0.31, 0.27, 0.29};
  int count = 0;
  const double p = shepard(s, pg, 0, "p", 0, 1, &count);
  ck_assert_int_gt(count, 20);
  ck_assert_double_eq(series(r.sim, "probe/g/count"), count);
  ck_assert_double_eq_tol(series(r.sim, "probe/g/p"), p, 1e-13 * fabs(p));
  const double rho = shepard(s, pg, 0, "rho", 0, 1, &count);
  ck_assert_double_eq_tol(series(r.sim, "probe/g/rho"), rho, 1e-13 * rho);
  const char *vc[3] = {"probe/g/v_x", "probe/g/v_y", "probe/g/v_z"};
  for (int c = 0; c < 3; ++c) {
    const double v = shepard(s, pg, 0, "v", c, 3, &count);
    ck_assert_double_eq_tol(series(r.sim, vc[c]), v, 1e-13 * (fabs(v) + 1e-3));
  }
  ck_assert(fabs(series(r.sim, "probe/g/v_x")) > 1e-3); /* the gas moves at the gauge */
  /* a constant field (every particle has the same mass) is reproduced to round-off */
  const ej_real *m = ej_set_field(s, "m");
  ck_assert_double_eq_tol(series(r.sim, "probe/g/m"), m[0], 1e-14 * m[0]);
  /* the probe's own radius */
  const double pr[3] = {0.3, 0.3, 0.3};
  const double rr = shepard(s, pr, 0.12, "rho", 0, 1, &count);
  ck_assert_double_eq(series(r.sim, "probe/r/count"), count);
  ck_assert_double_eq_tol(series(r.sim, "probe/r/rho"), rr, 1e-13 * rr);
  /* no material at the point */
  ck_assert_double_eq(series(r.sim, "probe/far/count"), 0);
  ck_assert(isnan(series(r.sim, "probe/far/p")));

  /* tracer: the position and velocity of its particle, wherever the sorts put it */
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  const int32_t *id = ej_set_field_int((ej_set *)s, "id");
  ej_idx at = 0;
  while (at < ej_set_count(s) && id[at] != want) ++at;
  ck_assert_int_lt(at, ej_set_count(s));
  ck_assert_double_eq(series(r.sim, "probe/t/id"), want);
  ck_assert_double_eq(series(r.sim, "probe/t/x"), x[3 * at]);
  ck_assert_double_eq(series(r.sim, "probe/t/z"), x[3 * at + 2]);
  ck_assert_double_eq(series(r.sim, "probe/t/v_y"), v[3 * at + 1]);
  ck_assert(fabs(v[3 * at]) > 1e-3); /* it moves */
  vrun_free(&r);
}
END_TEST

/* The last series row of two runs: the same columns, bitwise the same values. */
static void same_row(const ej_sim *a, const ej_sim *b, const char *what)
{
  ck_assert_int_eq(a->reports.n, b->reports.n);
  for (int k = 0; k < a->reports.n; ++k) {
    ck_assert_str_eq(a->reports.names[k], b->reports.names[k]);
    const double va = a->reports.values[k], vb = b->reports.values[k];
    ck_assert_msg(!memcmp(&va, &vb, sizeof va), "%s: %.17g vs %.17g%s", a->reports.names[k], va, vb, what);
  }
}

/* 1 and 2 threads: the same columns bitwise; a restart from step 15 ends on the same row as the
 * uninterrupted run. */
START_TEST(test_threads_and_restart)
{
  char dir[64], scene[128], half[128], cp[160];
  vrun_dir(dir, sizeof dir, "probes_rs");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(half, sizeof half, "%s/h.yaml", dir);
  vrun_write(scene, probe_scene);
  char text[sizeof probe_scene + 8];
  snprintf(text, sizeof text, "%s", probe_scene);
  char *ms = strstr(text, "max_steps: 30");
  ck_assert_ptr_nonnull(ms);
  memcpy(ms, "max_steps: 15", 13);
  vrun_write(half, text);
  vrun a, b, c, d;
  open_run(&a, dir, scene, "a.h5", 1, NULL);
  vrun_run(&a);
  open_run(&b, dir, scene, "b.h5", 2, NULL);
  vrun_run(&b);
  ck_assert_int_ge(a.sim->reports.n, 16);
  same_row(a.sim, b.sim, "");
  open_run(&c, dir, half, "c.h5", 1, NULL);
  vrun_run(&c);
  ck_assert_int_eq((int)c.sim->step, 15);
  snprintf(cp, sizeof cp, "%s/c.h5", dir);
  open_run(&d, dir, scene, "d.h5", 1, cp);
  vrun_run(&d);
  ck_assert_int_eq((int)d.sim->step, 30);
  same_row(a.sim, d.sim, " after the restart");
  vrun_free(&a);
  vrun_free(&b);
  vrun_free(&c);
  vrun_free(&d);
}
END_TEST

/* A gauge on a symmetry plane averages both sides (the set's mirror images, from the owned state):
 * the half model's gauge reads the full model's, and the velocity normal to the plane is 0. */
static const char mirror_scene[] =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1, cfl: 0.3, max_steps: 10}\n"
    "output: {file: out.h5, fields: [v]}\n"
    "materials:\n"
    "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  gas:\n"
    "    {method: sph, material: gas, shape: {box: {min: [%s, 0, 0], max: [0.3, 0.3, 0.3]}}, spacing: 0.05, p: 1, "
    "initial: [{region: {sphere: {center: [0, 0, 0], radius: 0.15}}, p: 100}]}\n"
    "%s"
    "probes:\n"
    "  - {name: g, set: gas, point: [0, 0.12, 0.13], fields: [p, v]}\n";

START_TEST(test_gauge_on_symmetry_plane)
{
  char dir[64], full[128], half[128], text[2048];
  vrun_dir(dir, sizeof dir, "probes_mirror");
  snprintf(full, sizeof full, "%s/full.yaml", dir);
  snprintf(half, sizeof half, "%s/half.yaml", dir);
  snprintf(text, sizeof text, mirror_scene, "-0.3", "");
  vrun_write(full, text);
  snprintf(text, sizeof text, mirror_scene, "0",
           "boundaries:\n  - {symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}}\n");
  vrun_write(half, text);
  vrun a, b;
  open_run(&a, dir, full, "full.h5", 1, NULL);
  vrun_run(&a);
  open_run(&b, dir, half, "half.h5", 1, NULL);
  vrun_run(&b);
  ck_assert_int_gt(b.sim->sets[0]->n_ghost, 0);
  const double vmax = fabs(series(a.sim, "probe/g/v_y")) + fabs(series(a.sim, "probe/g/v_z"));
  ck_assert(vmax > 1e-3);
  ck_assert_double_eq(series(b.sim, "probe/g/count"), series(a.sim, "probe/g/count"));
  ck_assert_double_eq_tol(series(b.sim, "probe/g/v_x"), 0, 1e-13 * vmax);
  ck_assert_double_eq_tol(series(a.sim, "probe/g/v_x"), 0, 1e-13 * vmax); /* the full model is symmetric */
  const char *cols[3] = {"probe/g/p", "probe/g/v_y", "probe/g/v_z"};
  for (int k = 0; k < 3; ++k) {
    const double fa = series(a.sim, cols[k]), fb = series(b.sim, cols[k]);
    ck_assert_msg(fabs(fa - fb) <= 1e-10 * fabs(fa), "%s: full %.15g, half %.15g", cols[k], fa, fb);
  }
  vrun_free(&a);
  vrun_free(&b);
}
END_TEST

/* output.set_series: each set's energy and momentum (LS-DYNA's MATSUM) add up to the run's, and its
 * kinetic energy and momentum are those of its particles. */
START_TEST(test_set_series)
{
  char dir[64], scene[128];
  vrun_dir(dir, sizeof dir, "set_series");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  vrun_write(scene, "ejecta: 1\n"
                    "dimension: 3\n"
                    "time: {end: 1, cfl: 0.3, max_steps: 10}\n"
                    "output: {file: out.h5, set_series: true}\n"
                    "materials:\n"
                    "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n"
                    "  hot:\n"
                    "    {method: sph, material: gas, shape: {box: {min: [0, 0, 0], max: [0.3, 0.3, 0.3]}}, spacing: 0.05, "
                    "p: 10, velocity: [1, 0, 0]}\n"
                    "  cold:\n"
                    "    {method: sph, material: gas, shape: {box: {min: [0.5, 0, 0], max: [0.8, 0.3, 0.3]}}, spacing: "
                    "0.05, p: 1}\n");
  vrun r;
  open_run(&r, dir, scene, "a.h5", 2, NULL);
  vrun_run(&r);
  const ej_energy *E = &r.sim->energy;
  const double kin = series(r.sim, "set/hot/kinetic") + series(r.sim, "set/cold/kinetic");
  const double in = series(r.sim, "set/hot/internal") + series(r.sim, "set/cold/internal");
  const double px = series(r.sim, "set/hot/momentum_x") + series(r.sim, "set/cold/momentum_x");
  const double visc = series(r.sim, "set/hot/viscous") + series(r.sim, "set/cold/viscous");
  ck_assert_double_eq_tol(kin, E->kinetic, 1e-13 * E->kinetic);
  ck_assert_double_eq_tol(in, E->internal, 1e-13 * E->internal);
  ck_assert_double_eq_tol(px, E->momentum[0], 1e-13 * fabs(E->momentum[0]));
  ck_assert(fabs(E->momentum[0]) > 0.02); /* the hot block (0.027 kg) moves at 1 m/s */
  ck_assert_double_eq_tol(visc, E->viscous, 1e-13 * fabs(E->viscous) + 1e-300);
  for (int i = 0; i < 2; ++i) {
    const ej_set *s = r.sim->sets[i];
    const ej_real *m = ej_set_field(s, "m"), *v = ej_set_field(s, "v");
    double k = 0, p = 0, pa = 0;
    for (ej_idx j = 0; j < ej_set_count(s); ++j) {
      k += 0.5 * m[j] * (v[3 * j] * v[3 * j] + v[3 * j + 1] * v[3 * j + 1] + v[3 * j + 2] * v[3 * j + 2]);
      p += m[j] * v[3 * j], pa += m[j] * fabs(v[3 * j]);
    }
    char name[64];
    snprintf(name, sizeof name, "set/%s/kinetic", s->name);
    ck_assert_double_eq_tol(series(r.sim, name), k, 1e-13 * k);
    snprintf(name, sizeof name, "set/%s/momentum_x", s->name);
    ck_assert_double_eq_tol(series(r.sim, name), p, 1e-13 * pa);
  }
  ck_assert(series(r.sim, "set/cold/kinetic") > 0); /* its free surfaces expand */
  vrun_free(&r);
}
END_TEST

/* A field the set does not have: an input error at the field, found when the sets exist (so
 * `ejecta check` reports it too). */
START_TEST(test_unknown_field)
{
  char text[sizeof probe_scene + 64];
  snprintf(text, sizeof text, "%s  - {set: gas, point: [0, 0, 0], fields: [rho, pres]}\n", probe_scene);
  vrun_refuses_text("probes_bad", text, "probe 'probe4': set 'gas' has no field 'pres' ('ejecta describe sph' lists",
                    22, 48);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("probes");
  TCase *tc = tcase_create("probes");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_gauge_and_tracer);
  tcase_add_test(tc, test_threads_and_restart);
  tcase_add_test(tc, test_gauge_on_symmetry_plane);
  tcase_add_test(tc, test_set_series);
  tcase_add_test(tc, test_unknown_field);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
