/* Numerical-fault watchdog through the `ejecta` executable: a non-finite field, a particle
 * leaving the scene's `domain`, and the adaptive step falling below `time.dt_min` or below
 * `time.dt_min_ratio` times the first step. Each run
 * stops with exit 1 and one message naming the step, the set and the particle; no file is left
 * under the output's final name, and NAME.partial keeps the state at the failure (last frame
 * and a checkpoint at the failing step) that `--restart` reads. Runs use --threads 1, so the
 * failing step is reproducible and predicted from a clean run's /series/energy/dt. */
#include <check.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_tmpdir.h"

#define EJECTA EJ_TEST_BINARY_DIR "/bin/ejecta"

static char tmpdir[256];

static void make_tmpdir(void)
{
  ej_test_tmpdir(tmpdir, sizeof tmpdir, "watchdog");
}

static void cleanup(void)
{
  ej_test_rmtree(tmpdir);
}

static void write_scene(const char *name, const char *text)
{
  char path[512];
  snprintf(path, sizeof path, "%s/%s", tmpdir, name);
  FILE *f = fopen(path, "w");
  ck_assert_ptr_nonnull(f);
  fputs(text, f);
  fclose(f);
}

/* `ejecta ARGS` in tmpdir (threads 1, no progress); stderr into err; returns the exit code. */
static int run(const char *args, char *err, size_t errlen)
{
  char cmd[2048], errpath[512];
  snprintf(errpath, sizeof errpath, "%s/stderr.txt", tmpdir);
  snprintf(cmd, sizeof cmd, "cd %s && %s run %s --threads 1 --no-progress > stdout.txt 2> %s", tmpdir, EJECTA, args,
           errpath);
  int st = system(cmd);
  FILE *f = fopen(errpath, "r");
  size_t n = f ? fread(err, 1, errlen - 1, f) : 0;
  err[n] = 0;
  if (f) fclose(f);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int exists(const char *name)
{
  char path[600];
  snprintf(path, sizeof path, "%s/%s", tmpdir, name);
  struct stat st;
  return stat(path, &st) == 0;
}

/* The /checkpoint step attribute of tmpdir/name (-1 if unreadable) and its number of frames. */
static long long checkpoint_step(const char *name, long long *n_frames)
{
  char path[600];
  snprintf(path, sizeof path, "%s/%s", tmpdir, name);
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return -1;
  long long step = -1;
  hid_t cp = H5Gopen2(f, "/checkpoint", H5P_DEFAULT);
  if (cp >= 0) {
    hid_t a = H5Aopen(cp, "step", H5P_DEFAULT);
    int64_t s = -1;
    if (a >= 0 && H5Aread(a, H5T_NATIVE_INT64, &s) >= 0) step = s;
    if (a >= 0) H5Aclose(a);
    H5Gclose(cp);
  }
  hid_t fr = H5Gopen2(f, "/frames", H5P_DEFAULT);
  H5G_info_t info = {0};
  if (fr >= 0 && H5Gget_info(fr, &info) >= 0) *n_frames = (long long)info.nlinks;
  if (fr >= 0) H5Gclose(fr);
  H5Fclose(f);
  return step;
}

/* /series/energy/dt of a finished run: n values into dt (at most cap). */
static int read_dt(const char *name, double *dt, int cap)
{
  char path[600];
  snprintf(path, sizeof path, "%s/%s", tmpdir, name);
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_msg(f >= 0, "cannot open %s", path);
  hid_t d = H5Dopen2(f, "/series/energy/dt", H5P_DEFAULT);
  ck_assert(d >= 0);
  hid_t sp = H5Dget_space(d);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(sp, &n, NULL);
  ck_assert(n > 0 && n <= (hsize_t)cap);
  ck_assert(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, dt) >= 0);
  H5Sclose(sp);
  H5Dclose(d);
  H5Fclose(f);
  return (int)n;
}

#define GAS "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"

/* Checks shared by the three faults: exit 1, one error line naming step, set and particle, no
 * final file, and a .partial whose checkpoint is at the failing step. */
static void expect_failure(const char *scene, const char *out, const char *what, long long step)
{
  char args[600], err[8192], want[64], partial[300];
  snprintf(args, sizeof args, "%s", scene);
  int code = run(args, err, sizeof err);
  ck_assert_msg(code == 1, "exit %d: %s", code, err);
  snprintf(want, sizeof want, "at step %lld,", step);
  ck_assert_msg(strstr(err, "error: watchdog: ") && strstr(err, what) && strstr(err, want) &&
                    strstr(err, "set 'tube'") && strstr(err, "particle id "),
                "expected '%s' %s, set and particle in:\n%s", what, want, err);
  ck_assert_msg(!exists(out), "a failed run left %s under its final name", out);
  snprintf(partial, sizeof partial, "%s.partial", out);
  ck_assert_msg(exists(partial) && strstr(err, partial), "no %s announced:\n%s", partial, err);
  long long frames = 0;
  ck_assert_int_eq(checkpoint_step(partial, &frames), step);
  ck_assert(frames >= 2); /* the first frame and the one at the failure */
}

/* Gravity 1e308 m/s^2 with dt = 0.01 s: v = g t passes DBL_MAX at step ceil(DBL_MAX / (g dt)) =
 * 180 while x = g t^2 / 2 is still finite. */
START_TEST(test_non_finite_field)
{
  make_tmpdir();
  write_scene("nan.yaml", "ejecta: 1\ndimension: 1\ntime: {end: 3, dt: 0.01}\noutput: {file: nan.h5, every: 1}\n"
                          "gravity: [1e308]\n" GAS
                          "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [0.2]}}, "
                          "spacing: 0.01, p: 1}\n");
  const long long step = (long long)ceil(1.7976931348623157e308 / (1e308 * 0.01));
  expect_failure("nan.yaml", "nan.h5", "non-finite 'v'", step);
  /* The checkpoint at the failure is readable: the restart runs (and fails on the next step). */
  char err[8192];
  ck_assert_int_eq(run("nan.yaml --restart nan.h5.partial -o again.h5", err, sizeof err), 1);
  ck_assert_msg(!strstr(err, "cannot restart"), "%s", err);
  cleanup();
}
END_TEST

/* A gas column expanding into vacuum: its outermost particles leave the domain box. The failing
 * step is the first one whose frame has a particle outside (found with a clean run). */
START_TEST(test_leaves_domain)
{
  make_tmpdir();
  static const char head[] = "ejecta: 1\ndimension: 1\ntime: {end: 0.02, max_steps: %d}\n"
                             "output: {file: %s, every: 0}\n" GAS "%s"
                             "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [-0.5], max: [0.5]}}, "
                             "spacing: 0.01, p: 1e5}\n";
  char text[2048];
  snprintf(text, sizeof text, head, 400, "free.h5", "domain: {box: {min: [-0.55], max: [0.503]}}\n");
  write_scene("free.yaml", text);
  char err[8192];
  int code = run("free.yaml", err, sizeof err);
  ck_assert_msg(code == 1, "exit %d: %s", code, err);
  const char *at = strstr(err, "at step ");
  ck_assert_ptr_nonnull(at);
  long long step = atoll(at + 8);
  ck_assert_msg(step > 1, "%s", err); /* the domain holds the initial particles: a fault during the run */
  expect_failure("free.yaml", "free.h5", "left the domain", step);
  /* The reported position is outside the box, beyond its upper face. */
  const char *pos = strstr(err, "particle id ");
  ck_assert_ptr_nonnull(pos);
  pos = strstr(pos, " at (");
  ck_assert_ptr_nonnull(pos);
  ck_assert_msg(atof(pos + 5) > 0.503, "%s", err);
  /* One step fewer runs clean with the same domain: the fault is at the reported step, not before. */
  snprintf(text, sizeof text, head, (int)step - 1, "before.h5", "domain: {box: {min: [-0.55], max: [0.503]}}\n");
  write_scene("before.yaml", text);
  ck_assert_msg(run("before.yaml", err, sizeof err) == 0, "%s", err);
  /* Restart from the failure with a larger domain continues to the end. */
  snprintf(text, sizeof text, head, (int)step + 20, "wide.h5", "domain: {box: {min: [-2], max: [2]}}\n");
  write_scene("wide.yaml", text);
  ck_assert_msg(run("wide.yaml --restart free.h5.partial", err, sizeof err) == 0, "%s", err);
  ck_assert(exists("wide.h5"));
  cleanup();
}
END_TEST

/* Two gas streams colliding at 1000 m/s: the shock shrinks the step. A clean run gives the
 * step series; dt_min between the first step and the smallest one must stop the run at the
 * end of the step before the first one below it. */
START_TEST(test_dt_floor)
{
  make_tmpdir();
  static const char head[] = "ejecta: 1\ndimension: 1\ntime: {end: 0.05, max_steps: %d%s}\n"
                             "output: {file: %s, every: 0}\n" GAS
                             "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [-0.5], max: [0.5]}}, "
                             "spacing: 0.01, p: 1, velocity: [1000],\n"
                             "         initial: [{region: {box: {min: [0], max: [0.5]}}, velocity: [-1000]}]}\n"
                             "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n"
                             "  - symmetry: {point: [0.5], normal: [-1]}\n";
  char text[2048], err[8192], extra[64];
  snprintf(text, sizeof text, head, 1000, "", "clean.h5");
  write_scene("clean.yaml", text);
  ck_assert_msg(run("clean.yaml", err, sizeof err) == 0, "%s", err);
  static double dt[2048];
  int n = read_dt("clean.h5", dt, 2048);
  /* Row k of the series is the step taken at step k (row 0: the first step). */
  double lo = dt[0];
  for (int k = 1; k < n; ++k) lo = fmin(lo, dt[k]);
  ck_assert_msg(lo < 0.9 * dt[0], "the step does not shrink (%g to %g): the test needs a new scene", dt[0], lo);
  const double floor_dt = sqrt(dt[0] * lo);
  int first = -1;
  for (int k = 1; k < n && first < 0; ++k)
    if (dt[k] < floor_dt) first = k;
  ck_assert(first > 1);
  /* the clean run went through with the default dt_min_ratio 1e-4: its steps stay above it */
  ck_assert(lo > 1e-4 * dt[0]);
  snprintf(extra, sizeof extra, ", dt_min: %.17g", floor_dt);
  snprintf(text, sizeof text, head, 1000, extra, "floor.h5");
  write_scene("floor.yaml", text);
  /* The step for step `first` is computed at the end of step first - 1. */
  expect_failure("floor.yaml", "floor.h5", "below time.dt_min", first - 1);
  char want[64];
  snprintf(want, sizeof want, "time step %.6g s", dt[first]);
  run("floor.yaml", err, sizeof err);
  ck_assert_msg(strstr(err, want) && strstr(err, "its stable step"), "expected '%s' in:\n%s", want, err);
  /* The same floor as a ratio to the first step (time.dt_min_ratio) stops the same step. */
  const double ratio = floor_dt / dt[0];
  snprintf(extra, sizeof extra, ", dt_min_ratio: %.17g", ratio);
  snprintf(text, sizeof text, head, 1000, extra, "ratio.h5");
  write_scene("ratio.yaml", text);
  expect_failure("ratio.yaml", "ratio.h5", "below time.dt_min_ratio", first - 1);
  /* Restarting without the floor continues from the failing state. */
  snprintf(text, sizeof text, head, first + 10, "", "cont.h5");
  write_scene("cont.yaml", text);
  ck_assert_msg(run("cont.yaml --restart floor.h5.partial", err, sizeof err) == 0, "%s", err);
  cleanup();
}
END_TEST

/* Bad watchdog settings are input errors (exit 2) at the key. */
START_TEST(test_bad_settings)
{
  make_tmpdir();
  char err[8192];
  write_scene("a.yaml", "ejecta: 1\ndimension: 1\ntime: {end: 1, dt: 0.1, dt_min: 0.01}\n" GAS
                        "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n");
  ck_assert_int_eq(run("a.yaml", err, sizeof err), 2);
  ck_assert_msg(strstr(err, "a.yaml:3:25: error:") && strstr(err, "fixed dt"), "%s", err);
  write_scene("b.yaml", "ejecta: 1\ndimension: 1\ntime: {end: 1}\ndomain: {box: {min: [0]}}\n" GAS
                        "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n");
  ck_assert_int_eq(run("b.yaml", err, sizeof err), 2);
  ck_assert_msg(strstr(err, "b.yaml:4:"), "%s", err);
  /* a domain that does not hold the initial particles is bad input (exit 2 at the domain, nothing
   * written), not a watchdog stop at step 0 (exit 1, a .partial) as before 2026-12-02 */
  write_scene("c.yaml", "ejecta: 1\ndimension: 1\ntime: {end: 1}\noutput: {file: c.h5}\n"
                        "domain: {box: {min: [0.5], max: [3]}}\n" GAS
                        "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n");
  ck_assert_int_eq(run("c.yaml", err, sizeof err), 2);
  ck_assert_msg(strstr(err, "c.yaml:5:9: error:") && strstr(err, "outside the domain"), "%s", err);
  ck_assert(!exists("c.h5") && !exists("c.h5.partial"));
  cleanup();
}
END_TEST

int main(void)
{
  Suite *s = suite_create("watchdog");
  TCase *tc = tcase_create("watchdog");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_non_finite_field);
  tcase_add_test(tc, test_leaves_domain);
  tcase_add_test(tc, test_dt_floor);
  tcase_add_test(tc, test_bad_settings);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
