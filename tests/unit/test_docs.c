/* The pages docs/plugins/NAME.md are generated from the plugins' parameter tables (`make docs`, i.e.
 * `ejecta describe --markdown -o docs/plugins`); this test fails when a committed page is stale,
 * missing or left over from a removed plugin, like test_schema does for the JSON Schema. */
#include <check.h>
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_tmpdir.h"

#define DOCS EJ_TEST_SOURCE_DIR "/docs/plugins"
#define FIX "run 'make docs' (ejecta describe --markdown -o docs/plugins) and commit docs/plugins"

static char *slurp(const char *path, size_t *len)
{
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *t = malloc((size_t)n + 1);
  ck_assert_ptr_nonnull(t);
  ck_assert_int_eq(fread(t, 1, (size_t)n, f), (size_t)n);
  fclose(f);
  t[n] = 0;
  *len = (size_t)n;
  return t;
}

/* Names of the *.md files of dir, sorted, as one "a.md\nb.md\n" string. */
static void list_md(const char *dir, char *out, size_t cap)
{
  DIR *d = opendir(dir);
  ck_assert_msg(d != NULL, "cannot open %s: " FIX, dir);
  char names[256][128];
  int n = 0;
  for (struct dirent *e; (e = readdir(d)) && n < 256;) {
    size_t l = strlen(e->d_name);
    if (l > 3 && l < 128 && !strcmp(e->d_name + l - 3, ".md")) memcpy(names[n++], e->d_name, l + 1);
  }
  closedir(d);
  qsort(names, (size_t)n, sizeof names[0], (int (*)(const void *, const void *))strcmp);
  out[0] = 0;
  for (int i = 0; i < n; ++i) {
    strncat(out, names[i], cap - strlen(out) - 2);
    strncat(out, "\n", cap - strlen(out) - 1);
  }
}

START_TEST(test_docs_fresh)
{
  char tmp[256], cmd[1024];
  ej_test_tmpdir(tmp, sizeof tmp, "docs");
  /* Only the in-tree plugins (the build tree): test fixtures must not leak into the docs. */
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH= %s/bin/ejecta describe --markdown -o %s > /dev/null 2> %s/err.txt",
           EJ_TEST_BINARY_DIR, tmp, tmp);
  int st = system(cmd);
  ck_assert_msg(WIFEXITED(st) && WEXITSTATUS(st) == 0, "ejecta describe --markdown failed");
  static char want[32768], have[32768];
  list_md(tmp, want, sizeof want);
  list_md(DOCS, have, sizeof have);
  ck_assert_msg(strstr(want, "README.md\n") && strstr(want, "sph.md\n"), "generated pages:\n%s", want);
  ck_assert_msg(!strcmp(want, have), "docs/plugins has pages\n%s\nthe plugins give\n%s\n" FIX, have, want);
  for (char *name = want, *nl; (nl = strchr(name, '\n')); name = nl + 1) {
    *nl = 0;
    char a[512], b[512];
    ck_assert(strlen(name) < 128);
    snprintf(a, sizeof a, "%s/%.127s", tmp, name);
    snprintf(b, sizeof b, "%s/%.127s", DOCS, name);
    size_t la, lb;
    char *ta = slurp(a, &la), *tb = slurp(b, &lb);
    ck_assert_ptr_nonnull(ta);
    ck_assert_ptr_nonnull(tb);
    ck_assert_msg(la == lb && !memcmp(ta, tb, la), "docs/plugins/%s is stale: " FIX, name);
    free(ta);
    free(tb);
    remove(a);
  }
  ej_test_rmtree(tmp);
}
END_TEST

/* A page has the parameter table with every column, and `describe NAME --markdown` prints the
 * same page to stdout. */
START_TEST(test_docs_page)
{
  char tmp[256], cmd[1024];
  ej_test_tmpdir(tmp, sizeof tmp, "docs");
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH= %s/bin/ejecta describe --markdown ideal_gas > %s/page.md",
           EJ_TEST_BINARY_DIR, tmp);
  ck_assert_int_eq(system(cmd), 0);
  char path[512];
  snprintf(path, sizeof path, "%s/page.md", tmp);
  size_t n;
  char *t = slurp(path, &n);
  ck_assert_ptr_nonnull(t);
  ck_assert_msg(strstr(t, "# ideal_gas (eos)") && strstr(t, "| name | type | unit | default | bounds | choices | description |") &&
                    strstr(t, "| `gamma` | number | 1 | 1.4 | (1, inf) | - | Ratio of specific heats"),
                "page:\n%s", t);
  free(t);
  /* An unknown name is exit 2. */
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH= %s/bin/ejecta describe --markdown no_such_plugin 2> /dev/null",
           EJ_TEST_BINARY_DIR);
  int st = system(cmd);
  ck_assert(WIFEXITED(st) && WEXITSTATUS(st) == 2);
  ej_test_rmtree(tmp);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("docs");
  TCase *tc = tcase_create("docs");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_docs_fresh);
  tcase_add_test(tc, test_docs_page);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
