/* Shapes (primitives and CSG) parsed from scene nodes, lattice fill with region-wise spacing
 * and seeded jitter, and CSV particle import. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "scene_impl.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef enum ej_shape_kind {
  EJ_SHAPE_BOX,
  EJ_SHAPE_CYLINDER,
  EJ_SHAPE_SPHERE,
  EJ_SHAPE_HALF_SPACE,
  EJ_SHAPE_UNION,
  EJ_SHAPE_INTERSECT
} ej_shape_kind;

static const char *const ej_shape_words[] = {"box", "cylinder", "sphere", "half_space", "union", "intersect"};
#define EJ_SHAPE_NWORDS 6
/* Nesting deeper than this is surely a mistake, and unbounded recursion on crafted input is a
 * stack overflow. */
#define EJ_SHAPE_MAX_DEPTH 64

struct ej_shape {
  ej_shape_kind kind;
  ej_loc loc; /* file points into the document, which the scene keeps */
  int dim;
  /* box: lo, hi; cylinder: centre, unit axis; sphere: centre; half space: point, unit normal */
  ej_real p[3], q[3];
  ej_real r, h;
  int n_parts; /* union / intersect members */
  ej_shape **parts;
  int n_minus;
  const ej_shape **minus; /* subtracted shapes; minus_owned[k] false for other sets' shapes */
  bool *minus_owned;
};

const ej_loc *ej_shape_loc(const ej_shape *s) { return &s->loc; }

void ej_shape_destroy(ej_shape *s)
{
  if (!s) return;
  for (int k = 0; k < s->n_parts; ++k) ej_shape_destroy(s->parts[k]);
  ej_free(s->parts);
  for (int k = 0; k < s->n_minus; ++k)
    if (s->minus_owned[k]) ej_shape_destroy((ej_shape *)s->minus[k]);
  ej_free((void *)s->minus);
  ej_free(s->minus_owned);
  ej_free(s);
}

/* ------------------------------------------------------------------ node helpers */

static const char *ej_node_kind_word(const ej_node *n)
{
  switch (n->type) {
  case EJ_NODE_MAP: return "a map";
  case EJ_NODE_SEQ: return "a list";
  default: return "a scalar";
  }
}

static ej_err ej_node_length(const ej_node *n, const char *key, ej_real *v)
{
  if (n->type != EJ_NODE_SCALAR)
    return ej_error_input(&n->loc, "'%s' must be a length (a number with an optional unit such as mm), got %s",
                          key, ej_node_kind_word(n));
  EJ_TRY(ej_units_parse(n->text, "m", &n->loc, v));
  return EJ_OK;
}

ej_err ej_node_vector(const ej_node *n, int dim, const char *unit, ej_real v[3])
{
  v[0] = v[1] = v[2] = 0;
  bool ok = n->type == EJ_NODE_SEQ && (n->n == 3 || n->n == dim);
  if (!ok) {
    if (dim == 3) return ej_error_input(&n->loc, "expected a list of 3 numbers, got %s%s", ej_node_kind_word(n),
                                        n->type == EJ_NODE_SEQ ? " of another length" : "");
    return ej_error_input(&n->loc, "expected a list of %d or 3 numbers, got %s%s", dim, ej_node_kind_word(n),
                          n->type == EJ_NODE_SEQ ? " of another length" : "");
  }
  for (int k = 0; k < n->n; ++k) {
    const ej_node *it = n->items[k];
    if (it->type != EJ_NODE_SCALAR)
      return ej_error_input(&it->loc, "expected a number, got %s", ej_node_kind_word(it));
    EJ_TRY(ej_units_parse(it->text, unit, &it->loc, &v[k]));
  }
  return EJ_OK;
}

/* Unknown keys of a shape's parameter map, with the nearest allowed key suggested. */
static ej_err ej_shape_check_keys(const ej_node *m, const char *shape, const char *const *allowed, int n)
{
  for (int i = 0; i < m->n; ++i) {
    bool known = false;
    for (int k = 0; k < n; ++k) known = known || strcmp(m->keys[i], allowed[k]) == 0;
    if (known) continue;
    const char *near = ej_nearest_word(m->keys[i], allowed, n);
    if (near)
      return ej_error_input(&m->key_locs[i], "unknown key '%s' in %s; did you mean '%s'?", m->keys[i], shape, near);
    return ej_error_input(&m->key_locs[i], "unknown key '%s' in %s", m->keys[i], shape);
  }
  return EJ_OK;
}

static ej_real ej_dot(const ej_real a[3], const ej_real b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* ------------------------------------------------------------------ parsing */

static ej_err ej_shape_parse_at(const ej_node *node, int dim, const ej_shape_env *env, int depth, ej_shape **out);

static ej_err ej_parse_box(const ej_node *m, int dim, ej_shape *s)
{
  static const char *const keys[] = {"min", "max", "center", "size"};
  EJ_TRY(ej_shape_check_keys(m, "box", keys, 4));
  const ej_node *mn = ej_node_get(m, "min"), *mx = ej_node_get(m, "max");
  const ej_node *c = ej_node_get(m, "center"), *sz = ej_node_get(m, "size");
  if ((mn || mx) && (c || sz))
    return ej_error_input(&m->loc, "box takes either 'min' and 'max' or 'center' and 'size', not both");
  if (mn && mx) {
    EJ_TRY(ej_node_vector(mn, dim, "m", s->p));
    EJ_TRY(ej_node_vector(mx, dim, "m", s->q));
  } else if (c && sz) {
    ej_real cc[3], ss[3];
    EJ_TRY(ej_node_vector(c, dim, "m", cc));
    EJ_TRY(ej_node_vector(sz, dim, "m", ss));
    for (int k = 0; k < dim; ++k)
      if (!(ss[k] > 0)) return ej_error_input(&sz->loc, "box size must be > 0 in each of the %d used dimensions", dim);
    for (int k = 0; k < 3; ++k) {
      s->p[k] = cc[k] - 0.5 * ss[k];
      s->q[k] = cc[k] + 0.5 * ss[k];
    }
  } else {
    return ej_error_input(&m->loc, "box needs 'min' and 'max' (or 'center' and 'size')");
  }
  for (int k = 0; k < dim; ++k)
    if (!(s->p[k] < s->q[k]))
      return ej_error_input(mn ? &mx->loc : &sz->loc, "box min must be < max in %c (got %g and %g)", "xyz"[k],
                            s->p[k], s->q[k]);
  return EJ_OK;
}

static ej_err ej_parse_positive_length(const ej_node *m, const char *shape, const char *key, ej_real *v)
{
  const ej_node *n = ej_node_get(m, key);
  if (!n) return ej_error_input(&m->loc, "%s needs '%s'", shape, key);
  EJ_TRY(ej_node_length(n, key, v));
  if (!(*v > 0)) return ej_error_input(&n->loc, "%s %s must be > 0, got %g m", shape, key, *v);
  return EJ_OK;
}

static ej_err ej_parse_unit_vector(const ej_node *n, int dim, const char *shape, const char *key, ej_real v[3])
{
  EJ_TRY(ej_node_vector(n, dim, "1", v));
  ej_real len = sqrt(ej_dot(v, v));
  if (!(len > 0) || !isfinite(len)) return ej_error_input(&n->loc, "%s %s must be a non-zero vector", shape, key);
  for (int k = 0; k < 3; ++k) v[k] /= len;
  return EJ_OK;
}

static ej_err ej_parse_cylinder(const ej_node *m, int dim, ej_shape *s)
{
  static const char *const keys[] = {"base", "center", "axis", "radius", "height"};
  EJ_TRY(ej_shape_check_keys(m, "cylinder", keys, 5));
  const ej_node *base = ej_node_get(m, "base"), *ctr = ej_node_get(m, "center"), *axis = ej_node_get(m, "axis");
  if (base && ctr) return ej_error_input(&ctr->loc, "cylinder takes 'base' or 'center', not both");
  if (!base && !ctr) return ej_error_input(&m->loc, "cylinder needs 'base' (centre of its bottom face) or 'center'");
  ej_real at[3];
  EJ_TRY(ej_node_vector(base ? base : ctr, dim, "m", at));
  if (axis) {
    EJ_TRY(ej_parse_unit_vector(axis, dim, "cylinder", "axis", s->q));
  } else {
    s->q[0] = s->q[1] = 0;
    s->q[2] = 1;
  }
  EJ_TRY(ej_parse_positive_length(m, "cylinder", "radius", &s->r));
  EJ_TRY(ej_parse_positive_length(m, "cylinder", "height", &s->h));
  /* Stored by its centre so that the point test is symmetric. */
  for (int k = 0; k < 3; ++k) s->p[k] = base ? at[k] + 0.5 * s->h * s->q[k] : at[k];
  return EJ_OK;
}

static ej_err ej_parse_sphere(const ej_node *m, int dim, ej_shape *s)
{
  static const char *const keys[] = {"center", "radius"};
  EJ_TRY(ej_shape_check_keys(m, "sphere", keys, 2));
  const ej_node *c = ej_node_get(m, "center");
  if (!c) return ej_error_input(&m->loc, "sphere needs 'center'");
  EJ_TRY(ej_node_vector(c, dim, "m", s->p));
  EJ_TRY(ej_parse_positive_length(m, "sphere", "radius", &s->r));
  return EJ_OK;
}

static ej_err ej_parse_half_space(const ej_node *m, int dim, ej_shape *s)
{
  static const char *const keys[] = {"point", "normal"};
  EJ_TRY(ej_shape_check_keys(m, "half_space", keys, 2));
  const ej_node *p = ej_node_get(m, "point"), *n = ej_node_get(m, "normal");
  if (!p || !n) return ej_error_input(&m->loc, "half_space needs 'point' and 'normal' (pointing out of the material)");
  EJ_TRY(ej_node_vector(p, dim, "m", s->p));
  EJ_TRY(ej_parse_unit_vector(n, dim, "half_space", "normal", s->q));
  /* A normal along an unused axis makes every point of the scene's plane (line) inside. */
  ej_real in_plane = 0;
  for (int k = 0; k < dim; ++k) in_plane += s->q[k] * s->q[k];
  if (in_plane < 1e-24)
    return ej_error_input(&n->loc, "half_space normal has no component in the %d used dimension%s", dim,
                          dim > 1 ? "s" : "");
  return EJ_OK;
}

static ej_err ej_parse_members(const ej_node *seq, int dim, const ej_shape_env *env, int depth, const char *word,
                               ej_shape *s)
{
  if (seq->type != EJ_NODE_SEQ || seq->n == 0)
    return ej_error_input(&seq->loc, "%s takes a non-empty list of shapes, got %s", word,
                          seq->type == EJ_NODE_SEQ ? "an empty list" : ej_node_kind_word(seq));
  s->parts = ej_calloc((size_t)seq->n, sizeof *s->parts);
  EJ_ENSURE(s->parts, EJ_ERR_MEM, "out of memory");
  for (int k = 0; k < seq->n; ++k) {
    EJ_TRY(ej_shape_parse_at(seq->items[k], dim, env, depth + 1, &s->parts[k]));
    s->n_parts = k + 1;
  }
  return EJ_OK;
}

static ej_err ej_parse_minus(const ej_node *seq, int dim, const ej_shape_env *env, int depth, ej_shape *s)
{
  if (seq->type != EJ_NODE_SEQ)
    return ej_error_input(&seq->loc, "'minus' takes a list of shapes or set names, got %s", ej_node_kind_word(seq));
  s->minus = ej_calloc((size_t)seq->n, sizeof *s->minus);
  s->minus_owned = ej_calloc((size_t)seq->n, sizeof *s->minus_owned);
  EJ_ENSURE(s->minus && s->minus_owned, EJ_ERR_MEM, "out of memory");
  for (int k = 0; k < seq->n; ++k) {
    const ej_node *it = seq->items[k];
    if (it->type == EJ_NODE_SCALAR) {
      int before = ej_error_count();
      const ej_shape *other = env && env->lookup ? env->lookup(env->ctx, it->text, &it->loc) : NULL;
      if (!other) {
        if (ej_error_count() > before) EJ_FAIL(EJ_ERR_INPUT, NULL);
        const char *near = env ? ej_nearest_word(it->text, env->names, env->n_names) : NULL;
        if (near)
          return ej_error_input(&it->loc, "'minus' names undefined set '%s'; did you mean '%s'?", it->text, near);
        return ej_error_input(&it->loc, "'minus' names undefined set '%s'", it->text);
      }
      s->minus[k] = other;
    } else {
      ej_shape *sub = NULL;
      EJ_TRY(ej_shape_parse_at(it, dim, env, depth + 1, &sub));
      s->minus[k] = sub;
      s->minus_owned[k] = true;
    }
    s->n_minus = k + 1;
  }
  return EJ_OK;
}

static ej_err ej_shape_parse_at(const ej_node *node, int dim, const ej_shape_env *env, int depth, ej_shape **out)
{
  *out = NULL;
  if (depth > EJ_SHAPE_MAX_DEPTH) return ej_error_input(&node->loc, "shapes nested too deeply");
  if (node->type != EJ_NODE_MAP)
    return ej_error_input(&node->loc,
                          "expected a shape (a map with one of box, cylinder, sphere, half_space, union, intersect), "
                          "got %s",
                          ej_node_kind_word(node));
  int word = -1, body = -1, minus = -1;
  for (int i = 0; i < node->n; ++i) {
    const char *key = node->keys[i];
    if (strcmp(key, "minus") == 0) {
      minus = i;
      continue;
    }
    int w = -1;
    for (int k = 0; k < EJ_SHAPE_NWORDS; ++k)
      if (strcmp(key, ej_shape_words[k]) == 0) w = k;
    if (w < 0) {
      static const char *const cands[] = {"box", "cylinder", "sphere", "half_space", "union", "intersect", "minus"};
      const char *near = ej_nearest_word(key, cands, 7);
      if (near) return ej_error_input(&node->key_locs[i], "unknown shape '%s'; did you mean '%s'?", key, near);
      return ej_error_input(&node->key_locs[i],
                            "unknown shape '%s' (expected box, cylinder, sphere, half_space, union or intersect)", key);
    }
    if (word >= 0)
      return ej_error_input(&node->key_locs[i], "a shape has one kind, found both '%s' and '%s' (use union)",
                            ej_shape_words[word], key);
    word = w;
    body = i;
  }
  if (word < 0)
    return ej_error_input(&node->loc, "expected one of box, cylinder, sphere, half_space, union, intersect%s",
                          minus >= 0 ? " beside 'minus'" : "");

  ej_shape *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->kind = (ej_shape_kind)word;
  s->loc = node->loc;
  s->dim = dim;
  const ej_node *b = node->items[body];
  ej_err rc = EJ_OK;
  if (s->kind <= EJ_SHAPE_HALF_SPACE && b->type != EJ_NODE_MAP) {
    rc = ej_error_input(&b->loc, "%s takes a map of parameters, got %s", ej_shape_words[word], ej_node_kind_word(b));
    goto out_destroy_shape;
  }
  switch (s->kind) {
  case EJ_SHAPE_BOX: EJ_TRY_GOTO(rc, ej_parse_box(b, dim, s), out_destroy_shape); break;
  case EJ_SHAPE_CYLINDER: EJ_TRY_GOTO(rc, ej_parse_cylinder(b, dim, s), out_destroy_shape); break;
  case EJ_SHAPE_SPHERE: EJ_TRY_GOTO(rc, ej_parse_sphere(b, dim, s), out_destroy_shape); break;
  case EJ_SHAPE_HALF_SPACE: EJ_TRY_GOTO(rc, ej_parse_half_space(b, dim, s), out_destroy_shape); break;
  case EJ_SHAPE_UNION:
  case EJ_SHAPE_INTERSECT:
    EJ_TRY_GOTO(rc, ej_parse_members(b, dim, env, depth, ej_shape_words[word], s), out_destroy_shape);
    break;
  }
  if (minus >= 0) EJ_TRY_GOTO(rc, ej_parse_minus(node->items[minus], dim, env, depth, s), out_destroy_shape);
  *out = s;
  return EJ_OK;

out_destroy_shape:
  ej_shape_destroy(s);
  return rc;
}

ej_err ej_shape_parse_env(const ej_node *node, int dim, const ej_shape_env *env, ej_shape **out)
{
  EJ_ENSURE(node && out && dim >= 1 && dim <= 3, EJ_ERR_ARG, "bad arguments");
  EJ_TRY(ej_shape_parse_at(node, dim, env, 0, out));
  return EJ_OK;
}

typedef struct ej_simple_lookup {
  ej_shape_lookup_fn fn;
  void *ctx;
} ej_simple_lookup;

static const ej_shape *ej_simple_lookup_call(void *ctx, const char *name, const ej_loc *at)
{
  (void)at;
  const ej_simple_lookup *l = ctx;
  return l->fn ? l->fn(l->ctx, name) : NULL;
}

ej_err ej_shape_parse(const ej_node *node, int dim, ej_shape_lookup_fn lookup, void *ctx, ej_shape **out)
{
  ej_simple_lookup l = {lookup, ctx};
  ej_shape_env env = {.lookup = ej_simple_lookup_call, .ctx = &l};
  EJ_TRY(ej_shape_parse_env(node, dim, &env, out));
  return EJ_OK;
}

/* ------------------------------------------------------------------ point test and bounds */

bool ej_shape_contains(const ej_shape *s, const ej_real x[3])
{
  ej_real d[3] = {0, 0, 0};
  bool in = false;
  /* Unused components are taken at the shape's own reference point, so a 2D scene sees
   * the shape's section through that point (a z-axis cylinder is a disc). */
  if (s->kind != EJ_SHAPE_BOX && s->kind <= EJ_SHAPE_HALF_SPACE)
    for (int k = 0; k < s->dim; ++k) d[k] = x[k] - s->p[k];
  switch (s->kind) {
  case EJ_SHAPE_BOX:
    in = true;
    for (int k = 0; k < s->dim; ++k) in = in && x[k] >= s->p[k] && x[k] <= s->q[k];
    break;
  case EJ_SHAPE_SPHERE: in = ej_dot(d, d) <= s->r * s->r; break;
  case EJ_SHAPE_CYLINDER: {
    ej_real t = ej_dot(d, s->q);
    ej_real rad[3] = {d[0] - t * s->q[0], d[1] - t * s->q[1], d[2] - t * s->q[2]};
    in = fabs(t) <= 0.5 * s->h && ej_dot(rad, rad) <= s->r * s->r;
    break;
  }
  case EJ_SHAPE_HALF_SPACE: in = ej_dot(d, s->q) <= 0; break;
  case EJ_SHAPE_UNION:
    for (int k = 0; k < s->n_parts && !in; ++k) in = ej_shape_contains(s->parts[k], x);
    break;
  case EJ_SHAPE_INTERSECT:
    in = true;
    for (int k = 0; k < s->n_parts && in; ++k) in = ej_shape_contains(s->parts[k], x);
    break;
  }
  for (int k = 0; k < s->n_minus && in; ++k) in = !ej_shape_contains(s->minus[k], x);
  return in;
}

/* false when unbounded */
static bool ej_shape_box(const ej_shape *s, ej_real lo[3], ej_real hi[3])
{
  switch (s->kind) {
  case EJ_SHAPE_BOX:
    for (int k = 0; k < 3; ++k) lo[k] = s->p[k], hi[k] = s->q[k];
    return true;
  case EJ_SHAPE_SPHERE:
    for (int k = 0; k < 3; ++k) lo[k] = s->p[k] - s->r, hi[k] = s->p[k] + s->r;
    return true;
  case EJ_SHAPE_CYLINDER:
    for (int k = 0; k < 3; ++k) {
      ej_real a = s->q[k];
      ej_real e = 0.5 * s->h * fabs(a) + s->r * sqrt(fmax(0.0, 1 - a * a));
      lo[k] = s->p[k] - e;
      hi[k] = s->p[k] + e;
    }
    return true;
  case EJ_SHAPE_HALF_SPACE: return false;
  case EJ_SHAPE_UNION:
    for (int k = 0; k < 3; ++k) lo[k] = INFINITY, hi[k] = -INFINITY;
    for (int i = 0; i < s->n_parts; ++i) {
      ej_real l[3], h[3];
      if (!ej_shape_box(s->parts[i], l, h)) return false;
      for (int k = 0; k < 3; ++k) lo[k] = fmin(lo[k], l[k]), hi[k] = fmax(hi[k], h[k]);
    }
    return true;
  case EJ_SHAPE_INTERSECT: {
    bool any = false;
    for (int k = 0; k < 3; ++k) lo[k] = -INFINITY, hi[k] = INFINITY;
    for (int i = 0; i < s->n_parts; ++i) {
      ej_real l[3], h[3];
      if (!ej_shape_box(s->parts[i], l, h)) continue;
      any = true;
      for (int k = 0; k < 3; ++k) lo[k] = fmax(lo[k], l[k]), hi[k] = fmin(hi[k], h[k]);
    }
    return any;
  }
  }
  return false;
}

ej_err ej_shape_bounds(const ej_shape *s, ej_real lo[3], ej_real hi[3])
{
  if (!ej_shape_box(s, lo, hi))
    return ej_error_input(&s->loc, "shape is unbounded (a half_space must be intersected with a bounded shape)");
  for (int k = s->dim; k < 3; ++k) lo[k] = hi[k] = 0;
  return EJ_OK;
}

/* ------------------------------------------------------------------ points */

void ej_points_free(ej_points *p)
{
  if (!p) return;
  ej_free(p->x);
  ej_free(p->vol);
  ej_free(p->spacing);
  memset(p, 0, sizeof *p);
}

static uint64_t ej_splitmix64(uint64_t z)
{
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

ej_real ej_uniform(uint64_t seed, uint64_t counter)
{
  uint64_t z = ej_splitmix64(ej_splitmix64(seed) ^ counter);
  return (ej_real)(z >> 11) * 0x1.0p-53;
}

ej_real ej_lattice_cell_volume(ej_lattice lat, int dim, ej_real s)
{
  if (lat == EJ_LATTICE_HCP && dim == 3) return s * s * s / sqrt(2.0);
  if (lat == EJ_LATTICE_HCP && dim == 2) return s * s * sqrt(3.0) / 2;
  return dim == 1 ? s : dim == 2 ? s * s : s * s * s;
}

/* Grows three parallel arrays; capacity in points. */
static ej_err ej_points_push(ej_points *p, ej_idx *cap, const ej_real x[3], ej_real vol, ej_real s)
{
  if (p->n == *cap) {
    EJ_ENSURE(*cap < INT32_MAX / 2, EJ_ERR_INPUT, "too many particles");
    ej_idx nc = *cap ? 2 * *cap : 1024;
    ej_real *nx = ej_realloc(p->x, (size_t)nc * 3 * sizeof *nx);
    EJ_ENSURE(nx, EJ_ERR_MEM, "out of memory");
    p->x = nx;
    ej_real *nv = ej_realloc(p->vol, (size_t)nc * sizeof *nv);
    EJ_ENSURE(nv, EJ_ERR_MEM, "out of memory");
    p->vol = nv;
    ej_real *ns = ej_realloc(p->spacing, (size_t)nc * sizeof *ns);
    EJ_ENSURE(ns, EJ_ERR_MEM, "out of memory");
    p->spacing = ns;
    *cap = nc;
  }
  memcpy(&p->x[3 * (size_t)p->n], x, 3 * sizeof *x);
  p->vol[p->n] = vol;
  p->spacing[p->n] = s;
  ++p->n;
  return EJ_OK;
}

/* Region-wise spacing (docs/core.md, "Geometry"): the coarse lattice (the set's spacing)
 * is assigned cell by cell by its site: a coarse site inside the shape and in no refine region
 * is a particle; a coarse cell whose site lies in refine region r (the first that contains it)
 * is given up to region r, whose lattice then fills exactly that cell (its points inside the
 * shape). The refined zone is thus the union of the given-up coarse cells: the region boundary
 * snaps to coarse cell faces, and coarse and fine particles tile the shape without a gap or an
 * overlap (exactly when the coarse spacing is an integer multiple of the fine one on the cubic
 * lattice; within one fine spacing otherwise). In the coarse cells whose site is outside the
 * shape (cut by its surface; no coarse particle) a fine point is kept where its own first
 * region is r. Testing the fine points against the region everywhere instead left a gap (or an
 * overlap) of up to half a coarse spacing wherever the region boundary cut a coarse cell
 * (validation/tlpd_refine). */
typedef struct ej_lattice_pass {
  const ej_shape *shape;
  const ej_fill *f;
  const ej_real *lo; /* anchor */
  ej_real s;
  int region; /* -1: the coarse lattice; r: refine region r's lattice */
} ej_lattice_pass;

static bool ej_lattice_hcp(const ej_fill *f) { return f->lattice == EJ_LATTICE_HCP && f->dim > 1; }

/* Site (i, j, k) of the lattice of spacing s anchored at lo; the one formula for every pass,
 * so that a site recomputed from a point is bitwise the site the coarse pass tested. */
static void ej_lattice_site(const ej_fill *f, const ej_real *lo, ej_real s, int64_t i, int64_t j, int64_t k,
                            ej_real x[3])
{
  const int dim = f->dim;
  x[0] = x[1] = x[2] = 0;
  if (ej_lattice_hcp(f)) {
    /* ABAB stacking: odd rows shift half a spacing in x; odd layers shift by the
     * centroid of a triangle, (s/2, s/(2 sqrt 3)); x shifts are taken modulo s. */
    int odd = (int)(((j & 1) + (dim == 3 ? (k & 1) : 0)) & 1);
    x[0] = lo[0] + ((ej_real)i + 0.5 + 0.5 * odd) * s;
    x[1] = lo[1] + ((ej_real)j + 0.5) * (s * sqrt(3.0) / 2) + ((dim == 3 && (k & 1)) ? s / (2 * sqrt(3.0)) : 0);
    if (dim == 3) x[2] = lo[2] + ((ej_real)k + 0.5) * (s * sqrt(2.0 / 3.0));
  } else {
    int64_t idx[3] = {i, j, k};
    for (int d = 0; d < dim; ++d) x[d] = lo[d] + ((ej_real)idx[d] + 0.5) * s;
  }
}

/* The coarse site whose cell holds x: the cubic cell by floor, the hcp Voronoi cell by the
 * nearest site among the neighbours of the estimated index (ties: the first in index order). */
static void ej_coarse_site(const ej_fill *f, const ej_real *lo, const ej_real x[3], ej_real c[3])
{
  const ej_real s = f->spacing;
  if (!ej_lattice_hcp(f)) {
    int64_t idx[3] = {0, 0, 0};
    for (int d = 0; d < f->dim; ++d) {
      const double q = floor((x[d] - lo[d]) / s);
      idx[d] = (int64_t)(f->origin ? q : fmax(0.0, q)); /* a lattice through origin extends both ways */
    }
    ej_lattice_site(f, lo, s, idx[0], idx[1], idx[2], c);
    return;
  }
  const ej_real py = s * sqrt(3.0) / 2, pz = s * sqrt(2.0 / 3.0);
  int64_t k0 = f->dim == 3 ? (int64_t)floor((x[2] - lo[2]) / pz) : 0;
  int64_t j0 = (int64_t)floor((x[1] - lo[1]) / py);
  ej_real best = INFINITY;
  for (int64_t k = k0 - 1; k <= k0 + 1; ++k) {
    if ((k < 0 && !f->origin) || (f->dim < 3 && k != 0)) continue;
    for (int64_t j = j0 - 1; j <= j0 + 1; ++j) {
      if (j < 0 && !f->origin) continue;
      int64_t i0 = (int64_t)floor((x[0] - lo[0]) / s);
      for (int64_t i = i0 - 1; i <= i0 + 1; ++i) {
        if (i < 0 && !f->origin) continue;
        ej_real y[3];
        ej_lattice_site(f, lo, s, i, j, k, y);
        ej_real d2 = 0;
        for (int d = 0; d < f->dim; ++d) d2 += (y[d] - x[d]) * (y[d] - x[d]);
        if (d2 < best) {
          best = d2;
          memcpy(c, y, sizeof y);
        }
      }
    }
  }
}

/* First refine region containing x, -1 for none. */
static int ej_region_of(const ej_fill *f, const ej_real x[3])
{
  for (int r = 0; r < f->n_refine; ++r)
    if (ej_shape_contains(f->refine[r].region, x)) return r;
  return -1;
}

static bool ej_keep(const ej_lattice_pass *L, const ej_real x[3])
{
  if (!ej_shape_contains(L->shape, x)) return false;
  if (L->region < 0) return ej_region_of(L->f, x) < 0;
  ej_real c[3];
  ej_coarse_site(L->f, L->lo, x, c);
  /* a coarse cell whose site is outside the shape has no coarse particle to tile against (it
   * straddles the shape's surface): there the region itself decides, so that a region reaching
   * the surface is filled up to it */
  if (!ej_shape_contains(L->shape, c)) return ej_region_of(L->f, x) == L->region;
  return ej_region_of(L->f, c) == L->region;
}

/* Enumerates the lattice of L over the index range covering [blo, bhi] and keeps the points
 * ej_keep accepts. */
static ej_err ej_lattice_run(const ej_lattice_pass *L, const ej_real blo[3], const ej_real bhi[3], ej_points *out,
                             ej_idx *cap)
{
  const int dim = L->f->dim;
  const bool hcp = ej_lattice_hcp(L->f);
  const ej_real s = L->s;
  /* row and layer pitch */
  ej_real step[3] = {s, hcp ? s * sqrt(3.0) / 2 : s, hcp ? s * sqrt(2.0 / 3.0) : s};
  int64_t i0[3] = {0, 0, 0}, i1[3] = {0, 0, 0};
  double total = 1;
  for (int k = 0; k < dim; ++k) {
    /* one index of slack each side covers the hcp row offsets; the point test does the rest */
    double a = floor((blo[k] - L->lo[k]) / step[k]) - 1, b = ceil((bhi[k] - L->lo[k]) / step[k]) + 1;
    if (!(b >= a) || !isfinite(a) || !isfinite(b)) return EJ_OK;
    if (a < 0 && !L->f->origin) a = 0; /* from the shape's lowest corner: no site below it */
    if (b - a > 4e9) b = a + 4e9; /* the total check below rejects it */
    i0[k] = (int64_t)a;
    i1[k] = (int64_t)b;
    total *= (double)(i1[k] - i0[k] + 1);
  }
  if (total > 2e9)
    return ej_error_input(&L->shape->loc, "spacing %g m is too fine for this shape: %.3g lattice points to test", s,
                          total);
  const ej_real vol = ej_lattice_cell_volume(L->f->lattice, dim, s);
  for (int64_t k = i0[2]; k <= i1[2]; ++k)
    for (int64_t j = i0[1]; j <= i1[1]; ++j)
      for (int64_t i = i0[0]; i <= i1[0]; ++i) {
        ej_real x[3];
        ej_lattice_site(L->f, L->lo, s, i, j, k, x);
        if (ej_keep(L, x)) EJ_TRY(ej_points_push(out, cap, x, vol, s));
      }
  return EJ_OK;
}

/* Kernel number density n_i = sum_j W(|x_i - x_j|, h_ij) of the points x (self included), cubic
 * spline (Monaghan 1992) with h_ij = 0.65 (s_i + s_j), i.e. 1.3 times the pair's mean spacing. */
static ej_err ej_number_density(ej_nbrlist *L, int dim, const ej_real *x, const ej_real *sp, const ej_real *radius,
                                ej_idx n, ej_real *nd)
{
  EJ_TRY(ej_nbrlist_build(L, dim, x, radius, n, x, radius, n, 0.0, false));
  const ej_real sigma = dim == 1 ? 2.0 / 3.0 : dim == 2 ? 10.0 / (7.0 * M_PI) : 1.0 / M_PI;
  const ej_off *off = L->pub.off;
  const ej_idx *idx = L->pub.idx;
  for (ej_idx i = 0; i < n; ++i) {
    ej_real sum = 0.0;
    for (ej_off k = off[i]; k < off[i + 1]; ++k) { /* the list includes i itself (same = false) */
      const ej_idx j = idx[k];
      ej_real r2 = 0.0;
      for (int c = 0; c < dim; ++c) {
        const ej_real d = x[3 * (size_t)i + c] - x[3 * (size_t)j + c];
        r2 += d * d;
      }
      const ej_real h = 0.65 * (sp[i] + sp[j]);
      sum += sigma * ej_spline_shape(sqrt(r2) / h) / (dim == 1 ? h : dim == 2 ? h * h : h * h * h);
    }
    nd[i] = sum;
  }
  return EJ_OK;
}

/* jitter_volume: kernel. A jittered particle keeps its lattice cell's mass by default, so the
 * cloud's density is off by up to the jitter per axis wherever the particles bunch or spread: a
 * continuity density that starts from the scene's uniform rho keeps that error (validation/sod
 * README, "Hard case: jittered lattice"). Here V_i = V_cell,i n_lattice,i / n_jittered,i, the ratio
 * of the kernel number densities at the particle before and after the jitter (the lattice sum
 * cancels the truncation of both at the shape's boundary and the kernel's lattice bias), then one
 * factor restores the set's total volume. x0: the unjittered positions. Why h = 1.3 spacings
 * (docs/core.md, "Geometry"): on jitter 0.3 clouds, among 0.8-2 spacings, it gives the SPH kernel
 * sums sum_j V_j W_ij at the sph method's default h (1D 2, 2D 1.5, 3D 1.3 spacings) the closest to 1
 * in 1D and within 20 % (2D) and 26 % (3D) of the best, and the 1D Sod hard case passes. */
static ej_err ej_kernel_volumes(int dim, const ej_real *x0, ej_points *out)
{
  const ej_idx n = out->n;
  ej_err rc = EJ_OK;
  ej_nbrlist *L = NULL;
  ej_real *radius = ej_malloc(sizeof(ej_real) * (size_t)n), *n0 = ej_malloc(sizeof(ej_real) * (size_t)n);
  ej_real *n1 = ej_malloc(sizeof(ej_real) * (size_t)n);
  if (!radius || !n0 || !n1) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
    goto out_free;
  }
  /* support of the pair (i, j): 2 h_ij = 1.3 (s_i + s_j) <= max(2.6 s_i, 2.6 s_j) */
  for (ej_idx i = 0; i < n; ++i) radius[i] = 2.6 * out->spacing[i];
  EJ_TRY_GOTO(rc, ej_nbrlist_create(&L), out_free);
  EJ_TRY_GOTO(rc, ej_number_density(L, dim, x0, out->spacing, radius, n, n0), out_free);
  EJ_TRY_GOTO(rc, ej_number_density(L, dim, out->x, out->spacing, radius, n, n1), out_free);
  double before = 0.0, after = 0.0;
  for (ej_idx i = 0; i < n; ++i) {
    before += out->vol[i];
    out->vol[i] *= n0[i] / n1[i]; /* both > 0: the self term */
    after += out->vol[i];
  }
  const ej_real scale = (ej_real)(before / after);
  for (ej_idx i = 0; i < n; ++i) out->vol[i] *= scale;
out_free:
  ej_nbrlist_destroy(L);
  ej_free(radius);
  ej_free(n0);
  ej_free(n1);
  return rc;
}

ej_err ej_shape_fill(const ej_shape *shape, const ej_fill *f, ej_points *out)
{
  memset(out, 0, sizeof *out);
  EJ_ENSURE(shape && f && f->dim >= 1 && f->dim <= 3, EJ_ERR_ARG, "bad arguments");
  EJ_ENSURE(f->spacing > 0, EJ_ERR_ARG, "spacing must be > 0");
  ej_real lo[3], hi[3];
  EJ_TRY(ej_shape_bounds(shape, lo, hi));
  /* the anchor of every lattice of the fill: the shape's lowest corner, or the given origin (the
   * enumeration below then runs over negative indices too) */
  ej_real anchor[3];
  for (int k = 0; k < 3; ++k) anchor[k] = f->origin && k < f->dim ? f->origin[k] : lo[k];
  ej_idx cap = 0;
  ej_err rc = EJ_OK;
  ej_lattice_pass coarse = {shape, f, anchor, f->spacing, -1};
  EJ_TRY_GOTO(rc, ej_lattice_run(&coarse, lo, hi, out, &cap), out_free_points);
  for (int r = 0; r < f->n_refine; ++r) {
    ej_real rlo[3], rhi[3];
    if (ej_shape_box(f->refine[r].region, rlo, rhi)) {
      /* the given-up coarse cells reach past the region by less than one coarse spacing */
      for (int k = 0; k < 3; ++k)
        rlo[k] = fmax(rlo[k] - f->spacing, lo[k]), rhi[k] = fmin(rhi[k] + f->spacing, hi[k]);
    } else {
      memcpy(rlo, lo, sizeof rlo);
      memcpy(rhi, hi, sizeof rhi);
    }
    EJ_ENSURE(f->refine[r].spacing > 0, EJ_ERR_ARG, "refine spacing must be > 0");
    ej_lattice_pass fine = {shape, f, anchor, f->refine[r].spacing, r};
    EJ_TRY_GOTO(rc, ej_lattice_run(&fine, rlo, rhi, out, &cap), out_free_points);
  }
  /* After selection, so that the particle count never depends on the jitter. */
  if (f->jitter > 0) {
    ej_real *x0 = NULL;
    if (f->jitter_volume == EJ_JITTER_VOLUME_KERNEL && out->n > 0) {
      x0 = ej_malloc(sizeof(ej_real) * 3 * (size_t)out->n);
      if (!x0) {
        rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
        goto out_free_points;
      }
      memcpy(x0, out->x, sizeof(ej_real) * 3 * (size_t)out->n);
    }
    for (ej_idx p = 0; p < out->n; ++p)
      for (int k = 0; k < f->dim; ++k)
        out->x[3 * (size_t)p + k] += (ej_uniform(f->seed, 3 * (uint64_t)p + (uint64_t)k) - 0.5) * f->jitter *
                                     out->spacing[p];
    if (x0) {
      rc = ej_kernel_volumes(f->dim, x0, out);
      ej_free(x0);
      if (rc != EJ_OK) goto out_free_points;
    }
  }
  return EJ_OK;

out_free_points:
  ej_points_free(out);
  return rc;
}

/* ------------------------------------------------------------------ CSV import */

enum { EJ_COL_X, EJ_COL_Y, EJ_COL_Z, EJ_COL_VOL, EJ_COL_SPACING, EJ_NCOLS };
static const char *const ej_col_names[EJ_NCOLS] = {"x", "y", "z", "vol", "spacing"};

/* Printable excerpt of untrusted bytes for a message. */
static void ej_excerpt(char *dst, size_t cap, const char *src, size_t len)
{
  size_t n = 0, max = cap > 4 ? cap - 4 : 0;
  for (size_t i = 0; i < len && n < max; ++i) {
    unsigned char c = (unsigned char)src[i];
    dst[n++] = (c >= 32 && c < 127) ? (char)c : '?';
  }
  if (len > max && cap >= 4) {
    memcpy(dst + n, "...", 3);
    n += 3;
  }
  dst[n] = 0;
}

static bool ej_is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/* Trims blanks of [*b, *e). */
static void ej_trim(const char *t, size_t *b, size_t *e)
{
  while (*b < *e && ej_is_blank(t[*b])) ++*b;
  while (*e > *b && ej_is_blank(t[*e - 1])) --*e;
}

static ej_err ej_read_file(const char *path, const ej_loc *where, char **text, size_t *len)
{
  FILE *fp = fopen(path, "rb");
  if (!fp) return ej_error_input(where, "cannot read particle file '%s': %s", path, strerror(errno));
  char *buf = NULL;
  size_t n = 0, cap = 0;
  ej_err rc = EJ_OK;
  for (;;) {
    if (cap - n < 65536) {
      if (cap > (size_t)INT_MAX) {
        rc = ej_error_input(where, "particle file '%s' is too large (over 2 GiB)", path);
        goto out_free_buf;
      }
      cap = cap ? 2 * cap : 65536;
      char *nb = ej_realloc(buf, cap + 1);
      if (!nb) {
        rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
        goto out_free_buf;
      }
      buf = nb;
    }
    size_t got = fread(buf + n, 1, cap - n, fp);
    n += got;
    if (got == 0) break;
  }
  if (ferror(fp)) {
    rc = ej_error_input(where, "error reading particle file '%s'", path);
    goto out_free_buf;
  }
  fclose(fp);
  buf[n] = 0;
  *text = buf;
  *len = n;
  return EJ_OK;

out_free_buf:
  ej_free(buf);
  fclose(fp);
  return rc;
}

typedef struct ej_csv {
  const char *path;
  const char *t;
  size_t len;
  int ncol;
  int col_kind[EJ_NCOLS]; /* kind of the k-th column in the file */
} ej_csv;

static ej_err ej_csv_header(ej_csv *c, size_t *pos, bool have[EJ_NCOLS])
{
  size_t p = *pos, end = p;
  while (end < c->len && c->t[end] != '\n') ++end;
  ej_loc at = {c->path, 1, 1};
  size_t b0 = p, e0 = end;
  ej_trim(c->t, &b0, &e0);
  if (b0 == e0)
    return ej_error_input(&at, "particle file is empty: expected a header line of column names (x, y, z, vol, spacing)");
  size_t b = p;
  for (;;) {
    size_t e = b;
    while (e < end && c->t[e] != ',') ++e;
    size_t nb = b, ne = e;
    ej_trim(c->t, &nb, &ne);
    ej_loc cl = {c->path, 1, (int)(nb - *pos) + 1};
    int kind = -1;
    for (int k = 0; k < EJ_NCOLS; ++k)
      if (ne - nb == strlen(ej_col_names[k]) && memcmp(c->t + nb, ej_col_names[k], ne - nb) == 0) kind = k;
    char name[48];
    ej_excerpt(name, sizeof name, c->t + nb, ne - nb);
    if (kind < 0) {
      const char *near = ne - nb < 40 ? ej_nearest_word(name, ej_col_names, EJ_NCOLS) : NULL;
      if (near) return ej_error_input(&cl, "unknown column '%s'; did you mean '%s'?", name, near);
      return ej_error_input(&cl, "unknown column '%s' (expected x, y, z, vol, spacing)", name);
    }
    if (have[kind]) return ej_error_input(&cl, "column '%s' appears twice", name);
    if (c->ncol == EJ_NCOLS) return ej_error_input(&cl, "too many columns");
    have[kind] = true;
    c->col_kind[c->ncol++] = kind;
    if (e >= end) break;
    b = e + 1;
  }
  *pos = end < c->len ? end + 1 : end;
  return EJ_OK;
}

ej_err ej_points_read_csv(const char *path, int dim, ej_real spacing, const ej_loc *where, ej_points *out)
{
  memset(out, 0, sizeof *out);
  EJ_ENSURE(path && out && dim >= 1 && dim <= 3, EJ_ERR_ARG, "bad arguments");
  char *text = NULL;
  size_t len = 0;
  EJ_TRY(ej_read_file(path, where, &text, &len));
  ej_err rc = EJ_OK;
  ej_csv c = {.path = path, .t = text, .len = len};
  size_t pos = 0;
  if (len >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0) pos = 3; /* UTF-8 byte-order mark */
  bool have[EJ_NCOLS] = {false};
  EJ_TRY_GOTO(rc, ej_csv_header(&c, &pos, have), out_free_text);
  for (int k = 0; k < dim; ++k)
    if (!have[k]) {
      ej_loc at = {path, 1, 1};
      rc = ej_error_input(&at, "particle file lacks column '%s' (a %dD scene needs %s)", ej_col_names[k], dim,
                          dim == 1 ? "x" : dim == 2 ? "x and y" : "x, y and z");
      goto out_free_text;
    }
  if (!have[EJ_COL_VOL] && !have[EJ_COL_SPACING] && !(spacing > 0)) {
    rc = ej_error_input(where, "particle file '%s' has no 'vol' or 'spacing' column: give the set a 'spacing'", path);
    goto out_free_text;
  }
  ej_idx cap = 0;
  int line = 1;
  while (pos < len) {
    ++line;
    size_t end = pos;
    while (end < len && text[end] != '\n') ++end;
    size_t lb = pos, le = end;
    ej_trim(text, &lb, &le);
    size_t start = pos;
    pos = end < len ? end + 1 : end;
    if (lb == le) continue;
    ej_real val[EJ_NCOLS] = {0};
    int ncol = 0;
    size_t b = start;
    for (;;) {
      size_t e = b;
      while (e < end && text[e] != ',') ++e;
      if (ncol < c.ncol) {
        size_t nb = b, ne = e;
        ej_trim(text, &nb, &ne);
        ej_loc at = {path, line, (int)(nb - start) + 1};
        const char *cname = ej_col_names[c.col_kind[ncol]];
        char num[64];
        char *stop = NULL;
        bool ok = ne > nb && ne - nb < sizeof num;
        if (ok) {
          memcpy(num, text + nb, ne - nb);
          num[ne - nb] = 0;
          val[c.col_kind[ncol]] = strtod(num, &stop);
          ok = stop == num + (ne - nb) && isfinite(val[c.col_kind[ncol]]);
        }
        if (!ok) {
          char got[40];
          ej_excerpt(got, sizeof got, text + nb, ne - nb);
          rc = ej_error_input(&at, "expected a number in column '%s', got '%s'", cname, got);
          goto out_free_points;
        }
        if ((c.col_kind[ncol] == EJ_COL_VOL || c.col_kind[ncol] == EJ_COL_SPACING) && !(val[c.col_kind[ncol]] > 0)) {
          rc = ej_error_input(&at, "column '%s' must be > 0, got %g", cname, val[c.col_kind[ncol]]);
          goto out_free_points;
        }
      }
      ++ncol;
      if (e >= end) break;
      b = e + 1;
    }
    if (ncol != c.ncol) {
      ej_loc at = {path, line, 1};
      rc = ej_error_input(&at, "line has %d value%s, expected %d (one per column of the header)", ncol,
                          ncol == 1 ? "" : "s", c.ncol);
      goto out_free_points;
    }
    if (line == INT_MAX) {
      ej_loc at = {path, line, 1};
      rc = ej_error_input(&at, "too many lines");
      goto out_free_points;
    }
    ej_real x[3] = {0, 0, 0};
    for (int k = 0; k < dim; ++k) x[k] = val[k];
    ej_real s = have[EJ_COL_SPACING] ? val[EJ_COL_SPACING]
                : have[EJ_COL_VOL]   ? pow(val[EJ_COL_VOL], 1.0 / dim)
                                     : spacing;
    ej_real vol = have[EJ_COL_VOL] ? val[EJ_COL_VOL] : pow(s, dim);
    /* A spacing of 1e-200 or 1e200 m is a number, but its cube is no volume (found by fuzzing). */
    if (!(vol > 0 && isfinite(vol) && s > 0 && isfinite(s))) {
      ej_loc at = {path, line, 1};
      rc = ej_error_input(&at, "particle volume %g m^%d and spacing %g m out of range (spacing^%d must be a positive "
                               "finite number)", vol, dim, s, dim);
      goto out_free_points;
    }
    EJ_TRY_GOTO(rc, ej_points_push(out, &cap, x, vol, s), out_free_points);
  }
  if (out->n == 0) {
    ej_loc at = {path, line, 1};
    rc = ej_error_input(&at, "particle file has a header but no rows of particles");
    goto out_free_points;
  }
  ej_free(text);
  return EJ_OK;

out_free_points:
  ej_points_free(out);
out_free_text:
  ej_free(text);
  return rc;
}
