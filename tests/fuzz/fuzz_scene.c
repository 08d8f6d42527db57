/* libFuzzer harness: YAML scene parser and validator (ej_doc_parse_string + ej_scene_from_doc)
 * with a registry holding every in-tree plugin, statically linked (no dlopen).
 * Built by tests/fuzz/build.sh (make fuzz); fuzz_plugins.h is generated from plugins/. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "fuzz_plugins.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Lattice fill of every set of a valid scene (shapes, CSG, refinement, jitter) when it makes at
 * most about 2e4 points; sets read from files are left to fuzz_csv (a scene must not make the
 * harness read arbitrary paths). Filled points must be finite with positive volume. */
static void ej_fuzz_fill(const ej_scene *scene)
{
  for (int i = 0; i < scene->n_sets; ++i) {
    const ej_scene_set *s = &scene->sets[i];
    if (s->file || !s->shape) continue;
    ej_real lo[3], hi[3], sp = s->spacing;
    for (int k = 0; k < s->n_refine; ++k) sp = s->refine[k].spacing < sp ? s->refine[k].spacing : sp;
    const int depth = ej_error_count();
    if (ej_shape_bounds(s->shape, lo, hi) != EJ_OK) {
      ej_error_truncate(depth);
      continue;
    }
    double est = 1;
    for (int k = 0; k < scene->dimension; ++k) est *= (hi[k] - lo[k]) / (0.8 * sp) + 3;
    if (!(est < 2e4)) continue;
    ej_points pts;
    ej_err rc = ej_scene_set_points(scene, i, &pts);
    if (rc == EJ_OK) {
      for (ej_idx p = 0; p < pts.n; ++p) {
        for (int k = 0; k < 3; ++k)
          if (!isfinite(pts.x[3 * p + k])) abort();
        if (!(pts.vol[p] > 0) || !isfinite(pts.vol[p]) || !(pts.spacing[p] > 0)) abort();
      }
      ej_points_free(&pts);
    } else if (rc != EJ_ERR_INPUT) {
      ej_error_print(stderr, "fuzz_scene", true);
      abort();
    }
    ej_error_truncate(depth);
  }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  if (size > 65536) return -1;
  char *text = malloc(size + 1);
  if (!text) return 0;
  memcpy(text, data, size);
  text[size] = 0;
  ej_registry *reg = NULL;
  if (ej_registry_create(&reg) != EJ_OK || ej_registry_set_path(reg, "") != EJ_OK) abort();
  for (size_t k = 0; k < sizeof ej_fuzz_plugins / sizeof ej_fuzz_plugins[0]; ++k)
    if (ej_registry_add_static(reg, ej_fuzz_plugins[k]()) != EJ_OK) abort();
  ej_doc *doc = NULL;
  if (ej_doc_parse_string("fuzz.yaml", text, &doc) == EJ_OK) {
    ej_scene *scene = NULL;
    ej_err rc = ej_scene_from_doc(doc, reg, &scene); /* takes doc */
    /* A validator must answer with an input error, never with an internal one. */
    if (rc == EJ_ERR_INTERNAL || rc == EJ_ERR_ARG) {
      ej_error_print(stderr, "fuzz_scene", true);
      abort();
    }
    if (rc == EJ_OK) {
      ej_fuzz_fill(scene);
      ej_scene_free(scene);
    }
  }
  ej_error_clear();
  ej_registry_destroy(reg);
  free(text);
  return 0;
}
