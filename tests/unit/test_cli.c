/* The ejecta executable on bad input: one line FILE:LINE:COL: error: ..., exit code 2, and no
 * output file left behind. Also the good paths of check/plugins/describe/schema, the
 * watchdog's exit code 1, and a run stopped by SIGINT (exit 130, state kept for --restart). */
#include <check.h>
#include <signal.h>
#include <stdbool.h>
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
  ej_test_tmpdir(tmpdir, sizeof tmpdir, "cli");
}

static void write_file(const char *path, const char *text)
{
  FILE *f = fopen(path, "w");
  ck_assert_ptr_nonnull(f);
  fputs(text, f);
  fclose(f);
}

/* The file at path into buf (NUL-terminated; empty when it cannot be read). */
static void slurp(const char *path, char *buf, size_t len)
{
  FILE *f = fopen(path, "r");
  size_t n = f ? fread(buf, 1, len - 1, f) : 0;
  buf[n] = 0;
  if (f) fclose(f);
}

/* Runs a command, captures stderr into err, returns the exit code. */
static int run(const char *args, char *err, size_t errlen)
{
  char cmd[2048], errpath[512];
  snprintf(errpath, sizeof errpath, "%s/stderr.txt", tmpdir);
  snprintf(cmd, sizeof cmd, "cd %s && %s %s > stdout.txt 2> %s", tmpdir, EJECTA, args, errpath);
  int st = system(cmd);
  FILE *f = fopen(errpath, "r");
  size_t n = f ? fread(err, 1, errlen - 1, f) : 0;
  err[n] = 0;
  if (f) fclose(f);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int count_lines(const char *s)
{
  int n = 0;
  for (; *s; ++s) n += *s == '\n';
  return n;
}

static bool exists(const char *path)
{
  struct stat st;
  return stat(path, &st) == 0;
}

#define GOOD_HEAD                                                                                                  \
  "ejecta: 1\n"                                                                                                    \
  "dimension: 1\n"                                                                                                 \
  "time: {end: 0.01 s}\n"                                                                                          \
  "output: {file: out/r.h5}\n"                                                                                     \
  "materials:\n"                                                                                                   \
  "  gas: {rho0: 1.0, eos: {model: ideal_gas, gamma: 1.4}}\n"

typedef struct bad_case {
  const char *name, *scene, *expect;
  int line, col;
} bad_case;

static const bad_case bad_cases[] = {
    {"malformed_yaml", GOOD_HEAD "sets:\n  tube: {method: sph, material: gas\n", "malformed YAML", 0, 0},
    {"unknown_key",
     GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacng: 0.1}\n",
     "did you mean 'spacing'", 8, 74},
    {"wrong_type",
     GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: abc}\n",
     "spacing", 8, 83},
    {"out_of_range", GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, "
                               "spacing: 0.1, alpha: -1}\n",
     "out of range", 8, 95},
    {"missing_required", "ejecta: 1\ndimension: 1\ntime: {cfl: 0.3}\n", "missing required key 'end'", 3, 7},
    {"unknown_plugin",
     GOOD_HEAD "sets:\n  tube: {method: sfh, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n",
     "did you mean 'sph'", 8, 18},
    {"wrong_unit_dimension",
     GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 4 GPa}\n",
     "length", 8, 83},
    {"no_particles",
     GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [0.01]}}, spacing: 1}\n",
     "no particles", 8, 3},
    {"undefined_material",
     GOOD_HEAD "sets:\n  tube: {method: sph, material: gsa, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n",
     "did you mean 'gas'", 8, 33},
    {"unwritable_output",
     "ejecta: 1\ndimension: 1\ntime: {end: 0.01 s}\noutput: {file: /proc/ejecta_forbidden/r.h5}\n"
     "materials:\n  gas: {rho0: 1.0, eos: {model: ideal_gas, gamma: 1.4}}\n"
     "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n",
     "cannot write output file", 4, 16},
};

START_TEST(test_bad_input)
{
  const bad_case *c = &bad_cases[_i];
  make_tmpdir();
  char scene[512], args[600], err[8192];
  snprintf(scene, sizeof scene, "%s/%s.yaml", tmpdir, c->name);
  write_file(scene, c->scene);
  snprintf(args, sizeof args, "run %s", scene);
  int code = run(args, err, sizeof err);
  ck_assert_msg(code == 2, "%s: exit code %d, stderr: %s", c->name, code, err);
  ck_assert_msg(count_lines(err) == 1, "%s: expected one line, got: %s", c->name, err);
  ck_assert_msg(strstr(err, c->expect), "%s: '%s' not in: %s", c->name, c->expect, err);
  ck_assert_msg(strstr(err, "error:"), "%s: no 'error:' in %s", c->name, err);
  char where[600];
  if (c->line) {
    snprintf(where, sizeof where, "%s:%d:%d: error:", scene, c->line, c->col);
    ck_assert_msg(strstr(err, where), "%s: expected location '%s' in: %s", c->name, where, err);
  } else {
    snprintf(where, sizeof where, "%s:", scene);
    ck_assert_msg(strstr(err, where), "%s: no file name in: %s", c->name, err);
  }
  char out[600];
  snprintf(out, sizeof out, "%s/out/r.h5", tmpdir);
  ck_assert_msg(!exists(out), "%s: output file written", c->name);
  snprintf(out, sizeof out, "%s/out/r.h5.partial", tmpdir);
  ck_assert_msg(!exists(out), "%s: partial output file left", c->name);
}
END_TEST

START_TEST(test_missing_scene_file)
{
  make_tmpdir();
  char err[4096];
  int code = run("run does_not_exist.yaml", err, sizeof err);
  ck_assert_int_eq(code, 2);
  ck_assert_int_eq(count_lines(err), 1);
  ck_assert_msg(strstr(err, "does_not_exist.yaml") && strstr(err, "No such file"), "%s", err);
}
END_TEST

START_TEST(test_check_and_run)
{
  make_tmpdir();
  char scene[512], args[600], err[8192];
  snprintf(scene, sizeof scene, "%s/good.yaml", tmpdir);
  write_file(scene, GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, "
                              "spacing: 0.01, p: 1}\n"
                              "probes:\n  - {name: g, set: tube, point: [0.5], fields: [p]}\n"
                              "  - {name: t, set: tube, point: [0.2], follow: true, fields: [v]}\n"
                              "boundaries:\n  - {region: {box: {min: [0.99], max: [2]}}, non_reflecting: {normal: [1], "
                              "cp: 1.18}}\n"
                              "  - {region: {box: {min: [-1], max: [0.01]}}, pressure: {normal: [-1], blast: {charge: "
                              "[-1], tnt: 1 kg, time: 10 s}}}\n");
  snprintf(args, sizeof args, "check %s", scene);
  ck_assert_int_eq(run(args, err, sizeof err), 0);
  {
    /* check says where each probe measures: the gauge's nearest particle, the tracer's particle */
    char path[600], buf[4096];
    snprintf(path, sizeof path, "%s/stdout.txt", tmpdir);
    slurp(path, buf, sizeof buf);
    ck_assert_msg(strstr(buf, "probe 'g': gauge in set 'tube' at (0.5, 0, 0) m, nearest particle 0.005 m away, 2 "
                              "columns") &&
                      strstr(buf, "probe 't': tracer of particle id 19 of set 'tube', at (0.195, 0, 0) m") &&
                      strstr(buf, "on set 'tube': 1 particles, boundary 1 (1D), rho c_p 1.18, rho c_s 0 kg/(m^2 s)") &&
                      strstr(buf, "pressure (line 14) on set 'tube': 1 particles, face 1 (1D); 1 kg TNT air burst: Z "
                                  "1.005-1.005 m/kg^(1/3), arrival 0.0005368-0.0005368 s after detonation"),
                  "%s", buf);
  }
  char out[600];
  snprintf(out, sizeof out, "%s/out/r.h5", tmpdir);
  ck_assert(!exists(out)); /* check writes nothing */
  snprintf(args, sizeof args, "run %s --threads 1", scene);
  ck_assert_msg(run(args, err, sizeof err) == 0, "%s", err);
  ck_assert(exists(out));
  snprintf(out, sizeof out, "%s/out/r.xdmf", tmpdir);
  ck_assert(exists(out));
}
END_TEST

/* A pressure region two particle layers thick: check warns (the load would act on both); and on a
 * fluid set, that the load is no piston. */
START_TEST(test_check_thick_face)
{
  make_tmpdir();
  char scene[512], args[600], err[8192];
  snprintf(scene, sizeof scene, "%s/thick.yaml", tmpdir);
  write_file(scene, "ejecta: 1\ndimension: 2\ntime: {end: 0.01 s}\n"
                    "materials:\n  gas: {rho0: 1.0, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n  box: {method: sph, material: gas, shape: {box: {min: [0, 0], max: [1, 1]}}, spacing: 0.1, "
                    "p: 1}\n"
                    "boundaries:\n  - {region: {box: {min: [0, 0.8], max: [1, 1]}}, pressure: {normal: [0, 1], value: 1}}\n"
                    "  - {region: {box: {min: [0, 0], max: [1, 0.1]}}, pressure: {normal: [0, -1], value: 1}}\n");
  snprintf(args, sizeof args, "check %s", scene);
  ck_assert_int_eq(run(args, err, sizeof err), 0);
  char path[600], buf[4096];
  snprintf(path, sizeof path, "%s/stdout.txt", tmpdir);
  slurp(path, buf, sizeof buf);
  ck_assert_msg(strstr(buf, "warning: pressure (line 9) on set 'box': 10 particles of its region lie under another one "
                            "of it") != NULL,
                "%s", buf);
  ck_assert_msg(strstr(buf, "(line 10) on set 'box': 10 particles of its region") == NULL, "%s", buf); /* one layer */
  /* a gas: the load is no piston */
  ck_assert_msg(strstr(buf, "warning: pressure (line 10) on set 'box': material 'gas' has no strength model") != NULL,
                "%s", buf);
}
END_TEST

START_TEST(test_failed_run_exit_1)
{
  make_tmpdir();
  char scene[512], args[600], err[8192];
  snprintf(scene, sizeof scene, "%s/nan.yaml", tmpdir);
  /* An absurd energy jump makes the stable step vanish: a run that fails, not bad input. */
  write_file(scene, GOOD_HEAD "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, "
                              "spacing: 0.01, e: 1.0e300, initial: [{region: {box: {min: [0], max: [0.5]}}, "
                              "e: 1.0e-300}]}\n");
  snprintf(args, sizeof args, "run %s", scene);
  int code = run(args, err, sizeof err);
  ck_assert_msg(code == 1, "exit %d: %s", code, err);
  ck_assert_msg(strstr(err, "error:"), "%s", err);
  char out[600];
  snprintf(out, sizeof out, "%s/out/r.h5", tmpdir);
  ck_assert(!exists(out)); /* a failed run never leaves a file that looks whole */
}
END_TEST

START_TEST(test_info_commands)
{
  make_tmpdir();
  char err[8192];
  ck_assert_int_eq(run("plugins", err, sizeof err), 0);
  ck_assert_int_eq(run("describe sph", err, sizeof err), 0);
  char path[600], buf[65536];
  snprintf(path, sizeof path, "%s/stdout.txt", tmpdir);
  FILE *f = fopen(path, "r");
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  buf[n] = 0;
  fclose(f);
  ck_assert_msg(strstr(buf, "alpha") && strstr(buf, "kernel") && strstr(buf, "rho"), "%s", buf);
  ck_assert_int_eq(run("describe scene", err, sizeof err), 0); /* the core's keys, from their tables */
  f = fopen(path, "r");
  n = fread(buf, 1, sizeof buf - 1, f);
  buf[n] = 0;
  fclose(f);
  ck_assert_msg(strstr(buf, "dt_min_ratio") && strstr(buf, "skin") && strstr(buf, "set_series") &&
                    strstr(buf, "probes[]") && strstr(buf, "follow") && strstr(buf, "jitter_volume") &&
                    strstr(buf, "energy_total") && strstr(buf, "periodic"),
                "%s", buf);
  ck_assert_int_eq(run("describe sfh", err, sizeof err), 2);
  ck_assert_msg(strstr(err, "did you mean 'sph'"), "%s", err);
  ck_assert_int_eq(run("schema -o s.json", err, sizeof err), 0);
  ck_assert_int_eq(run("frobnicate", err, sizeof err), 2);
  ck_assert_int_eq(run("run", err, sizeof err), 2);
}
END_TEST

/* Reads a whole small file into buf (empty if missing). */
/* SIGINT during a run: the run stops after the step in progress with exit code 130, leaves a
 * last frame and a checkpoint in NAME.partial (no file under the final name, no XDMF sidecar),
 * and `--restart NAME.partial` continues it to the same state as an uninterrupted run (the same
 * step count and, to the printed digits, the same energy balance). */
START_TEST(test_sigint_keeps_state)
{
  make_tmpdir();
  char scene[512], path[600], partial[600], xdmf[600], err[8192], out1[8192];
  snprintf(scene, sizeof scene, "%s/long.yaml", tmpdir);
  /* far longer than the test waits: it can only end by the signal */
  write_file(scene, "ejecta: 1\ndimension: 1\ntime: {end: 100 s}\noutput: {file: out/r.h5, every: 1 s}\n"
                    "materials:\n  gas: {rho0: 1.0, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n  tube: {method: sph, material: gas, shape: {box: {min: [0], max: [1]}}, "
                    "spacing: 0.001, p: 1}\n");
  snprintf(path, sizeof path, "%s/out/r.h5", tmpdir);
  snprintf(partial, sizeof partial, "%s/out/r.h5.partial", tmpdir);
  snprintf(xdmf, sizeof xdmf, "%s/out/r.xdmf", tmpdir);
  char errpath[600];
  snprintf(errpath, sizeof errpath, "%s/stderr_sig.txt", tmpdir);
  pid_t pid = fork();
  ck_assert_int_ge(pid, 0);
  if (pid == 0) {
    /* a child of a background job may inherit SIGINT ignored: the CLI keeps an ignored SIGINT */
    signal(SIGINT, SIG_DFL);
    if (chdir(tmpdir) != 0 || !freopen(errpath, "w", stderr) || !freopen("/dev/null", "w", stdout)) _exit(99);
    execl(EJECTA, EJECTA, "run", scene, "--threads", "1", "--no-progress", (char *)NULL);
    _exit(98);
  }
  /* the output is created after the handlers are installed: from then on SIGINT means "stop" */
  for (int k = 0; k < 6000 && !exists(partial); ++k) usleep(10000);
  ck_assert_msg(exists(partial), "no %s after 60 s", partial);
  usleep(100000);
  ck_assert_int_eq(kill(pid, SIGINT), 0);
  int st = 0;
  ck_assert_int_eq(waitpid(pid, &st, 0), pid);
  slurp(errpath, err, sizeof err);
  ck_assert_msg(WIFEXITED(st) && WEXITSTATUS(st) == 130, "status %d: %s", st, err);
  ck_assert_msg(strstr(err, "stopped by SIGINT") && strstr(err, "--restart"), "%s", err);
  ck_assert(exists(partial));
  ck_assert(!exists(path)); /* only a complete run takes the final name */
  ck_assert(!exists(xdmf));
  /* the stop time, from "stopped by SIGINT at step N, t = T s" */
  const char *at = strstr(err, ", t = ");
  ck_assert_ptr_nonnull(at);
  const double t_stop = strtod(at + 6, NULL);
  ck_assert_msg(t_stop > 0.0 && t_stop < 100.0, "%s", err);
  /* continue a little beyond the stop, and compare with an uninterrupted run to the same time */
  char args[1400], end[64];
  snprintf(end, sizeof end, "%.17g", 1.5 * t_stop + 1e-3);
  snprintf(args, sizeof args, "run %s --threads 1 --restart out/r.h5.partial --end %s", scene, end);
  ck_assert_msg(run(args, err, sizeof err) == 0, "%s", err);
  ck_assert(exists(path));
  char sout[600];
  snprintf(sout, sizeof sout, "%s/stdout.txt", tmpdir);
  slurp(sout, out1, sizeof out1);
  snprintf(args, sizeof args, "run %s --threads 1 --end %s -o out/fresh.h5", scene, end);
  ck_assert_msg(run(args, err, sizeof err) == 0, "%s", err);
  char out2[8192];
  slurp(sout, out2, sizeof out2);
  const char *s1 = strstr(out1, " steps"), *s2 = strstr(out2, " steps");
  const char *b1 = strstr(out1, "energy balance"), *b2 = strstr(out2, "energy balance");
  ck_assert_msg(s1 && s2 && b1 && b2, "%s\n%s", out1, out2);
  /* "(N steps": the step counts of the two runs */
  const char *n1 = s1, *n2 = s2;
  while (n1 > out1 && n1[-1] != '(') --n1;
  while (n2 > out2 && n2[-1] != '(') --n2;
  ck_assert_msg(strtol(n1, NULL, 10) == strtol(n2, NULL, 10), "%s\n%s", out1, out2);
  ck_assert_msg(!strcmp(b1, b2), "restarted: %s\nuninterrupted: %s", b1, b2);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("cli");
  TCase *tc = tcase_create("bad input");
  tcase_set_timeout(tc, 120);
  tcase_add_loop_test(tc, test_bad_input, 0, (int)(sizeof bad_cases / sizeof bad_cases[0]));
  tcase_add_test(tc, test_missing_scene_file);
  tcase_add_test(tc, test_check_and_run);
  tcase_add_test(tc, test_check_thick_face);
  tcase_add_test(tc, test_failed_run_exit_1);
  tcase_add_test(tc, test_info_commands);
  tcase_add_test(tc, test_sigint_keeps_state);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
