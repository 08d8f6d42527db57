/* Core-private declarations shared by the modules of libejecta. Not installed. */
#ifndef EJ_CORE_IMPL_H
#define EJ_CORE_IMPL_H
#ifndef EJ_CORE_BUILD
#error "core_impl.h is private to libejecta"
#endif

#include <math.h>
#include <stdio.h>

#include "ejecta/ejecta.h"

/* ================================================================== error stack (error.c) */

#define EJ_ERROR_MAX_FRAMES 32
#define EJ_ERROR_MSG_LEN 512

typedef struct ej_error_frame {
  ej_err code;
  const char *file, *func; /* code location */
  int line;
  char msg[EJ_ERROR_MSG_LEN]; /* empty for propagation frames */
  ej_loc where;               /* input location (where.file NULL if none) */
  char where_file[256];
} ej_error_frame;

/* Number of frames on this thread's stack and frame k (0 = innermost). */
int ej_error_count(void);
const ej_error_frame *ej_error_frame_at(int k);
/* The first frame carrying a message (the cause), or NULL. */
const ej_error_frame *ej_error_cause(void);
void ej_error_clear(void);
/* Drops frames pushed after the stack had n frames (recovering from an expected failure). */
void ej_error_truncate(int n);
/* Prints "PROG: error: FILE:LINE:COL: message" (one line) for input errors, and the
 * code frames too for internal errors or when debug is true. */
void ej_error_print(FILE *out, const char *prog, bool debug);
/* Copy frames from another thread's stack snapshot (OpenMP regions). */
void ej_error_import(const ej_error_frame *frames, int n);

/* ================================================================== small utilities */

/* Growable byte buffer for text (schema, describe, XDMF). */
typedef struct ej_buf {
  char *data;
  size_t len, cap;
} ej_buf;
ej_err ej_buf_printf(ej_buf *b, const char *fmt, ...) EJ_PRINTF(2, 3);
void ej_buf_free(ej_buf *b);

/* strdup through ej_malloc. */
char *ej_strdup(const char *s);
/* name as a path beside file: name itself when absolute, else file's directory + name (name alone
 * when file has no directory or is NULL); through ej_malloc, NULL when out of memory. */
char *ej_path_beside(const char *file, const char *name);
/* Levenshtein distance, for "did you mean". */
int ej_edit_distance(const char *a, const char *b);
/* Nearest of n candidates within a small distance, or NULL. */
const char *ej_nearest_word(const char *word, const char *const *cands, int n);

/* ================================================================== YAML document (yaml.c) */

typedef enum ej_node_type { EJ_NODE_SCALAR, EJ_NODE_MAP, EJ_NODE_SEQ } ej_node_type;

typedef struct ej_node ej_node;
struct ej_node {
  ej_node_type type;
  ej_loc loc;         /* start mark of the node */
  char *text;         /* EJ_NODE_SCALAR: the scalar text */
  bool quoted;        /* scalar was quoted (then never a number) */
  bool path_resolved; /* text was made relative to the scene file's directory (EJ_PF_PATH) */
  int n;              /* number of items (SEQ) or pairs (MAP) */
  ej_node **items;    /* SEQ items, or MAP values */
  char **keys;        /* MAP keys */
  ej_loc *key_locs;   /* MAP key locations */
};

typedef struct ej_doc {
  char *path;
  char *text; /* file contents verbatim */
  size_t text_len;
  ej_node *root;
} ej_doc;

/* Reads and parses a YAML file. Missing file and malformed YAML are input errors with a
 * location (the file itself for a missing file). Duplicate map keys are input errors. */
ej_err ej_doc_load(const char *path, ej_doc **doc);
ej_err ej_doc_parse_string(const char *name, const char *text, ej_doc **doc);
void ej_doc_destroy(ej_doc *doc);
/* Value of key in a map node, or NULL. */
const ej_node *ej_node_get(const ej_node *map, const char *key);
const ej_loc *ej_node_key_loc(const ej_node *map, const char *key);

/* ================================================================== units (units.c) */

/* Parses "value [unit]" against the declared unit (see ej_param.unit) and returns SI.
 * A plain number is in the declared unit. A unit of another dimension, an unknown unit or a
 * malformed number is an input error at loc. */
ej_err ej_units_parse(const char *text, const char *declared_unit, const ej_loc *loc, double *si);
/* Dimension check helper: true if unit expressions a and b have the same dimension. */
bool ej_units_compatible(const char *a, const char *b);

/* ================================================================== parameters (params.c) */

/* ej_diag carries the block being validated, for check_config errors. */
struct ej_diag {
  const ej_node *block;
  const char *what; /* "material 'sand' (drucker_prager)" */
};

/* Applies defaults, then the keys of map (unknown key: error with nearest suggestion; wrong
 * type; out of range; missing required), then check_config. skip lists keys of the block
 * that belong to the caller (e.g. "model"), NULL-terminated. config is zeroed by caller. */
ej_err ej_params_apply(const ej_param *table, void *config, const ej_node *map, const char *what,
                       const char *const *skip, ej_config_check_fn check);
ej_err ej_params_defaults(const ej_param *table, void *config);
/* Human-readable table (ejecta describe). */
ej_err ej_params_describe(ej_buf *out, const ej_param *table, int indent);
/* Markdown table of a table (name, type, unit, default, bounds, choices, doc; nested blocks as
 * block.key rows): `ejecta describe --markdown`, docs/plugins/. */
ej_err ej_params_markdown(ej_buf *out, const ej_param *table);
/* JSON Schema object ("type":"object","properties":{...}) for a table. */
ej_err ej_params_schema(ej_buf *out, const ej_param *table, const char *const *extra_keys);

/* ================================================================== geometry (geometry.c) */

typedef struct ej_shape ej_shape; /* owned by the scene */

/* Parses a shape node: {box: {min, max}}, {cylinder: {base|center, axis, radius, height}},
 * {sphere: {center, radius}}, {half_space: {point, normal}} (inside = side opposite to the
 * normal), {union: [...]}, {intersect: [...]}, and any shape with a sibling key
 * "minus: [shape or set name...]". Set names in minus are resolved through lookup. */
typedef const ej_shape *(*ej_shape_lookup_fn)(void *ctx, const char *set_name);
ej_err ej_shape_parse(const ej_node *node, int dim, ej_shape_lookup_fn lookup, void *ctx, ej_shape **out);
void ej_shape_destroy(ej_shape *s);
bool ej_shape_contains(const ej_shape *s, const ej_real x[3]);
/* Bounding box; EJ_ERR_INPUT (at the shape's location) if unbounded. */
ej_err ej_shape_bounds(const ej_shape *s, ej_real lo[3], ej_real hi[3]);
const ej_loc *ej_shape_loc(const ej_shape *s);

typedef enum ej_lattice { EJ_LATTICE_CUBIC = 0, EJ_LATTICE_HCP = 1 } ej_lattice;
/* Volume of a jittered particle (set key jitter_volume): its lattice cell's, or the cell's scaled
 * by the kernel number density of the unjittered lattice over the jittered cloud's (ej_shape_fill). */
typedef enum ej_jitter_volume { EJ_JITTER_VOLUME_CELL = 0, EJ_JITTER_VOLUME_KERNEL = 1 } ej_jitter_volume;

/* Region-wise spacing: the first refinement region containing a point decides its spacing. */
typedef struct ej_refine {
  ej_shape *region;
  ej_real spacing;
} ej_refine;

/* Generated particles: positions, volumes and the local lattice spacing. */
typedef struct ej_points {
  ej_idx n;
  ej_real *x;       /* [n][3] */
  ej_real *vol;     /* [n] (per unit depth in 2D, per unit area in 1D) */
  ej_real *spacing; /* [n] */
} ej_points;
void ej_points_free(ej_points *p);

/* ================================================================== scene (scene.c) */

typedef struct ej_scene_material {
  char *name;
  ej_loc loc;
  ej_real rho0;
  const ej_eos_ops *eos_ops; /* NULL if none */
  void *eos_config;
  const ej_material_ops *mat_ops; /* strength model, NULL if none */
  void *mat_config;
} ej_scene_material;

/* Region-wise initial conditions, applied in order after the set-wide ones. */
typedef struct ej_scene_init {
  ej_shape *region; /* NULL = whole set */
  ej_loc loc;
  bool has_rho, has_e, has_p, has_v, has_energy_total;
  ej_real rho, e, p, v[3];
  ej_real energy_total; /* J: spread over the region's particles in proportion to mass */
} ej_scene_init;

typedef struct ej_scene_set {
  char *name;
  ej_loc loc;
  const ej_method_ops *method_ops;
  void *method_config;
  int material; /* index into scene materials */
  /* geometry */
  ej_shape *shape;       /* NULL when imported from a file */
  ej_real spacing;
  ej_lattice lattice;
  ej_real jitter;        /* fraction of the local spacing, uniform in [-j/2, j/2] per component */
  uint64_t seed;
  ej_jitter_volume jitter_volume;
  bool has_origin;       /* lattice_origin given: the lattice passes through origin */
  ej_real origin[3];
  ej_real mass;          /* > 0: the particles' volumes are scaled to this total mass */
  int n_refine;
  ej_refine *refine;
  char *file;            /* CSV particle file (columns x,y,z[,vol][,...]) or NULL */
  ej_loc file_loc;
  /* initial conditions */
  int n_init;
  ej_scene_init *init;   /* init[0] is the set-wide one (region NULL) */
} ej_scene_set;

typedef enum ej_bc_kind {
  EJ_BC_FIX,
  EJ_BC_VELOCITY,
  EJ_BC_SYMMETRY,
  EJ_BC_PERIODIC,
  EJ_BC_NONREFLECT,
  EJ_BC_PRESSURE
} ej_bc_kind;

/* PRESSURE: where p(t) comes from */
typedef enum ej_pressure_source { EJ_PRESSURE_VALUE, EJ_PRESSURE_CURVE, EJ_PRESSURE_BLAST } ej_pressure_source;
enum { EJ_BURST_AIR = 0, EJ_BURST_SURFACE = 1 };

typedef struct ej_scene_bc {
  ej_bc_kind kind;
  ej_loc loc;
  int set;          /* set index, -1 = every set */
  ej_shape *region; /* FIX / VELOCITY / NONREFLECT: particles inside at t = 0; NULL = whole set */
  bool comp[3];     /* FIX: constrained components; VELOCITY: prescribed components */
  ej_real velocity[3];
  ej_real until;    /* VELOCITY: prescribed while t <= until (INFINITY: for the whole run) */
  ej_real point[3], normal[3]; /* SYMMETRY plane (normal unit, pointing into the domain);
                                * NONREFLECT: outward unit normal, or (radial) the centre in point */
  bool radial;                 /* NONREFLECT: normal = (x - point) / |x - point| */
  ej_real rho, cp, cs;         /* NONREFLECT: impedance overrides; NAN = from the set's material */
  bool cavity;                 /* PRESSURE, radial: the face looks at point (its outward normal is -radial) */
  ej_pressure_source source;   /* PRESSURE: value, curve or blast */
  ej_real p_value;             /* PRESSURE value: constant, Pa */
  int n_curve;                 /* PRESSURE curve: points (t, p), t increasing; end values hold outside */
  ej_real *curve_t, *curve_p;
  int burst;                   /* PRESSURE blast: EJ_BURST_AIR (spherical) or EJ_BURST_SURFACE (hemispherical) */
  ej_real tnt, t_det, charge[3]; /* PRESSURE blast: TNT mass (kg), detonation time, charge centre */
  int axis;                    /* PERIODIC: 0, 1, 2 */
  ej_real lo, hi;              /* PERIODIC: period [lo, hi) */
} ej_scene_bc;

typedef struct ej_scene_interaction {
  ej_loc loc;
  const ej_interaction_ops *ops;
  void *config;
  int set_a, set_b;
} ej_scene_interaction;

/* A probe (scene `probes:`): a point gauge fixed in space, or a tracer that follows the particle
 * nearest to its point at t = 0; its fields go to /series/probe/<name>/ every step. */
#define EJ_MAX_PROBE_FIELDS 16
typedef struct ej_scene_probe {
  char *name;
  ej_loc loc;
  int set;          /* set index */
  ej_real point[3];
  bool follow;      /* tracer: the particle nearest to point at t = 0 */
  ej_real radius;   /* gauge: support of the weights; 0 = each particle's own search radius */
  int n_fields;
  char *fields[EJ_MAX_PROBE_FIELDS];
  ej_loc field_locs[EJ_MAX_PROBE_FIELDS];
} ej_scene_probe;

typedef struct ej_scene {
  ej_doc *doc; /* kept for the verbatim text and locations */
  int dimension;
  /* time */
  ej_real t_end, cfl, dt_fixed; /* dt_fixed 0 = adaptive */
  ej_real dt_max;               /* 0 = none */
  int64_t max_steps;            /* 0 = none */
  ej_real dt_min;               /* watchdog floor of the adaptive step; 0 = none */
  ej_real dt_min_ratio;         /* watchdog floor relative to the first adaptive step; 0 = none */
  ej_shape *domain;             /* watchdog: particles must stay inside; NULL = anywhere */
  ej_loc domain_loc;
  /* output */
  char *output_file;
  ej_loc output_loc;
  ej_real output_every;     /* 0: first and last frame only */
  ej_real checkpoint_every; /* 0: only at the end */
  bool set_series;          /* per-set energy and momentum series (output.set_series) */
  int n_output_fields;      /* 0 = every EJ_FIELD_OUTPUT field */
  char **output_fields;
  ej_loc *output_field_locs;
  /* neighbours */
  ej_real skin; /* Verlet skin as a fraction of each particle's search radius (default 0.15) */
  ej_real ghost_reach; /* m: smallest ghost-layer thickness (neighbours.ghost_reach) */
  ej_real gravity[3];
  int n_materials;
  ej_scene_material *materials;
  int n_sets;
  ej_scene_set *sets;
  int n_bcs; /* at most 32 */
  ej_scene_bc *bcs;
  int n_interactions;
  ej_scene_interaction *interactions;
  int n_probes;
  ej_scene_probe *probes;
} ej_scene;

/* Loads and validates a scene, loading through reg only the plugins it names. */
ej_err ej_scene_load_impl(const char *path, ej_registry *reg, ej_scene **scene);
ej_err ej_scene_from_doc(ej_doc *doc, ej_registry *reg, ej_scene **scene); /* takes doc */
void ej_scene_free(ej_scene *s);
/* Particles of a set: lattice fill of the shape with region-wise spacing and jitter, or CSV
 * import. An empty result is an input error at the set's location. */
ej_err ej_scene_set_points(const ej_scene *sc, int set, ej_points *pts);
/* JSON Schema of the whole scene format from the registry's tables. */
ej_err ej_scene_schema(ej_registry *reg, ej_buf *out);
/* `ejecta describe scene`: the core's scene keys, from their parameter tables. */
ej_err ej_scene_describe(ej_buf *out);

/* ================================================================== registry and loader */

typedef enum ej_kind { EJ_KIND_METHOD, EJ_KIND_MATERIAL, EJ_KIND_EOS, EJ_KIND_INTERACTION, EJ_KIND_COUNT } ej_kind;

const char *ej_kind_name(ej_kind k);
/* Finds name of kind k, loading the plugin file ej_<name>.so from the search path if it is
 * not registered yet. Unknown names are input errors at loc with the nearest known name. */
ej_err ej_registry_require(ej_registry *reg, ej_kind k, const char *name, const ej_loc *loc, const void **ops);
/* Registers a plugin linked into the executable (tests, static builds). */
ej_err ej_registry_add_static(ej_registry *reg, const ej_plugin_info *info);
/* Loads one plugin file (checks ABI, signature, entry symbol, ops tables, duplicates). */
ej_err ej_registry_load_file(ej_registry *reg, const char *path);
/* Loads every plugin file in the search path (plugins, describe, schema). */
ej_err ej_registry_load_all(ej_registry *reg);
/* Registered ops of kind k: count and item. */
int ej_registry_count(const ej_registry *reg, ej_kind k);
const void *ej_registry_item(const ej_registry *reg, ej_kind k, int i);
/* Loaded plugin files: name, version, path. */
int ej_registry_plugin_count(const ej_registry *reg);
const ej_plugin_info *ej_registry_plugin(const ej_registry *reg, int i, const char **path);
/* Name and params of any ops table (all kinds share the first members' layout). */
typedef struct ej_ops_head {
  size_t struct_size;
  const char *name, *summary, *doc;
  const ej_param *params;
  size_t config_size;
  ej_config_check_fn check_config;
} ej_ops_head;

/* ================================================================== particle sets */

#define EJ_MAX_FIELDS 64 /* ghost_dirty and the pass masks are uint64_t */
_Static_assert(EJ_MAX_FIELDS < 256 && (EJ_MAX_FIELDS & (EJ_MAX_FIELDS - 1)) == 0,
               "ftab holds field index + 1 in a uint8_t and is probed with a power-of-two mask");
#define EJ_MAX_PASS_MASKS 16
#define EJ_ALL_FIELDS (~UINT64_C(0))
#define EJ_MAX_HIST 32
#define EJ_FIELD_NAME_LEN 32

typedef struct ej_field {
  char name[EJ_FIELD_NAME_LEN];
  ej_field_kind kind;
  int ncomp;
  unsigned flags;
  const char *unit;
  ej_energy_role energy;
  int rate;    /* index of the rate field, -1 */
  int rate_of; /* index of the field this is the rate of, -1 */
  int half;    /* index of the half-step copy (integrated fields), -1 */
  void *data;  /* ej_real or int32_t, cap * ncomp */
} ej_field;

/* A rigid transform of ghost images: x' = Q x + b. */
typedef struct ej_xform {
  ej_real Q[9];
  ej_real b[3];
} ej_xform;

#define EJ_MAX_XFORMS 255 /* ghost_xf is a uint8_t */

typedef struct ej_nbrlist ej_nbrlist;

struct ej_set {
  char *name;
  int index;
  int dim;
  ej_idx n, n_ghost, cap;
  int n_fields;
  ej_field fields[EJ_MAX_FIELDS];
  /* Name lookup (ej_set_find_field): an open-addressing table of 2 EJ_MAX_FIELDS slots, each
   * 0 (empty) or field index + 1, probed linearly from the name's FNV-1a hash; fhash[k] is field
   * k's hash, compared before the strcmp. Plugins look fields up by name in every chunk of every
   * pass (512 particles): the linear strcmp scan was 4.5 % of the fine buried-charge step. */
  uint32_t fhash[EJ_MAX_FIELDS];
  uint8_t ftab[2 * EJ_MAX_FIELDS];
  int f_x, f_v, f_a, f_m, f_vol0, f_id, f_xb, f_rb, f_x0; /* base field indices (-1 absent) */
  ej_real spacing_min;
  const ej_real *t, *dt; /* the simulation's clock (NULL outside a run) */
  const struct ej_sim *sim; /* the run it belongs to (NULL outside one): ej_set_held, ej_set_image_source */
  int n_hist;
  int f_hist[EJ_MAX_HIST]; /* fields of the strength model's history variables */
  bool in_interaction;     /* a two-set interaction lists it: x_build kept current */
  bool wants_images;       /* an interaction with needs_images (ABI 1.9) lists it: images even without a list */
  bool has_images;         /* a symmetry or periodic boundary gives it images (ej_set_has_images, ABI 1.10) */
  ej_real due_d, due_e;    /* skin watch of the step: max d, max (R - R_build) + d - skin R_build, d = |x - x_build| */
  uint8_t *bond_flags;     /* [n_bonds] per CSR entry of a reference family */
  ej_off n_bonds;
  int64_t list_builds;     /* builds of its own list (ej_set_list_builds) */
  /* method */
  const ej_method_ops *mops;
  const void *mconfig;
  void *mstate;
  ej_model *model;
  ej_nbr_config nbr_config;
  ej_nbrlist *list; /* own list, NULL if none */
  ej_real *radius;  /* [cap] search radius */
  /* ghosts: ghost g (index n + g) copies source ghost_src[g] through xforms[ghost_xf[g]] */
  ej_idx *ghost_src;
  uint8_t *ghost_xf;
  /* boundary-condition masks: per particle bit k set if bcs[k] applies (k < 32) */
  uint32_t *bc_mask;
  /* non_reflecting bcs[k]: the dashpots' impedances rho c_p and rho c_s on this set (kg/(m^2 s)) */
  ej_real nr_zp[32], nr_zs[32];
  uint32_t nr_bits; /* bit k: bcs[k] is a non-reflecting boundary on this set */
  uint32_t pr_bits; /* bit k: bcs[k] is a pressure load on this set */
  /* Ghost refresh by need (bit k = field k, EJ_MAX_FIELDS <= 64): fields written since the last
   * refresh; what each method pass and post_step writes (ej_method_ops.pass_writes; all bits when
   * the method does not say, or past EJ_MAX_PASS_MASKS passes); fields the integrator writes. */
  uint64_t ghost_dirty;
  uint64_t pass_mask[EJ_MAX_PASS_MASKS + 1]; /* [0]: post_step, [1 + k]: pass k */
  uint64_t foreign_mask;                     /* fields the method did not declare (EOS, history) */
  uint64_t step_mask;                        /* x, v, a and the integrated fields, rates, halves */
  char *perm_tmp;                            /* ej_set_permute's scratch, grown with cap */
  size_t perm_tmp_size;
};

struct ej_model {
  char *name;
  ej_real rho0;
  ej_eos *eos;
  ej_material *mat;
};
struct ej_eos {
  const ej_eos_ops *ops;
  const void *config;
  void *state;
};
struct ej_material {
  const ej_material_ops *ops;
  void *state;
};

ej_err ej_set_create(const char *name, int index, int dim, ej_set **s);
void ej_set_destroy(ej_set *s);
/* Adds a field (idempotent for an identical declaration; a conflicting kind is an error). */
ej_err ej_set_add_field(ej_set *s, const ej_field_decl *d, int *index);
int ej_set_find_field(const ej_set *s, const char *name);
/* "scalar", "vec3", "sym6", "tensor9" or "int" (output attributes, describe). */
const char *ej_field_kind_name(ej_field_kind k);
/* Sets capacity for owned + ghost particles (reallocates every field). */
ej_err ej_set_reserve(ej_set *s, ej_idx cap);
/* Reorders owned particles: new i takes old perm[i], for every field. */
ej_err ej_set_permute(ej_set *s, const ej_idx *perm);
/* Copies every (ghosted) field from sources to ghosts, applying transforms. */
void ej_set_update_ghosts(ej_set *s, const ej_xform *xf);
/* Copies the ghosted fields in s->ghost_dirty only (then clears it): equal to a full refresh
 * when every write since the last refresh was marked in ghost_dirty. One parallel region. */
void ej_set_refresh_ghosts(ej_set *s, const ej_xform *xf);
/* Ghost g's value of field f (index) from its source's CURRENT value, as a full refresh would
 * write it (vectors rotated, points moved, tensors Q A Q^T): out holds ncomp values (an int32 for
 * EJ_INT). The probes read mirror and periodic images through it. */
void ej_set_ghost_value(const ej_set *s, int f, const ej_xform *xf, ej_idx g, void *out);
/* Checks that every ghosted field of every ghost equals its full refresh (bitwise); returns the
 * first stale field's index (and its ghost in *ghost), or -1. Serial (tests, EJECTA_GHOST_CHECK). */
int ej_set_ghosts_stale(const ej_set *s, const ej_xform *xf, ej_idx *ghost);

/* ================================================================== neighbours (neighbours.c) */

/* Uniform-grid cell lists and CSR lists. Scratch arrays are kept between rebuilds and only grow. */
struct ej_nbrlist {
  ej_nbr pub;    /* view given to plugins (points at off / idx) */
  ej_off *off;   /* [row_cap + 1] */
  ej_idx *idx;   /* [idx_cap] */
  ej_idx row_cap;
  ej_off idx_cap;
  /* cell-grid scratch */
  ej_idx *cell_start; /* [n_cells + 1] */
  ej_idx *cell_items; /* [item_cap] candidate indices sorted by cell */
  ej_idx *cell_of;    /* [item_cap] */
  ej_real *cell_pos;  /* [4 pos_cap]: x, y, z, r of cell_items[k] at k, k + pos_cap, ... (SoA) */
  int64_t pos_cap;
  int64_t cell_cap;
  ej_idx item_cap;
  /* one-pass build scratch: per-thread buffers of one block of rows */
  ej_idx **tbuf; /* [n_tbuf] */
  int64_t *tcap; /* [n_tbuf] */
  int n_tbuf;
};

ej_err ej_nbrlist_create(ej_nbrlist **L);
void ej_nbrlist_destroy(ej_nbrlist *L);
/* Rows: points xa[0..na) with radii ra; candidates xb[0..nb) with radii rb (rb may equal ra).
 * Pair (i, j) is listed iff |xb_j - xa_i| < max(ra_i, rb_j) + skin, and j != i when same.
 * dim selects the components used (1: x, 2: x y, 3: x y z). Each row is sorted ascending by j. 
 * Deterministic and identical for any thread count (OpenMP inside). */
ej_err ej_nbrlist_build(ej_nbrlist *L, int dim, const ej_real *xa, const ej_real *ra, ej_idx na,
                        const ej_real *xb, const ej_real *rb, ej_idx nb, ej_real skin, bool same);
/* Cell-order permutation of n points for locality: perm[new] = old (stable). */
ej_err ej_nbr_sort_order(int dim, const ej_real *x, ej_idx n, ej_real cell, ej_idx *perm);
/* The cell of ej_nbrlist_build's grid for the most populous radius class of the radii
 * r[0..n) * scale (the class's largest scaled radius; ties: the class of larger radii), so that
 * ej_nbr_sort_order with it puts most rows' candidates in ascending order. 0 when n is 0. */
ej_real ej_nbr_sort_cell(const ej_real *r, ej_idx n, ej_real scale);

/* The cubic B-spline kernel's shape (Monaghan 1992), f(0) = 1, zero from q = 2 on: the kernel
 * number density of jitter_volume: kernel (geometry.c) and the probes' gauge weights (sim.c). */
static inline ej_real ej_spline_shape(ej_real q)
{
  const ej_real t = 2.0 - q;
  return q < 1.0 ? 1.0 - 1.5 * q * q + 0.75 * q * q * q : q < 2.0 ? 0.25 * t * t * t : 0.0;
}

/* A particle's share of a boundary face from its volume: vol0^((d-1)/d) (3D m^2, 2D m per m of
 * thickness, 1D 1): the non-reflecting dashpots' area (sim.c) and ejecta check's sum of it. */
static inline ej_real ej_face_area(int dim, ej_real vol0)
{
  return dim == 3 ? cbrt(vol0 * vol0) : dim == 2 ? sqrt(vol0) : 1;
}

/* Kingery-Bulmash air-blast curves (blast.c): scaled values at Z = R / W^(1/3) (m/kg^(1/3)), SI:
 * peak incident and normally reflected overpressure (Pa), their impulses over W^(1/3) (Pa s/kg^(1/3)),
 * arrival time and positive duration over W^(1/3) (s/kg^(1/3)). Z is clamped into the fitted range. */
typedef struct ej_blast_kb {
  ej_real p_i, p_r, i_i, i_r, t_a, t_d;
} ej_blast_kb;
void ej_blast_range(int burst, ej_real *z_min, ej_real *z_max);
void ej_blast_curves(int burst, ej_real z, ej_blast_kb *out);
/* The decay a of the Friedlander pulse with peak P, impulse I and duration *t_d; when even a = 0 (a
 * triangle) cannot carry I, *t_d becomes 2 I / P and a = 0. */
ej_real ej_blast_decay(ej_real P, ej_real I, ej_real *t_d);
ej_real ej_blast_friedlander(ej_real P, ej_real a, ej_real t_d, ej_real tau);
/* The blast at one face point, for any time: the arrival t0 (s), and the reflected and incident
 * Friedlander pulses already weighted by the angle rule (peaks p_r, p_i, decays, durations). Seven
 * numbers: a loaded particle keeps them (field load_blast), its face does not move. */
typedef struct ej_blast_pt {
  ej_real t0, p_r, a_r, td_r, p_i, a_i, td_i;
} ej_blast_pt;
void ej_blast_point(int burst, ej_real w_tnt, const ej_real charge[3], ej_real t_det, const ej_real x[3],
                    const ej_real n[3], ej_blast_pt *o);
ej_real ej_blast_eval(const ej_blast_pt *b, ej_real t);
/* Overpressure at time t on a face at x with outward unit normal n, from w_tnt kg of TNT at charge
 * detonated at t_det (Randers-Pehrson & Bannister's angle rule): ej_blast_eval of ej_blast_point. */
ej_real ej_blast_pressure(int burst, ej_real w_tnt, const ej_real charge[3], ej_real t_det, const ej_real x[3],
                         const ej_real n[3], ej_real t);

/* At a face point x (outward normal n): scaled distance, arrival time (s, from detonation), peak
 * overpressure (Pa) and impulse (Pa s) of the blast load there. */
typedef struct ej_blast_face {
  ej_real z, t_a, p, impulse;
} ej_blast_face;
void ej_blast_peak(int burst, ej_real w_tnt, const ej_real charge[3], const ej_real x[3], const ej_real n[3],
                   ej_blast_face *out);

/* The force F of pressure load bc on a particle at x with volume vol0 at time t (sim.c): -p A n on
 * its share A = ej_face_area of the face, n the face's outward normal there; returns p. blast: the
 * particle's kept blast point for a blast load (NULL: computed here). */
/* The outward unit normal of a face boundary's face (non_reflecting, pressure) at x: the given
 * normal, or radial from the centre (towards it for a cavity); false at a radial face's centre. */
bool ej_bc_face_normal(const ej_scene_bc *bc, const ej_real x[3], ej_real n[3]);
ej_real ej_pressure_load(const ej_scene_bc *bc, int dim, const ej_real x[3], ej_real vol0, ej_real t,
                         const ej_blast_pt *blast, ej_real F[3]);

/* The owned particle of s nearest to p (the smaller id on a tie) and its squared distance (dim
 * components); -1 for an empty set. */
ej_idx ej_set_nearest(const ej_set *s, int dim, const ej_real p[3], ej_real *d2);
/* Renumbers a list after its row set and column set were permuted by perm (perm[new] = old;
 * same permutation for rows and columns: fixed families of one set). */
ej_err ej_nbrlist_permute(ej_nbrlist *L, const ej_idx *perm);

/* ================================================================== comm (comm.c) */
/* Every global reduction goes through here: serial today, MPI tomorrow. */
ej_real ej_comm_min(ej_real v);
void ej_comm_sum(ej_real *v, int n);

/* ================================================================== simulation (sim.c) */

typedef struct ej_energy {
  ej_real kinetic, internal, viscous, plastic, hourglass;
  ej_real external; /* accumulated external work: gravity + plugins' WORK - DISSIPATED series */
  ej_real work_gravity; /* accumulated work of gravity, prescribed velocities, dashpots and pressure loads
                         * (the core's own external work; checkpointed as energy_work_gravity) */
  ej_real total0;   /* kinetic + internal at t = 0 */
  ej_real balance;  /* kinetic + internal - total0 - external */
  ej_real momentum[3];
} ej_energy;

/* An optional op appended after ABI 1.0: present in the table and not NULL. */
#define EJ_HAS_OP(ops, type, member)                                                                    \
  ((ops)->struct_size >= offsetof(type, member) + sizeof(((type *)0)->member) && (ops)->member)

typedef struct ej_inter {
  const ej_interaction_ops *ops;
  const void *config;
  void *state;
  ej_set *a, *b;     /* b NULL for a one-set interaction */
  ej_nbrlist *list;  /* a -> b (NULL for one set) */
  ej_nbrlist *list_ba; /* b -> a when ops->both_ways */
  int pre_slot;        /* the method pass before which the pre-passes run, -1: never (ej_inter_pre_slot) */
  /* fields each pass writes on a ([0]) and b ([1]) (ABI 1.11 pass_writes; ej_inter_write_masks):
   * [k][0] post_step, [k][1 + n_pre_passes + pass] pass; EJ_ALL_FIELDS when the plugin does not say */
  uint64_t wmask[2][EJ_MAX_PASS_MASKS + 1];
} ej_inter;

/* Per-step series reported by plugins, in a fixed order decided on the first step. */
#define EJ_MAX_REPORTS 256
typedef struct ej_reports {
  int n;
  char names[EJ_MAX_REPORTS][96]; /* "<set or interaction>/<name>" */
  ej_real values[EJ_MAX_REPORTS];
  bool fixed; /* names decided */
} ej_reports;

typedef struct ej_output ej_output;

/* A probe at run time (sim.c "Probes"): its columns, /series/probe/<name>/<col_name>. */
#define EJ_MAX_PROBE_COLS (3 + 9 * EJ_MAX_PROBE_FIELDS)
typedef struct ej_probe {
  const ej_scene_probe *sp;
  ej_set *set;
  char owner[48];                /* "probe/<name>" */
  int n_cols;
  int col_field[EJ_MAX_PROBE_COLS]; /* field index; -1: the tracer's position or the gauge's count */
  int col_comp[EJ_MAX_PROBE_COLS];
  char col_name[EJ_MAX_PROBE_COLS][40];
  int32_t id; /* tracer: the particle id it follows */
  ej_idx at;  /* tracer: the index where that id was last found */
} ej_probe;

/* One thread's block of chunks in ej_for_chunks's affinity schedule: the next chunk to take and
 * the block's end, 128 bytes apart so that two counters never share a cache line (the owner's is
 * not shared until others steal), whatever the alignment of the allocation. */
#define EJ_MAX_BLOCKS 256
typedef struct ej_chunk_block {
  int64_t next;
  int64_t end;
  char pad[112];
} ej_chunk_block;

struct ej_sim {
  ej_scene *scene; /* borrowed */
  ej_registry *reg; /* borrowed */
  int dim;
  int n_sets;
  ej_set **sets;
  ej_model *models; /* [scene->n_materials] */
  int n_inter;
  ej_inter *inter;
  ej_xform xforms[EJ_MAX_XFORMS];
  int n_xforms;
  /* time */
  ej_real t, dt;
  ej_real dt_first; /* first adaptive step of this process (time.dt_min_ratio's reference); 0 before it */
  int64_t step;
  int64_t n_rebuilds;
  /* diagnostics */
  ej_energy energy;
  ej_reports reports;
  int n_probes;
  ej_probe *probes; /* [scene->n_probes] */
  ej_real (*set_sums)[8]; /* output.set_series: each set's energy and momentum sums (EJ_NRED) of the step */
  /* output */
  ej_output *out;
  char *out_path;
  ej_real next_output, next_checkpoint;
  int64_t frame;
  int threads;
  bool progress;
  int stop_signal; /* ej_sim_request_stop: the signal (or -1) that stopped the run before its end; 0 */
  /* chunking for deterministic parallel reductions */
  ej_idx chunk;
  ej_real *chunk_scratch; /* per-chunk partial sums */
  int64_t chunk_scratch_cap;
  bool affinity;                          /* ej_for_chunks: affinity schedule (OMP_SCHEDULE unset) */
  ej_chunk_block blocks[EJ_MAX_BLOCKS];   /* its per-thread chunk blocks                        */
  /* EJECTA_GHOST_CHECK=1: after each partial ghost refresh, compare with a full one */
  bool ghost_check;
  /* EJECTA_PROFILE=1: wall time of the step loop and of its parallel regions */
  bool profile;
  double prof_loop, prof_par, prof_out;
  int64_t prof_regions;
};

/* Runs a method's declare op against a set (describe, tests). */
ej_err ej_decl_probe(const ej_method_ops *m, const void *config, ej_set *s);

/* ================================================================== output (output.c) */

/* Opens path + ".partial" for writing and writes /meta (scene text verbatim, plugins and
 * versions, build signature, ejecta version). An unwritable path is an input error at
 * scene->output_loc. */
ej_err ej_output_open(ej_output **out, const ej_sim *sim, const char *path);
/* Writes /frames/NNNNNN/<set>/<field> (owned particles) with attributes time and step. */
ej_err ej_output_frame(ej_output *out, const ej_sim *sim);
/* Appends one row of the energy/momentum series (buffered; flushed in blocks). */
ej_err ej_output_series(ej_output *out, const ej_sim *sim);
/* Writes /checkpoint (every non-scratch field of every set plus the sim scalars), replacing
 * the previous one. */
ej_err ej_output_checkpoint(ej_output *out, const ej_sim *sim);
/* Flushes, writes the XDMF sidecar (path with .xdmf) and renames .partial to path when
 * success; on failure removes the partial file. Always frees out. */
ej_err ej_output_close(ej_output *out, bool success);
/* Reads /checkpoint of a file into a sim built from the same scene. */
ej_err ej_checkpoint_read(const char *path, ej_sim *sim);

#endif /* EJ_CORE_IMPL_H */
