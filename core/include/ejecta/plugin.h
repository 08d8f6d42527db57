/* ejecta plugin SDK: the only header a plugin includes.
 *
 * ABI rules (DESIGN.md "Plugins"):
 *  - a plugin exports exactly one symbol, ej_plugin_info_v1(), returning a const descriptor;
 *  - the first four members of ej_plugin_info are frozen for every ABI version;
 *  - every ops table starts with size_t struct_size and only ever grows at the end;
 *  - calls are per batch / particle range, never per pair: pair loops live in the plugin.
 *
 * Conventions: SI units, Cauchy stress tension-positive, pressure compression-positive
 * (p = -tr(sigma)/3), Voigt order xx yy zz xy yz zx, pair vectors x_ij = x_j - x_i.
 */
#ifndef EJ_PLUGIN_H
#define EJ_PLUGIN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ejecta/config.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EJ_ABI_MAJOR 1 /* incompatible change: every plugin must be rebuilt */
#define EJ_ABI_MINOR 13 /* members appended to an info or ops struct; services added */

#if defined(__GNUC__)
#define EJ_EXPORT __attribute__((visibility("default")))
#define EJ_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define EJ_EXPORT
#define EJ_PRINTF(a, b)
#endif

typedef double ej_real;   /* "real=f64" in the build signature */
typedef int32_t ej_idx;   /* particle index inside a set ("idx=i32") */
typedef int64_t ej_off;   /* offsets into CSR neighbour arrays */

/* ------------------------------------------------------------------ errors */

typedef enum ej_err {
  EJ_OK = 0,
  EJ_ERR_ARG,         /* caller broke a documented precondition (a bug)        */
  EJ_ERR_INPUT,       /* scene / YAML / particle file rejected (user's mistake) */
  EJ_ERR_MEM,         /* allocation failed                                      */
  EJ_ERR_IO,          /* file could not be read or written                      */
  EJ_ERR_ABI,         /* plugin built for another ABI or build signature        */
  EJ_ERR_PLUGIN,      /* plugin misbehaved: bad ops table, failed register      */
  EJ_ERR_UNSUPPORTED, /* valid request this build or plugin cannot serve        */
  EJ_ERR_NUMERIC,     /* NaN, rho <= 0, singular matrix, dt -> 0                */
  EJ_ERR_INTERNAL     /* broken core invariant: always a bug                    */
} ej_err;

/* A position in an input file; line and col are 1-based, 0 when unknown. */
typedef struct ej_loc {
  const char *file;
  int line, col;
} ej_loc;

/* Pushes a frame on the calling thread's error stack and returns code.
 * fmt == NULL means "propagating, no new message". */
ej_err ej_error_push(ej_err code, const char *file, int line, const char *func, const char *fmt, ...)
    EJ_PRINTF(5, 6);
/* An input error tied to a place in the scene or a particle file. */
ej_err ej_error_input(const ej_loc *where, const char *fmt, ...) EJ_PRINTF(2, 3);

#define EJ_FAIL(code, ...) return ej_error_push((code), __FILE__, __LINE__, __func__, __VA_ARGS__)
#define EJ_ENSURE(cond, code, ...)                                                                      \
  do {                                                                                                  \
    if (!(cond)) EJ_FAIL((code), __VA_ARGS__);                                                          \
  } while (0)
#define EJ_TRY(expr)                                                                                    \
  do {                                                                                                  \
    ej_err ej_try_rc_ = (expr);                                                                         \
    if (ej_try_rc_ != EJ_OK) return ej_error_push(ej_try_rc_, __FILE__, __LINE__, __func__, NULL);      \
  } while (0)
#define EJ_TRY_GOTO(rc, expr, label)                                                                    \
  do {                                                                                                  \
    (rc) = (expr);                                                                                      \
    if ((rc) != EJ_OK) {                                                                                \
      ej_error_push((rc), __FILE__, __LINE__, __func__, NULL);                                          \
      goto label;                                                                                       \
    }                                                                                                   \
  } while (0)

/* ------------------------------------------------------------------ memory */

/* Plugins allocate through the core so that accounting and failure injection work. */
void *ej_malloc(size_t size);
void *ej_calloc(size_t n, size_t size); /* overflow-checked */
void *ej_realloc(void *p, size_t size);
void ej_free(void *p);

/* ------------------------------------------------------------------ parameters */

typedef enum ej_ptype {
  EJ_PT_REAL,       /* ej_real                                          */
  EJ_PT_INT,        /* int64_t                                          */
  EJ_PT_BOOL,       /* bool                                             */
  EJ_PT_ENUM,       /* int: index into choices                          */
  EJ_PT_STRING,     /* const char * (owned by the scene)                */
  EJ_PT_REAL_ARRAY, /* ej_real[count]; a YAML sequence of count numbers */
  EJ_PT_BLOCK       /* nested struct at offset, described by sub        */
} ej_ptype;

enum {
  EJ_PF_REQUIRED = 1u << 0,
  EJ_PF_HAS_MIN = 1u << 1,
  EJ_PF_HAS_MAX = 1u << 2,
  EJ_PF_MIN_OPEN = 1u << 3, /* value must be > min, not >= */
  EJ_PF_MAX_OPEN = 1u << 4,
  EJ_PF_EXPERT = 1u << 5,
  /* EJ_PT_STRING naming a file the plugin reads (ABI 1.10): a relative path is taken from the
   * directory of the scene file that holds the value (as a set's `file:`), and a file that cannot
   * be opened for reading is bad input at the value's line:col, found by `ejecta check` */
  EJ_PF_PATH = 1u << 6
};

/* One parameter: name is both the YAML key and the C field. unit is an SI unit
 * expression ("Pa", "kg/m^3", "J/kg", "m", "s", "1" for none) or "deg" for angles
 * (plain numbers are degrees, stored in radians). Numbers in a scene may carry any unit of
 * the same dimension ("8.7 GPa", "4 mm", "1.6 g/cm^3") and are stored in SI. def, min and max
 * are written in the declared unit (so "deg", 30, 0, 90 means degrees); bounds are checked
 * after conversion to SI. */
typedef struct ej_param {
  const char *name;
  ej_ptype type;
  size_t offset;
  unsigned flags;
  const char *unit;
  double def, min, max;
  int count;                   /* EJ_PT_REAL_ARRAY length */
  const char *const *choices;  /* EJ_PT_ENUM: NULL-terminated */
  const char *def_str;         /* EJ_PT_STRING default, or EJ_PT_ENUM default word */
  const struct ej_param *sub;  /* EJ_PT_BLOCK: {0}-terminated table */
  size_t sub_size;             /* EJ_PT_BLOCK: sizeof nested struct */
  const char *doc;             /* one sentence: describe, docs and schema */
} ej_param;

/* A wrong C type for the field is a compile error (_Generic guard). */
#define EJ_PARAM_REAL(cfg, field, unit_, def_, min_, max_, flags_, doc_)                                \
  {.name = #field, .type = EJ_PT_REAL,                                                                  \
   .offset = offsetof(cfg, field) + 0 * sizeof(_Generic(((cfg *)0)->field, ej_real: 1)),               \
   .flags = (flags_), .unit = (unit_), .def = (def_), .min = (min_), .max = (max_), .doc = (doc_)}
#define EJ_PARAM_INT(cfg, field, def_, min_, max_, flags_, doc_)                                        \
  {.name = #field, .type = EJ_PT_INT,                                                                   \
   .offset = offsetof(cfg, field) + 0 * sizeof(_Generic(((cfg *)0)->field, int64_t: 1)),               \
   .flags = (flags_), .unit = "1", .def = (def_), .min = (min_), .max = (max_), .doc = (doc_)}
#define EJ_PARAM_BOOL(cfg, field, def_, doc_)                                                           \
  {.name = #field, .type = EJ_PT_BOOL,                                                                  \
   .offset = offsetof(cfg, field) + 0 * sizeof(_Generic(((cfg *)0)->field, bool: 1)), .unit = "1",     \
   .def = (def_), .doc = (doc_)}
#define EJ_PARAM_ENUM(cfg, field, choices_, def_word, doc_)                                             \
  {.name = #field, .type = EJ_PT_ENUM,                                                                  \
   .offset = offsetof(cfg, field) + 0 * sizeof(_Generic(((cfg *)0)->field, int: 1)), .unit = "1",      \
   .choices = (choices_), .def_str = (def_word), .doc = (doc_)}
#define EJ_PARAM_STRING(cfg, field, def_, flags_, doc_)                                                 \
  {.name = #field, .type = EJ_PT_STRING,                                                                \
   .offset = offsetof(cfg, field) + 0 * sizeof(_Generic(((cfg *)0)->field, const char *: 1)),          \
   .flags = (flags_), .unit = "1", .def_str = (def_), .doc = (doc_)}
#define EJ_PARAM_ARRAY(cfg, field, n, unit_, flags_, doc_)                                              \
  {.name = #field, .type = EJ_PT_REAL_ARRAY, .offset = offsetof(cfg, field), .flags = (flags_),         \
   .unit = (unit_), .count = (n), .doc = (doc_)}
#define EJ_PARAM_BLOCK(cfg, field, subtable, substruct, flags_, doc_)                                   \
  {.name = #field, .type = EJ_PT_BLOCK, .offset = offsetof(cfg, field), .flags = (flags_),              \
   .unit = "1", .sub = (subtable), .sub_size = sizeof(substruct), .doc = (doc_)}

/* Cross-field checks report through a diagnostic that knows where the block is. */
typedef struct ej_diag ej_diag;
/* Reports an input error at the YAML node of key (or the block itself when key is NULL). */
ej_err ej_diag_error(ej_diag *d, const char *key, const char *fmt, ...) EJ_PRINTF(3, 4);
typedef ej_err (*ej_config_check_fn)(const void *config, ej_diag *diag);

/* ------------------------------------------------------------------ particle sets */

typedef struct ej_set ej_set;       /* core-owned particle set (opaque) */
typedef struct ej_range {
  ej_idx begin, end;
} ej_range;

typedef enum ej_field_kind {
  EJ_SCALAR = 1,
  EJ_VEC3 = 3,
  EJ_SYM6 = 6,    /* Voigt xx yy zz xy yz zx */
  EJ_TENSOR9 = 9, /* row-major 3x3 */
  EJ_INT = 101    /* int32_t, one component */
} ej_field_kind;

/* Budget roles: the core sums m * field over a set for the energy budget. */
typedef enum ej_energy_role {
  EJ_ENERGY_NONE = 0,
  EJ_ENERGY_INTERNAL,  /* specific internal energy, J/kg, part of the conserved total   */
  EJ_ENERGY_VISCOUS,   /* specific work dissipated by artificial viscosity (reported)   */
  EJ_ENERGY_PLASTIC,   /* specific plastic work (reported)                              */
  EJ_ENERGY_HOURGLASS  /* specific work dissipated by hourglass control (reported)      */
} ej_energy_role;

enum {
  EJ_FIELD_OUTPUT = 1u << 0,   /* written to frames unless the scene lists fields      */
  EJ_FIELD_POSITION = 1u << 1, /* a point (vec3): mirrored/translated, not only rotated */
  EJ_FIELD_NO_GHOST = 1u << 2, /* not copied to ghost particles                          */
  EJ_FIELD_SCRATCH = 1u << 3   /* recomputed every step: not checkpointed                */
};

/* A field a plugin needs. Declaring a field with a rate makes the core allocate the rate
 * field (same kind), zero it before each compute and integrate field += dt * rate. */
typedef struct ej_field_decl {
  const char *name;
  ej_field_kind kind;
  unsigned flags;
  const char *unit;
  const char *rate; /* name of its rate field, or NULL */
  ej_energy_role energy;
  const char *doc;
} ej_field_decl;

ej_idx ej_set_count(const ej_set *s);     /* owned particles                        */
ej_idx ej_set_count_all(const ej_set *s); /* owned + ghosts (neighbours may be ghosts) */
int ej_set_dim(const ej_set *s);          /* 1, 2 or 3 */
const char *ej_set_name(const ej_set *s);
/* Field data for owned + ghost particles, ncomp values per particle; NULL if the scene
 * declared no such field. The pointer is valid until the next neighbour rebuild. */
ej_real *ej_set_field(const ej_set *s, const char *name);
int32_t *ej_set_field_int(const ej_set *s, const char *name);
/* Initial spacing of particle i's lattice (for kernel sizes and time steps). */
ej_real ej_set_spacing_min(const ej_set *s);
/* Simulation time at the configuration being computed (t_n+1 inside compute) and the step. */
ej_real ej_set_time(const ej_set *s);
ej_real ej_set_dt(const ej_set *s);
/* History variables of the set's strength model: fills hist[k] with the base of variable k
 * (owned + ghost particles, one value each, allocated by the core as scalar fields named by
 * the material's hist_names) and returns their number (0 without a strength model). */
int ej_set_hist(const ej_set *s, ej_real **hist, int max);

/* ------------------------------------------------------------------ neighbours */

typedef enum ej_nbr_config {
  EJ_NBR_NONE = 0,
  EJ_NBR_CURRENT,  /* current configuration, rebuilt with a Verlet skin */
  EJ_NBR_REFERENCE /* reference configuration, built once (fixed families) */
} ej_nbr_config;

/* A CSR list: row i (an owned particle of the first set) lists indices j into the second set
 * (owned or ghost). Each row is sorted ascending by j, deterministic. Current lists contain
 * every pair with |x_j - x_i| < max(R_i, R_j) (+ the skin), never i itself. */
typedef struct ej_nbr {
  ej_idx n_rows;
  const ej_off *off; /* [n_rows + 1] */
  const ej_idx *idx; /* [off[n_rows]] */
} ej_nbr;

/* Per-bond state of a set's reference-configuration family (EJ_NBR_REFERENCE): one byte per
 * CSR entry of its list (bond k of particle i is entry nbr->off[i] + k), zero when the family is
 * built, owned and checkpointed by the core (so a restart keeps broken bonds). The method uses
 * the bits as it likes (bit 0 = broken, by convention). NULL for other sets or before the first
 * build (available from the first compute on). */
uint8_t *ej_set_bond_flags(const ej_set *s);

/* --- ABI 1.5. How many times the set's own neighbour list has been built in this process: the
 * rows (and the particle order, which a rebuild may change) stay the same between two passes
 * that see the same count, so a method may cache what it derives from the list (rkpm caches,
 * per entry, the position of the row's particle in its neighbour's row). 0 before the first
 * build; a restart starts again from 0. */
int64_t ej_set_list_builds(const ej_set *s);

/* --- ABI 1.10. Whether the set gets mirror or periodic images (ghost particles): a symmetry or
 * periodic boundary applies to it and it has a neighbour list of its own or is a partner of an
 * interaction with needs_images. Known from the interactions' create on (so a plugin that cannot
 * take images refuses the scene at check time); whether a given step has any ghosts also depends
 * on the particles' distance to the planes (ej_set_count_all). */
bool ej_set_has_images(const ej_set *s);

/* --- ABI 1.12. Essential boundaries, for methods whose nodal values are not their coefficients
 * (rkpm's transformation method). ej_set_held: the components of owned particle i that an active
 * `fix` or `velocity` boundary holds at the set's current time, as bits (1: x, 2: y, 4: z); the
 * core keeps them at the prescribed velocity (zero acceleration after the force evaluation).
 * ej_set_image_source: for a ghost j (ej_set_count(s) <= j < ej_set_count_all(s)) the owned
 * particle it is an image of, and in Q the 3x3 tensor (row-major) that maps the source's vectors
 * to the image's (a product of mirrors: v_j = Q v_src); an owned j returns j and Q = I. */
unsigned ej_set_held(const ej_set *s, ej_idx i);
ej_idx ej_set_image_source(const ej_set *s, ej_idx j, ej_real Q[9]);

/* --- ABI 1.13. Initial stress, for methods that integrate a rate-form Cauchy stress (tlpd,
 * rkpm): one `initial_stress` block with the same keys in every such method. A method embeds an
 * ej_initial_stress in its config, lists it with
 *   EJ_PARAM_BLOCK(my_config, initial_stress, ej_initial_stress_params, ej_initial_stress, 0, "...")
 * calls ej_initial_stress_check from its check_config and ej_initial_stress_apply from setup,
 * on its `stress` field (sym6, owned particles). Sources (one of them; none leaves the stress
 * alone): `uniform` (six values), `file` (a CSV of points x, y, z, sxx ... szx: each particle takes
 * the nearest row within a quarter of its spacing) or `geostatic: true` (the overburden of the
 * set's own density under the scene's gravity below `surface`, plus `surcharge`, horizontal
 * stresses `k0` times the vertical one). Input errors name the set and the particle. */
typedef struct ej_initial_stress {
  ej_real uniform[6];
  const char *file;
  bool geostatic;
  ej_real surface, k0, surcharge;
} ej_initial_stress;
extern const ej_param ej_initial_stress_params[];
ej_err ej_initial_stress_check(const ej_initial_stress *c, ej_diag *diag);
ej_err ej_initial_stress_apply(const ej_initial_stress *c, const ej_set *set, ej_real *stress);

/* ------------------------------------------------------------------ EOS */

typedef struct ej_eos ej_eos; /* an EOS instance (opaque) */
typedef struct ej_decl ej_decl;

typedef struct ej_eos_ops {
  size_t struct_size;
  const char *name, *summary, *doc;
  const ej_param *params;
  size_t config_size;
  ej_config_check_fn check_config;
  ej_err (*create)(const void *config, void **state);
  /* p and c (sound speed) for n points; c may be NULL. */
  ej_err (*evaluate)(const void *state, ej_idx n, const ej_real *rho, const ej_real *e, ej_real *p,
                     ej_real *c);
  void (*destroy)(void *state);
  /* --- ABI 1.1: an EOS with per-particle state (programmed burn). All three may be NULL. */
  /* Fields this EOS needs on every set made of its material (lighting time, burn fraction). */
  ej_err (*declare)(const void *config, int dim, ej_decl *d);
  /* After initial conditions, before the method's setup (lighting times from x). Serial. */
  ej_err (*setup)(const void *state, ej_set *set);
  /* p and c for the particles of r: rho[k], e[k], p[k], c[k] belong to particle r.begin + k.
   * May read the set's fields and time and write its own declared fields of particles in r. */
  ej_err (*evaluate_set)(const void *state, ej_set *set, ej_range r, const ej_real *rho, const ej_real *e,
                         ej_real *p, ej_real *c);
} ej_eos_ops;

/* Plain p(rho, e) without particle state (burn fraction taken as 1). */
ej_err ej_eos_evaluate(const ej_eos *eos, ej_idx n, const ej_real *rho, const ej_real *e, ej_real *p,
                       ej_real *c);
/* What methods call: the EOS's evaluate_set if it has one, else evaluate. Arrays as in
 * ej_eos_ops.evaluate_set (indexed from r.begin). */
ej_err ej_eos_evaluate_set(const ej_eos *eos, ej_set *set, ej_range r, const ej_real *rho, const ej_real *e,
                           ej_real *p, ej_real *c);

/* ------------------------------------------------------------------ materials (strength) */

typedef struct ej_material ej_material; /* a material instance (opaque) */

/* A VUMAT-like batch of n points of one material. */
typedef struct ej_mat_batch {
  ej_idx n;
  ej_real dt;
  const ej_real *rho; /* [n] current density                                        */
  const ej_real *e;   /* [n] specific internal energy                               */
  const ej_real *d;   /* [n][6] rate of deformation, rotation-neutralised (Voigt)   */
  const ej_real *F;   /* [n][9] deformation gradient, or NULL                        */
  const ej_real *p;   /* [n] pressure from the attached EOS, or NULL                 */
  ej_real *stress;    /* [n][6] in: rotated stress at t_n; out: Cauchy at t_n+1       */
  ej_real *const *hist; /* [n_hist] -> [n]: history variable k of point i is hist[k][i]  */
  ej_real *c;         /* [n] out: sound speed                                        */
  ej_real *w_plastic; /* [n] out: specific plastic work increment, or NULL           */
  int32_t *failed;    /* [n] out: set to 1 when the point fails (erosion, point failure), or NULL */
} ej_mat_batch;

typedef struct ej_material_ops {
  size_t struct_size;
  const char *name, *summary, *doc;
  const ej_param *params;
  size_t config_size;
  ej_config_check_fn check_config;
  int n_hist;
  const char *const *hist_names;
  bool needs_eos; /* volumetric response from the EOS the scene attaches */
  ej_err (*create)(const void *config, void **state);
  /* Initial history values of n points: hist[k][i] as in ej_mat_batch. May be NULL (zeros). */
  ej_err (*init_hist)(const void *state, ej_idx n, ej_real *const *hist);
  /* Convention: update returns the total Cauchy stress; a material with needs_eos adds -p I
   * from b->p to its deviatoric stress; one without computes the volumetric part itself. */
  ej_err (*update)(const void *state, ej_mat_batch *b);
  void (*destroy)(void *state);
  /* Initial (elastic) bulk and shear moduli at the reference density: stable steps, hourglass
   * and bond constants. Required. */
  ej_err (*moduli)(const void *state, ej_real *K, ej_real *G);
  /* --- ABI 1.9. For a model whose need of an EOS depends on its configuration (needs_eos false;
   * von_mises and johnson_cook `volumetric: eos`): the name of the parameter whose value asks for
   * the EOS, or NULL when this configuration does not. The core refuses such a material without an
   * eos at that parameter's line:col (ejecta check, exit 2) instead of failing at the first update.
   * May be NULL (or absent in an older table): needs_eos alone decides. */
  const char *(*eos_required_by)(const void *config);
} ej_material_ops;

ej_err ej_material_update(const ej_material *mat, ej_mat_batch *b);
ej_err ej_material_moduli(const ej_material *mat, ej_real *K, ej_real *G);
int ej_material_n_hist(const ej_material *mat);

/* What a set is made of: reference density, EOS and strength model (either may be NULL). */
typedef struct ej_model ej_model;
ej_real ej_model_rho0(const ej_model *m);
const ej_eos *ej_model_eos(const ej_model *m);
const ej_material *ej_model_material(const ej_model *m);
const char *ej_model_name(const ej_model *m);
/* What a set is made of (interactions read the other set's EOS or moduli through it). */
const ej_model *ej_set_model(const ej_set *s);

/* ------------------------------------------------------------------ methods */

/* Filled by a method's (or an EOS's) declare op: the fields and neighbour list it needs. */
ej_err ej_decl_field(ej_decl *d, const ej_field_decl *f);
/* Neighbour list over the method's own set, in the given configuration. */
ej_err ej_decl_neighbours(ej_decl *d, ej_nbr_config config);

/* Counters a plugin reports (e.g. shape-tensor fallbacks), summed over the run. */
typedef struct ej_counter {
  const char *name;
  int64_t value;
} ej_counter;

/* Per-step scalars a plugin reports (mean damage, indenter force): written each step to
 * /series/<set or interaction>/<name>. A role other than NONE also enters the energy budget:
 * WORK is the cumulative work done on the particles by external agents (J), DISSIPATED the
 * cumulative energy removed by the plugin (J) (contact damping, hourglass in an interaction). */
typedef enum ej_series_role { EJ_SERIES_PLAIN = 0, EJ_SERIES_WORK, EJ_SERIES_DISSIPATED } ej_series_role;
typedef struct ej_series_value {
  const char *name; /* static string, same order every step */
  ej_real value;
  ej_series_role role;
} ej_series_value;
#define EJ_MAX_SERIES 16 /* per plugin instance */

/* Checkpointed instance state (ABI 1.8, ej_method_ops and ej_interaction_ops save_state /
 * load_state). A checkpoint holds every field and the bond flags; what a plugin keeps in its own
 * state and needs to continue a run (a rigid body's orientation, the work or dissipation it has
 * summed so far, the previous step's power of a trapezoid rule) it hands to the core through
 * save_state: at most max (= EJ_MAX_STATE) values into buf, their count into *n. The core writes
 * them with every checkpoint and, on a restart, after create and setup and after the checkpoint's
 * fields are read, passes them back to load_state with the count saved; a checkpoint without them
 * (written by an older build) leaves the state as setup made it. With both a restarted run
 * continues bitwise (tests/unit/test_restart_methods.c). */
#define EJ_MAX_STATE 64

typedef struct ej_method_ops {
  size_t struct_size;
  const char *name, *summary, *doc;
  const ej_param *params;
  size_t config_size;
  ej_config_check_fn check_config;
  /* The fields and neighbours this configuration needs (called before allocation). */
  ej_err (*declare)(const void *config, int dim, ej_decl *d);
  ej_err (*create)(const void *config, ej_set *set, const ej_model *model, void **state);
  /* After particles exist and initial fields are set (density, energy, velocity):
   * initialise method fields (smoothing length, shape tensors...). Serial. */
  ej_err (*setup)(void *state, ej_set *set);
  /* Search radius of the owned particles in r: radius[k] belongs to particle r.begin + k. */
  ej_err (*support)(void *state, const ej_set *set, ej_range r, ej_real *radius);
  /* Number of passes per step; the core refreshes ghosts between passes. */
  int n_passes;
  /* One pass over owned particles in r; writes only particles in r (gather form). */
  ej_err (*compute)(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r);
  /* Largest stable step over particles in r (before the CFL factor). */
  ej_err (*stable_dt)(void *state, const ej_set *set, ej_range r, ej_real *dt);
  /* After the step is complete (bond breaking, damage). May be NULL. */
  ej_err (*post_step)(void *state, ej_set *set, ej_range r);
  /* Counters to report at the end of the run. May be NULL. */
  ej_err (*counters)(void *state, ej_counter *out, int max, int *n);
  void (*destroy)(void *state);
  /* Passes this instance needs (1..n_passes), when it depends on the configuration: the core
   * then calls passes 0..count-1 only, saving the ghost refreshes of unused ones. May be NULL. */
  int (*pass_count)(const void *state);
  /* --- ABI 1.1. Per-step series (serial, after post_step). May be NULL. */
  ej_err (*report)(void *state, const ej_set *set, ej_series_value *out, int max, int *n);
  /* The method carries its own constitutive constants (bond-based PD): its sets' material may
   * give only rho0. Otherwise a material needs an EOS or a strength model. */
  bool self_constitutive;
  /* --- ABI 1.3. The set's fields that compute pass `pass` (0 .. passes-1) writes, or with
   * pass = EJ_PASS_POST_STEP those post_step writes: up to max names into names; returns their
   * number, or -1 for "any field" (also the meaning of a NULL op or an older table). Called once,
   * after create. The core then copies to the ghosts, before each pass, only the ghosted fields
   * written since the last refresh (by the integrator, a rebuild, this method's declared writes,
   * interactions, or the EOS and strength model: fields the method did not declare itself count
   * as written by every pass), so a field written but not named leaves stale ghosts. */
  int (*pass_writes)(const void *state, int pass, const char **names, int max);
  /* --- ABI 1.4. post_step(r) writes only particles in r and reads, of the particles outside r,
   * no field that the second half kick writes (v and the fields integrated from rates): x, x0,
   * bond flags and fields of the passes are fine. The core then runs it in the kick's parallel
   * region, each chunk right after its own kick, and (when no set needs a post_step region of
   * its own and no interaction has a post_step) the step's energy sums and watchdog in that region
   * too: two parallel regions fewer per step, same results. false (or an older table): post_step
   * runs in a region of its own after every set's kick. */
  bool post_step_local;
  /* --- ABI 1.6. After every interaction of a force evaluation (so after the method's own
   * passes and every interaction's passes), before the core applies gravity and constraints:
   * completes rates that need the interactions' shares too (sph's continuity renormalised over
   * its own and the other sets' neighbours, `renormalize_interfaces`). Writes only particles in
   * r; reads only particles in r. May be NULL. */
  ej_err (*finish)(void *state, ej_set *set, ej_range r);
  /* --- ABI 1.8. Instance state that lives neither in fields nor in bond flags (a rigid body's
   * orientation, work summed over the run): see EJ_MAX_STATE. May be NULL. */
  ej_err (*save_state)(const void *state, ej_real *buf, int max, int *n);
  ej_err (*load_state)(void *state, const ej_real *buf, int n);
  /* --- ABI 1.12. Serial work over the whole set, for what no range can do alone (rkpm's
   * transformation method for essential boundaries solves a linear system over the held nodes).
   * Called once per force evaluation (the initial one too) with stage = pass after method pass
   * `pass` has run over every range (before the ghost refresh of the next pass), and with stage =
   * EJ_STAGE_FORCES after every interaction and the method's finish, before the core adds gravity
   * and applies the constraints. Writes owned particles only. With stage = pass its writes count
   * as that pass's (pass_writes); with EJ_STAGE_FORCES it may write a and the rates. May be NULL. */
  ej_err (*serial)(void *state, ej_set *set, const ej_nbr *nbr, int stage);
} ej_method_ops;
#define EJ_PASS_POST_STEP (-1) /* pass_writes: the fields post_step writes */
#define EJ_STAGE_FORCES (-2)   /* serial: after the interactions and finish */

/* ------------------------------------------------------------------ interactions */

/* An interaction acts on two sets (scene: sets: [a, b]) through a current-configuration list
 * from a to b whose reach is max(R_i, R_j) from both methods' support ops, or on one set
 * (sets: [a]; b == NULL, ab == NULL: rigid indenter, walls). compute is called after every
 * set has completed all its passes (so stress, pressure and density of both sets are those
 * of t_n+1), for pass = 0 .. n_passes-1 with ghosts refreshed in between, over ranges r of
 * a's owned particles, and adds to a's acceleration and rates of particles in r only
 * (gather form). With both_ways the core also
 * builds the list from b to a and calls compute(state, b, a, ba, pass, r) over ranges of b,
 * so a pairwise force is applied to both sides without scatter. */
typedef struct ej_interaction_ops {
  size_t struct_size;
  const char *name, *summary, *doc;
  const ej_param *params;
  size_t config_size;
  ej_config_check_fn check_config;
  ej_err (*create)(const void *config, ej_set *a, ej_set *b, void **state);
  ej_err (*compute)(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r);
  ej_err (*stable_dt)(void *state, const ej_set *a, const ej_set *b, ej_real *dt);
  void (*destroy)(void *state);
  /* --- ABI 1.1 */
  bool both_ways;
  int n_passes; /* 0 is taken as 1 */
  /* After the step is complete (serial): advance a kinematic body, accumulate work. May be NULL. */
  ej_err (*post_step)(void *state, ej_set *a, ej_set *b);
  /* Per-step series, as for methods. May be NULL. */
  ej_err (*report)(void *state, ej_series_value *out, int max, int *n);
  /* Sets it acts on: 1, 2, or 0 for either; the scene is checked against it. */
  int n_sets;
  /* Passes before the methods' passes (ABI 1.2; 0 or absent in an older plugin's table: none): compute is
   * called with pass = -n_pre_passes .. -1, over a's ranges (and b's with both_ways), after the
   * drift and the neighbour rebuild and before any method pass of the step, so x and v are those
   * of t_n+1 and every other field is still the previous evaluation's. For fields that a method
   * reads in its own passes (sph_wall fills sph's L_wall, the wall's share of a solid's velocity
   * gradient, before sph's stress pass). */
  int n_pre_passes;
  /* --- ABI 1.4. post_step writes no particle field of a or b (it sums and advances the plugin's
   * own state: work, reaction force, a kinematic body). The core may then run the step's energy
   * sums and watchdog before it, in the sets' end-of-step regions (ej_method_ops.post_step_local).
   * false (or an older table): the diagnostics wait for it in a region of their own. */
  bool post_step_sums_only;
  /* --- ABI 1.7. Where the pre-passes run. NULL (or an older table): before any method pass, as
   * above. A field name: right before the first method pass, of a or b, whose pass_writes names
   * that field (a method without pass_writes counts as writing every field in every pass), so the
   * pre-passes see what the passes before it wrote (sph's h, floored rho, EOS) and feed the pass
   * that reads them; in a scene where neither set has the field they do not run at all. `continuum`
   * adds the other set's share of sph's shape tensor this way, before the pass that inverts it
   * ("M_inv"). */
  const char *pre_pass_before;
  /* --- ABI 1.8. Instance state that lives neither in fields nor in bond flags (work or
   * dissipation summed over the run, the previous step's power of a trapezoid rule): see
   * EJ_MAX_STATE. May be NULL. */
  ej_err (*save_state)(const void *state, ej_real *buf, int max, int *n);
  ej_err (*load_state)(void *state, const ej_real *buf, int n);
  /* --- ABI 1.9. The pairs need both sets' mirror and periodic images, so that a pair across a
   * symmetry plane or periodic face acts on both sides: a set with no neighbour list of its own (a
   * rigid_body without normals) then gets its images for this interaction too (kernel_contact).
   * false (or an older table): only sets with a list of their own have images (sph_wall's wall set
   * must have none). */
  bool needs_images;
  /* --- ABI 1.11. The fields of a set that compute pass `pass` (-n_pre_passes .. n_passes-1) writes
   * while that set's rows are processed: side 0 is the scene's first set (a), side 1 the second (b).
   * Up to max names into names; returns their number, or -1 for "every field" (also the meaning of a
   * NULL op or an older table). A name the set does not have is skipped (a coupling names rho_dot,
   * which only an SPH side has). The core then copies to that set's ghosts, before the next pass,
   * only these fields (and those the method, the integrator, the EOS and the strength model wrote),
   * as for pass_writes of a method; without it an interaction's pass counts as writing every field
   * of both sets, so a coupled set's images are refreshed in full once a step. post_step is not
   * covered: it writes every field, or none with post_step_sums_only. EJECTA_GHOST_CHECK=1 compares
   * every partial refresh with a full one. */
  int (*pass_writes)(const void *state, int pass, int side, const char **names, int max);
} ej_interaction_ops;

/* ------------------------------------------------------------------ registration */

typedef struct ej_registry ej_registry;
ej_err ej_register_method(ej_registry *reg, const ej_method_ops *ops);
ej_err ej_register_material(ej_registry *reg, const ej_material_ops *ops);
ej_err ej_register_eos(ej_registry *reg, const ej_eos_ops *ops);
ej_err ej_register_interaction(ej_registry *reg, const ej_interaction_ops *ops);

/* Pure data: readable before the ABI is trusted. The first four members never move. */
typedef struct ej_plugin_info {
  size_t struct_size;
  unsigned abi_major, abi_minor;
  const char *build_signature;
  const char *name, *version, *license, *summary;
  ej_err (*register_all)(ej_registry *reg);
} ej_plugin_info;
typedef const ej_plugin_info *(*ej_plugin_info_fn)(void);
#define EJ_PLUGIN_ENTRY_SYMBOL "ej_plugin_info_v1"

/* Defines the plugin descriptor, a static accessor ej_plugin_<name>_info() (for linking a
 * plugin into tests) and, in shared builds (EJ_PLUGIN_SHARED), the exported entry symbol. */
#ifdef EJ_PLUGIN_SHARED
#define EJ_PLUGIN_ENTRY_(pname)                                                                         \
  EJ_EXPORT const ej_plugin_info *ej_plugin_info_v1(void);                                              \
  EJ_EXPORT const ej_plugin_info *ej_plugin_info_v1(void) { return &ej_info_##pname##_; }
#else
#define EJ_PLUGIN_ENTRY_(pname)
#endif
#define EJ_PLUGIN_DEFINE(pname, version_, license_, summary_, register_fn)                              \
  static const ej_plugin_info ej_info_##pname##_ = {                                                    \
      .struct_size = sizeof(ej_plugin_info), .abi_major = EJ_ABI_MAJOR, .abi_minor = EJ_ABI_MINOR,      \
      .build_signature = EJ_BUILD_SIGNATURE, .name = #pname, .version = (version_),                    \
      .license = (license_), .summary = (summary_), .register_all = (register_fn)};                    \
  const ej_plugin_info *ej_plugin_##pname##_info(void);                                                 \
  const ej_plugin_info *ej_plugin_##pname##_info(void) { return &ej_info_##pname##_; }                  \
  EJ_PLUGIN_ENTRY_(pname)

#ifdef __cplusplus
}
#endif
#endif /* EJ_PLUGIN_H */
