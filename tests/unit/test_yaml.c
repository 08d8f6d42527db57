/* YAML documents: node and key locations, duplicate keys, malformed YAML, missing files,
 * quoted scalars, and the constructs a scene refuses (anchors, several documents). */
#define _POSIX_C_SOURCE 200809L
#include <check.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"

static void expect_parse_error(const char *text, int line, int col, const char *want)
{
  ej_doc *doc = NULL;
  ej_err rc = ej_doc_parse_string("t.yaml", text, &doc);
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  ck_assert_ptr_null(doc);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_msg(strstr(f->msg, want), "message '%s' lacks '%s'", f->msg, want);
  ck_assert_str_eq(f->where.file, "t.yaml");
  ck_assert_msg(f->where.line == line && f->where.col == col, "'%s' at %d:%d, expected %d:%d", f->msg,
                f->where.line, f->where.col, line, col);
  ej_error_clear();
}

START_TEST(test_locations)
{
  const char *text = "ejecta: 1\n"
                     "time: {end: 0.8 ms, cfl: 0.3}\n"
                     "sets:\n"
                     "  soil:\n"
                     "    spacing: 4 mm\n"
                     "    point: [0, 0, -0.03]\n"
                     "    list:\n"
                     "      - a\n"
                     "      - 'b'\n"
                     "      - \"c d\"\n";
  ej_doc *doc = NULL;
  ck_assert_int_eq(ej_doc_parse_string("t.yaml", text, &doc), EJ_OK);
  ck_assert_str_eq(doc->path, "t.yaml");
  ck_assert_str_eq(doc->text, text);
  ck_assert_uint_eq(doc->text_len, strlen(text));
  const ej_node *root = doc->root;
  ck_assert_int_eq(root->type, EJ_NODE_MAP);
  ck_assert_int_eq(root->n, 3);
  ck_assert_int_eq(root->loc.line, 1);
  ck_assert_int_eq(root->loc.col, 1);
  ck_assert_ptr_eq(root->loc.file, doc->path);

  const ej_node *time = ej_node_get(root, "time");
  ck_assert_int_eq(time->type, EJ_NODE_MAP);
  ck_assert_int_eq(time->loc.line, 2);
  ck_assert_int_eq(time->loc.col, 7);
  const ej_loc *kl = ej_node_key_loc(time, "cfl");
  ck_assert_int_eq(kl->line, 2);
  ck_assert_int_eq(kl->col, 21);
  const ej_node *cfl = ej_node_get(time, "cfl");
  ck_assert_str_eq(cfl->text, "0.3");
  ck_assert_int_eq(cfl->loc.col, 26);
  ck_assert(!cfl->quoted);

  const ej_node *soil = ej_node_get(ej_node_get(root, "sets"), "soil");
  ck_assert_int_eq(soil->type, EJ_NODE_MAP);
  ck_assert_int_eq(soil->loc.line, 5);
  ck_assert_int_eq(soil->loc.col, 5);
  kl = ej_node_key_loc(soil, "point");
  ck_assert_int_eq(kl->line, 6);
  ck_assert_int_eq(kl->col, 5);
  const ej_node *pt = ej_node_get(soil, "point");
  ck_assert_int_eq(pt->type, EJ_NODE_SEQ);
  ck_assert_int_eq(pt->n, 3);
  ck_assert_str_eq(pt->items[2]->text, "-0.03");
  ck_assert_int_eq(pt->items[2]->loc.line, 6);
  ck_assert_int_eq(pt->items[2]->loc.col, 19);
  const ej_node *list = ej_node_get(soil, "list");
  ck_assert_int_eq(list->n, 3);
  ck_assert_int_eq(list->items[1]->loc.line, 9);
  ck_assert_int_eq(list->items[1]->loc.col, 9);
  ck_assert(!list->items[0]->quoted);
  ck_assert(list->items[1]->quoted);
  ck_assert(list->items[2]->quoted);
  ck_assert_str_eq(list->items[2]->text, "c d");

  ck_assert_ptr_null(ej_node_get(root, "nope"));
  ck_assert_ptr_null(ej_node_key_loc(root, "nope"));
  ck_assert_ptr_null(ej_node_get(cfl, "x")); /* not a map */
  ck_assert_ptr_null(ej_node_get(NULL, "x"));
  ej_doc_destroy(doc);
  ej_doc_destroy(NULL);
}
END_TEST

START_TEST(test_duplicate_key)
{
  expect_parse_error("a: 1\nb:\n  x: 1\n  y: 2\n  x: 3\n", 5, 3, "duplicate key 'x' (first at line 3)");
}
END_TEST

START_TEST(test_malformed)
{
  expect_parse_error("a: 1\nb: [1, 2\nc: 3\n", 3, 2, "malformed YAML");
  expect_parse_error("a:\n  b: 1\n c: 2\n", 3, 2, "malformed YAML: did not find expected key");
  expect_parse_error("a: 'unterminated\n", 2, 1, "malformed YAML: found unexpected end of stream");
  /* reader errors come with a byte offset only: located from the text (before: line 0, "at byte") */
  expect_parse_error("a: 1\nb: x\x01\n", 2, 5, "control characters are not allowed");
  expect_parse_error("a: 1\n# caf\xe9 z\n", 2, 7, "invalid trailing UTF-8 octet");
  expect_parse_error("a: 1\n# \xc3\xa9\xff\n", 2, 4, "invalid leading UTF-8 octet");
}
END_TEST

START_TEST(test_refused_constructs)
{
  expect_parse_error("a: &x 1\nb: *x\n", 1, 4, "anchors (&x) are not supported");
  expect_parse_error("a: 1\nb: *x\n", 2, 4, "aliases");
  expect_parse_error("a: 1\n---\nb: 2\n", 2, 1, "one YAML document");
  expect_parse_error("[1, 2]: 3\n", 1, 1, "map keys must be plain names");
  expect_parse_error("a: {? {b: 1} : 2}\n", 1, 7, "map keys must be plain names");
  ej_doc *doc = NULL;
  ck_assert_int_eq(ej_doc_parse_string("t.yaml", "# only a comment\n", &doc), EJ_ERR_INPUT);
  ck_assert_str_eq(ej_error_cause()->msg, "scene file is empty");
  ck_assert_int_eq(ej_error_cause()->where.line, 0);
  ej_error_clear();
  ck_assert_int_eq(ej_doc_parse_string("t.yaml", "", &doc), EJ_ERR_INPUT);
  ck_assert_str_eq(ej_error_cause()->msg, "scene file is empty");
  ej_error_clear();
  ck_assert_int_eq(ej_doc_parse_string("t.yaml", "---\n...\n", &doc), EJ_ERR_INPUT);
  ck_assert_str_eq(ej_error_cause()->msg, "scene file is empty");
  ej_error_clear();
}
END_TEST

START_TEST(test_empty_values_and_str_tag)
{
  ej_doc *doc = NULL;
  ck_assert_int_eq(ej_doc_parse_string("t.yaml", "a:\nb: !!str 12\nc: ''\n", &doc), EJ_OK);
  const ej_node *a = ej_node_get(doc->root, "a");
  ck_assert_int_eq(a->type, EJ_NODE_SCALAR);
  ck_assert_str_eq(a->text, "");
  ck_assert(!a->quoted);
  ck_assert(ej_node_get(doc->root, "b")->quoted);
  ck_assert(ej_node_get(doc->root, "c")->quoted);
  ej_doc_destroy(doc);
}
END_TEST

START_TEST(test_load_file)
{
  char path[] = "/tmp/ej_test_yaml_XXXXXX";
  int fd = mkstemp(path);
  ck_assert_int_ge(fd, 0);
  const char *text = "dimension: 2\n# comment kept verbatim\nsets: {a: {spacing: 1 mm}}\n";
  ck_assert_int_eq(write(fd, text, strlen(text)), (ssize_t)strlen(text));
  close(fd);
  ej_doc *doc = NULL;
  ck_assert_int_eq(ej_doc_load(path, &doc), EJ_OK);
  ck_assert_str_eq(doc->text, text);
  ck_assert_str_eq(doc->path, path);
  const ej_node *a = ej_node_get(ej_node_get(doc->root, "sets"), "a");
  ck_assert_int_eq(ej_node_key_loc(a, "spacing")->line, 3);
  ck_assert_int_eq(ej_node_key_loc(a, "spacing")->col, 12);
  ck_assert_str_eq(ej_node_key_loc(a, "spacing")->file, path);
  ej_doc_destroy(doc);
  unlink(path);

  doc = NULL;
  ck_assert_int_eq(ej_doc_load("/nonexistent/dir/scene.yaml", &doc), EJ_ERR_INPUT);
  ck_assert_ptr_null(doc);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_str_eq(f->msg, "cannot open scene file: No such file or directory");
  ck_assert_str_eq(f->where.file, "/nonexistent/dir/scene.yaml");
  ck_assert_int_eq(f->where.line, 0);
  ej_error_clear();

  ck_assert_int_eq(ej_doc_load("/tmp", &doc), EJ_ERR_INPUT);
  ck_assert_ptr_nonnull(strstr(ej_error_cause()->msg, "scene file"));
  ej_error_clear();
}
END_TEST

int main(void)
{
  Suite *s = suite_create("yaml");
  TCase *tc = tcase_create("yaml");
  tcase_add_test(tc, test_locations);
  tcase_add_test(tc, test_duplicate_key);
  tcase_add_test(tc, test_malformed);
  tcase_add_test(tc, test_refused_constructs);
  tcase_add_test(tc, test_empty_values_and_str_tag);
  tcase_add_test(tc, test_load_file);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
