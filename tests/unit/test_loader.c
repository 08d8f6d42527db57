/* Plugin loader and registry: every refusal class names the file, registration failures
 * unwind, only the plugins a scene names are loaded. Fixtures: tests/fixtures/. */
#include <check.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

#define FIXDIR EJ_TEST_BINARY_DIR "/tests/fixtures"

static ej_registry *fx_registry(void)
{
  ej_registry *reg;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_set_path(reg, FIXDIR), EJ_OK);
  return reg;
}

/* Loads a fixture and checks the code and that the message names the file and says why. */
static void expect_refusal(const char *fx, ej_err code, const char *why)
{
  ej_registry *reg = fx_registry();
  char path[1024];
  snprintf(path, sizeof path, "%s/ej_fx_%s.so", FIXDIR, fx);
  ej_error_clear();
  ck_assert_int_eq(ej_registry_load_file(reg, path), code);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_msg(strstr(f->msg, path), "message does not name the file: %s", f->msg);
  ck_assert_msg(strstr(f->msg, why), "message '%s' lacks '%s'", f->msg, why);
  ck_assert_int_eq(ej_registry_count(reg, EJ_KIND_EOS), 0);
  ck_assert_int_eq(ej_registry_plugin_count(reg), 0);
  ej_error_clear();
  ej_registry_destroy(reg);
}

START_TEST(test_good_loads)
{
  ej_registry *reg = fx_registry();
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_good.so"), EJ_OK);
  ck_assert_int_eq(ej_registry_count(reg, EJ_KIND_EOS), 1);
  const ej_eos_ops *ops = ej_registry_item(reg, EJ_KIND_EOS, 0);
  ck_assert_str_eq(ops->name, "fx_good");
  ck_assert_uint_eq(ops->struct_size, sizeof(ej_eos_ops));
  const char *path;
  const ej_plugin_info *info = ej_registry_plugin(reg, 0, &path);
  ck_assert_str_eq(info->version, "0.0.1");
  /* loading the same file twice is a no-op */
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_good.so"), EJ_OK);
  ck_assert_int_eq(ej_registry_plugin_count(reg), 1);
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_bad_abi) { expect_refusal("bad_abi", EJ_ERR_ABI, "ABI 99."); }
END_TEST
START_TEST(test_newer_minor) { expect_refusal("newer_minor", EJ_ERR_ABI, "newer than this core"); }
END_TEST
START_TEST(test_bad_signature) { expect_refusal("bad_signature", EJ_ERR_ABI, "build signature 'real=f32"); }
END_TEST
START_TEST(test_no_entry) { expect_refusal("no_entry", EJ_ERR_PLUGIN, "does not export ej_plugin_info_v1"); }
END_TEST
START_TEST(test_missing_op) { expect_refusal("missing_op", EJ_ERR_PLUGIN, "failed to register"); }
END_TEST
START_TEST(test_bad_params) { expect_refusal("bad_params", EJ_ERR_PLUGIN, "failed to register"); }
END_TEST

START_TEST(test_missing_op_reason)
{
  ej_registry *reg = fx_registry();
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_missing_op.so"), EJ_ERR_PLUGIN);
  bool found = false;
  for (int k = 0; k < ej_error_count(); ++k)
    found |= strstr(ej_error_frame_at(k)->msg, "required op 'evaluate' is missing") != NULL;
  ck_assert(found);
  ej_error_clear();
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_duplicate)
{
  ej_registry *reg = fx_registry();
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_good.so"), EJ_OK);
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_dup.so"), EJ_ERR_PLUGIN);
  bool found = false;
  for (int k = 0; k < ej_error_count(); ++k) {
    const char *m = ej_error_frame_at(k)->msg;
    found |= strstr(m, "duplicate plugin name 'fx_good'") && strstr(m, "ej_fx_good.so");
  }
  ck_assert(found);
  ck_assert_int_eq(ej_registry_count(reg, EJ_KIND_EOS), 1);
  ej_error_clear();
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_fail_midway_unwinds)
{
  ej_registry *reg = fx_registry();
  ck_assert_int_eq(ej_registry_load_file(reg, FIXDIR "/ej_fx_fail_midway.so"), EJ_ERR_PLUGIN);
  ck_assert_int_eq(ej_registry_count(reg, EJ_KIND_EOS), 0); /* fx_first was unwound */
  ck_assert_int_eq(ej_registry_plugin_count(reg), 0);
  ej_error_clear();
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_require_loads_only_named)
{
  ej_registry *reg = fx_registry();
  const void *ops;
  ej_loc loc = {"scene.yaml", 3, 7};
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_EOS, "fx_good", &loc, &ops), EJ_OK);
  ck_assert_int_eq(ej_registry_plugin_count(reg), 1); /* the broken fixtures were never opened */
  ck_assert_str_eq(((const ej_eos_ops *)ops)->name, "fx_good");
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_require_unknown)
{
  ej_registry *reg = fx_registry();
  const void *ops;
  ej_loc loc = {"scene.yaml", 3, 7};
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_EOS, "fx_goof", &loc, &ops), EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_int_eq(f->where.line, 3);
  ck_assert_int_eq(f->where.col, 7);
  ck_assert_msg(strstr(f->msg, "unknown eos 'fx_goof'; did you mean 'fx_good'?"), "%s", f->msg);
  ej_error_clear();
  /* right name, wrong kind */
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_METHOD, "fx_good", &loc, &ops), EJ_ERR_INPUT);
  ck_assert_msg(strstr(ej_error_cause()->msg, "is an eos plugin, not a method"), "%s", ej_error_cause()->msg);
  ej_error_clear();
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_real_plugins_and_env_path)
{
  /* The default path finds the in-tree plugins; EJECTA_PLUGIN_PATH adds the fixtures. */
  ej_registry *reg;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  const void *ops;
  ej_loc loc = {"s.yaml", 1, 1};
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_METHOD, "sph", &loc, &ops), EJ_OK);
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_EOS, "ideal_gas", &loc, &ops), EJ_OK);
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_EOS, "fx_good", &loc, &ops), EJ_OK);
  ck_assert_int_eq(ej_registry_plugin_count(reg), 3);
  ej_registry_destroy(reg);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("loader");
  TCase *tc = tcase_create("refusals");
  tcase_add_test(tc, test_good_loads);
  tcase_add_test(tc, test_bad_abi);
  tcase_add_test(tc, test_newer_minor);
  tcase_add_test(tc, test_bad_signature);
  tcase_add_test(tc, test_no_entry);
  tcase_add_test(tc, test_missing_op);
  tcase_add_test(tc, test_missing_op_reason);
  tcase_add_test(tc, test_bad_params);
  tcase_add_test(tc, test_duplicate);
  tcase_add_test(tc, test_fail_midway_unwinds);
  tcase_add_test(tc, test_require_loads_only_named);
  tcase_add_test(tc, test_require_unknown);
  tcase_add_test(tc, test_real_plugins_and_env_path);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
