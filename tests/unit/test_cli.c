/* The ejecta executable on bad input: one line FILE:LINE:COL: error: ..., exit code 2, and no
 * output file left behind. Also the good paths of check/plugins/describe/schema, and the
 * watchdog's exit code 1. */
#include <check.h>
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
                              "spacing: 0.01, p: 1}\n");
  snprintf(args, sizeof args, "check %s", scene);
  ck_assert_int_eq(run(args, err, sizeof err), 0);
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
  ck_assert_int_eq(run("describe sfh", err, sizeof err), 2);
  ck_assert_msg(strstr(err, "did you mean 'sph'"), "%s", err);
  ck_assert_int_eq(run("schema -o s.json", err, sizeof err), 0);
  ck_assert_int_eq(run("frobnicate", err, sizeof err), 2);
  ck_assert_int_eq(run("run", err, sizeof err), 2);
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
  tcase_add_test(tc, test_failed_run_exit_1);
  tcase_add_test(tc, test_info_commands);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
