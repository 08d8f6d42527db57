/* tools/bubble.py, which every soil-bubble number of validation/buried_charge comes from
 * (measure(): height and width of all soil and of the coherent dome; axis_front(): the highest
 * soil and the 90 % front within a fixed 30 mm of the axis), on particle sets whose answers are
 * known by construction. The checks run in Debian's /usr/bin/python3 (numpy, scipy), the
 * interpreter the validation scripts use; without it the test is skipped (exit 77). */
#include <check.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#define PY "/usr/bin/python3"

/* The synthetic scene, dx = 10 mm, ground surface z_s = 0:
 * - a ground lattice (z = -5, -15 mm) over 0.2 x 0.2 m, below z_s + dx/2: not bubble;
 * - a coherent cap: a 9 x 9 patch (x, y = -40 ... 40 mm) of two layers at z = 100 and 110 mm
 *   (every particle has at least 3 neighbours within 1.5 dx);
 * - an isolated fragment on the axis at z = 300 mm (no neighbour within 1.5 dx);
 * - an isolated fragment at r = 40 mm, z = 500 mm (outside the 2 dx and the 30 mm windows);
 * - an isolated fragment at r = 25 mm, z = 400 mm (inside the 30 mm window, outside 2 dx);
 * - a particle 4 mm above the surface on the axis (below z_s + dx/2: not bubble).
 * Expected:
 * - all soil: height 300 mm (the axis fragment); width twice the largest r below half the
 *   height, the cap's corner: 2 sqrt(2) 40 mm;
 * - coherent (>= 3 neighbours): height 110 mm (the cap's top layer); width 0: the flat cap lies
 *   above half its own height, and the width is that of the dome's lower half;
 * - within 30 mm: the cap's 5 x 5 centre (r <= 28.3 mm) in two layers and the fragments at 300
 *   and 400 mm, 52 heights: highest 400 mm; 0.9 quantile (numpy's linear rule) at position 45.9 of
 *   0..51: 110 mm. Without the fragments: 110 and 110 mm. With a column of 10 particles at 200 mm on the axis (and
 *   no fragment): 60 heights, position 53.1 among them: 200 mm. Nothing above the surface: 0, 0. */
static const char *script =
    "import sys, math\n"
    "sys.path.insert(0, sys.argv[1])\n"
    "import numpy as np\n"
    "import bubble\n"
    "dx = 0.01\n"
    "g = [(i * dx, j * dx, z) for i in range(-10, 11) for j in range(-10, 11) for z in (-0.005, -0.015)]\n"
    "cap = [(i * dx, j * dx, z) for i in range(-4, 5) for j in range(-4, 5) for z in (0.10, 0.11)]\n"
    "frag = [(0.0, 0.0, 0.30), (0.04, 0.0, 0.50), (0.025, 0.0, 0.40), (0.0, 0.0, 0.004)]\n"
    "x = np.array(g + cap + frag)\n"
    "fail = 0\n"
    "def near(what, got, want, tol=1e-12):\n"
    "    global fail\n"
    "    ok = abs(got - want) <= tol\n"
    "    print(f'{what}: {got:.6f} (expected {want:.6f})', '' if ok else 'WRONG')\n"
    "    fail += not ok\n"
    "h, w = bubble.measure(x, 0.0, dx)\n"
    "near('all soil height', h, 0.30); near('all soil width', w, 2 * math.sqrt(2) * 0.04)\n"
    "h, w = bubble.measure(x, 0.0, dx, min_nbrs=3)\n"
    "near('coherent height', h, 0.11); near('coherent width', w, 0.0)\n"
    "top, f90 = bubble.axis_front(x, 0.0, dx)\n"
    "near('highest within 30 mm', top, 0.40); near('90 % front within 30 mm', f90, 0.11)\n"
    "top, f90 = bubble.axis_front(np.array(g + cap), 0.0, dx)\n"
    "near('highest within 30 mm, no fragment', top, 0.11); near('90 % front, no fragment', f90, 0.11)\n"
    "col = [(k * 0.001, 0.0, 0.20) for k in range(10)]\n"
    "top, f90 = bubble.axis_front(np.array(g + cap + col), 0.0, dx)\n"
    "near('90 % front with a column at 200 mm', f90, 0.20)\n"
    "top, f90 = bubble.axis_front(np.array(g), 0.0, dx)\n"
    "near('nothing above the surface: highest', top, 0.0); near('nothing above the surface: front', f90, 0.0)\n"
    "near('spacing of the ground', bubble.spacing(np.array(g)), dx, 1e-12)\n"
    "sys.exit(1 if fail else 0)\n";

START_TEST(test_bubble_measures)
{
  if (access(PY, X_OK) != 0) {
    fprintf(stderr, "test_bubble: %s missing, skipped\n", PY);
    exit(77);
  }
  char path[] = "/tmp/ejecta_bubble_XXXXXX";
  const int fd = mkstemp(path);
  ck_assert_int_ge(fd, 0);
  FILE *f = fdopen(fd, "w");
  ck_assert_ptr_nonnull(f);
  fputs(script, f);
  fclose(f);
  char cmd[600];
  snprintf(cmd, sizeof cmd, PY " %s %s/tools", path, EJ_TEST_SOURCE_DIR);
  const int st = system(cmd);
  unlink(path);
  ck_assert_msg(WIFEXITED(st) && WEXITSTATUS(st) == 0, "tools/bubble.py measures wrong (see the lines above)");
}
END_TEST

int main(void)
{
  Suite *s = suite_create("bubble");
  TCase *tc = tcase_create("measures");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_bubble_measures);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_set_fork_status(sr, CK_NOFORK);
  srunner_run_all(sr, CK_NORMAL);
  const int nf = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nf ? EXIT_FAILURE : EXIT_SUCCESS;
}
