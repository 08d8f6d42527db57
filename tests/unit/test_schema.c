/* schemas/scene.schema.json is generated from the parameter tables (`make schema`); this
 * test fails when the committed file is stale, as GStreamer's plugin cache check does. */
#include <check.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

START_TEST(test_schema_fresh)
{
  ej_registry *reg;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  /* only the in-tree plugins: test fixtures must not leak into the schema */
  ck_assert_int_eq(ej_registry_set_path(reg, EJ_TEST_BINARY_DIR "/plugins"), EJ_OK);
  ck_assert_int_eq(ej_registry_load_all(reg), EJ_OK);
  ej_buf b = {0};
  ck_assert_int_eq(ej_scene_schema(reg, &b), EJ_OK);
  FILE *f = fopen(EJ_TEST_SOURCE_DIR "/schemas/scene.schema.json", "rb");
  ck_assert_msg(f, "schemas/scene.schema.json is missing: run 'make schema' and commit it");
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *text = malloc((size_t)n + 1);
  ck_assert_int_eq(fread(text, 1, (size_t)n, f), (size_t)n);
  fclose(f);
  text[n] = 0;
  ck_assert_msg((size_t)n == b.len && !memcmp(text, b.data, b.len),
                "schemas/scene.schema.json is stale: run 'make schema' and commit it");
  free(text);
  ej_buf_free(&b);
  ej_registry_destroy(reg);
}
END_TEST

START_TEST(test_schema_is_json)
{
  ej_registry *reg;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_set_path(reg, EJ_TEST_BINARY_DIR "/plugins"), EJ_OK);
  ck_assert_int_eq(ej_registry_load_all(reg), EJ_OK);
  ej_buf b = {0};
  ck_assert_int_eq(ej_scene_schema(reg, &b), EJ_OK);
  FILE *p = popen("/usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); "
                  "assert \"sets\" in d[\"properties\"]' 2>/dev/null",
                  "w");
  ck_assert_ptr_nonnull(p);
  fwrite(b.data, 1, b.len, p);
  int st = pclose(p);
  ck_assert_msg(st == 0, "the schema is not valid JSON with a 'sets' property");
  ej_buf_free(&b);
  ej_registry_destroy(reg);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("schema");
  TCase *tc = tcase_create("schema");
  tcase_add_test(tc, test_schema_fresh);
  tcase_add_test(tc, test_schema_is_json);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
