/* The installed SDK: `cmake --install` into a temporary prefix, then build the out-of-tree
 * plugin examples/plugin-template against it (CMake package), run its own tests, load it
 * through EJECTA_PLUGIN_PATH with the installed `ejecta` (describe, check, run), and build the
 * same plugin by hand with pkg-config. Both plugins must export ej_plugin_info_v1 only. */
#include <check.h>
#include <hdf5.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_tmpdir.h"

/* A sanitizer build (make test-sanitize) installs an instrumented libejecta: whatever links it
 * must be instrumented too, or the ASan runtime is not first in the library list. */
#ifdef __SANITIZE_ADDRESS__
#define SAN_FLAGS "-fsanitize=address,undefined"
#else
#define SAN_FLAGS ""
#endif

static char prefix[256];
static char log_path[320];

/* Runs a shell command (printf-style), output appended to the log; returns the exit code. */
static int sh(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int sh(const char *fmt, ...)
{
  char cmd[4096], full[4600];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(cmd, sizeof cmd, fmt, ap);
  va_end(ap);
  FILE *lf = fopen(log_path, "a");
  if (lf) fprintf(lf, "\n$ %s\n", cmd), fclose(lf);
  snprintf(full, sizeof full, "( %s ) >> %s 2>&1", cmd, log_path);
  int st = system(full);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* Text of a command's stdout (at most n - 1 bytes). */
static int capture(char *out, size_t n, const char *cmd)
{
  FILE *p = popen(cmd, "r");
  ck_assert_ptr_nonnull(p);
  size_t got = fread(out, 1, n - 1, p);
  out[got] = 0;
  int st = pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void dump_log(void)
{
  char cmd[400];
  snprintf(cmd, sizeof cmd, "tail -n 60 %s >&2", log_path);
  if (system(cmd)) return;
}

#define SH_OK(...)                                                                                      \
  do {                                                                                                  \
    int rc_ = sh(__VA_ARGS__);                                                                          \
    if (rc_ != 0) dump_log();                                                                           \
    ck_assert_msg(rc_ == 0, "command failed (exit %d), see %s", rc_, log_path);                         \
  } while (0)

static bool exists(const char *fmt, const char *a)
{
  char p[512];
  snprintf(p, sizeof p, fmt, a);
  struct stat st;
  return stat(p, &st) == 0;
}

/* Largest eps_p of set 'block' in the last frame of an output file (-1 if absent). */
static double max_eps_p(const char *path)
{
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return -1;
  double best = -1;
  hid_t fr = H5Gopen2(f, "/frames", H5P_DEFAULT);
  H5G_info_t info;
  char name[64], ds[160];
  if (fr >= 0 && H5Gget_info(fr, &info) >= 0 && info.nlinks > 0 &&
      H5Lget_name_by_idx(fr, ".", H5_INDEX_NAME, H5_ITER_INC, info.nlinks - 1, name, sizeof name, H5P_DEFAULT) > 0) {
    snprintf(ds, sizeof ds, "/frames/%s/block/eps_p", name);
    hid_t d = H5Dopen2(f, ds, H5P_DEFAULT);
    if (d >= 0) {
      hid_t sp = H5Dget_space(d);
      hssize_t n = H5Sget_simple_extent_npoints(sp);
      double *v = n > 0 ? malloc((size_t)n * sizeof *v) : NULL;
      if (v && H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v) >= 0)
        for (hssize_t i = 0; i < n; ++i) best = v[i] > best ? v[i] : best;
      free(v);
      H5Sclose(sp);
      H5Dclose(d);
    }
  }
  if (fr >= 0) H5Gclose(fr);
  H5Fclose(f);
  return best;
}

START_TEST(test_install_and_template)
{
  ej_test_tmpdir(prefix, sizeof prefix, "sdk");
  snprintf(log_path, sizeof log_path, "%s/log.txt", prefix);
  const char *src = EJ_TEST_SOURCE_DIR, *bin = EJ_TEST_BINARY_DIR;

  SH_OK("cmake --install %s --prefix %s/inst", bin, prefix);
  static const char *const files[] = {"include/ejecta/ejecta.h", "include/ejecta/plugin.h", "include/ejecta/tensor.h",
                                      "include/ejecta/config.h", "lib/libejecta.so", "bin/ejecta",
                                      "lib/cmake/ejecta/ejectaConfig.cmake", "lib/cmake/ejecta/ejectaTargets.cmake",
                                      "lib/pkgconfig/ejecta.pc", "lib/ejecta/plugins/ej_ideal_gas.so"};
  for (size_t k = 0; k < sizeof files / sizeof files[0]; ++k) {
    char f[400];
    snprintf(f, sizeof f, "%s/inst/%s", prefix, files[k]);
    ck_assert_msg(exists("%s", f), "not installed: %s", files[k]);
  }

  /* The template, built with the CMake package; its own ctest runs its unit test, `check`
   * of its scene and `describe`. */
  SH_OK("cmake -S %s/examples/plugin-template -B %s/tb -DCMAKE_PREFIX_PATH=%s/inst -DCMAKE_BUILD_TYPE=Release "
        "'-DCMAKE_C_FLAGS=%s'",
        src, prefix, prefix, SAN_FLAGS);
  SH_OK("cmake --build %s/tb", prefix);
  SH_OK("ctest --test-dir %s/tb --output-on-failure", prefix);
  ck_assert(exists("%s/tb/ej_my_von_mises.so", prefix));

  char cmd[1024], out[16384];
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH=%s/tb %s/inst/bin/ejecta describe my_von_mises 2>&1", prefix, prefix);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert_msg(strstr(out, "material my_von_mises") && strstr(out, "yield_stress") && strstr(out, "hardening") &&
                    strstr(out, "Pa"),
                "describe output:\n%s", out);

  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH=%s/tb %s/inst/bin/ejecta check %s/examples/plugin-template/scene.yaml 2>&1",
           prefix, prefix, src);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert_msg(strstr(out, "OK"), "check output:\n%s", out);

  /* Without the plugin on the path the same scene is refused with exit 2, naming the plugin. */
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH=%s %s/inst/bin/ejecta check %s/examples/plugin-template/scene.yaml 2>&1",
           prefix, prefix, src);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 2);
  ck_assert_msg(strstr(out, "my_von_mises"), "check output without the plugin:\n%s", out);

  snprintf(cmd, sizeof cmd,
           "EJECTA_PLUGIN_PATH=%s/tb %s/inst/bin/ejecta run %s/examples/plugin-template/scene.yaml -o %s/run.h5 "
           "--no-progress --threads 1 2>&1",
           prefix, prefix, src, prefix);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert(exists("%s/run.h5", prefix) && exists("%s/run.xdmf", prefix));
  /* The method called the plugin's update: the impact left plastic strain in its history field. */
  char h5[400];
  snprintf(h5, sizeof h5, "%s/run.h5", prefix);
  ck_assert_msg(max_eps_p(h5) > 0.01, "no plastic strain in %s: was the material updated?", h5);

  /* The exported symbols of the CMake-built plugin: ej_plugin_info_v1 only. */
  snprintf(cmd, sizeof cmd, "nm -D --defined-only %s/tb/ej_my_von_mises.so | awk '$2 ~ /[TDBR]/ {print $3}'", prefix);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert_msg(!strcmp(out, "ej_plugin_info_v1\n"), "exported symbols:\n%s", out);

  /* pkg-config: the relocatable ejecta.pc gives flags that build the same plugin by hand. */
  SH_OK("mkdir -p %s/pc && export PKG_CONFIG_PATH=%s/inst/lib/pkgconfig && cc -shared " SAN_FLAGS " "
        "$(pkg-config --variable=plugin_cflags ejecta) $(pkg-config --cflags ejecta) -o %s/pc/ej_my_von_mises.so "
        "%s/examples/plugin-template/my_von_mises.c $(pkg-config --libs ejecta)",
        prefix, prefix, prefix, src);
  snprintf(cmd, sizeof cmd, "nm -D --defined-only %s/pc/ej_my_von_mises.so | awk '$2 ~ /[TDBR]/ {print $3}'", prefix);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert_msg(!strcmp(out, "ej_plugin_info_v1\n"), "exported symbols (pkg-config build):\n%s", out);
  snprintf(cmd, sizeof cmd, "EJECTA_PLUGIN_PATH=%s/pc %s/inst/bin/ejecta describe my_von_mises 2>&1", prefix, prefix);
  ck_assert_int_eq(capture(out, sizeof out, cmd), 0);
  ck_assert(strstr(out, "yield_stress") != NULL);

  sh("rm -rf %s", prefix);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("sdk");
  TCase *tc = tcase_create("install");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_install_and_template);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
