/* Inputs found by the libFuzzer harnesses (tests/fuzz, `make fuzz`), each with the fix it
 * needed, and a replay of the fuzz corpora through the same checks in the ordinary build (and
 * under ASan/UBSan with `make test-sanitize`): the scene validator answers OK or an input error,
 * never an internal one; the CSV importer accepts only finite positions and positive finite
 * volumes and spacings. */
#include <check.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scene_impl.h"

#define CORPUS EJ_TEST_SOURCE_DIR "/tests/fuzz/corpus_"

static char csv_path[256];

static void write_bytes(const char *path, const char *data, size_t n)
{
  FILE *f = fopen(path, "wb");
  ck_assert_ptr_nonnull(f);
  ck_assert_int_eq(fwrite(data, 1, n, f), n);
  fclose(f);
}

/* The fuzz_csv harness's input format: byte 0 selects the dimension (1 + b % 3) and whether the
 * set gives a spacing ((b / 3) % 2); the rest is the file. Returns the importer's code. */
static ej_err csv_case(const char *data, size_t n, ej_points *pts)
{
  const int dim = 1 + (unsigned char)data[0] % 3;
  const ej_real spacing = ((unsigned char)data[0] / 3) % 2 ? 0.01 : 0.0;
  write_bytes(csv_path, data + 1, n - 1);
  ej_loc where = {"regress.yaml", 1, 1};
  ej_err rc = ej_points_read_csv(csv_path, dim, spacing, &where, pts);
  if (rc == EJ_OK)
    for (ej_idx i = 0; i < pts->n; ++i) {
      for (int k = 0; k < 3; ++k) ck_assert(isfinite(pts->x[3 * i + k]) && (k < dim || pts->x[3 * i + k] == 0));
      ck_assert(pts->vol[i] > 0 && isfinite(pts->vol[i]) && pts->spacing[i] > 0 && isfinite(pts->spacing[i]));
    }
  return rc;
}

static void csv_setup(void) { snprintf(csv_path, sizeof csv_path, "/tmp/ejecta_fuzzreg_%d.csv", (int)getpid()); }
static void csv_teardown(void) { remove(csv_path); }

/* fuzz_csv, found in the first minutes: a spacing whose cube underflows to 0 (1e-200 m) or
 * overflows to inf (1e200 m) gave particles of zero or infinite volume. Fixed in
 * ej_points_read_csv (geometry.c): such a row is an input error at its line. */
START_TEST(test_csv_volume_out_of_range)
{
  static const char *const cases[] = {"\x02x,y,z,spacing\n0,0,0,1e-200\n", "\x02x,y,z,spacing\n0,0,0,1e200\n",
                                      "\x01x,y,spacing\n0,0,1\n1,0,1e-170\n"};
  static const int lines[] = {2, 2, 3};
  for (int k = 0; k < 3; ++k) {
    ej_points pts;
    ck_assert_int_eq(csv_case(cases[k], strlen(cases[k]), &pts), EJ_ERR_INPUT);
    const ej_error_frame *f = ej_error_cause();
    ck_assert_msg(f && strstr(f->msg, "out of range") && f->where.line == lines[k], "case %d: %s (line %d)", k,
                  f ? f->msg : "?", f ? f->where.line : -1);
    ej_error_clear();
  }
  /* The set's own spacing (no spacing or vol column) is checked the same way. */
  write_bytes(csv_path, "x,y,z\n0,0,0\n", 12);
  ej_loc where = {"regress.yaml", 1, 1};
  ej_points pts;
  ck_assert_int_eq(ej_points_read_csv(csv_path, 3, 1e-200, &where, &pts), EJ_ERR_INPUT);
  ej_error_clear();
}
END_TEST

static int corpus_files(const char *dir, char names[][256], int max)
{
  DIR *d = opendir(dir);
  ck_assert_msg(d != NULL, "no corpus %s", dir);
  int n = 0;
  for (struct dirent *e; (e = readdir(d)) && n < max;)
    if (e->d_name[0] != '.') snprintf(names[n++], 256, "%s/%.200s", dir, e->d_name);
  closedir(d);
  return n;
}

static char *slurp(const char *path, size_t *len)
{
  FILE *f = fopen(path, "rb");
  ck_assert_ptr_nonnull(f);
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

START_TEST(test_replay_csv_corpus)
{
  static char names[512][256];
  int n = corpus_files(CORPUS "csv", names, 512);
  ck_assert(n >= 4);
  for (int k = 0; k < n; ++k) {
    size_t len;
    char *t = slurp(names[k], &len);
    if (len >= 1) {
      ej_points pts;
      ej_err rc = csv_case(t, len, &pts);
      ck_assert_msg(rc == EJ_OK || rc == EJ_ERR_INPUT, "%s: code %d", names[k], rc);
      if (rc == EJ_OK) ej_points_free(&pts);
      ej_error_clear();
    }
    free(t);
  }
}
END_TEST

/* As fuzz_scene: the lattice fill of every set of a valid scene that makes at most ~2e4 points. */
static void fill_small_sets(const ej_scene *sc, const char *name)
{
  for (int i = 0; i < sc->n_sets; ++i) {
    const ej_scene_set *s = &sc->sets[i];
    if (s->file || !s->shape) continue;
    ej_real lo[3], hi[3], sp = s->spacing;
    for (int k = 0; k < s->n_refine; ++k) sp = fmin(sp, s->refine[k].spacing);
    if (ej_shape_bounds(s->shape, lo, hi) != EJ_OK) {
      ej_error_clear();
      continue;
    }
    double est = 1;
    for (int k = 0; k < sc->dimension; ++k) est *= (hi[k] - lo[k]) / (0.8 * sp) + 3;
    if (!(est < 2e4)) continue;
    ej_points pts;
    ej_err rc = ej_scene_set_points(sc, i, &pts);
    ck_assert_msg(rc == EJ_OK || rc == EJ_ERR_INPUT, "%s: set %d: code %d", name, i, rc);
    if (rc == EJ_OK) {
      for (ej_idx p = 0; p < pts.n; ++p)
        ck_assert(isfinite(pts.x[3 * p]) && isfinite(pts.x[3 * p + 1]) && isfinite(pts.x[3 * p + 2]) &&
                  pts.vol[p] > 0 && isfinite(pts.vol[p]));
      ej_points_free(&pts);
    }
    ej_error_clear();
  }
}

/* Scenes through the parser and validator with the in-tree plugins of the build tree. */
START_TEST(test_replay_scene_corpus)
{
  static char names[512][256];
  int n = corpus_files(CORPUS "scene", names, 512);
  ck_assert(n >= 3);
  int ok = 0;
  for (int k = 0; k < n; ++k) {
    size_t len;
    char *t = slurp(names[k], &len);
    ej_registry *reg;
    ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
    ck_assert_int_eq(ej_registry_set_path(reg, EJ_TEST_BINARY_DIR "/plugins"), EJ_OK);
    ej_doc *doc = NULL;
    if (ej_doc_parse_string("fuzz.yaml", t, &doc) == EJ_OK) {
      ej_scene *sc = NULL;
      ej_err rc = ej_scene_from_doc(doc, reg, &sc);
      ck_assert_msg(rc == EJ_OK || rc == EJ_ERR_INPUT || rc == EJ_ERR_PLUGIN || rc == EJ_ERR_ABI,
                    "%s: code %d", names[k], rc);
      if (rc == EJ_OK) {
        ++ok;
        fill_small_sets(sc, names[k]);
        ej_scene_free(sc);
      }
    }
    ej_error_clear();
    ej_registry_destroy(reg);
    free(t);
  }
  ck_assert(ok >= 3); /* the seeds taken from examples/ are valid scenes */
}
END_TEST

int main(void)
{
  Suite *s = suite_create("fuzz_regressions");
  TCase *tc = tcase_create("fuzz");
  tcase_add_checked_fixture(tc, csv_setup, csv_teardown);
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_csv_volume_out_of_range);
  tcase_add_test(tc, test_replay_csv_corpus);
  tcase_add_test(tc, test_replay_scene_corpus);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
