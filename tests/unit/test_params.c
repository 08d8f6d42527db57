/* Parameter tables: defaults, every type, each validation error class with its location,
 * check_config through ej_diag_error, describe and JSON Schema output. */
#define _POSIX_C_SOURCE 200809L
#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct fail_cfg {
  ej_real stretch;
  int64_t min_bonds;
} fail_cfg;

typedef struct test_cfg {
  ej_real gamma;
  ej_real cfl;
  ej_real angle;
  ej_real rho;
  int64_t steps;
  bool verbose;
  int kernel;
  const char *label;
  ej_real point[3];
  fail_cfg failure;
} test_cfg;

static const char *const kernels[] = {"cubic", "quintic", "wendland", NULL};

static const ej_param fail_params[] = {
    EJ_PARAM_REAL(fail_cfg, stretch, "1", 0.05, 0, 1, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Critical stretch."),
    EJ_PARAM_INT(fail_cfg, min_bonds, 2, 0, 0, EJ_PF_HAS_MIN, "Bonds a particle keeps."),
    {0}};

static const ej_param test_params[] = {
    EJ_PARAM_REAL(test_cfg, gamma, "1", 0, 1, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN, "Adiabatic exponent."),
    EJ_PARAM_REAL(test_cfg, cfl, "1", 0.3, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN, "Courant number."),
    EJ_PARAM_REAL(test_cfg, angle, "deg", 30, 0, 90, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX, "Friction angle."),
    EJ_PARAM_REAL(test_cfg, rho, "kg/m^3", 1000, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Density \"rho\"."),
    EJ_PARAM_INT(test_cfg, steps, 10, 1, 100, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX, "Number of steps."),
    EJ_PARAM_BOOL(test_cfg, verbose, 1, "Print more."),
    EJ_PARAM_ENUM(test_cfg, kernel, kernels, "quintic", "Smoothing kernel."),
    EJ_PARAM_STRING(test_cfg, label, "none", 0, "A label."),
    EJ_PARAM_ARRAY(test_cfg, point, 3, "m", 0, "A point."),
    EJ_PARAM_BLOCK(test_cfg, failure, fail_params, fail_cfg, 0, "Bond failure."),
    {0}};

static const char *const skip[] = {"model", NULL};

/* Applies text's root map to cfg; returns the code and keeps the error for the caller. */
static ej_err apply(const char *text, test_cfg *cfg, ej_config_check_fn check, ej_doc **doc)
{
  ck_assert_int_eq(ej_doc_parse_string("p.yaml", text, doc), EJ_OK);
  memset(cfg, 0, sizeof *cfg);
  return ej_params_apply(test_params, cfg, (*doc)->root, "eos 'gas'", skip, check);
}

static void expect_error(const char *text, int line, int col, const char *want)
{
  test_cfg cfg;
  ej_doc *doc = NULL;
  ck_assert_int_eq(apply(text, &cfg, NULL, &doc), EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_msg(strstr(f->msg, want), "message '%s' lacks '%s'", f->msg, want);
  ck_assert_msg(f->where.line == line && f->where.col == col, "'%s' at %d:%d, expected %d:%d", f->msg,
                f->where.line, f->where.col, line, col);
  ck_assert_str_eq(f->where.file, "p.yaml");
  ej_error_clear();
  ej_doc_destroy(doc);
}

START_TEST(test_defaults)
{
  test_cfg cfg;
  memset(&cfg, 0xff, sizeof cfg);
  ck_assert_int_eq(ej_params_defaults(test_params, &cfg), EJ_OK);
  ck_assert(cfg.cfl == 0.3);
  ck_assert(fabs(cfg.angle - M_PI / 6) < 1e-15);
  ck_assert(cfg.rho == 1000);
  ck_assert_int_eq(cfg.steps, 10);
  ck_assert(cfg.verbose);
  ck_assert_int_eq(cfg.kernel, 1);
  ck_assert_str_eq(cfg.label, "none");
  ck_assert(cfg.point[0] == 0 && cfg.point[1] == 0 && cfg.point[2] == 0);
  ck_assert(cfg.failure.stretch == 0.05);
  ck_assert_int_eq(cfg.failure.min_bonds, 2);
}
END_TEST

START_TEST(test_apply_all_types)
{
  test_cfg cfg;
  ej_doc *doc = NULL;
  ck_assert_int_eq(apply("model: ideal_gas\ngamma: 1.4\ncfl: 1\nangle: 0.5 rad\nrho: 1.6 g/cm^3\nsteps: 42\n"
                         "verbose: off\nkernel: wendland\nlabel: 'hello world'\npoint: [1 mm, 2, -3 cm]\n"
                         "failure: {stretch: 0.1}\n",
                         &cfg, NULL, &doc),
                   EJ_OK);
  ck_assert(cfg.gamma == 1.4);
  ck_assert(cfg.cfl == 1);
  ck_assert(cfg.angle == 0.5);
  ck_assert(fabs(cfg.rho - 1600) < 1e-9);
  ck_assert_int_eq(cfg.steps, 42);
  ck_assert(!cfg.verbose);
  ck_assert_int_eq(cfg.kernel, 2);
  ck_assert_str_eq(cfg.label, "hello world");
  ck_assert(fabs(cfg.point[0] - 1e-3) < 1e-18 && cfg.point[1] == 2 && fabs(cfg.point[2] + 0.03) < 1e-16);
  ck_assert(cfg.failure.stretch == 0.1);
  ck_assert_int_eq(cfg.failure.min_bonds, 2);
  ej_doc_destroy(doc);

  /* bounds are inclusive where declared so: 90 deg and 0 deg pass */
  ck_assert_int_eq(apply("gamma: 1\nangle: 90 deg\nsteps: 100\n", &cfg, NULL, &doc), EJ_OK);
  ck_assert(fabs(cfg.angle - M_PI / 2) < 1e-15);
  ej_doc_destroy(doc);
  ck_assert_int_eq(apply("gamma: 1\nangle: 0\nsteps: 1\n", &cfg, NULL, &doc), EJ_OK);
  ej_doc_destroy(doc);
}
END_TEST

START_TEST(test_unknown_key)
{
  expect_error("gamma: 1.4\n  \ncfll: 0.3\n", 3, 1, "unknown key 'cfll' in eos 'gas'; did you mean 'cfl'?");
  expect_error("gamma: 1.4\nmodle: x\n", 2, 1, "did you mean 'model'?");
  expect_error("gamma: 1.4\nzzzzzzzz: 1\n", 2, 1, "unknown key 'zzzzzzzz' in eos 'gas' (valid keys: gamma, cfl,");
  expect_error("gamma: 1.4\nfailure: {stretch: 0.1, strech: 1}\n", 2, 25,
               "unknown key 'strech' in eos 'gas'.failure; did you mean 'stretch'?");
}
END_TEST

START_TEST(test_wrong_type)
{
  expect_error("gamma: {a: 1}\n", 1, 8, "'gamma' in eos 'gas' must be a number, got a mapping");
  expect_error("gamma: '1.4'\n", 1, 8, "'gamma' in eos 'gas' must be a number, got a quoted string \"1.4\"");
  expect_error("gamma: 1.4\nrho: [1]\n", 2, 6, "'rho' in eos 'gas' must be a number (kg/m^3), got a list");
  expect_error("gamma: 1.4\nrho: 4 m\n", 2, 6,
               "'rho' in eos 'gas' expects a density (kg/m^3), got '4 m' (a length)");
  expect_error("gamma: 1.4\nrho: 4 kgg\n", 2, 6, "'rho' in eos 'gas': unknown unit 'kgg'");
  expect_error("gamma: abc\n", 1, 8, "'gamma' in eos 'gas': expected a number, got 'abc'");
  expect_error("gamma:\n", 1, 7, "'gamma' in eos 'gas' has no value; expected a number");
  expect_error("gamma: 1.4\nsteps: 1.5\n", 2, 8, "'steps' in eos 'gas' must be an integer, got '1.5'");
  expect_error("gamma: 1.4\nverbose: maybe\n", 2, 10, "'verbose' in eos 'gas' must be true or false, got 'maybe'");
  expect_error("gamma: 1.4\nlabel: [a]\n", 2, 8, "'label' in eos 'gas' must be a text, got a list");
  expect_error("gamma: 1.4\npoint: 3\n", 2, 8, "'point' in eos 'gas' must be a list of 3 numbers, got '3'");
  expect_error("gamma: 1.4\npoint: [1, 2]\n", 2, 8, "'point' in eos 'gas' must be a list of 3 numbers, got 2");
  expect_error("gamma: 1.4\npoint: [1, 2, 3 s]\n", 2, 15, "'point[2]' in eos 'gas' expects a length (m)");
  expect_error("gamma: 1.4\nfailure: 3\n", 2, 10, "'failure' in eos 'gas' must be a mapping, got '3'");
  /* a long value is cut at 60 characters with "..." (and, where the kind of value is named, its
   * length), not silently */
  expect_error("gamma: 'aaaaaaaaaabbbbbbbbbbccccccccccddddddddddeeeeeeeeeeffffffffffgggggggggg'\n", 1, 8,
               "got a quoted string \"aaaaaaaaaabbbbbbbbbbccccccccccddddddddddeeeeeeeeeeffffffffff...\" (70 characters)");
  expect_error("gamma: aaaaaaaaaabbbbbbbbbbccccccccccddddddddddeeeeeeeeeeffffffffffgggggggggg\n", 1, 8,
               "expected a number, got 'aaaaaaaaaabbbbbbbbbbccccccccccddddddddddeeeeeeeeeeffffffffff...'");
  {
    /* a message longer than the error frame ends in "..." */
    char key[700];
    memset(key, 'k', sizeof key - 1);
    key[sizeof key - 1] = '\0';
    char doc[800];
    snprintf(doc, sizeof doc, "gamma: 1.4\n%s: 1\n", key);
    test_cfg cfg;
    ej_doc *d = NULL;
    ck_assert_int_eq(apply(doc, &cfg, NULL, &d), EJ_ERR_INPUT);
    const ej_error_frame *f = ej_error_cause();
    ck_assert_ptr_nonnull(f);
    const size_t len = strlen(f->msg);
    ck_assert_uint_eq(len, sizeof f->msg - 1);
    ck_assert_str_eq(f->msg + len - 3, "...");
    ck_assert_ptr_nonnull(strstr(f->msg, "unknown key 'kkkk"));
    ej_error_clear();
    ej_doc_destroy(d);
  }
}
END_TEST

START_TEST(test_out_of_range)
{
  expect_error("gamma: 1.4\ncfl: 1.5\n", 2, 6, "'cfl' = 1.5 is out of range (0, 1] in eos 'gas'");
  expect_error("gamma: 1.4\ncfl: 0\n", 2, 6, "'cfl' = 0 is out of range (0, 1] in eos 'gas'");
  expect_error("gamma: 0.5\n", 1, 8, "'gamma' = 0.5 is out of range [1, inf) in eos 'gas'");
  expect_error("gamma: 1.4\nangle: 95\n", 2, 8, "'angle' = 95 is out of range [0, 90] deg in eos 'gas'");
  expect_error("gamma: 1.4\nangle: 2 rad\n", 2, 8, "'angle' = 2 rad is out of range [0, 90] deg");
  expect_error("gamma: 1.4\nrho: 0 g/cm^3\n", 2, 6, "'rho' = 0 g/cm^3 is out of range (0, inf) kg/m^3");
  expect_error("gamma: 1.4\nsteps: 0\n", 2, 8, "'steps' = 0 is out of range [1, 100] in eos 'gas'");
  expect_error("gamma: 1.4\nfailure:\n  stretch: 0\n", 3, 12, "'stretch' = 0 is out of range (0, inf) in eos 'gas'.failure");
}
END_TEST

START_TEST(test_missing_required)
{
  expect_error("cfl: 0.5\n", 1, 1, "eos 'gas' is missing required key 'gamma' (Adiabatic exponent.)");
  expect_error("a: 1\nb:\n  cfl: 0.5\n", 1, 1, "unknown key 'a'");
  /* a nested map reports at its own start */
  test_cfg cfg;
  ej_doc *doc = NULL;
  ck_assert_int_eq(ej_doc_parse_string("p.yaml", "eos:\n  cfl: 0.5\n", &doc), EJ_OK);
  ck_assert_int_eq(ej_params_apply(test_params, &cfg, ej_node_get(doc->root, "eos"), "eos", NULL, NULL),
                   EJ_ERR_INPUT);
  ck_assert_int_eq(ej_error_cause()->where.line, 2);
  ck_assert_int_eq(ej_error_cause()->where.col, 3);
  ej_error_clear();
  ej_doc_destroy(doc);
}
END_TEST

START_TEST(test_bad_enum)
{
  expect_error("gamma: 1.4\nkernel: quintc\n", 2, 9,
               "'kernel' in eos 'gas' must be one of cubic, quintic, wendland, got 'quintc'; did you mean 'quintic'?");
  expect_error("gamma: 1.4\nkernel: gaussian\n", 2, 9, "must be one of cubic, quintic, wendland, got 'gaussian'");
}
END_TEST

static ej_err check_cfl(const void *config, ej_diag *d)
{
  const test_cfg *c = config;
  if (c->cfl > 0.5 && c->kernel == 0) return ej_diag_error(d, "cfl", "cfl %g is too large for the cubic kernel", c->cfl);
  if (c->steps == 7) return ej_diag_error(d, NULL, "seven steps are unlucky");
  if (c->steps == 8) return ej_diag_error(d, "failure", "eight is not allowed either");
  return EJ_OK;
}

START_TEST(test_check_config)
{
  test_cfg cfg;
  ej_doc *doc = NULL;
  ck_assert_int_eq(apply("gamma: 1.4\nkernel: cubic\n\ncfl: 0.9\n", &cfg, check_cfl, &doc), EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_str_eq(f->msg, "eos 'gas': cfl 0.9 is too large for the cubic kernel");
  ck_assert_int_eq(f->where.line, 4);
  ck_assert_int_eq(f->where.col, 1);
  ej_error_clear();
  ej_doc_destroy(doc);

  ck_assert_int_eq(apply("\ngamma: 1.4\nsteps: 7\n", &cfg, check_cfl, &doc), EJ_ERR_INPUT);
  f = ej_error_cause();
  ck_assert_str_eq(f->msg, "eos 'gas': seven steps are unlucky");
  ck_assert_int_eq(f->where.line, 2);
  ej_error_clear();
  ej_doc_destroy(doc);

  /* a key the block does not have falls back to the block */
  ck_assert_int_eq(apply("gamma: 1.4\nsteps: 8\n", &cfg, check_cfl, &doc), EJ_ERR_INPUT);
  ck_assert_int_eq(ej_error_cause()->where.line, 1);
  ej_error_clear();
  ej_doc_destroy(doc);

  ck_assert_int_eq(apply("gamma: 1.4\ncfl: 0.9\n", &cfg, check_cfl, &doc), EJ_OK);
  ej_doc_destroy(doc);
}
END_TEST

START_TEST(test_describe)
{
  ej_buf b = {0};
  ck_assert_int_eq(ej_params_describe(&b, test_params, 2), EJ_OK);
  const char *want[] = {"  gamma", "required", "number [kg/m^3]", "[0, 90] deg", "one of cubic|quintic|wendland",
                        "[3 numbers] [m]", "true|false", "integer", "text", "block", "      stretch",
                        "Courant number.", "(0, 1]", "quintic"};
  for (size_t i = 0; i < sizeof want / sizeof want[0]; ++i)
    ck_assert_msg(strstr(b.data, want[i]), "describe lacks '%s':\n%s", want[i], b.data);
  ej_buf_free(&b);
}
END_TEST

/* Validates JSON with Python when it is there (it is on every CI image); otherwise checks that
 * braces, brackets and quotes balance. */
static void assert_json(const char *text)
{
  int depth = 0;
  bool in_str = false;
  for (const char *c = text; *c; ++c) {
    if (in_str) {
      if (*c == '\\') ++c;
      else if (*c == '"') in_str = false;
      continue;
    }
    if (*c == '"') in_str = true;
    else if (*c == '{' || *c == '[') ++depth;
    else if (*c == '}' || *c == ']') ck_assert_int_ge(--depth, 0);
  }
  ck_assert(!in_str);
  ck_assert_int_eq(depth, 0);
  if (access("/usr/bin/python3", X_OK) != 0) return;
  FILE *p = popen("/usr/bin/python3 -c 'import json,sys; json.load(sys.stdin)'", "w");
  ck_assert_ptr_nonnull(p);
  fputs(text, p);
  ck_assert_msg(pclose(p) == 0, "schema is not valid JSON:\n%s", text);
}

START_TEST(test_schema)
{
  ej_buf b = {0};
  const char *extra[] = {"model", NULL};
  ck_assert_int_eq(ej_params_schema(&b, test_params, extra), EJ_OK);
  assert_json(b.data);
  const char *want[] = {"{\"type\":\"object\",\"additionalProperties\":false,\"properties\":{\"gamma\":",
                        "\"required\":[\"gamma\"]",
                        "\"x-unit\":\"kg/m^3\"",
                        "\"exclusiveMinimum\":0",
                        "\"enum\":[\"cubic\",\"quintic\",\"wendland\"],\"default\":\"quintic\"",
                        "\"minItems\":3,\"maxItems\":3",
                        "\"model\":{}",
                        "\"description\":\"Density \\\"rho\\\".\"",
                        "\"pattern\":\"^\\\\s*[-+0-9.eE]+\\\\s*\\\\S*$\"",
                        "\"default\":0.3",
                        "\"failure\":{\"type\":\"object\""};
  for (size_t i = 0; i < sizeof want / sizeof want[0]; ++i)
    ck_assert_msg(strstr(b.data, want[i]), "schema lacks '%s':\n%s", want[i], b.data);
  /* deterministic: the same table gives the same text */
  ej_buf c = {0};
  ck_assert_int_eq(ej_params_schema(&c, test_params, extra), EJ_OK);
  ck_assert_str_eq(b.data, c.data);
  ej_buf_free(&b);
  ej_buf_free(&c);
}
END_TEST

/* ej_path_beside, which resolves EJ_PF_PATH values and a set's file: beside the file that names them */
START_TEST(test_path_beside)
{
  const char *cases[][3] = {{"dir/sub/scene.yaml", "m.yaml", "dir/sub/m.yaml"},
                            {"dir/scene.yaml", "../d/m.yaml", "dir/../d/m.yaml"},
                            {"/abs/scene.yaml", "m.yaml", "/abs/m.yaml"},
                            {"scene.yaml", "m.yaml", "m.yaml"},
                            {"dir/scene.yaml", "/etc/m.yaml", "/etc/m.yaml"},
                            {NULL, "m.yaml", "m.yaml"},
                            {NULL, "/etc/m.yaml", "/etc/m.yaml"},
                            {"dir/", "m.yaml", "dir/m.yaml"}};
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    char *p = ej_path_beside(cases[k][0], cases[k][1]);
    ck_assert_ptr_nonnull(p);
    ck_assert_msg(strcmp(p, cases[k][2]) == 0, "case %zu: '%s' beside '%s' gave '%s', expected '%s'", k,
                  cases[k][1], cases[k][0] ? cases[k][0] : "(null)", p, cases[k][2]);
    ej_free(p);
  }
}
END_TEST

int main(void)
{
  Suite *s = suite_create("params");
  TCase *tc = tcase_create("params");
  tcase_add_test(tc, test_defaults);
  tcase_add_test(tc, test_apply_all_types);
  tcase_add_test(tc, test_unknown_key);
  tcase_add_test(tc, test_wrong_type);
  tcase_add_test(tc, test_out_of_range);
  tcase_add_test(tc, test_missing_required);
  tcase_add_test(tc, test_bad_enum);
  tcase_add_test(tc, test_check_config);
  tcase_add_test(tc, test_describe);
  tcase_add_test(tc, test_schema);
  tcase_add_test(tc, test_path_beside);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
