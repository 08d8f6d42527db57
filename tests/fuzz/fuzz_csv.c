/* libFuzzer harness: CSV particle importer (ej_points_read_csv, core/src/geometry.c).
 * The first byte picks the dimension (1..3) and whether the set gives a spacing; the rest is
 * the file, written to a private temporary file because the importer reads a path. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scene_impl.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static char ej_fuzz_path[64];

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  if (size < 1 || size > 65536) return -1;
  if (!ej_fuzz_path[0]) /* memory-backed when possible: one file write per input */
    snprintf(ej_fuzz_path, sizeof ej_fuzz_path, "%s/ej_fuzz_csv.%d.csv", access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp",
             (int)getpid());
  const int dim = 1 + data[0] % 3;
  const ej_real spacing = (data[0] / 3) % 2 ? 0.01 : 0.0;
  FILE *f = fopen(ej_fuzz_path, "wb");
  if (!f) abort();
  if (size > 1 && fwrite(data + 1, 1, size - 1, f) != size - 1) abort();
  fclose(f);
  ej_loc where = {"fuzz.yaml", 1, 1};
  ej_points pts;
  ej_err rc = ej_points_read_csv(ej_fuzz_path, dim, spacing, &where, &pts);
  if (rc == EJ_OK) {
    /* Every accepted particle has finite coordinates and a positive volume and spacing. */
    for (ej_idx i = 0; i < pts.n; ++i) {
      for (int k = 0; k < 3; ++k)
        if (!(pts.x[3 * i + k] == pts.x[3 * i + k]) || (k >= dim && pts.x[3 * i + k] != 0)) abort();
      if (!(pts.vol[i] > 0) || !(pts.spacing[i] > 0) || !isfinite(pts.vol[i]) || !isfinite(pts.spacing[i])) abort();
    }
    ej_points_free(&pts);
  } else if (rc != EJ_ERR_INPUT && rc != EJ_ERR_MEM) {
    ej_error_print(stderr, "fuzz_csv", true);
    abort();
  }
  ej_error_clear();
  return 0;
}
