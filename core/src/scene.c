/* Scene files: validation of the whole YAML scene (one precise error with file:line:col),
 * plugin configs through the registry, particle generation per set and the JSON Schema of
 * the format. The core blocks are described by ej_param tables so that validation and the
 * schema come from the same data. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "scene_impl.h"

#define EJ_WHAT_MAX 160
#define EJ_MAX_BCS 32

/* ------------------------------------------------------------------ core parameter tables */

typedef struct ej_time_cfg {
  ej_real end, cfl, dt, dt_max;
  int64_t max_steps;
  ej_real dt_min, dt_min_ratio;
} ej_time_cfg;

typedef struct ej_neigh_cfg {
  ej_real skin, ghost_reach;
} ej_neigh_cfg;

typedef struct ej_top_cfg {
  int64_t ejecta, dimension;
  ej_time_cfg time;
  ej_neigh_cfg neighbours;
} ej_top_cfg;

static const ej_param ej_time_params[] = {
    EJ_PARAM_REAL(ej_time_cfg, end, "s", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "End time of the run."),
    EJ_PARAM_REAL(ej_time_cfg, cfl, "1", 0.3, 0, 1, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN | EJ_PF_HAS_MAX,
                  "Courant factor applied to the smallest stable step of the methods."),
    EJ_PARAM_REAL(ej_time_cfg, dt, "s", 0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Fixed time step; omitted = adaptive (cfl times the stable step)."),
    EJ_PARAM_REAL(ej_time_cfg, dt_max, "s", 0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Upper bound of the adaptive step; omitted = none."),
    EJ_PARAM_INT(ej_time_cfg, max_steps, 0, 0, 0, EJ_PF_HAS_MIN, "Stop after this many steps; 0 = no limit."),
    EJ_PARAM_REAL(ej_time_cfg, dt_min, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Watchdog floor of the adaptive step: below it the run stops (exit 1) naming the limiting set "
                  "and particle; 0 = only a zero or non-finite step stops it."),
    EJ_PARAM_REAL(ej_time_cfg, dt_min_ratio, "1", 1e-4, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Watchdog floor relative to the run's first adaptive step (LS-DYNA's DTMIN idea): a step below "
                  "dt_min_ratio times the first one stops the run like dt_min does; 0 = off."),
    {0}};

static const ej_param ej_neigh_params[] = {
    EJ_PARAM_REAL(ej_neigh_cfg, skin, "1", 0.15, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Verlet skin as a fraction of each particle's search radius: lists hold the pairs closer than "
                  "(1 + skin) max(R_i, R_j) at the build."),
    EJ_PARAM_REAL(ej_neigh_cfg, ghost_reach, "m", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Smallest thickness of every set's layer of mirror and periodic ghosts. A set with fixed families "
                  "(tlpd, rkpm lagrangian) makes its ghosts once, within its own largest radius, but they are also "
                  "the candidates of its interaction partners' rows: give here the largest search radius a partner "
                  "will reach (sph: 2 h_max h_factor times its spacing) when the two meet at a symmetry plane."),
    {0}};

static const ej_param ej_top_params[] = {
    EJ_PARAM_INT(ej_top_cfg, ejecta, 1, 1, 1, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                 "Scene format version; must be 1."),
    EJ_PARAM_INT(ej_top_cfg, dimension, 3, 1, 3, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                 "Spatial dimension: 1, 2 (plane strain) or 3."),
    EJ_PARAM_BLOCK(ej_top_cfg, time, ej_time_params, ej_time_cfg, EJ_PF_REQUIRED, "End time and time step control."),
    EJ_PARAM_BLOCK(ej_top_cfg, neighbours, ej_neigh_params, ej_neigh_cfg, 0, "Neighbour search settings."),
    {0}};
static const char *const ej_top_manual[] = {"output", "gravity", "materials", "sets", "interactions", "boundaries",
                                            "domain", "probes", NULL};

typedef struct ej_output_cfg {
  const char *file;
  ej_real every, checkpoint_every;
  bool set_series;
} ej_output_cfg;

static const ej_param ej_output_params[] = {
    EJ_PARAM_STRING(ej_output_cfg, file, NULL, 0,
                    "HDF5 output file; default out/<scene name>.h5, relative to the current directory."),
    EJ_PARAM_REAL(ej_output_cfg, every, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Interval between frames; 0 = first and last frame only."),
    EJ_PARAM_REAL(ej_output_cfg, checkpoint_every, "s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Interval between checkpoints; 0 = at the end only."),
    EJ_PARAM_BOOL(ej_output_cfg, set_series, false,
                  "Per-set energy budget and momentum every step, /series/set/<set>/<column> (kinetic, internal, "
                  "viscous, plastic, hourglass, momentum_x/y/z; LS-DYNA's MATSUM): they add up to /series/energy."),
    {0}};
static const char *const ej_output_manual[] = {"fields", NULL};

/* Probes (DESIGN.md "Diagnostics": point gauges as time series; docs/core.md "Probes"). */
typedef struct ej_probe_cfg {
  const char *name;
  bool follow;
  ej_real radius;
} ej_probe_cfg;

static const ej_param ej_probe_params[] = {
    EJ_PARAM_STRING(ej_probe_cfg, name, NULL, 0,
                    "Name (letters, digits, _ . -): the series are /series/probe/<name>/<column>; default probe<k>, "
                    "k = its place in the list from 0."),
    EJ_PARAM_BOOL(ej_probe_cfg, follow, false,
                  "false: a gauge fixed in space, each field the Shepard average (cubic-spline weights, particle "
                  "volumes) over the set's particles whose support covers the point, NaN where none does; true: a "
                  "tracer, the fields of the particle nearest to the point at t = 0 wherever it goes, and its "
                  "position."),
    EJ_PARAM_REAL(ej_probe_cfg, radius, "m", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Gauge only: support radius of the weights; 0 = each particle's own neighbour-search radius "
                  "(sph: 2 h; peridynamics: the horizon)."),
    {0}};
static const char *const ej_probe_manual[] = {"set", "point", "fields", NULL};

typedef struct ej_mat_cfg {
  ej_real rho0;
} ej_mat_cfg;

static const ej_param ej_mat_params[] = {
    EJ_PARAM_REAL(ej_mat_cfg, rho0, "kg/m^3", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Reference density."),
    {0}};
static const char *const ej_mat_manual[] = {"eos", "model", NULL};

typedef struct ej_set_cfg {
  ej_real spacing, jitter, rho, e, p, mass;
  ej_real lattice_origin[3];
  int lattice, jitter_volume;
  int64_t seed;
} ej_set_cfg;

static const char *const ej_lattice_names[] = {"cubic", "hcp", NULL};
static const char *const ej_jitter_volume_names[] = {"cell", "kernel", NULL};

static const ej_param ej_set_params[] = {
    EJ_PARAM_REAL(ej_set_cfg, spacing, "m", 0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Lattice spacing (required with shape; with file, used when it has no vol column)."),
    EJ_PARAM_ENUM(ej_set_cfg, lattice, ej_lattice_names, "cubic",
                  "Lattice: cubic, or hcp (hexagonal close-packed, spacing = nearest-neighbour distance)."),
    EJ_PARAM_REAL(ej_set_cfg, jitter, "1", 0, 0, 1, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MAX_OPEN,
                  "Random displacement of each coordinate, as a fraction of the local spacing."),
    EJ_PARAM_INT(ej_set_cfg, seed, 1, 0, 0, EJ_PF_HAS_MIN, "Seed of the jitter."),
    EJ_PARAM_ENUM(ej_set_cfg, jitter_volume, ej_jitter_volume_names, "cell",
                  "Volume (and so mass) of a jittered particle: cell, its lattice cell's, so that the local density "
                  "of the cloud is off by up to the jitter per axis; kernel, the cell volume times the kernel number "
                  "density of the unjittered lattice over that of the jittered cloud at the particle (cubic spline, "
                  "h = 1.3 spacings), scaled so that the set's total volume is unchanged: the volumes then follow "
                  "the arrangement (docs/core.md, \"Geometry\"). No effect without jitter."),
    EJ_PARAM_ARRAY(ej_set_cfg, lattice_origin, 3, "m", 0,
                   "A corner of a lattice cell: the lattice (and every refine region's) passes through this point "
                   "instead of the shape's lowest corner. Two sets with the same origin and spacing tile each other "
                   "exactly, e.g. a charge and the soil cut out around it with minus (docs/core.md, \"Geometry\"). "
                   "Three numbers in every dimension (the unused ones ignored)."),
    EJ_PARAM_REAL(ej_set_cfg, mass, "kg", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Total mass of the set: every particle's volume is scaled by one factor so that the sum of "
                  "rho V is this (a lattice holds its shape's volume only to about a layer of cells); a smoothing "
                  "length or horizon taken from the volume follows the factor^(1/dim); 0 = the lattice's own."),
    EJ_PARAM_REAL(ej_set_cfg, rho, "kg/m^3", 0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Initial density; default the material's rho0."),
    EJ_PARAM_REAL(ej_set_cfg, e, "J/kg", 0, 0, 0, 0, "Initial specific internal energy."),
    EJ_PARAM_REAL(ej_set_cfg, p, "Pa", 0, 0, 0, 0, "Initial pressure (sets e through the EOS)."),
    {0}};
static const char *const ej_set_manual[] = {"method", "material", "shape", "file", "refine", "velocity", "initial",
                                            NULL};

typedef struct ej_init_cfg {
  ej_real rho, e, p, energy_total;
} ej_init_cfg;

static const ej_param ej_init_params[] = {
    EJ_PARAM_REAL(ej_init_cfg, rho, "kg/m^3", 0, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Initial density."),
    EJ_PARAM_REAL(ej_init_cfg, e, "J/kg", 0, 0, 0, 0, "Initial specific internal energy."),
    EJ_PARAM_REAL(ej_init_cfg, p, "Pa", 0, 0, 0, 0, "Initial pressure (sets e through the EOS)."),
    EJ_PARAM_REAL(ej_init_cfg, energy_total, "J", 0, 0, 0, 0,
                  "Energy added to the region, spread over its particles in proportion to mass."),
    {0}};
static const char *const ej_init_manual[] = {"region", "velocity", NULL};

typedef struct ej_refine_cfg {
  ej_real spacing;
} ej_refine_cfg;

static const ej_param ej_refine_params[] = {
    EJ_PARAM_REAL(ej_refine_cfg, spacing, "m", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Lattice spacing inside the region."),
    {0}};
static const char *const ej_refine_manual[] = {"region", NULL};

typedef struct ej_periodic_cfg {
  int axis;
  ej_real min, max;
} ej_periodic_cfg;

static const char *const ej_axis_names[] = {"x", "y", "z", NULL};

static const ej_param ej_periodic_params[] = {
    EJ_PARAM_ENUM(ej_periodic_cfg, axis, ej_axis_names, "x", "Periodic axis (must be used by the dimension)."),
    EJ_PARAM_REAL(ej_periodic_cfg, min, "m", 0, 0, 0, EJ_PF_REQUIRED, "Lower end of the period."),
    EJ_PARAM_REAL(ej_periodic_cfg, max, "m", 0, 0, 0, EJ_PF_REQUIRED, "Upper end of the period."),
    {0}};

/* non_reflecting: Lysmer-Kuhlemeyer viscous boundary (docs/core.md "Non-reflecting boundaries"). */
typedef struct ej_nonrefl_cfg {
  ej_real rho, cp, cs;
} ej_nonrefl_cfg;

static const ej_param ej_nonrefl_params[] = {
    EJ_PARAM_REAL(ej_nonrefl_cfg, rho, "kg/m^3", 0, 0, 0, EJ_PF_HAS_MIN,
                  "Density of the dashpots' impedances rho c_p and rho c_s; 0 = the material's rho0."),
    EJ_PARAM_REAL(ej_nonrefl_cfg, cp, "m/s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "P-wave speed of the normal dashpot; 0 = sqrt((K + 4G/3) / rho0) from the strength model's initial "
                  "moduli (required for a set without one)."),
    EJ_PARAM_REAL(ej_nonrefl_cfg, cs, "m/s", 0, 0, 0, EJ_PF_HAS_MIN,
                  "S-wave speed of the tangential dashpot; 0 = sqrt(G / rho0) from the strength model, none for a set "
                  "without one (a fluid)."),
    {0}};
static const char *const ej_nonrefl_manual[] = {"normal", "center", NULL};

/* pressure: a load p(t) on a face (docs/core.md "Pressure loads"); the normal, the curve and the
 * blast block are parsed by hand. */
typedef struct ej_pressure_cfg {
  ej_real value;
  bool cavity;
} ej_pressure_cfg;

static const ej_param ej_pressure_params[] = {
    EJ_PARAM_REAL(ej_pressure_cfg, value, "Pa", 0, 0, 0, 0,
                  "Constant pressure from t = 0 (one of value, curve, blast); negative pulls."),
    EJ_PARAM_BOOL(ej_pressure_cfg, cavity, 0,
                  "With center: the face is a cavity wall around center (outward normal towards it), so the "
                  "pressure pushes away from center; without: a convex face, pushed towards it."),
    {0}};
static const char *const ej_pressure_manual[] = {"normal", "center", "curve", "blast", NULL};

typedef struct ej_blast_cfg {
  ej_real tnt, time;
  int burst;
} ej_blast_cfg;

static const char *const ej_burst_names[] = {"air", "surface", NULL};
static const ej_param ej_blast_params[] = {
    EJ_PARAM_REAL(ej_blast_cfg, tnt, "kg", 0, 0, 0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "TNT-equivalent mass W of the charge."),
    EJ_PARAM_ENUM(ej_blast_cfg, burst, ej_burst_names, "air",
                  "air: spherical free-air burst; surface: hemispherical burst on the ground (the reflected "
                  "ground wave included), Kingery-Bulmash curves of each."),
    EJ_PARAM_REAL(ej_blast_cfg, time, "s", 0, 0, 0, EJ_PF_HAS_MIN, "Detonation time."),
    {0}};
static const char *const ej_blast_manual[] = {"charge", NULL};

/* ------------------------------------------------------------------ loader state */

typedef struct ej_loader {
  ej_scene *sc;
  ej_registry *reg;
  const ej_node *sets_node;
  const char **set_names; /* [n_sets], for did-you-mean */
  const char **mat_names;
  int *shape_state; /* per set: 0 not parsed, 1 being parsed, 2 done */
  ej_shape_env env;
} ej_loader;

static const char *ej_kind_word(const ej_node *n)
{
  return n->type == EJ_NODE_MAP ? "a map" : n->type == EJ_NODE_SEQ ? "a list" : "a scalar";
}

static ej_err ej_expect_map(const ej_node *n, const char *what)
{
  if (n->type != EJ_NODE_MAP) return ej_error_input(&n->loc, "%s must be a map, got %s", what, ej_kind_word(n));
  return EJ_OK;
}

static ej_err ej_expect_word(const ej_node *n, const char *what, const char **text)
{
  if (n->type != EJ_NODE_SCALAR || !n->text || !n->text[0])
    return ej_error_input(&n->loc, "%s must be a name, got %s", what,
                          n->type == EJ_NODE_SCALAR ? "an empty value" : ej_kind_word(n));
  *text = n->text;
  return EJ_OK;
}

static int ej_index_of(const char *const *names, int n, const char *word)
{
  for (int i = 0; i < n; ++i)
    if (names[i] && strcmp(names[i], word) == 0) return i;
  return -1;
}

/* Keys outside allowed, reported with the nearest allowed key. */
static ej_err ej_check_keys(const ej_node *m, const char *what, const char *const *allowed)
{
  int n = 0;
  while (allowed[n]) ++n;
  for (int i = 0; i < m->n; ++i) {
    if (ej_index_of(allowed, n, m->keys[i]) >= 0) continue;
    const char *near = ej_nearest_word(m->keys[i], allowed, n);
    if (near)
      return ej_error_input(&m->key_locs[i], "unknown key '%s' in %s; did you mean '%s'?", m->keys[i], what, near);
    return ej_error_input(&m->key_locs[i], "unknown key '%s' in %s", m->keys[i], what);
  }
  return EJ_OK;
}

/* NULL-terminated union of a fixed key list and a parameter table's names (skip lists). */
static const char **ej_keys_join(const char *const *a, const ej_param *t)
{
  int na = 0, nt = 0;
  while (a && a[na]) ++na;
  while (t && t[nt].name) ++nt;
  const char **out = ej_calloc((size_t)(na + nt + 1), sizeof *out);
  if (!out) return NULL;
  for (int i = 0; i < na; ++i) out[i] = a[i];
  for (int i = 0; i < nt; ++i) out[na + i] = t[i].name;
  return out;
}

static ej_err ej_apply_with(const ej_param *table, void *cfg, const ej_node *map, const char *what,
                            const char *const *manual, const ej_param *other, ej_config_check_fn check)
{
  const char **skip = ej_keys_join(manual, other);
  EJ_ENSURE(skip, EJ_ERR_MEM, "out of memory");
  ej_err rc = ej_params_apply(table, cfg, map, what, skip, check);
  ej_free(skip);
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);
  return EJ_OK;
}

/* ------------------------------------------------------------------ shapes of sets */

static ej_err ej_set_shape(ej_loader *L, int i);

static const ej_shape *ej_lookup_set_shape(void *ctx, const char *name, const ej_loc *at)
{
  ej_loader *L = ctx;
  int j = ej_index_of(L->set_names, L->sc->n_sets, name);
  if (j < 0) return NULL;
  if (L->shape_state[j] == 1) {
    ej_error_input(at, "set '%s' subtracts itself (through 'minus')", name);
    return NULL;
  }
  const ej_node *sn = L->sets_node->items[j];
  if (sn->type != EJ_NODE_MAP || !ej_node_get(sn, "shape")) {
    ej_error_input(at, "'minus' names set '%s', which has no shape (its particles come from a file)", name);
    return NULL;
  }
  if (ej_set_shape(L, j) != EJ_OK) return NULL;
  return L->sc->sets[j].shape;
}

/* Parses set i's shape once, possibly early when another set subtracts it. */
static ej_err ej_set_shape(ej_loader *L, int i)
{
  if (L->shape_state[i] == 2) return EJ_OK;
  const ej_node *sn = L->sets_node->items[i];
  const ej_node *shape = ej_node_get(sn, "shape");
  L->shape_state[i] = 1;
  EJ_TRY(ej_shape_parse_env(shape, L->sc->dimension, &L->env, &L->sc->sets[i].shape));
  L->shape_state[i] = 2;
  return EJ_OK;
}

static ej_err ej_region(ej_loader *L, const ej_node *n, ej_shape **out)
{
  EJ_TRY(ej_shape_parse_env(n, L->sc->dimension, &L->env, out));
  return EJ_OK;
}

/* ------------------------------------------------------------------ materials */

static ej_err ej_parse_eos(ej_loader *L, ej_scene_material *m, const ej_node *eos)
{
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "material '%s' eos", m->name);
  EJ_TRY(ej_expect_map(eos, what));
  const ej_node *model = ej_node_get(eos, "model");
  if (!model)
    return ej_error_input(&eos->loc, "%s needs 'model' (the equation of state, e.g. ideal_gas)", what);
  const char *name = NULL;
  EJ_TRY(ej_expect_word(model, "eos model", &name));
  const void *ops;
  EJ_TRY(ej_registry_require(L->reg, EJ_KIND_EOS, name, &model->loc, &ops));
  m->eos_ops = ops;
  m->eos_config = ej_calloc(1, m->eos_ops->config_size);
  EJ_ENSURE(m->eos_config, EJ_ERR_MEM, "out of memory");
  snprintf(what, sizeof what, "material '%s' eos (%s)", m->name, name);
  static const char *const skip[] = {"model", NULL};
  EJ_TRY(ej_params_apply(m->eos_ops->params, m->eos_config, eos, what, skip, m->eos_ops->check_config));
  return EJ_OK;
}

static ej_err ej_parse_material(ej_loader *L, int i, const ej_node *mats)
{
  ej_scene_material *m = &L->sc->materials[i];
  const ej_node *node = mats->items[i];
  m->name = ej_strdup(mats->keys[i]);
  EJ_ENSURE(m->name, EJ_ERR_MEM, "out of memory");
  m->loc = mats->key_locs[i];
  L->mat_names[i] = m->name;
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "material '%s'", m->name);
  EJ_TRY(ej_expect_map(node, what));
  const ej_node *model = ej_node_get(node, "model"), *eos = ej_node_get(node, "eos");
  const ej_param *strength = NULL, *rho_param = NULL;
  if (model) {
    const char *name = NULL;
    EJ_TRY(ej_expect_word(model, "material model", &name));
    const void *ops;
    EJ_TRY(ej_registry_require(L->reg, EJ_KIND_MATERIAL, name, &model->loc, &ops));
    m->mat_ops = ops;
    strength = m->mat_ops->params;
    m->mat_config = ej_calloc(1, m->mat_ops->config_size);
    EJ_ENSURE(m->mat_config, EJ_ERR_MEM, "out of memory");
    char mwhat[EJ_WHAT_MAX];
    snprintf(mwhat, sizeof mwhat, "material '%s' (%s)", m->name, name);
    /* rho0 is the material's; a strength model that declares a rho0 parameter (jh2: mu = rho/rho0 -
     * 1) receives the same value */
    static const char *const skip[] = {"rho0", "eos", "model", NULL}, *const skip_eos[] = {"eos", "model", NULL};
    for (const ej_param *p = strength; p && p->name; ++p)
      if (!strcmp(p->name, "rho0")) rho_param = p;
    EJ_TRY(ej_params_apply(strength, m->mat_config, node, mwhat, rho_param ? skip_eos : skip,
                           m->mat_ops->check_config));
  }
  ej_mat_cfg cfg = {0};
  EJ_TRY(ej_apply_with(ej_mat_params, &cfg, node, what, ej_mat_manual, strength, NULL));
  /* (the strength table's rho0, when it has one, took the key: same value, same unit) */
  m->rho0 = rho_param ? *(const ej_real *)((const char *)m->mat_config + rho_param->offset) : cfg.rho0;
  if (eos) EJ_TRY(ej_parse_eos(L, m, eos));
  if (m->mat_ops && m->mat_ops->needs_eos && !m->eos_ops)
    return ej_error_input(&m->loc, "material '%s': strength model '%s' needs an equation of state (eos: {model: ...})",
                          m->name, m->mat_ops->name);
  const ej_material_ops *mo = m->mat_ops;
  if (mo && !m->eos_ops &&
      mo->struct_size >= offsetof(ej_material_ops, eos_required_by) + sizeof mo->eos_required_by &&
      mo->eos_required_by) {
    const char *key = mo->eos_required_by(m->mat_config);
    const ej_node *kn = key ? ej_node_get(node, key) : NULL;
    if (key)
      return ej_error_input(kn ? &kn->loc : &m->loc,
                            "material '%s': %s with %s: %s needs an equation of state; expected 'eos: {model: ...}' "
                            "on the material or another value of '%s'",
                            m->name, mo->name, key, kn && kn->type == EJ_NODE_SCALAR ? kn->text : "(default)", key);
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ sets */


/* A physical vector (a velocity, gravity, a face normal): a 1D or 2D scene may write 3 numbers, but the
 * axes it does not have must be 0 (before 2026-12-02 such components were applied silently: particles
 * left the line or plane). Points and shapes keep their third component (a 2D cylinder along z is a disk). */
static ej_err ej_node_vector_plane(const ej_node *n, int dim, const char *unit, ej_real v[3])
{
  EJ_TRY(ej_node_vector(n, dim, unit, v)); /* a list of dim or 3 numbers */
  for (int k = dim; k < n->n; ++k)
    if (v[k] != 0)
      return ej_error_input(&n->items[k]->loc,
                            "component %d is %g, but the scene has dimension %d: a velocity, gravity or normal "
                            "must have 0 beyond its first %d components (or give %d numbers)",
                            k + 1, v[k], dim, dim, dim);
  return EJ_OK;
}

static ej_err ej_parse_init(ej_loader *L, const char *set, ej_scene_init *in, const ej_node *n, bool whole_set)
{
  char what[EJ_WHAT_MAX];
  if (whole_set) {
    snprintf(what, sizeof what, "set '%s'", set);
  } else {
    snprintf(what, sizeof what, "set '%s' initial condition", set);
    EJ_TRY(ej_expect_map(n, what));
    ej_init_cfg cfg = {0};
    EJ_TRY(ej_apply_with(ej_init_params, &cfg, n, what, ej_init_manual, NULL, NULL));
    in->rho = cfg.rho, in->e = cfg.e, in->p = cfg.p, in->energy_total = cfg.energy_total;
    in->has_energy_total = ej_node_get(n, "energy_total") != NULL;
    const ej_node *r = ej_node_get(n, "region");
    if (r) EJ_TRY(ej_region(L, r, &in->region));
  }
  in->loc = n->loc;
  in->has_rho = ej_node_get(n, "rho") != NULL;
  in->has_e = ej_node_get(n, "e") != NULL;
  in->has_p = ej_node_get(n, "p") != NULL;
  const ej_node *v = ej_node_get(n, "velocity");
  if (v) {
    EJ_TRY(ej_node_vector_plane(v, L->sc->dimension, "m/s", in->v));
    in->has_v = true;
  }
  if (in->has_e && in->has_p)
    return ej_error_input(ej_node_key_loc(n, "p"), "%s: give either 'e' or 'p', not both", what);
  if (in->has_energy_total && in->has_p)
    return ej_error_input(ej_node_key_loc(n, "energy_total"), "%s: give either 'energy_total' or 'p', not both",
                          what);
  return EJ_OK;
}

static ej_err ej_parse_refine(ej_loader *L, ej_scene_set *s, const ej_node *n)
{
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "set '%s' refine", s->name);
  if (n->type != EJ_NODE_SEQ)
    return ej_error_input(&n->loc, "%s must be a list of {region, spacing}, got %s", what, ej_kind_word(n));
  s->refine = ej_calloc((size_t)n->n, sizeof *s->refine);
  EJ_ENSURE(s->refine, EJ_ERR_MEM, "out of memory");
  s->n_refine = n->n;
  for (int k = 0; k < n->n; ++k) {
    const ej_node *it = n->items[k];
    EJ_TRY(ej_expect_map(it, what));
    ej_refine_cfg cfg = {0};
    EJ_TRY(ej_params_apply(ej_refine_params, &cfg, it, what, ej_refine_manual, NULL));
    const ej_node *r = ej_node_get(it, "region");
    if (!r) return ej_error_input(&it->loc, "%s entry needs 'region' (a shape)", what);
    EJ_TRY(ej_region(L, r, &s->refine[k].region));
    s->refine[k].spacing = cfg.spacing;
  }
  return EJ_OK;
}

static ej_err ej_resolve_file(ej_loader *L, ej_scene_set *s, const ej_node *f)
{
  const char *name = NULL;
  EJ_TRY(ej_expect_word(f, "file", &name));
  s->file = ej_path_beside(L->sc->doc->path, name);
  EJ_ENSURE(s->file, EJ_ERR_MEM, "out of memory");
  s->file_loc = f->loc;
  return EJ_OK;
}

static ej_err ej_parse_set(ej_loader *L, int i)
{
  ej_scene *sc = L->sc;
  ej_scene_set *s = &sc->sets[i];
  const ej_node *node = L->sets_node->items[i];
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "set '%s'", s->name);
  EJ_TRY(ej_expect_map(node, what));

  const ej_node *method = ej_node_get(node, "method");
  if (!method) return ej_error_input(&s->loc, "set '%s' needs 'method' (the method plugin, e.g. sph)", s->name);
  const char *mname = NULL;
  EJ_TRY(ej_expect_word(method, "method", &mname));
  const void *ops;
  EJ_TRY(ej_registry_require(L->reg, EJ_KIND_METHOD, mname, &method->loc, &ops));
  s->method_ops = ops;
  s->method_config = ej_calloc(1, s->method_ops->config_size);
  EJ_ENSURE(s->method_config, EJ_ERR_MEM, "out of memory");
  char mwhat[EJ_WHAT_MAX];
  snprintf(mwhat, sizeof mwhat, "set '%s' (%s)", s->name, mname);
  const char **core = ej_keys_join(ej_set_manual, ej_set_params);
  EJ_ENSURE(core, EJ_ERR_MEM, "out of memory");
  ej_err rc = ej_params_apply(s->method_ops->params, s->method_config, node, mwhat, core,
                              s->method_ops->check_config);
  ej_free(core);
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);

  ej_set_cfg cfg = {0};
  EJ_TRY(ej_apply_with(ej_set_params, &cfg, node, what, ej_set_manual, s->method_ops->params, NULL));
  s->spacing = cfg.spacing;
  s->lattice = cfg.lattice == 1 ? EJ_LATTICE_HCP : EJ_LATTICE_CUBIC;
  s->jitter = cfg.jitter;
  s->seed = (uint64_t)cfg.seed;
  s->jitter_volume = cfg.jitter_volume == 1 ? EJ_JITTER_VOLUME_KERNEL : EJ_JITTER_VOLUME_CELL;
  s->mass = cfg.mass;
  s->has_origin = ej_node_get(node, "lattice_origin") != NULL;
  memcpy(s->origin, cfg.lattice_origin, sizeof s->origin);

  const ej_node *mat = ej_node_get(node, "material");
  if (!mat) return ej_error_input(&s->loc, "set '%s' needs 'material' (a key of materials)", s->name);
  const char *matname = NULL;
  EJ_TRY(ej_expect_word(mat, "material", &matname));
  s->material = ej_index_of(L->mat_names, sc->n_materials, matname);
  if (s->material < 0) {
    const char *near = ej_nearest_word(matname, L->mat_names, sc->n_materials);
    if (near)
      return ej_error_input(&mat->loc, "set '%s' uses undefined material '%s'; did you mean '%s'?", s->name, matname,
                            near);
    return ej_error_input(&mat->loc, "set '%s' uses undefined material '%s'%s", s->name, matname,
                          sc->n_materials ? "" : " (the scene has no 'materials')");
  }

  /* A material without EOS and strength model serves only methods with their own constants. */
  const ej_scene_material *sm = &sc->materials[s->material];
  const bool self = s->method_ops->struct_size >= offsetof(ej_method_ops, self_constitutive) + sizeof(bool) &&
                    s->method_ops->self_constitutive;
  if (!sm->eos_ops && !sm->mat_ops && !self)
    return ej_error_input(&sm->loc,
                          "material '%s' needs an equation of state (eos: {model: ...}) or a strength model "
                          "(model: ...) for set '%s' (method %s)",
                          sm->name, s->name, s->method_ops->name);

  const ej_node *shape = ej_node_get(node, "shape"), *file = ej_node_get(node, "file");
  if (shape && file)
    return ej_error_input(ej_node_key_loc(node, "file"), "set '%s' takes either 'shape' or 'file', not both", s->name);
  if (!shape && !file)
    return ej_error_input(&s->loc, "set '%s' needs 'shape' (with 'spacing') or 'file' (a CSV particle file)", s->name);
  const ej_node *refine = ej_node_get(node, "refine");
  if (shape) {
    if (!ej_node_get(node, "spacing"))
      return ej_error_input(&s->loc, "set '%s' needs 'spacing' (the lattice spacing of its shape)", s->name);
    EJ_TRY(ej_set_shape(L, i));
    ej_real lo[3], hi[3];
    EJ_TRY(ej_shape_bounds(s->shape, lo, hi));
    if (refine) EJ_TRY(ej_parse_refine(L, s, refine));
  } else {
    EJ_TRY(ej_resolve_file(L, s, file));
    static const char *const shape_only[] = {"refine",         "lattice", "jitter", "seed", "jitter_volume",
                                             "lattice_origin", NULL};
    for (int k = 0; shape_only[k]; ++k)
      if (ej_node_get(node, shape_only[k]))
        return ej_error_input(ej_node_key_loc(node, shape_only[k]),
                              "'%s' applies to sets filled from a shape, not to particle files", shape_only[k]);
  }

  const ej_node *initial = ej_node_get(node, "initial");
  if (initial && initial->type != EJ_NODE_SEQ)
    return ej_error_input(&initial->loc, "set '%s' initial must be a list of {region, ...}, got %s", s->name,
                          ej_kind_word(initial));
  int n_init = 1 + (initial ? initial->n : 0);
  s->init = ej_calloc((size_t)n_init, sizeof *s->init);
  EJ_ENSURE(s->init, EJ_ERR_MEM, "out of memory");
  s->n_init = n_init;
  s->init[0].rho = cfg.rho, s->init[0].e = cfg.e, s->init[0].p = cfg.p;
  EJ_TRY(ej_parse_init(L, s->name, &s->init[0], node, true));
  s->init[0].loc = s->loc;
  for (int k = 1; k < n_init; ++k) EJ_TRY(ej_parse_init(L, s->name, &s->init[k], initial->items[k - 1], false));
  return EJ_OK;
}

/* ------------------------------------------------------------------ interactions, boundaries */

static ej_err ej_set_ref(ej_loader *L, const ej_node *n, const char *what, int *index)
{
  const char *name = NULL;
  EJ_TRY(ej_expect_word(n, what, &name));
  *index = ej_index_of(L->set_names, L->sc->n_sets, name);
  if (*index >= 0) return EJ_OK;
  const char *near = ej_nearest_word(name, L->set_names, L->sc->n_sets);
  if (near) return ej_error_input(&n->loc, "%s names undefined set '%s'; did you mean '%s'?", what, name, near);
  return ej_error_input(&n->loc, "%s names undefined set '%s'", what, name);
}

static ej_err ej_parse_interaction(ej_loader *L, ej_scene_interaction *it, const ej_node *n)
{
  EJ_TRY(ej_expect_map(n, "an interaction"));
  it->loc = n->loc;
  const ej_node *model = ej_node_get(n, "model"), *sets = ej_node_get(n, "sets");
  if (!model) return ej_error_input(&n->loc, "interaction needs 'model' (the interaction plugin, e.g. pd_sph)");
  const char *name = NULL;
  EJ_TRY(ej_expect_word(model, "interaction model", &name));
  const void *ops;
  EJ_TRY(ej_registry_require(L->reg, EJ_KIND_INTERACTION, name, &model->loc, &ops));
  it->ops = ops;
  it->config = ej_calloc(1, it->ops->config_size);
  EJ_ENSURE(it->config, EJ_ERR_MEM, "out of memory");
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "interaction '%s'", name);
  static const char *const skip[] = {"model", "sets", NULL};
  EJ_TRY(ej_params_apply(it->ops->params, it->config, n, what, skip, it->ops->check_config));
  if (!sets) return ej_error_input(&n->loc, "%s needs 'sets: [a, b]' (or '[a]' for a one-set interaction)", what);
  if (sets->type != EJ_NODE_SEQ || sets->n < 1 || sets->n > 2)
    return ej_error_input(&sets->loc, "%s: 'sets' must be a list of one or two set names", what);
  const int want = it->ops->struct_size >= offsetof(ej_interaction_ops, n_sets) + sizeof(int) ? it->ops->n_sets : 0;
  if (want == 1 && sets->n != 1)
    return ej_error_input(&sets->loc, "%s acts on one set: write 'sets: [name]'", what);
  if (want == 2 && sets->n != 2)
    return ej_error_input(&sets->loc, "%s couples two sets: write 'sets: [a, b]'", what);
  EJ_TRY(ej_set_ref(L, sets->items[0], "interaction", &it->set_a));
  it->set_b = -1;
  if (sets->n == 2) EJ_TRY(ej_set_ref(L, sets->items[1], "interaction", &it->set_b));
  if (want == 2 && it->set_a == it->set_b)
    return ej_error_input(&sets->items[1]->loc, "%s couples two different sets, got '%s' twice", what,
                          sets->items[1]->text ? sets->items[1]->text : "?");
  return EJ_OK;
}

static ej_err ej_parse_components(const ej_node *n, int dim, const char *what, bool comp[3])
{
  comp[0] = comp[1] = comp[2] = false;
  if (n->type == EJ_NODE_SCALAR && n->text && strcmp(n->text, "all") == 0) {
    for (int k = 0; k < dim; ++k) comp[k] = true;
    return EJ_OK;
  }
  if (n->type != EJ_NODE_SEQ || n->n == 0)
    return ej_error_input(&n->loc, "%s must be a list of components (x, y, z) or 'all'", what);
  for (int k = 0; k < n->n; ++k) {
    const ej_node *c = n->items[k];
    int a = c->type == EJ_NODE_SCALAR && c->text ? ej_index_of(ej_axis_names, 3, c->text) : -1;
    if (a < 0)
      return ej_error_input(&c->loc, "%s: expected a component x, y or z, got '%s'", what,
                            c->type == EJ_NODE_SCALAR && c->text ? c->text : ej_kind_word(c));
    if (a >= dim) return ej_error_input(&c->loc, "%s: component '%s' is not used in a %dD scene", what, c->text, dim);
    comp[a] = true;
  }
  return EJ_OK;
}


/* An outward unit normal (a plane face) or a centre (a spherical one), as non_reflecting and
 * pressure take them; what names the block in the messages. */
static ej_err ej_face_normal(ej_loader *L, const ej_node *v, const char *what, ej_scene_bc *bc)
{
  const int dim = L->sc->dimension;
  const ej_node *nn = ej_node_get(v, "normal"), *cn = ej_node_get(v, "center");
  if (!nn == !cn)
    return ej_error_input(nn && cn ? &cn->loc : &v->loc,
                          "%s needs one of 'normal' (a plane face, outward) and 'center' (a spherical one)%s", what,
                          nn ? ", not both" : "");
  if (nn) {
    EJ_TRY(ej_node_vector_plane(nn, dim, "1", bc->normal));
    ej_real len = 0;
    for (int k = 0; k < 3; ++k) len += bc->normal[k] * bc->normal[k];
    len = sqrt(len);
    if (!(len > 0) || !isfinite(len)) return ej_error_input(&nn->loc, "%s normal must be a non-zero vector", what);
    for (int k = 0; k < 3; ++k) bc->normal[k] /= len;
  } else {
    bc->radial = true;
    EJ_TRY(ej_node_vector(cn, dim, "m", bc->point));
  }
  return EJ_OK;
}

/* pressure: {normal | center [, cavity], one of value, curve: [[t, p], ...], blast: {charge, tnt, burst, time}} */
static ej_err ej_parse_pressure(ej_loader *L, const ej_node *v, ej_scene_bc *bc)
{
  ej_pressure_cfg cfg = {0};
  EJ_TRY(ej_params_apply(ej_pressure_params, &cfg, v, "pressure", ej_pressure_manual, NULL));
  EJ_TRY(ej_face_normal(L, v, "pressure", bc));
  const ej_node *cav = ej_node_get(v, "cavity");
  if (cav && !bc->radial)
    return ej_error_input(&cav->loc, "cavity is for a face around 'center'; a plane face gives its outward normal");
  bc->cavity = cfg.cavity;
  const char *const src[] = {"value", "curve", "blast"};
  int which = -1;
  for (int k = 0; k < 3; ++k)
    if (ej_node_get(v, src[k])) {
      if (which >= 0)
        return ej_error_input(ej_node_key_loc(v, src[k]), "pressure takes one of value, curve, blast; found both "
                              "'%s' and '%s'", src[which], src[k]);
      which = k;
    }
  if (which < 0)
    return ej_error_input(&v->loc, "pressure needs one of 'value' (a constant, e.g. 1 MPa), 'curve' ([[t, p], ...]) "
                                   "and 'blast' ({charge, tnt})");
  if (which == 0) {
    bc->source = EJ_PRESSURE_VALUE;
    bc->p_value = cfg.value;
    if (!isfinite(bc->p_value)) return ej_error_input(&ej_node_get(v, "value")->loc, "pressure value must be finite");
  } else if (which == 1) {
    bc->source = EJ_PRESSURE_CURVE;
    const ej_node *c = ej_node_get(v, "curve");
    if (c->type != EJ_NODE_SEQ || c->n < 1)
      return ej_error_input(&c->loc, "curve: expected a list of [time, pressure] points, e.g. [[0, 0], [1 ms, 2 MPa]]"
                                     ", got %s", c->type == EJ_NODE_SEQ ? "an empty list" : ej_kind_word(c));
    bc->curve_t = ej_malloc((size_t)c->n * sizeof *bc->curve_t);
    bc->curve_p = ej_malloc((size_t)c->n * sizeof *bc->curve_p);
    EJ_ENSURE(bc->curve_t && bc->curve_p, EJ_ERR_MEM, "out of memory");
    bc->n_curve = c->n;
    for (int k = 0; k < c->n; ++k) {
      const ej_node *pt = c->items[k];
      if (pt->type != EJ_NODE_SEQ || pt->n != 2 || pt->items[0]->type != EJ_NODE_SCALAR ||
          pt->items[1]->type != EJ_NODE_SCALAR)
        return ej_error_input(&pt->loc, "curve point %d: expected [time, pressure], e.g. [0.5 ms, 2 MPa]", k + 1);
      double t, p;
      EJ_TRY(ej_units_parse(pt->items[0]->text, "s", &pt->items[0]->loc, &t));
      EJ_TRY(ej_units_parse(pt->items[1]->text, "Pa", &pt->items[1]->loc, &p));
      if (!isfinite(t) || !isfinite(p))
        return ej_error_input(&pt->loc, "curve point %d: time and pressure must be finite", k + 1);
      if (k > 0 && !(t > bc->curve_t[k - 1]))
        return ej_error_input(&pt->items[0]->loc, "curve point %d: time %g s must be after the previous point's %g s",
                              k + 1, t, bc->curve_t[k - 1]);
      bc->curve_t[k] = t;
      bc->curve_p[k] = p;
    }
  } else {
    bc->source = EJ_PRESSURE_BLAST;
    const ej_node *bl = ej_node_get(v, "blast");
    EJ_TRY(ej_expect_map(bl, "blast"));
    ej_blast_cfg bc_cfg = {0};
    EJ_TRY(ej_params_apply(ej_blast_params, &bc_cfg, bl, "blast", ej_blast_manual, NULL));
    const ej_node *ch = ej_node_get(bl, "charge");
    if (!ch) return ej_error_input(&bl->loc, "blast needs 'charge': the centre of the charge, e.g. [0, 0, 1 m]");
    EJ_TRY(ej_node_vector(ch, L->sc->dimension, "m", bc->charge));
    bc->tnt = bc_cfg.tnt;
    bc->t_det = bc_cfg.time;
    bc->burst = bc_cfg.burst == 1 ? EJ_BURST_SURFACE : EJ_BURST_AIR;
  }
  return EJ_OK;
}

static ej_err ej_parse_bc(ej_loader *L, int index, ej_scene_bc *bc, const ej_node *n)
{
  const int dim = L->sc->dimension;
  EJ_TRY(ej_expect_map(n, "a boundary condition"));
  bc->loc = n->loc;
  bc->set = -1;
  static const char *const kinds[] = {"fix", "velocity", "symmetry", "periodic", "non_reflecting", "pressure", NULL};
  int kind = -1;
  for (int k = 0; kinds[k]; ++k)
    if (ej_node_get(n, kinds[k])) {
      if (kind >= 0)
        return ej_error_input(ej_node_key_loc(n, kinds[k]), "a boundary condition is one of fix, velocity, symmetry, "
                              "periodic, non_reflecting, pressure; found both '%s' and '%s'", kinds[kind], kinds[k]);
      kind = k;
    }
  if (kind < 0) {
    static const char *const all[] = {"fix", "velocity", "symmetry",   "periodic", "non_reflecting",
                                      "pressure", "set", "region", "components", NULL};
    EJ_TRY(ej_check_keys(n, "a boundary condition", all));
    return ej_error_input(&n->loc, "a boundary condition needs one of fix, velocity, symmetry, periodic, "
                                   "non_reflecting, pressure");
  }
  static const char *const keys_fix[] = {"fix", "set", "region", NULL};
  static const char *const keys_vel[] = {"velocity", "set", "region", "components", "until", NULL};
  static const char *const keys_sym[] = {"symmetry", "set", NULL};
  static const char *const keys_per[] = {"periodic", "set", NULL};
  static const char *const keys_nr[] = {"non_reflecting", "set", "region", NULL};
  static const char *const keys_pr[] = {"pressure", "set", "region", NULL};
  static const char *const *const keys[] = {keys_fix, keys_vel, keys_sym, keys_per, keys_nr, keys_pr};
  char what[EJ_WHAT_MAX];
  snprintf(what, sizeof what, "a %s boundary condition", kinds[kind]);
  EJ_TRY(ej_check_keys(n, what, keys[kind]));
  const ej_node *set = ej_node_get(n, "set"), *region = ej_node_get(n, "region");
  if (set) EJ_TRY(ej_set_ref(L, set, "boundary condition", &bc->set));
  if (region) EJ_TRY(ej_region(L, region, &bc->region));
  const ej_node *v = ej_node_get(n, kinds[kind]);
  switch (kind) {
  case 0:
    bc->kind = EJ_BC_FIX;
    EJ_TRY(ej_parse_components(v, dim, "fix", bc->comp));
    break;
  case 1: {
    bc->kind = EJ_BC_VELOCITY;
    EJ_TRY(ej_node_vector_plane(v, dim, "m/s", bc->velocity));
    /* until: the velocity is prescribed while t <= until, then the particles are free (an
     * impactor that separates); by default for the whole run */
    bc->until = INFINITY;
    const ej_node *u = ej_node_get(n, "until");
    if (u) {
      if (u->type != EJ_NODE_SCALAR)
        return ej_error_input(&u->loc, "until: expected a time (e.g. 50 us)");
      double t_until;
      EJ_TRY(ej_units_parse(u->text, "s", &u->loc, &t_until));
      if (!(t_until >= 0)) return ej_error_input(&u->loc, "until = %g s: expected a time >= 0", t_until);
      bc->until = t_until;
    }
    const ej_node *c = ej_node_get(n, "components");
    if (c) {
      EJ_TRY(ej_parse_components(c, dim, "components", bc->comp));
    } else {
      for (int k = 0; k < dim; ++k) bc->comp[k] = true;
    }
    break;
  }
  case 2: {
    bc->kind = EJ_BC_SYMMETRY;
    EJ_TRY(ej_expect_map(v, "symmetry"));
    static const char *const sk[] = {"point", "normal", NULL};
    EJ_TRY(ej_check_keys(v, "symmetry", sk));
    const ej_node *p = ej_node_get(v, "point"), *nn = ej_node_get(v, "normal");
    if (!p || !nn) return ej_error_input(&v->loc, "symmetry needs 'point' and 'normal' (pointing into the domain)");
    EJ_TRY(ej_node_vector(p, dim, "m", bc->point));
    EJ_TRY(ej_node_vector(nn, dim, "1", bc->normal));
    ej_real len = 0, in_plane = 0;
    for (int k = 0; k < 3; ++k) len += bc->normal[k] * bc->normal[k];
    for (int k = 0; k < dim; ++k) in_plane += bc->normal[k] * bc->normal[k];
    len = sqrt(len);
    if (!(len > 0) || !isfinite(len) || in_plane < 1e-24 * len * len)
      return ej_error_input(&nn->loc, "symmetry normal must be a non-zero vector in the %d used dimension%s", dim,
                            dim > 1 ? "s" : "");
    /* Mirror images across an unused axis would duplicate every particle. */
    for (int k = 0; k < 3; ++k) bc->normal[k] = k < dim ? bc->normal[k] / sqrt(in_plane) : 0;
    break;
  }
  case 3: {
    bc->kind = EJ_BC_PERIODIC;
    ej_periodic_cfg cfg = {0};
    EJ_TRY(ej_params_apply(ej_periodic_params, &cfg, v, "periodic", NULL, NULL));
    if (cfg.axis >= dim)
      return ej_error_input(&ej_node_get(v, "axis")->loc, "periodic axis '%s' is not used in a %dD scene",
                            ej_axis_names[cfg.axis], dim);
    if (!(cfg.min < cfg.max))
      return ej_error_input(&ej_node_get(v, "max")->loc, "periodic max must be > min (got %g and %g m)", cfg.max,
                            cfg.min);
    for (int b = 0; b < index; ++b)
      if (L->sc->bcs[b].kind == EJ_BC_PERIODIC && L->sc->bcs[b].axis == cfg.axis)
        return ej_error_input(&v->loc, "axis '%s' is already periodic (line %d)", ej_axis_names[cfg.axis],
                              L->sc->bcs[b].loc.line);
    bc->axis = cfg.axis;
    bc->lo = cfg.min;
    bc->hi = cfg.max;
    break;
  }
  case 4: {
    bc->kind = EJ_BC_NONREFLECT;
    if (!region)
      return ej_error_input(ej_node_key_loc(n, "non_reflecting"),
                            "non_reflecting needs 'region': the layer of particles on the truncated boundary "
                            "(one particle thick)");
    ej_nonrefl_cfg cfg = {0};
    EJ_TRY(ej_params_apply(ej_nonrefl_params, &cfg, v, "non_reflecting", ej_nonrefl_manual, NULL));
    EJ_TRY(ej_face_normal(L, v, "non_reflecting", bc));
    bc->rho = cfg.rho > 0 ? cfg.rho : NAN;
    bc->cp = cfg.cp > 0 ? cfg.cp : NAN;
    bc->cs = cfg.cs > 0 ? cfg.cs : NAN;
    break;
  }
  case 5:
    bc->kind = EJ_BC_PRESSURE;
    if (!region)
      return ej_error_input(ej_node_key_loc(n, "pressure"),
                            "pressure needs 'region': the layer of particles on the loaded face (one particle "
                            "thick)");
    EJ_TRY(ej_parse_pressure(L, v, bc));
    break;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ probes */

static ej_err ej_parse_probe(ej_loader *L, int k, const ej_node *n)
{
  ej_scene *sc = L->sc;
  ej_scene_probe *p = &sc->probes[k];
  EJ_TRY(ej_expect_map(n, "a probe"));
  p->loc = n->loc;
  p->set = -1;
  ej_probe_cfg cfg = {0};
  EJ_TRY(ej_params_apply(ej_probe_params, &cfg, n, "probe", ej_probe_manual, NULL));
  const ej_node *set = ej_node_get(n, "set"), *pt = ej_node_get(n, "point"), *fields = ej_node_get(n, "fields");
  if (!set) return ej_error_input(&n->loc, "a probe needs 'set': the name of the particle set it reads");
  EJ_TRY(ej_set_ref(L, set, "probe", &p->set));
  if (!pt) return ej_error_input(&n->loc, "a probe needs 'point': where it measures, e.g. [1 m, 0, 0]");
  EJ_TRY(ej_node_vector(pt, sc->dimension, "m", p->point));
  if (!fields)
    return ej_error_input(&n->loc, "a probe needs 'fields': a list of its set's field names, e.g. [p, rho, v]");
  if (fields->type != EJ_NODE_SEQ || fields->n == 0)
    return ej_error_input(&fields->loc, "probe fields must be a non-empty list of field names, got %s",
                          fields->type == EJ_NODE_SEQ ? "an empty list" : ej_kind_word(fields));
  if (fields->n > EJ_MAX_PROBE_FIELDS)
    return ej_error_input(&fields->items[EJ_MAX_PROBE_FIELDS]->loc, "a probe records at most %d fields",
                          EJ_MAX_PROBE_FIELDS);
  for (int f = 0; f < fields->n; ++f) {
    const char *name = NULL;
    EJ_TRY(ej_expect_word(fields->items[f], "a probe field", &name));
    for (int g = 0; g < p->n_fields; ++g)
      if (!strcmp(p->fields[g], name))
        return ej_error_input(&fields->items[f]->loc, "probe field '%s' is listed twice", name);
    p->fields[f] = ej_strdup(name);
    EJ_ENSURE(p->fields[f], EJ_ERR_MEM, "out of memory");
    p->field_locs[f] = fields->items[f]->loc;
    p->n_fields = f + 1;
  }
  p->follow = cfg.follow;
  p->radius = cfg.radius;
  const ej_node *rn = ej_node_get(n, "radius");
  if (p->follow && rn)
    return ej_error_input(&rn->loc, "radius applies to a gauge (follow: false); a tracer reads its own particle");
  const ej_node *nn = ej_node_get(n, "name");
  if (cfg.name) {
    bool ok = cfg.name[0] != 0 && strlen(cfg.name) <= 32;
    for (const char *c = cfg.name; *c; ++c)
      ok = ok && ((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '_' ||
                  *c == '.' || *c == '-');
    if (!ok)
      return ej_error_input(&nn->loc, "probe name '%s': expected 1 to 32 letters, digits, '_', '.' or '-'",
                            cfg.name);
    p->name = ej_strdup(cfg.name);
  } else {
    char buf[32];
    snprintf(buf, sizeof buf, "probe%d", k);
    p->name = ej_strdup(buf);
  }
  EJ_ENSURE(p->name, EJ_ERR_MEM, "out of memory");
  for (int j = 0; j < k; ++j)
    if (!strcmp(sc->probes[j].name, p->name))
      return ej_error_input(nn ? &nn->loc : &n->loc, "probe name '%s' is used twice (first at line %d)", p->name,
                            sc->probes[j].loc.line);
  return EJ_OK;
}

/* ------------------------------------------------------------------ top level */

static ej_err ej_parse_output(ej_loader *L, const ej_node *out)
{
  ej_scene *sc = L->sc;
  ej_output_cfg cfg = {0};
  if (out) {
    EJ_TRY(ej_params_apply(ej_output_params, &cfg, out, "output", ej_output_manual, NULL));
    sc->output_loc = ej_node_get(out, "file") ? ej_node_get(out, "file")->loc : out->loc;
  } else {
    EJ_TRY(ej_params_defaults(ej_output_params, &cfg));
    sc->output_loc = sc->doc->root->loc;
  }
  sc->output_every = cfg.every;
  sc->checkpoint_every = cfg.checkpoint_every;
  sc->set_series = cfg.set_series;
  if (cfg.file && cfg.file[0]) {
    sc->output_file = ej_strdup(cfg.file);
  } else {
    const char *path = sc->doc->path ? sc->doc->path : "scene";
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t n = strlen(base);
    const char *dot = strrchr(base, '.');
    if (dot && dot != base) n = (size_t)(dot - base);
    sc->output_file = ej_malloc(n + 8);
    if (sc->output_file) snprintf(sc->output_file, n + 8, "out/%.*s.h5", (int)n, base);
  }
  EJ_ENSURE(sc->output_file, EJ_ERR_MEM, "out of memory");
  const ej_node *fields = out ? ej_node_get(out, "fields") : NULL;
  if (fields) {
    if (fields->type != EJ_NODE_SEQ)
      return ej_error_input(&fields->loc, "output fields must be a list of field names, got %s", ej_kind_word(fields));
    sc->output_fields = ej_calloc((size_t)fields->n, sizeof *sc->output_fields);
    sc->output_field_locs = ej_calloc((size_t)fields->n, sizeof *sc->output_field_locs);
    EJ_ENSURE(sc->output_fields && sc->output_field_locs, EJ_ERR_MEM, "out of memory");
    for (int k = 0; k < fields->n; ++k) {
      const char *name = NULL;
      EJ_TRY(ej_expect_word(fields->items[k], "an output field", &name));
      sc->output_fields[k] = ej_strdup(name);
      EJ_ENSURE(sc->output_fields[k], EJ_ERR_MEM, "out of memory");
      sc->output_field_locs[k] = fields->items[k]->loc;
      sc->n_output_fields = k + 1;
    }
  }
  return EJ_OK;
}

static ej_err ej_scene_parse(ej_loader *L)
{
  ej_scene *sc = L->sc;
  const ej_node *root = sc->doc->root;
  if (!root) {
    ej_loc at = {sc->doc->path, 1, 1};
    return ej_error_input(&at, "scene is empty: expected a map with 'ejecta: 1', 'time' and 'sets'");
  }
  EJ_TRY(ej_expect_map(root, "the scene"));
  ej_top_cfg top = {0};
  EJ_TRY(ej_params_apply(ej_top_params, &top, root, "scene", ej_top_manual, NULL));
  sc->dimension = (int)top.dimension;
  sc->t_end = top.time.end;
  sc->cfl = top.time.cfl;
  sc->dt_fixed = top.time.dt;
  sc->dt_max = top.time.dt_max;
  sc->max_steps = top.time.max_steps;
  sc->dt_min = top.time.dt_min;
  sc->dt_min_ratio = top.time.dt_min_ratio;
  if (sc->dt_min > 0 && (sc->dt_fixed > 0 || (sc->dt_max > 0 && sc->dt_min >= sc->dt_max))) {
    const ej_node *tn = ej_node_get(root, "time");
    return ej_error_input(ej_node_key_loc(tn, "dt_min"), "time: dt_min = %g s %s", sc->dt_min,
                          sc->dt_fixed > 0 ? "bounds the adaptive step and cannot go with a fixed dt"
                                           : "must be smaller than dt_max");
  }
  sc->skin = top.neighbours.skin;
  sc->ghost_reach = top.neighbours.ghost_reach;

  EJ_TRY(ej_parse_output(L, ej_node_get(root, "output")));
  const ej_node *g = ej_node_get(root, "gravity");
  if (g) EJ_TRY(ej_node_vector_plane(g, sc->dimension, "m/s^2", sc->gravity));

  const ej_node *mats = ej_node_get(root, "materials");
  if (mats) {
    EJ_TRY(ej_expect_map(mats, "materials"));
    sc->materials = ej_calloc((size_t)mats->n, sizeof *sc->materials);
    L->mat_names = ej_calloc((size_t)mats->n, sizeof *L->mat_names);
    EJ_ENSURE(sc->materials && L->mat_names, EJ_ERR_MEM, "out of memory");
    sc->n_materials = mats->n;
    for (int i = 0; i < mats->n; ++i) EJ_TRY(ej_parse_material(L, i, mats));
  }

  const ej_node *sets = ej_node_get(root, "sets");
  if (!sets) return ej_error_input(&root->loc, "scene has no 'sets' (at least one particle set is needed)");
  EJ_TRY(ej_expect_map(sets, "sets"));
  if (sets->n == 0) return ej_error_input(&sets->loc, "'sets' is empty (at least one particle set is needed)");
  L->sets_node = sets;
  sc->sets = ej_calloc((size_t)sets->n, sizeof *sc->sets);
  L->set_names = ej_calloc((size_t)sets->n, sizeof *L->set_names);
  L->shape_state = ej_calloc((size_t)sets->n, sizeof *L->shape_state);
  EJ_ENSURE(sc->sets && L->set_names && L->shape_state, EJ_ERR_MEM, "out of memory");
  sc->n_sets = sets->n;
  /* Names first: shapes may subtract sets defined further down. */
  for (int i = 0; i < sets->n; ++i) {
    sc->sets[i].name = ej_strdup(sets->keys[i]);
    EJ_ENSURE(sc->sets[i].name, EJ_ERR_MEM, "out of memory");
    sc->sets[i].loc = sets->key_locs[i];
    sc->sets[i].material = -1;
    L->set_names[i] = sc->sets[i].name;
  }
  L->env = (ej_shape_env){.lookup = ej_lookup_set_shape, .ctx = L, .names = L->set_names, .n_names = sc->n_sets};
  for (int i = 0; i < sets->n; ++i) EJ_TRY(ej_parse_set(L, i));

  /* Watchdog: every particle must stay inside the domain shape (any shape, set names in minus). */
  const ej_node *dom = ej_node_get(root, "domain");
  if (dom) {
    EJ_TRY(ej_region(L, dom, &sc->domain));
    sc->domain_loc = dom->loc;
  }

  const ej_node *inter = ej_node_get(root, "interactions");
  if (inter) {
    if (inter->type != EJ_NODE_SEQ)
      return ej_error_input(&inter->loc, "interactions must be a list, got %s", ej_kind_word(inter));
    sc->interactions = ej_calloc((size_t)inter->n, sizeof *sc->interactions);
    EJ_ENSURE(sc->interactions, EJ_ERR_MEM, "out of memory");
    sc->n_interactions = inter->n;
    for (int k = 0; k < inter->n; ++k) EJ_TRY(ej_parse_interaction(L, &sc->interactions[k], inter->items[k]));
  }

  const ej_node *bcs = ej_node_get(root, "boundaries");
  if (bcs) {
    if (bcs->type != EJ_NODE_SEQ)
      return ej_error_input(&bcs->loc, "boundaries must be a list, got %s", ej_kind_word(bcs));
    if (bcs->n > EJ_MAX_BCS)
      return ej_error_input(&bcs->items[EJ_MAX_BCS]->loc, "too many boundary conditions (at most %d)", EJ_MAX_BCS);
    sc->bcs = ej_calloc((size_t)bcs->n, sizeof *sc->bcs);
    EJ_ENSURE(sc->bcs, EJ_ERR_MEM, "out of memory");
    sc->n_bcs = bcs->n;
    for (int k = 0; k < bcs->n; ++k) EJ_TRY(ej_parse_bc(L, k, &sc->bcs[k], bcs->items[k]));
  }

  const ej_node *probes = ej_node_get(root, "probes");
  if (probes) {
    if (probes->type != EJ_NODE_SEQ)
      return ej_error_input(&probes->loc, "probes must be a list, got %s", ej_kind_word(probes));
    sc->probes = ej_calloc((size_t)(probes->n > 0 ? probes->n : 1), sizeof *sc->probes);
    EJ_ENSURE(sc->probes, EJ_ERR_MEM, "out of memory");
    for (int k = 0; k < probes->n; ++k) {
      sc->n_probes = k + 1;
      EJ_TRY(ej_parse_probe(L, k, probes->items[k]));
    }
  }
  return EJ_OK;
}

ej_err ej_scene_from_doc(ej_doc *doc, ej_registry *reg, ej_scene **out)
{
  *out = NULL;
  ej_scene *sc = ej_calloc(1, sizeof *sc);
  if (!sc) {
    ej_doc_destroy(doc);
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  sc->doc = doc;
  ej_loader L = {.sc = sc, .reg = reg};
  ej_err rc = EJ_OK;
  EJ_TRY_GOTO(rc, ej_scene_parse(&L), out_free_scene);
  *out = sc;
  goto out_free_loader;

out_free_scene:
  ej_scene_free(sc);
out_free_loader:
  ej_free(L.set_names);
  ej_free(L.mat_names);
  ej_free(L.shape_state);
  return rc;
}

ej_err ej_scene_load_impl(const char *path, ej_registry *reg, ej_scene **scene)
{
  EJ_ENSURE(path && reg && scene, EJ_ERR_ARG, "NULL argument");
  *scene = NULL;
  ej_doc *doc = NULL;
  EJ_TRY(ej_doc_load(path, &doc));
  EJ_TRY(ej_scene_from_doc(doc, reg, scene));
  return EJ_OK;
}

ej_err ej_scene_load(const char *path, ej_registry *reg, ej_scene **scene)
{
  EJ_TRY(ej_scene_load_impl(path, reg, scene));
  return EJ_OK;
}

void ej_scene_destroy(ej_scene *scene) { ej_scene_free(scene); }

void ej_scene_free(ej_scene *sc)
{
  if (!sc) return;
  for (int i = 0; i < sc->n_materials; ++i) {
    ej_free(sc->materials[i].name);
    ej_free(sc->materials[i].eos_config);
    ej_free(sc->materials[i].mat_config);
  }
  ej_free(sc->materials);
  for (int i = 0; i < sc->n_sets; ++i) {
    ej_scene_set *s = &sc->sets[i];
    ej_free(s->name);
    ej_free(s->method_config);
    ej_shape_destroy(s->shape);
    for (int k = 0; k < s->n_refine; ++k) ej_shape_destroy(s->refine[k].region);
    ej_free(s->refine);
    ej_free(s->file);
    for (int k = 0; k < s->n_init; ++k) ej_shape_destroy(s->init[k].region);
    ej_free(s->init);
  }
  ej_free(sc->sets);
  for (int k = 0; k < sc->n_bcs; ++k) {
    ej_shape_destroy(sc->bcs[k].region);
    ej_free(sc->bcs[k].curve_t);
    ej_free(sc->bcs[k].curve_p);
  }
  ej_free(sc->bcs);
  ej_shape_destroy(sc->domain);
  for (int k = 0; k < sc->n_interactions; ++k) ej_free(sc->interactions[k].config);
  ej_free(sc->interactions);
  for (int k = 0; k < sc->n_output_fields; ++k) ej_free(sc->output_fields[k]);
  ej_free(sc->output_fields);
  for (int k = 0; k < sc->n_probes; ++k) {
    ej_free(sc->probes[k].name);
    for (int f = 0; f < sc->probes[k].n_fields; ++f) ej_free(sc->probes[k].fields[f]);
  }
  ej_free(sc->probes);
  ej_free(sc->output_field_locs);
  ej_free(sc->output_file);
  ej_doc_destroy(sc->doc);
  ej_free(sc);
}

/* ------------------------------------------------------------------ describe */

typedef struct ej_describe_key {
  const char *key, *what;
} ej_describe_key;

static ej_err ej_describe_section(ej_buf *b, const char *title, const char *intro, const ej_param *table,
                                  const ej_describe_key *keys)
{
  EJ_TRY(ej_buf_printf(b, "\n%s\n", title));
  if (intro) EJ_TRY(ej_buf_printf(b, "  %s\n", intro));
  if (table && table[0].name) EJ_TRY(ej_params_describe(b, table, 2));
  for (const ej_describe_key *k = keys; k && k->key; ++k) EJ_TRY(ej_buf_printf(b, "  %-18s %s\n", k->key, k->what));
  return EJ_OK;
}

/* `ejecta describe scene`: the core's keys, from the same tables that parse and check them and
 * that make the JSON Schema (plugins: `ejecta describe NAME`). */
ej_err ej_scene_describe(ej_buf *b)
{
  static const ej_describe_key top[] = {
      {"output", "HDF5 output: file, frame and checkpoint intervals, fields, set_series (below)"},
      {"gravity", "vector (m/s^2), e.g. [0, 0, -9.81]"},
      {"materials", "map name -> {rho0, eos: {model: NAME, ...}, model: NAME, ...}: 'ejecta describe NAME'"},
      {"sets", "map name -> a particle set (below)"},
      {"interactions", "list of {model: NAME, sets: [a] or [a, b], ...}: 'ejecta describe NAME'"},
      {"boundaries", "list of fix / velocity / symmetry / periodic conditions (below)"},
      {"domain", "a shape: a particle leaving it stops the run (exit 1)"},
      {"probes", "list of point gauges and tracers (below)"},
      {NULL, NULL}};
  static const ej_describe_key out[] = {
      {"fields", "list of field names written to frames; default every output field of each set"}, {NULL, NULL}};
  static const ej_describe_key set[] = {
      {"method", "plugin name and its parameters in the set's map ('ejecta describe NAME')"},
      {"material", "a name from materials"},
      {"shape", "box {min, max}, sphere {center, radius}, cylinder {base, axis, radius, height}, half_space "
                "{point, normal}, union / intersect [shapes], minus: [set names or shapes]"},
      {"file", "CSV of particles: columns x, y, z [, vol] (instead of shape)"},
      {"refine", "list of {region: shape, spacing}: region-wise lattice spacing (below)"},
      {"velocity", "initial velocity vector (m/s)"},
      {"initial", "list of {region: shape, rho, e, p, energy_total, velocity} overrides (below)"},
      {NULL, NULL}};
  static const ej_describe_key region[] = {{"region", "shape the entry applies to"}, {NULL, NULL}};
  static const ej_describe_key init[] = {{"region", "shape the entry applies to"},
                                         {"velocity", "initial velocity vector (m/s) in the region"},
                                         {NULL, NULL}};
  static const ej_describe_key bcs[] = {
      {"fix", "list of components [x, y, z] held at zero velocity; with set, region"},
      {"velocity", "prescribed velocity vector (m/s); with set, region, components, until (s)"},
      {"symmetry", "{point, normal}: mirror plane, the normal into the domain (mirror ghosts)"},
      {"periodic", "{axis, min, max} (below)"},
      {"non_reflecting", "{normal | center, rho, cp, cs} (below): viscous dashpots on the particles of region"},
      {"pressure", "{normal | center [, cavity], value | curve | blast} (below): a pressure p(t) on the particles "
                   "of region (a solid's face; on an SPH gas it is no piston)"},
      {"set", "the set it applies to (default: every set)"},
      {NULL, NULL}};
  static const ej_describe_key probe[] = {
      {"set", "the particle set it reads (required)"},
      {"point", "gauge point, or (follow) the point whose nearest particle at t = 0 is followed (m; required)"},
      {"fields", "list of the set's fields, one column a component (required; at most 16)"},
      {NULL, NULL}};
  EJ_TRY(ej_buf_printf(b, "scene: the core's keys (docs/core.md; JSON Schema: 'ejecta schema'; plugins: "
                          "'ejecta describe NAME')\n"));
  EJ_TRY(ej_describe_section(b, "top level", NULL, ej_top_params, top));
  EJ_TRY(ej_describe_section(b, "output", NULL, ej_output_params, out));
  EJ_TRY(ej_describe_section(b, "materials.<name>", NULL, ej_mat_params, NULL));
  EJ_TRY(ej_describe_section(b, "sets.<name>", NULL, ej_set_params, set));
  EJ_TRY(ej_describe_section(b, "sets.<name>.refine[]", NULL, ej_refine_params, region));
  EJ_TRY(ej_describe_section(b, "sets.<name>.initial[]", NULL, ej_init_params, init));
  EJ_TRY(ej_describe_section(b, "boundaries[]", "one of fix, velocity, symmetry, periodic, non_reflecting, pressure:",
                             NULL, bcs));
  EJ_TRY(ej_describe_section(b, "boundaries[].periodic", NULL, ej_periodic_params, NULL));
  static const ej_describe_key nonrefl[] = {
      {"normal", "outward normal of a plane boundary, e.g. [1, 0, 0] on the face x = max (one of normal, center)"},
      {"center", "centre of a spherical (2D: circular) boundary: normal (x - center)/|x - center| (m)"},
      {NULL, NULL}};
  EJ_TRY(ej_describe_section(b, "boundaries[].non_reflecting", NULL, ej_nonrefl_params, nonrefl));
  static const ej_describe_key press[] = {
      {"normal", "outward normal of a plane face, e.g. [0, 0, 1] on the top face (one of normal, center); the "
                 "pressure pushes against it"},
      {"center", "centre of a spherical (2D: circular) face: normal (x - center)/|x - center|, or its opposite with "
                 "cavity (m)"},
      {"curve", "[[t, p], ...]: p(t) linear between the points, the end values outside (s, Pa)"},
      {"blast", "{charge, tnt, burst, time} (below): Kingery-Bulmash air blast (CONWEP) on the face"},
      {NULL, NULL}};
  EJ_TRY(ej_describe_section(b, "boundaries[].pressure", NULL, ej_pressure_params, press));
  static const ej_describe_key blast[] = {{"charge", "centre of the charge (m; required)"}, {NULL, NULL}};
  EJ_TRY(ej_describe_section(b, "boundaries[].pressure.blast", NULL, ej_blast_params, blast));
  EJ_TRY(ej_describe_section(b, "probes[]", "recorded every step into /series/probe/<name>/<column>:",
                             ej_probe_params, probe));
  return EJ_OK;
}

/* ------------------------------------------------------------------ particles */

ej_err ej_scene_set_points(const ej_scene *sc, int set, ej_points *pts)
{
  EJ_ENSURE(sc && pts && set >= 0 && set < sc->n_sets, EJ_ERR_ARG, "bad set index %d", set);
  const ej_scene_set *s = &sc->sets[set];
  memset(pts, 0, sizeof *pts);
  if (s->file) {
    EJ_TRY(ej_points_read_csv(s->file, sc->dimension, s->spacing, &s->file_loc, pts));
    return EJ_OK;
  }
  EJ_ENSURE(s->shape, EJ_ERR_INTERNAL, "set '%s' has neither shape nor file", s->name);
  ej_fill f = {.dim = sc->dimension,
               .lattice = s->lattice,
               .spacing = s->spacing,
               .refine = s->refine,
               .n_refine = s->n_refine,
               .jitter = s->jitter,
               .seed = s->seed,
               .origin = s->has_origin ? s->origin : NULL,
               .jitter_volume = s->jitter_volume};
  EJ_TRY(ej_shape_fill(s->shape, &f, pts));
  if (pts->n == 0)
    return ej_error_input(&s->loc, "set '%s' has no particles: its shape holds no lattice point at spacing %g m",
                          s->name, s->spacing);
  return EJ_OK;
}

/* ------------------------------------------------------------------ JSON Schema */

static ej_err ej_json_string(ej_buf *b, const char *s)
{
  EJ_TRY(ej_buf_printf(b, "\""));
  for (; *s; ++s) {
    unsigned char c = (unsigned char)*s;
    if (c == '"' || c == '\\')
      EJ_TRY(ej_buf_printf(b, "\\%c", c));
    else if (c < 0x20)
      EJ_TRY(ej_buf_printf(b, "\\u%04x", c));
    else
      EJ_TRY(ej_buf_printf(b, "%c", c));
  }
  return ej_buf_printf(b, "\"");
}

/* Registry items of kind k sorted by name, so the schema never depends on load order. */
static ej_err ej_sorted_ops(ej_registry *reg, ej_kind k, const ej_ops_head ***out, int *n)
{
  *n = ej_registry_count(reg, k);
  *out = ej_calloc((size_t)*n + 1, sizeof **out);
  EJ_ENSURE(*out, EJ_ERR_MEM, "out of memory");
  for (int i = 0; i < *n; ++i) {
    const ej_ops_head *h = ej_registry_item(reg, k, i);
    int j = i;
    while (j > 0 && strcmp((*out)[j - 1]->name, h->name) > 0) {
      (*out)[j] = (*out)[j - 1];
      --j;
    }
    (*out)[j] = h;
  }
  return EJ_OK;
}

/* Extra (caller-owned) keys of a block: the manual keys plus, optionally, the names of
 * every table in list. */
static const char **ej_keys_union(const char *const *fixed, const ej_param *table, const ej_ops_head *const *list,
                                  int n)
{
  int cap = 1, nf = 0;
  while (fixed && fixed[nf]) ++nf;
  cap += nf;
  for (const ej_param *p = table; p && p->name; ++p) ++cap;
  for (int i = 0; i < n; ++i)
    for (const ej_param *p = list[i]->params; p && p->name; ++p) ++cap;
  const char **out = ej_calloc((size_t)cap, sizeof *out);
  if (!out) return NULL;
  int m = 0;
  for (int i = 0; i < nf; ++i) out[m++] = fixed[i];
  for (const ej_param *p = table; p && p->name; ++p)
    if (ej_index_of(out, m, p->name) < 0) out[m++] = p->name;
  for (int i = 0; i < n; ++i)
    for (const ej_param *p = list[i]->params; p && p->name; ++p)
      if (ej_index_of(out, m, p->name) < 0) out[m++] = p->name;
  return out;
}

static ej_err ej_schema_table(ej_buf *b, const ej_param *table, const char *const *fixed, const ej_param *other,
                              const ej_ops_head *const *list, int n)
{
  const char **extra = ej_keys_union(fixed, other, list, n);
  EJ_ENSURE(extra, EJ_ERR_MEM, "out of memory");
  ej_err rc = ej_params_schema(b, table, extra);
  ej_free(extra);
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);
  return EJ_OK;
}

static const char ej_schema_defs[] =
    "\"quantity\":{\"description\":\"A number, or a number with a unit such as \\\"4 mm\\\".\","
    "\"oneOf\":[{\"type\":\"number\"},{\"type\":\"string\",\"pattern\":\"^\\\\s*[-+0-9.eE]+\\\\s*\\\\S*$\"}]},"
    "\"vector\":{\"description\":\"dimension or 3 components; missing ones are 0.\",\"type\":\"array\","
    "\"minItems\":1,\"maxItems\":3,\"items\":{\"$ref\":\"#/$defs/quantity\"}},"
    "\"shape\":{\"type\":\"object\",\"additionalProperties\":false,\"properties\":{"
    "\"box\":{\"type\":\"object\",\"additionalProperties\":false,\"properties\":{\"min\":{\"$ref\":\"#/$defs/vector\"},"
    "\"max\":{\"$ref\":\"#/$defs/vector\"},\"center\":{\"$ref\":\"#/$defs/vector\"},\"size\":{\"$ref\":\"#/$defs/vector\"}}},"
    "\"cylinder\":{\"type\":\"object\",\"additionalProperties\":false,\"required\":[\"radius\",\"height\"],"
    "\"properties\":{\"base\":{\"$ref\":\"#/$defs/vector\"},\"center\":{\"$ref\":\"#/$defs/vector\"},"
    "\"axis\":{\"$ref\":\"#/$defs/vector\",\"default\":[0,0,1]},\"radius\":{\"$ref\":\"#/$defs/quantity\"},"
    "\"height\":{\"$ref\":\"#/$defs/quantity\"}}},"
    "\"sphere\":{\"type\":\"object\",\"additionalProperties\":false,\"required\":[\"center\",\"radius\"],"
    "\"properties\":{\"center\":{\"$ref\":\"#/$defs/vector\"},\"radius\":{\"$ref\":\"#/$defs/quantity\"}}},"
    "\"half_space\":{\"description\":\"Points x with (x - point) . normal <= 0: the normal points out of the "
    "material.\",\"type\":\"object\",\"additionalProperties\":false,\"required\":[\"point\",\"normal\"],"
    "\"properties\":{\"point\":{\"$ref\":\"#/$defs/vector\"},\"normal\":{\"$ref\":\"#/$defs/vector\"}}},"
    "\"union\":{\"type\":\"array\",\"minItems\":1,\"items\":{\"$ref\":\"#/$defs/shape\"}},"
    "\"intersect\":{\"type\":\"array\",\"minItems\":1,\"items\":{\"$ref\":\"#/$defs/shape\"}},"
    "\"minus\":{\"description\":\"Shapes or names of other sets subtracted from this shape.\",\"type\":\"array\","
    "\"items\":{\"oneOf\":[{\"type\":\"string\"},{\"$ref\":\"#/$defs/shape\"}]}}},"
    "\"oneOf\":[{\"required\":[\"box\"]},{\"required\":[\"cylinder\"]},{\"required\":[\"sphere\"]},"
    "{\"required\":[\"half_space\"]},{\"required\":[\"union\"]},{\"required\":[\"intersect\"]}]},"
    "\"components\":{\"oneOf\":[{\"const\":\"all\"},{\"type\":\"array\",\"minItems\":1,"
    "\"items\":{\"enum\":[\"x\",\"y\",\"z\"]}}]},";

/* Keys of a set that the core reads itself, with their schemas (the rest come from tables). */
static const char ej_schema_set_manual[] =
    "{\"required\":[\"method\",\"material\"],\"oneOf\":[{\"required\":[\"shape\"]},{\"required\":[\"file\"]}],"
    "\"properties\":{\"material\":{\"type\":\"string\",\"description\":\"A key of materials.\"},"
    "\"shape\":{\"$ref\":\"#/$defs/shape\"},"
    "\"file\":{\"type\":\"string\",\"description\":\"CSV particle file (columns x, y, z, vol, spacing), relative "
    "to the scene file.\"},"
    "\"refine\":{\"type\":\"array\",\"items\":%s},"
    "\"velocity\":{\"$ref\":\"#/$defs/vector\",\"description\":\"Initial velocity.\"},"
    "\"initial\":{\"type\":\"array\",\"description\":\"Region-wise initial conditions, applied in order.\","
    "\"items\":{\"allOf\":[%s,{\"properties\":{\"region\":{\"$ref\":\"#/$defs/shape\"},"
    "\"velocity\":{\"$ref\":\"#/$defs/vector\"}}}]}}}}";

static ej_err ej_schema_sets(ej_buf *b, ej_registry *reg)
{
  const ej_ops_head **m = NULL;
  int n = 0;
  EJ_TRY(ej_sorted_ops(reg, EJ_KIND_METHOD, &m, &n));
  ej_buf refine = {0}, init = {0};
  ej_err rc = EJ_OK;
  EJ_TRY_GOTO(rc, ej_buf_printf(&refine, "{\"allOf\":["), out_free);
  EJ_TRY_GOTO(rc, ej_params_schema(&refine, ej_refine_params, ej_refine_manual), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(&refine, ",{\"required\":[\"region\"],\"properties\":{\"region\":{\"$ref\":"
                                         "\"#/$defs/shape\"}}}]}"),
              out_free);
  EJ_TRY_GOTO(rc, ej_params_schema(&init, ej_init_params, ej_init_manual), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "\"set_core\":"), out_free);
  EJ_TRY_GOTO(rc, ej_schema_table(b, ej_set_params, ej_set_manual, NULL, m, n), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, ",\"set_keys\":"), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, ej_schema_set_manual, refine.data, init.data), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, ",\"set\":{\"description\":\"A particle set: its method plugin, material, "
                                   "geometry and initial conditions.\",\"type\":\"object\","),
              out_free);
  if (n == 0) {
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "\"allOf\":[{\"$ref\":\"#/$defs/set_core\"},{\"$ref\":\"#/$defs/set_keys\"}]}"),
                out_free);
  } else {
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "\"properties\":{\"method\":{\"enum\":["), out_free);
    for (int i = 0; i < n; ++i) {
      if (i) EJ_TRY_GOTO(rc, ej_buf_printf(b, ","), out_free);
      EJ_TRY_GOTO(rc, ej_json_string(b, m[i]->name), out_free);
    }
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "]}},\"oneOf\":["), out_free);
    for (int i = 0; i < n; ++i) {
      EJ_TRY_GOTO(rc, ej_buf_printf(b, "%s{\"allOf\":[{\"$ref\":\"#/$defs/set_core\"},{\"$ref\":\"#/$defs/set_keys\"},"
                                       "{\"properties\":{\"method\":{\"const\":",
                                    i ? "," : ""),
                  out_free);
      EJ_TRY_GOTO(rc, ej_json_string(b, m[i]->name), out_free);
      EJ_TRY_GOTO(rc, ej_buf_printf(b, "}}},"), out_free);
      EJ_TRY_GOTO(rc, ej_schema_table(b, m[i]->params, ej_set_manual, ej_set_params, NULL, 0), out_free);
      if (m[i]->summary) {
        EJ_TRY_GOTO(rc, ej_buf_printf(b, "],\"description\":"), out_free);
        EJ_TRY_GOTO(rc, ej_json_string(b, m[i]->summary), out_free);
        EJ_TRY_GOTO(rc, ej_buf_printf(b, "}"), out_free);
      } else {
        EJ_TRY_GOTO(rc, ej_buf_printf(b, "]}"), out_free);
      }
    }
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "]}"), out_free);
  }
out_free:
  ej_buf_free(&refine);
  ej_buf_free(&init);
  ej_free(m);
  return rc;
}

/* One alternative per plugin of kind k, discriminated by "model": {"const": name}. */
static ej_err ej_schema_models(ej_buf *b, const ej_ops_head *const *list, int n, const char *const *fixed,
                               const ej_param *other, const char *ref)
{
  for (int i = 0; i < n; ++i) {
    EJ_TRY(ej_buf_printf(b, "%s{\"allOf\":[", i ? "," : ""));
    if (ref) EJ_TRY(ej_buf_printf(b, "{\"$ref\":\"%s\"},", ref));
    EJ_TRY(ej_buf_printf(b, "{\"required\":[\"model\"],\"properties\":{\"model\":{\"const\":"));
    EJ_TRY(ej_json_string(b, list[i]->name));
    EJ_TRY(ej_buf_printf(b, "}}},"));
    EJ_TRY(ej_schema_table(b, list[i]->params, fixed, other, NULL, 0));
    EJ_TRY(ej_buf_printf(b, "]"));
    if (list[i]->summary) {
      EJ_TRY(ej_buf_printf(b, ",\"description\":"));
      EJ_TRY(ej_json_string(b, list[i]->summary));
    }
    EJ_TRY(ej_buf_printf(b, "}"));
  }
  return EJ_OK;
}

static ej_err ej_schema_materials(ej_buf *b, ej_registry *reg)
{
  const ej_ops_head **eos = NULL, **mat = NULL;
  int ne = 0, nm = 0;
  ej_err rc = EJ_OK;
  EJ_TRY_GOTO(rc, ej_sorted_ops(reg, EJ_KIND_EOS, &eos, &ne), out_free);
  EJ_TRY_GOTO(rc, ej_sorted_ops(reg, EJ_KIND_MATERIAL, &mat, &nm), out_free);
  static const char *const eos_fixed[] = {"model", NULL};
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "\"eos\":{\"description\":\"Equation of state: model and its parameters.\","
                                   "\"type\":\"object\",\"required\":[\"model\"],\"oneOf\":["),
              out_free);
  EJ_TRY_GOTO(rc, ej_schema_models(b, eos, ne, eos_fixed, NULL, NULL), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "]},\"material_core\":"), out_free);
  EJ_TRY_GOTO(rc, ej_schema_table(b, ej_mat_params, ej_mat_manual, NULL, mat, nm), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, ",\"material\":{\"description\":\"A material: reference density, equation of "
                                   "state and/or strength model.\",\"type\":\"object\",\"allOf\":[{\"$ref\":"
                                   "\"#/$defs/material_core\"},{\"properties\":{\"eos\":{\"$ref\":\"#/$defs/eos\"},"
                                   "\"model\":{\"type\":\"string\",\"description\":\"Strength model plugin.\"}}}],"
                                   "\"oneOf\":[{\"required\":[\"eos\"],\"not\":{\"required\":[\"model\"]},"
                                   "\"allOf\":["),
              out_free);
  static const char *const mat_fixed[] = {"rho0", "eos", "model", NULL};
  EJ_TRY_GOTO(rc, ej_params_schema(b, NULL, mat_fixed), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "]}"), out_free);
  if (nm) EJ_TRY_GOTO(rc, ej_buf_printf(b, ","), out_free);
  EJ_TRY_GOTO(rc, ej_schema_models(b, mat, nm, mat_fixed, NULL, NULL), out_free);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "]}"), out_free);
out_free:
  ej_free(eos);
  ej_free(mat);
  return rc;
}

static ej_err ej_schema_interactions(ej_buf *b, ej_registry *reg)
{
  const ej_ops_head **it = NULL;
  int n = 0;
  EJ_TRY(ej_sorted_ops(reg, EJ_KIND_INTERACTION, &it, &n));
  ej_err rc = EJ_OK;
  static const char *const fixed[] = {"model", "sets", NULL};
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "\"interaction\":{\"description\":\"An interaction between two sets, or acting on one set.\","
                                   "\"type\":\"object\",\"required\":[\"model\",\"sets\"],\"properties\":{\"sets\":"
                                   "{\"type\":\"array\",\"minItems\":1,\"maxItems\":2,\"items\":{\"type\":\"string\"}}}"),
              out_free);
  if (n) {
    EJ_TRY_GOTO(rc, ej_buf_printf(b, ",\"oneOf\":["), out_free);
    EJ_TRY_GOTO(rc, ej_schema_models(b, it, n, fixed, NULL, NULL), out_free);
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "]"), out_free);
  }
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "}"), out_free);
out_free:
  ej_free(it);
  return rc;
}

static const char ej_schema_bc_head[] =
    "\"boundary\":{\"description\":\"Boundary condition: fix, velocity, symmetry, periodic, non_reflecting or pressure.\",\"type\":\"object\","
    "\"oneOf\":["
    "{\"additionalProperties\":false,\"required\":[\"fix\"],\"properties\":{\"set\":{\"type\":\"string\"},"
    "\"region\":{\"$ref\":\"#/$defs/shape\"},\"fix\":{\"$ref\":\"#/$defs/components\"}}},"
    "{\"additionalProperties\":false,\"required\":[\"velocity\"],\"properties\":{\"set\":{\"type\":\"string\"},"
    "\"region\":{\"$ref\":\"#/$defs/shape\"},\"velocity\":{\"$ref\":\"#/$defs/vector\"},"
    "\"components\":{\"$ref\":\"#/$defs/components\"},\"until\":{\"$ref\":\"#/$defs/quantity\","
    "\"description\":\"Time [s] up to which the velocity is prescribed; then the particles are free. "
    "Default: the whole run.\"}}},"
    "{\"additionalProperties\":false,\"required\":[\"symmetry\"],\"properties\":{\"set\":{\"type\":\"string\"},"
    "\"symmetry\":{\"type\":\"object\",\"additionalProperties\":false,\"required\":[\"point\",\"normal\"],"
    "\"description\":\"Mirror plane; the normal points into the domain.\",\"properties\":{\"point\":"
    "{\"$ref\":\"#/$defs/vector\"},\"normal\":{\"$ref\":\"#/$defs/vector\"}}}}},"
    "{\"additionalProperties\":false,\"required\":[\"periodic\"],\"properties\":{\"set\":{\"type\":\"string\"},"
    "\"periodic\":";

/* The outward normal or centre of a face boundary (non_reflecting, pressure): one of the two. */
static const char ej_schema_face[] =
    "{\"oneOf\":[{\"required\":[\"normal\"]},{\"required\":[\"center\"]}],\"properties\":{\"normal\":{\"$ref\":"
    "\"#/$defs/vector\",\"description\":\"Outward normal of a plane face.\"},\"center\":{\"$ref\":\"#/$defs/"
    "vector\",\"description\":\"Centre of a spherical (2D: circular) face (m).\"}}}";

static ej_err ej_schema_compact(ej_registry *reg, ej_buf *b)
{
  EJ_TRY(ej_buf_printf(b, "{\"$schema\":\"https://json-schema.org/draft/2020-12/schema\","
                          "\"title\":\"ejecta scene\",\"description\":\"Generated by 'ejecta schema' from the "
                          "parameter tables of the core and of every plugin found. Do not edit.\","
                          "\"type\":\"object\",\"additionalProperties\":false,\"required\":["));
  for (const ej_param *p = ej_top_params; p->name; ++p)
    if (p->flags & EJ_PF_REQUIRED) EJ_TRY(ej_buf_printf(b, "\"%s\",", p->name));
  EJ_TRY(ej_buf_printf(b, "\"sets\"],\"properties\":{"));
  /* Table keys point into the table's own schema so that they have one source. */
  for (const ej_param *p = ej_top_params; p->name; ++p)
    EJ_TRY(ej_buf_printf(b, "\"%s\":{\"$ref\":\"#/$defs/scene_core/properties/%s\"},", p->name, p->name));
  EJ_TRY(ej_buf_printf(b, "\"output\":{\"allOf\":["));
  EJ_TRY(ej_params_schema(b, ej_output_params, ej_output_manual));
  EJ_TRY(ej_buf_printf(b, ",{\"properties\":{\"fields\":{\"type\":\"array\",\"items\":{\"type\":\"string\"},"
                          "\"description\":\"Fields written to frames; default every output field.\"}}}]},"
                          "\"gravity\":{\"$ref\":\"#/$defs/vector\",\"description\":\"Gravity (m/s^2).\"},"
                          "\"domain\":{\"$ref\":\"#/$defs/shape\",\"description\":\"Watchdog: a particle "
                          "leaving this shape stops the run (exit 1).\"},"
                          "\"materials\":{\"type\":\"object\",\"additionalProperties\":{\"$ref\":"
                          "\"#/$defs/material\"}},"
                          "\"sets\":{\"type\":\"object\",\"minProperties\":1,\"additionalProperties\":{\"$ref\":"
                          "\"#/$defs/set\"}},"
                          "\"interactions\":{\"type\":\"array\",\"items\":{\"$ref\":\"#/$defs/interaction\"}},"
                          "\"boundaries\":{\"type\":\"array\",\"maxItems\":%d,\"items\":{\"$ref\":"
                          "\"#/$defs/boundary\"}},"
                          "\"probes\":{\"type\":\"array\",\"items\":{\"$ref\":\"#/$defs/probe\"},"
                          "\"description\":\"Point gauges and tracers, written every step to /series/probe/<name>/.\"}"
                          "},\"$defs\":{\"scene_core\":",
                       EJ_MAX_BCS));
  EJ_TRY(ej_params_schema(b, ej_top_params, ej_top_manual));
  EJ_TRY(ej_buf_printf(b, ","));
  EJ_TRY(ej_buf_printf(b, "%s", ej_schema_defs));
  EJ_TRY(ej_buf_printf(b, "%s", ej_schema_bc_head));
  EJ_TRY(ej_params_schema(b, ej_periodic_params, NULL));
  EJ_TRY(ej_buf_printf(b, "}},{\"additionalProperties\":false,\"required\":[\"non_reflecting\",\"region\"],"
                          "\"properties\":{\"set\":{\"type\":\"string\"},\"region\":{\"$ref\":\"#/$defs/shape\"},"
                          "\"non_reflecting\":"));
  EJ_TRY(ej_buf_printf(b, "{\"allOf\":["));
  EJ_TRY(ej_params_schema(b, ej_nonrefl_params, ej_nonrefl_manual));
  EJ_TRY(ej_buf_printf(b, ",%s]}", ej_schema_face));
  EJ_TRY(ej_buf_printf(b, "}},{\"additionalProperties\":false,\"required\":[\"pressure\",\"region\"],"
                          "\"properties\":{\"set\":{\"type\":\"string\"},\"region\":{\"$ref\":\"#/$defs/shape\"},"
                          "\"pressure\":{\"allOf\":["));
  EJ_TRY(ej_params_schema(b, ej_pressure_params, ej_pressure_manual));
  EJ_TRY(ej_buf_printf(b, ",%s,{\"oneOf\":[{\"required\":[\"value\"]},{\"required\":[\"curve\"]},{\"required\":"
                          "[\"blast\"]}],\"properties\":{\"curve\":{\"type\":\"array\",\"minItems\":1,"
                          "\"description\":\"p(t): [[t, p], ...], linear between the points (s, Pa).\",\"items\":{\"type\":"
                          "\"array\",\"minItems\":2,\"maxItems\":2,\"items\":{\"$ref\":\"#/$defs/quantity\"}}},"
                          "\"blast\":{\"allOf\":[",
                       ej_schema_face));
  EJ_TRY(ej_params_schema(b, ej_blast_params, ej_blast_manual));
  EJ_TRY(ej_buf_printf(b, ",{\"required\":[\"charge\"],\"properties\":{\"charge\":{\"$ref\":\"#/$defs/vector\","
                          "\"description\":\"Centre of the charge (m).\"}}}]}}}]}}}]},"));
  EJ_TRY(ej_buf_printf(b, "\"probe\":{\"allOf\":["));
  EJ_TRY(ej_params_schema(b, ej_probe_params, ej_probe_manual));
  EJ_TRY(ej_buf_printf(b, ",{\"required\":[\"set\",\"point\",\"fields\"],\"properties\":{"
                          "\"set\":{\"type\":\"string\",\"description\":\"The particle set it reads.\"},"
                          "\"point\":{\"$ref\":\"#/$defs/vector\",\"description\":\"Gauge point, or (follow) the "
                          "point whose nearest particle at t = 0 is followed (m).\"},"
                          "\"fields\":{\"type\":\"array\",\"minItems\":1,\"maxItems\":%d,\"items\":{\"type\":"
                          "\"string\"},\"description\":\"Fields of the set, one column per component.\"}}}]},",
                       EJ_MAX_PROBE_FIELDS));
  EJ_TRY(ej_schema_materials(b, reg));
  EJ_TRY(ej_buf_printf(b, ","));
  EJ_TRY(ej_schema_sets(b, reg));
  EJ_TRY(ej_buf_printf(b, ","));
  EJ_TRY(ej_schema_interactions(b, reg));
  EJ_TRY(ej_buf_printf(b, "}}"));
  return EJ_OK;
}

/* Re-indents compact JSON (two spaces), keeping empty {} and [] and short scalar arrays on
 * one line, so that the committed schema diffs line by line. */
static ej_err ej_json_pretty(const char *in, size_t len, ej_buf *out)
{
  int depth = 0;
  bool str = false;
  for (size_t i = 0; i < len; ++i) {
    char c = in[i];
    if (str) {
      EJ_TRY(ej_buf_printf(out, "%c", c));
      if (c == '\\' && i + 1 < len) EJ_TRY(ej_buf_printf(out, "%c", in[++i]));
      else if (c == '"') str = false;
      continue;
    }
    switch (c) {
    case '"':
      str = true;
      EJ_TRY(ej_buf_printf(out, "%c", c));
      break;
    case '{':
    case '[': {
      char close = c == '{' ? '}' : ']';
      if (i + 1 < len && in[i + 1] == close) {
        EJ_TRY(ej_buf_printf(out, "%c%c", c, close));
        ++i;
        break;
      }
      /* arrays of plain scalars stay inline: [0, 0, 1] */
      if (c == '[') {
        size_t j = i + 1;
        bool q = false, flat = true;
        for (; j < len; ++j) {
          if (q) {
            if (in[j] == '\\') ++j;
            else if (in[j] == '"') q = false;
            continue;
          }
          if (in[j] == '"') q = true;
          else if (in[j] == '{' || in[j] == '[') flat = false;
          else if (in[j] == ']') break;
          if (!flat) break;
        }
        if (flat && j < len) {
          bool q2 = false;
          for (size_t k = i; k <= j; ++k) {
            char d = in[k];
            EJ_TRY(ej_buf_printf(out, "%c", d));
            if (q2) {
              if (d == '\\') EJ_TRY(ej_buf_printf(out, "%c", in[++k]));
              else if (d == '"') q2 = false;
            } else if (d == '"') {
              q2 = true;
            } else if (d == ',') {
              EJ_TRY(ej_buf_printf(out, " "));
            }
          }
          i = j;
          break;
        }
      }
      ++depth;
      EJ_TRY(ej_buf_printf(out, "%c\n%*s", c, 2 * depth, ""));
      break;
    }
    case '}':
    case ']':
      --depth;
      EJ_TRY(ej_buf_printf(out, "\n%*s%c", 2 * depth, "", c));
      break;
    case ',': EJ_TRY(ej_buf_printf(out, ",\n%*s", 2 * depth, "")); break;
    case ':': EJ_TRY(ej_buf_printf(out, ": ")); break;
    default: EJ_TRY(ej_buf_printf(out, "%c", c));
    }
  }
  return ej_buf_printf(out, "\n");
}

ej_err ej_scene_schema(ej_registry *reg, ej_buf *out)
{
  EJ_ENSURE(reg && out, EJ_ERR_ARG, "NULL argument");
  ej_buf compact = {0};
  ej_err rc = EJ_OK;
  EJ_TRY_GOTO(rc, ej_schema_compact(reg, &compact), out_free_compact);
  EJ_TRY_GOTO(rc, ej_json_pretty(compact.data, compact.len, out), out_free_compact);
out_free_compact:
  ej_buf_free(&compact);
  return rc;
}
