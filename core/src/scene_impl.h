/* Private interface between scene.c and geometry.c (lattice fill, CSV import, shapes that
 * subtract other sets). Not installed; include after core_impl.h. */
#ifndef EJ_SCENE_IMPL_H
#define EJ_SCENE_IMPL_H

#include "core_impl.h"

/* How a shape resolves set names in "minus" lists. lookup returns the named set's shape or
 * NULL; when it returns NULL after pushing an error itself (a cycle, a set without a shape)
 * the parse propagates that error, otherwise it reports an unknown set at `at` and suggests
 * the nearest of names. */
typedef struct ej_shape_env {
  const ej_shape *(*lookup)(void *ctx, const char *name, const ej_loc *at);
  void *ctx;
  const char *const *names;
  int n_names;
} ej_shape_env;

ej_err ej_shape_parse_env(const ej_node *node, int dim, const ej_shape_env *env, ej_shape **out);

/* Parses a vector of dim or 3 numbers (each may carry a unit of `unit`); missing components
 * are 0. */
ej_err ej_node_vector(const ej_node *node, int dim, const char *unit, ej_real v[3]);

/* Lattice fill of shape (see ej_scene_set_points). An empty result is not an error here: the
 * caller knows the set's name. */
typedef struct ej_fill {
  int dim;
  ej_lattice lattice;
  ej_real spacing;
  const ej_refine *refine;
  int n_refine;
  ej_real jitter; /* fraction of the local spacing */
  uint64_t seed;
  const ej_real *origin; /* a cell corner of every lattice of the fill; NULL: the shape's lowest corner */
  ej_jitter_volume jitter_volume; /* volumes of the jittered particles (ej_shape_fill) */
} ej_fill;
ej_err ej_shape_fill(const ej_shape *shape, const ej_fill *f, ej_points *out);

/* Volume of one lattice cell: s^dim (cubic), s^3/sqrt(2) (hcp 3D), s^2 sqrt(3)/2 (hcp 2D). */
ej_real ej_lattice_cell_volume(ej_lattice lat, int dim, ej_real s);

/* Reads a CSV particle file: header of column names (x, y, z, vol, spacing), then rows of
 * numbers. spacing > 0 supplies volume and spacing when the file has no such columns; where
 * is the scene location that names the file (for errors about the file as a whole). */
ej_err ej_points_read_csv(const char *path, int dim, ej_real spacing, const ej_loc *where, ej_points *out);

/* Deterministic counter-based uniform number in [0, 1). */
ej_real ej_uniform(uint64_t seed, uint64_t counter);

#endif /* EJ_SCENE_IMPL_H */
