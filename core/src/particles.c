/* Particle sets: structure of arrays, fields declared by name and allocated only when a
 * plugin of the scene declares them (DESIGN.md "Particle sets"). Owned particles come first,
 * ghost images (symmetry, periodic) after them. */
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core_impl.h"

const char *ej_field_kind_name(ej_field_kind k)
{
  switch (k) {
  case EJ_SCALAR: return "scalar";
  case EJ_VEC3: return "vec3";
  case EJ_SYM6: return "sym6";
  case EJ_TENSOR9: return "tensor9";
  case EJ_INT: return "int";
  }
  return "unknown";
}

static int ej_kind_ncomp(ej_field_kind k) { return k == EJ_INT ? 1 : (int)k; }
static size_t ej_kind_bytes(ej_field_kind k) { return k == EJ_INT ? sizeof(int32_t) : sizeof(ej_real); }

ej_err ej_set_create(const char *name, int index, int dim, ej_set **out)
{
  ej_set *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->name = ej_strdup(name);
  s->index = index;
  s->dim = dim;
  s->f_x0 = -1;
  /* until the simulation knows what the method writes: every field, every time */
  s->ghost_dirty = s->step_mask = EJ_ALL_FIELDS;
  for (int k = 0; k <= EJ_MAX_PASS_MASKS; ++k) s->pass_mask[k] = EJ_ALL_FIELDS;
  ej_err rc;
  static const ej_field_decl base[] = {
      {.name = "x", .kind = EJ_VEC3, .flags = EJ_FIELD_OUTPUT | EJ_FIELD_POSITION, .unit = "m", .doc = "position"},
      {.name = "v", .kind = EJ_VEC3, .flags = EJ_FIELD_OUTPUT, .unit = "m/s", .doc = "velocity"},
      {.name = "a", .kind = EJ_VEC3, .unit = "m/s^2", .doc = "acceleration"},
      {.name = "m", .kind = EJ_SCALAR, .unit = "kg", .doc = "mass"},
      {.name = "vol0", .kind = EJ_SCALAR, .unit = "m^3", .doc = "initial volume"},
      {.name = "id", .kind = EJ_INT, .flags = EJ_FIELD_OUTPUT, .unit = "1", .doc = "particle id"},
      {.name = "x_build", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "m",
       .doc = "position at the last neighbour rebuild"},
      {.name = "r_build", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "m",
       .doc = "search radius at the last neighbour rebuild"},
      {.name = "v_half", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST | EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "mid-step velocity"},
  };
  int *slots[] = {&s->f_x, &s->f_v, &s->f_a, &s->f_m, &s->f_vol0, &s->f_id, &s->f_xb, &s->f_rb, NULL};
  for (size_t k = 0; k < sizeof base / sizeof base[0]; ++k) {
    int idx;
    EJ_TRY_GOTO(rc, ej_set_add_field(s, &base[k], &idx), out_destroy);
    if (slots[k]) *slots[k] = idx;
  }
  EJ_ENSURE(s->name, EJ_ERR_MEM, "out of memory");
  *out = s;
  return EJ_OK;
out_destroy:
  ej_set_destroy(s);
  return rc;
}

void ej_set_destroy(ej_set *s)
{
  if (!s) return;
  for (int k = 0; k < s->n_fields; ++k) ej_free(s->fields[k].data);
  ej_nbrlist_destroy(s->list);
  ej_free(s->radius);
  ej_free(s->ghost_src);
  ej_free(s->ghost_xf);
  ej_free(s->bc_mask);
  ej_free(s->bond_flags);
  ej_free(s->perm_tmp);
  ej_free(s->name);
  ej_free(s);
}

/* FNV-1a, 32 bits (Fowler, Noll, Vo): the hash of the field-name table. */
static uint32_t ej_name_hash(const char *name)
{
  uint32_t h = 2166136261u;
  for (const unsigned char *c = (const unsigned char *)name; *c; ++c) h = (h ^ *c) * 16777619u;
  return h;
}

#define EJ_FTAB_MASK (2 * EJ_MAX_FIELDS - 1)

int ej_set_find_field(const ej_set *s, const char *name)
{
  const uint32_t h = ej_name_hash(name);
  /* at most EJ_MAX_FIELDS of the 2 EJ_MAX_FIELDS slots are used: the probe meets an empty slot */
  for (uint32_t q = h & EJ_FTAB_MASK;; q = (q + 1) & EJ_FTAB_MASK) {
    const int k = (int)s->ftab[q] - 1;
    if (k < 0) return -1;
    if (s->fhash[k] == h && !strcmp(s->fields[k].name, name)) return k;
  }
}

/* Enters field k (already named) into the lookup table. */
static void ej_set_index_field(ej_set *s, int k)
{
  const uint32_t h = ej_name_hash(s->fields[k].name);
  s->fhash[k] = h;
  uint32_t q = h & EJ_FTAB_MASK;
  while (s->ftab[q]) q = (q + 1) & EJ_FTAB_MASK;
  s->ftab[q] = (uint8_t)(k + 1);
}

static ej_err ej_set_alloc_field(ej_set *s, ej_field *f)
{
  size_t bytes = (size_t)s->cap * (size_t)f->ncomp * ej_kind_bytes(f->kind);
  f->data = ej_calloc(1, bytes ? bytes : 1);
  EJ_ENSURE(f->data, EJ_ERR_MEM, "out of memory for field '%s' of set '%s'", f->name, s->name);
  return EJ_OK;
}

static ej_err ej_set_push_field(ej_set *s, const char *name, ej_field_kind kind, unsigned flags, const char *unit,
                                ej_energy_role energy, int *index)
{
  EJ_ENSURE(s->n_fields < EJ_MAX_FIELDS, EJ_ERR_UNSUPPORTED, "set '%s': more than %d fields", s->name,
            EJ_MAX_FIELDS);
  EJ_ENSURE(strlen(name) < EJ_FIELD_NAME_LEN, EJ_ERR_PLUGIN, "field name '%s' is too long", name);
  ej_field *f = &s->fields[s->n_fields];
  memset(f, 0, sizeof *f);
  strcpy(f->name, name);
  f->kind = kind;
  f->ncomp = ej_kind_ncomp(kind);
  f->flags = flags;
  f->unit = unit;
  f->energy = energy;
  f->rate = f->rate_of = f->half = -1;
  EJ_TRY(ej_set_alloc_field(s, f));
  ej_set_index_field(s, s->n_fields);
  *index = s->n_fields++;
  return EJ_OK;
}

ej_err ej_set_add_field(ej_set *s, const ej_field_decl *d, int *index)
{
  EJ_ENSURE(d && d->name && d->name[0], EJ_ERR_PLUGIN, "field declaration without a name");
  EJ_ENSURE(d->kind == EJ_SCALAR || d->kind == EJ_VEC3 || d->kind == EJ_SYM6 || d->kind == EJ_TENSOR9 ||
                d->kind == EJ_INT,
            EJ_ERR_PLUGIN, "field '%s': invalid kind %d", d->name, (int)d->kind);
  int k = ej_set_find_field(s, d->name);
  if (k >= 0) {
    ej_field *f = &s->fields[k];
    EJ_ENSURE(f->kind == d->kind, EJ_ERR_PLUGIN, "set '%s': field '%s' declared with two different kinds", s->name,
              d->name);
    f->flags |= d->flags & (EJ_FIELD_OUTPUT);
    if (d->energy != EJ_ENERGY_NONE) f->energy = d->energy;
    if (index) *index = k;
    if (!d->rate || f->rate >= 0) return EJ_OK;
  } else {
    EJ_TRY(ej_set_push_field(s, d->name, d->kind, d->flags, d->unit, d->energy, &k));
    if (index) *index = k;
    if (!strcmp(d->name, "x0")) s->f_x0 = k;
  }
  if (d->rate) {
    EJ_ENSURE(d->kind != EJ_INT, EJ_ERR_PLUGIN, "field '%s': integer fields cannot have a rate", d->name);
    int r = ej_set_find_field(s, d->rate);
    if (r < 0) EJ_TRY(ej_set_push_field(s, d->rate, d->kind, EJ_FIELD_NO_GHOST, NULL, EJ_ENERGY_NONE, &r));
    EJ_ENSURE(s->fields[r].kind == d->kind && s->fields[r].rate_of < 0, EJ_ERR_PLUGIN,
              "set '%s': rate field '%s' conflicts with another field", s->name, d->rate);
    char hname[EJ_FIELD_NAME_LEN];
    int len = snprintf(hname, sizeof hname, "%s_half", d->name);
    EJ_ENSURE(len < (int)sizeof hname, EJ_ERR_PLUGIN, "field name '%s' is too long", d->name);
    int h;
    EJ_TRY(ej_set_push_field(s, hname, d->kind, EJ_FIELD_NO_GHOST | EJ_FIELD_SCRATCH, d->unit, EJ_ENERGY_NONE, &h));
    s->fields[k].rate = r;
    s->fields[k].half = h;
    s->fields[r].rate_of = k;
  }
  return EJ_OK;
}

ej_err ej_set_reserve(ej_set *s, ej_idx cap)
{
  if (cap <= s->cap) return EJ_OK;
  ej_idx old = s->cap;
  for (int k = 0; k < s->n_fields; ++k) {
    ej_field *f = &s->fields[k];
    size_t w = (size_t)f->ncomp * ej_kind_bytes(f->kind);
    char *d = ej_realloc(f->data, (size_t)cap * w);
    EJ_ENSURE(d, EJ_ERR_MEM, "out of memory growing set '%s' to %d particles", s->name, (int)cap);
    memset(d + (size_t)old * w, 0, (size_t)(cap - old) * w);
    f->data = d;
  }
  void *p;
  p = ej_realloc(s->radius, (size_t)cap * sizeof *s->radius);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  s->radius = p;
  p = ej_realloc(s->ghost_src, (size_t)cap * sizeof *s->ghost_src);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  s->ghost_src = p;
  p = ej_realloc(s->ghost_xf, (size_t)cap * sizeof *s->ghost_xf);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  s->ghost_xf = p;
  p = ej_realloc(s->bc_mask, (size_t)cap * sizeof *s->bc_mask);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  s->bc_mask = p;
  memset(s->bc_mask + old, 0, (size_t)(cap - old) * sizeof *s->bc_mask);
  s->cap = cap;
  return EJ_OK;
}

/* Each thread gathers (then copies back) its own static range of particles, field by field,
 * in one parallel region; the scratch is kept with the set and only grows (at a rebuild). */
ej_err ej_set_permute(ej_set *s, const ej_idx *perm)
{
  size_t maxw = sizeof(uint32_t);
  for (int k = 0; k < s->n_fields; ++k) {
    size_t w = (size_t)s->fields[k].ncomp * ej_kind_bytes(s->fields[k].kind);
    if (w > maxw) maxw = w;
  }
  const size_t need = (size_t)s->n * maxw;
  if (need > s->perm_tmp_size) {
    char *t = ej_realloc(s->perm_tmp, need);
    EJ_ENSURE(t, EJ_ERR_MEM, "out of memory reordering set '%s'", s->name);
    s->perm_tmp = t;
    s->perm_tmp_size = need;
  }
  char *tmp = s->perm_tmp;
  const ej_idx n = s->n;
#pragma omp parallel if (n > 4096)
  {
    for (int k = 0; k <= s->n_fields; ++k) {
      /* k == n_fields: the boundary-condition masks */
      char *d = k < s->n_fields ? (char *)s->fields[k].data : (char *)s->bc_mask;
      const size_t w = k < s->n_fields ? (size_t)s->fields[k].ncomp * ej_kind_bytes(s->fields[k].kind) : sizeof(uint32_t);
      /* fixed-size copies for the usual widths (int, scalar, vec3, sym6, tensor9): inlined */
#define EJ_PERM_GATHER(W)                                                                               \
  for (ej_idx i = i0; i < i1; ++i) memcpy(tt + (size_t)(i - i0) * (W), d + (size_t)perm[i] * (W), (W))
#ifdef _OPENMP
      const int64_t nt = omp_get_num_threads(), t = omp_get_thread_num();
#else
      const int64_t nt = 1, t = 0;
#endif
      const ej_idx i0 = (ej_idx)((int64_t)n * t / nt), i1 = (ej_idx)((int64_t)n * (t + 1) / nt);
      char *tt = tmp + (size_t)i0 * maxw; /* this thread's part of the scratch, whatever the width */
      switch (w) {
      case 4: EJ_PERM_GATHER(4); break;
      case 8: EJ_PERM_GATHER(8); break;
      case 24: EJ_PERM_GATHER(24); break;
      case 48: EJ_PERM_GATHER(48); break;
      case 72: EJ_PERM_GATHER(72); break;
      default: EJ_PERM_GATHER(w); break;
      }
#undef EJ_PERM_GATHER
      /* every gather of this field reads d: wait for all before overwriting it; then each thread
       * copies back the range it gathered (its scratch part [i0 maxw, i1 maxw) is its own, so the
       * next field's gather needs no barrier) */
#pragma omp barrier
      memcpy(d + (size_t)i0 * w, tt, (size_t)(i1 - i0) * w);
    }
  }
  s->ghost_dirty = EJ_ALL_FIELDS;
  return EJ_OK;
}

/* y = Q x (+ b for points). */
static inline void ej_xf_vec(const ej_xform *t, const ej_real *x, ej_real *y, bool point)
{
  for (int r = 0; r < 3; ++r) {
    y[r] = t->Q[3 * r] * x[0] + t->Q[3 * r + 1] * x[1] + t->Q[3 * r + 2] * x[2];
    if (point) y[r] += t->b[r];
  }
}

/* B = Q A Q^T for a full 3x3 A (row-major). */
static inline void ej_xf_mat(const ej_real *Q, const ej_real *A, ej_real *B)
{
  ej_real T[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) T[3 * i + j] = Q[3 * i] * A[j] + Q[3 * i + 1] * A[3 + j] + Q[3 * i + 2] * A[6 + j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) B[3 * i + j] = T[3 * i] * Q[3 * j] + T[3 * i + 1] * Q[3 * j + 1] + T[3 * i + 2] * Q[3 * j + 2];
}

static inline void ej_sym_to_full(const ej_real *s, ej_real *A)
{
  /* Voigt xx yy zz xy yz zx */
  A[0] = s[0], A[4] = s[1], A[8] = s[2];
  A[1] = A[3] = s[3];
  A[5] = A[7] = s[4];
  A[2] = A[6] = s[5];
}

static inline void ej_full_to_sym(const ej_real *A, ej_real *s)
{
  s[0] = A[0], s[1] = A[4], s[2] = A[8], s[3] = A[1], s[4] = A[5], s[5] = A[2];
}

/* Ghost g's value of field f, as a full refresh writes it: the source's value through the ghost's
 * transform (vectors rotated, points moved, tensors Q A Q^T). */
static inline void ej_ghost_value(const ej_set *s, const ej_field *f, const ej_xform *xf, ej_idx g, void *out)
{
  const ej_idx src = s->ghost_src[g];
  if (f->kind == EJ_INT) {
    ((int32_t *)out)[0] = ((const int32_t *)f->data)[src];
    return;
  }
  const int nc = f->ncomp;
  const ej_real *sv = (const ej_real *)f->data + (size_t)src * nc;
  ej_real *dst = out;
  const ej_xform *t = &xf[s->ghost_xf[g]];
  if (nc == 1) {
    dst[0] = sv[0];
  } else if (nc == 3) {
    ej_xf_vec(t, sv, dst, (f->flags & EJ_FIELD_POSITION) != 0);
  } else if (nc == 6) {
    ej_real A[9], B[9];
    ej_sym_to_full(sv, A);
    ej_xf_mat(t->Q, A, B);
    ej_full_to_sym(B, dst);
  } else {
    ej_xf_mat(t->Q, sv, dst);
  }
}

void ej_set_ghost_value(const ej_set *s, int f, const ej_xform *xf, ej_idx g, void *out)
{
  ej_ghost_value(s, &s->fields[f], xf, g, out);
}

/* Ghosts [g0, g1) of field f. */
static void ej_ghost_copy(const ej_set *s, const ej_field *f, const ej_xform *xf, ej_idx g0, ej_idx g1)
{
  const ej_idx n = s->n;
  if (f->kind == EJ_INT) {
    int32_t *d = f->data;
    for (ej_idx g = g0; g < g1; ++g) d[n + g] = d[s->ghost_src[g]];
    return;
  }
  ej_real *d = f->data;
  const int nc = f->ncomp;
  if (nc == 1) {
    for (ej_idx g = g0; g < g1; ++g) d[n + g] = d[s->ghost_src[g]];
    return;
  }
  for (ej_idx g = g0; g < g1; ++g) ej_ghost_value(s, f, xf, g, d + (size_t)(n + g) * nc);
}

void ej_set_refresh_ghosts(ej_set *s, const ej_xform *xf)
{
  const uint64_t dirty = s->ghost_dirty;
  s->ghost_dirty = 0;
  const ej_idx ng = s->n_ghost;
  if (!ng || !dirty) return;
  int list[EJ_MAX_FIELDS], nl = 0;
  for (int k = 0; k < s->n_fields; ++k)
    if (((dirty >> k) & 1u) && !(s->fields[k].flags & EJ_FIELD_NO_GHOST)) list[nl++] = k;
  if (!nl) return;
  /* one region: each thread copies every listed field of its own contiguous range of ghosts */
#pragma omp parallel if (ng > 4096)
  {
#ifdef _OPENMP
    const int64_t nt = omp_get_num_threads(), t = omp_get_thread_num();
#else
    const int64_t nt = 1, t = 0;
#endif
    const ej_idx g0 = (ej_idx)((int64_t)ng * t / nt), g1 = (ej_idx)((int64_t)ng * (t + 1) / nt);
    for (int q = 0; q < nl; ++q) ej_ghost_copy(s, &s->fields[list[q]], xf, g0, g1);
  }
}

void ej_set_update_ghosts(ej_set *s, const ej_xform *xf)
{
  s->ghost_dirty = EJ_ALL_FIELDS;
  ej_set_refresh_ghosts(s, xf);
}

int ej_set_ghosts_stale(const ej_set *s, const ej_xform *xf, ej_idx *ghost)
{
  for (int k = 0; k < s->n_fields; ++k) {
    const ej_field *f = &s->fields[k];
    if (f->flags & EJ_FIELD_NO_GHOST) continue;
    const size_t w = (size_t)f->ncomp * ej_kind_bytes(f->kind);
    for (ej_idx g = 0; g < s->n_ghost; ++g) {
      ej_real want[9];
      ej_ghost_value(s, f, xf, g, want);
      if (memcmp(want, (const char *)f->data + (size_t)(s->n + g) * w, w) != 0) {
        if (ghost) *ghost = g;
        return k;
      }
    }
  }
  return -1;
}

/* ------------------------------------------------------------------ plugin accessors */

ej_idx ej_set_count(const ej_set *s) { return s->n; }
ej_idx ej_set_count_all(const ej_set *s) { return s->n + s->n_ghost; }
int ej_set_dim(const ej_set *s) { return s->dim; }
const char *ej_set_name(const ej_set *s) { return s->name; }
ej_real ej_set_spacing_min(const ej_set *s) { return s->spacing_min; }

ej_real *ej_set_field(const ej_set *s, const char *name)
{
  int k = ej_set_find_field(s, name);
  return (k >= 0 && s->fields[k].kind != EJ_INT) ? s->fields[k].data : NULL;
}

int32_t *ej_set_field_int(const ej_set *s, const char *name)
{
  int k = ej_set_find_field(s, name);
  return (k >= 0 && s->fields[k].kind == EJ_INT) ? s->fields[k].data : NULL;
}

ej_real ej_model_rho0(const ej_model *m) { return m->rho0; }
const ej_eos *ej_model_eos(const ej_model *m) { return m->eos; }
const ej_material *ej_model_material(const ej_model *m) { return m->mat; }
const char *ej_model_name(const ej_model *m) { return m->name; }

ej_err ej_eos_evaluate(const ej_eos *eos, ej_idx n, const ej_real *rho, const ej_real *e, ej_real *p, ej_real *c)
{
  return eos->ops->evaluate(eos->state, n, rho, e, p, c);
}

ej_err ej_eos_evaluate_set(const ej_eos *eos, ej_set *set, ej_range r, const ej_real *rho, const ej_real *e,
                           ej_real *p, ej_real *c)
{
  const ej_eos_ops *o = eos->ops;
  if (o->struct_size >= offsetof(ej_eos_ops, evaluate_set) + sizeof o->evaluate_set && o->evaluate_set)
    return o->evaluate_set(eos->state, set, r, rho, e, p, c);
  return o->evaluate(eos->state, r.end - r.begin, rho, e, p, c);
}

ej_err ej_material_update(const ej_material *mat, ej_mat_batch *b) { return mat->ops->update(mat->state, b); }

ej_err ej_material_moduli(const ej_material *mat, ej_real *K, ej_real *G)
{
  const ej_material_ops *o = mat->ops;
  EJ_ENSURE(o->struct_size >= offsetof(ej_material_ops, moduli) + sizeof o->moduli && o->moduli, EJ_ERR_UNSUPPORTED,
            "material '%s' does not report its moduli (built against ABI 1.0)", o->name);
  return o->moduli(mat->state, K, G);
}

int ej_material_n_hist(const ej_material *mat) { return mat ? mat->ops->n_hist : 0; }

uint8_t *ej_set_bond_flags(const ej_set *s) { return s->bond_flags; }
int64_t ej_set_list_builds(const ej_set *s) { return s->list_builds; }

bool ej_set_has_images(const ej_set *s) { return s->has_images; }
const ej_model *ej_set_model(const ej_set *s) { return s->model; }

ej_real ej_set_time(const ej_set *s) { return s->t ? *s->t : 0; }
ej_real ej_set_dt(const ej_set *s) { return s->dt ? *s->dt : 0; }

int ej_set_hist(const ej_set *s, ej_real **hist, int max)
{
  int n = s->n_hist < max ? s->n_hist : max;
  for (int k = 0; k < n; ++k) hist[k] = s->fields[s->f_hist[k]].data;
  return s->n_hist;
}
