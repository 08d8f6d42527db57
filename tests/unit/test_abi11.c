/* ABI 1.1 core services, driven by small plugins defined in this file: EOS per-particle state
 * (declare/setup/evaluate_set, time through the set), strength-model history fields, one-set
 * and both-ways interactions, per-step series with energy roles, bond flags of reference
 * families (checkpointed), mirror ghosts of reference families. */
#include <check.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

/* ------------------------------------------------------------------ a point-mass method */

/* "pm": particles carry e (internal energy, with rate) and p; compute asks the EOS for p and
 * applies nothing else. With config ref = true it asks for reference families and counts
 * bonds; bonds flagged in post_step stay flagged. */
typedef struct pm_config {
  bool ref;
  ej_real radius; /* search radius in spacings */
} pm_config;
static const ej_param pm_params[] = {
    EJ_PARAM_BOOL(pm_config, ref, false, "Use reference families."),
    EJ_PARAM_REAL(pm_config, radius, "1", 1.5, 0.1, 10, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX, "Radius in spacings."),
    {0}};
typedef struct pm_state {
  pm_config cfg;
  const ej_model *model;
  int64_t bonds_seen, ghost_bonds;
  ej_real t_seen;
} pm_state;

static ej_err pm_declare(const void *config, int dim, ej_decl *d)
{
  (void)dim;
  const pm_config *c = config;
  static const ej_field_decl e = {.name = "e", .kind = EJ_SCALAR, .unit = "J/kg", .rate = "e_dot",
                                  .energy = EJ_ENERGY_INTERNAL, .flags = EJ_FIELD_OUTPUT, .doc = "energy"};
  static const ej_field_decl rho = {.name = "rho", .kind = EJ_SCALAR, .unit = "kg/m^3", .doc = "density"};
  static const ej_field_decl p = {.name = "p", .kind = EJ_SCALAR, .unit = "Pa", .flags = EJ_FIELD_OUTPUT, .doc = "p"};
  EJ_TRY(ej_decl_field(d, &e));
  EJ_TRY(ej_decl_field(d, &rho));
  EJ_TRY(ej_decl_field(d, &p));
  return ej_decl_neighbours(d, c->ref ? EJ_NBR_REFERENCE : EJ_NBR_CURRENT);
}
static ej_err pm_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  (void)set;
  pm_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "oom");
  s->cfg = *(const pm_config *)config;
  s->model = model;
  *state = s;
  return EJ_OK;
}
static ej_err pm_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  pm_state *s = state;
  for (ej_idx i = r.begin; i < r.end; ++i) radius[i - r.begin] = s->cfg.radius * ej_set_spacing_min(set);
  return EJ_OK;
}
static ej_err pm_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  (void)pass;
  pm_state *s = state;
  s->t_seen = ej_set_time(set);
  ej_real *rho = ej_set_field(set, "rho"), *e = ej_set_field(set, "e"), *p = ej_set_field(set, "p");
  if (ej_model_eos(s->model))
    EJ_TRY(ej_eos_evaluate_set(ej_model_eos(s->model), set, r, rho + r.begin, e + r.begin, p + r.begin, NULL));
  if (s->cfg.ref && r.begin == 0) { /* serial in these tests (one chunk) */
    s->bonds_seen = nbr->off[ej_set_count(set)];
    s->ghost_bonds = 0;
    for (ej_off k = 0; k < nbr->off[ej_set_count(set)]; ++k) s->ghost_bonds += nbr->idx[k] >= ej_set_count(set);
  }
  return EJ_OK;
}
static ej_err pm_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  (void)state, (void)set, (void)r;
  *dt = 1e-3;
  return EJ_OK;
}
/* Breaks the first bond of every particle once (bit 0), so the checkpoint carries flags. */
static ej_err pm_post_step(void *state, ej_set *set, ej_range r)
{
  pm_state *s = state;
  uint8_t *bf = ej_set_bond_flags(set);
  if (!s->cfg.ref) return EJ_OK;
  ck_assert_ptr_nonnull(bf);
  for (ej_idx i = r.begin; i < r.end; ++i) bf[i] |= 1u; /* entry i: any stable choice */
  return EJ_OK;
}
static ej_err pm_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  pm_state *s = state;
  ck_assert_int_ge(max, 2);
  int64_t flagged = 0;
  const uint8_t *bf = ej_set_bond_flags(set);
  for (ej_off k = 0; bf && k < s->bonds_seen; ++k) flagged += bf[k] & 1u;
  out[0] = (ej_series_value){"time_seen", s->t_seen, EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){"flagged", (ej_real)flagged, EJ_SERIES_PLAIN};
  *n = 2;
  return EJ_OK;
}
static void pm_destroy(void *state) { ej_free(state); }

static const ej_method_ops pm_ops = {.struct_size = sizeof(ej_method_ops), .name = "pm", .summary = "test method",
                                     .params = pm_params, .config_size = sizeof(pm_config), .declare = pm_declare,
                                     .create = pm_create, .support = pm_support, .n_passes = 1,
                                     .compute = pm_compute, .stable_dt = pm_stable_dt, .post_step = pm_post_step,
                                     .destroy = pm_destroy, .report = pm_report};

/* ------------------------------------------------------------------ an EOS with state */

/* "lit_gas": p = lit * rho * e with lit = 1 once t >= t_light = x / 1 m/s (a programmed burn
 * in miniature). */
typedef struct lg_config {
  ej_real speed;
} lg_config;
static const ej_param lg_params[] = {
    EJ_PARAM_REAL(lg_config, speed, "m/s", 1, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Lighting speed."), {0}};
static ej_err lg_create(const void *config, void **state)
{
  lg_config *c = ej_malloc(sizeof *c);
  EJ_ENSURE(c, EJ_ERR_MEM, "oom");
  *c = *(const lg_config *)config;
  *state = c;
  return EJ_OK;
}
static ej_err lg_evaluate(const void *state, ej_idx n, const ej_real *rho, const ej_real *e, ej_real *p, ej_real *c)
{
  (void)state;
  for (ej_idx i = 0; i < n; ++i) {
    p[i] = rho[i] * e[i];
    if (c) c[i] = 1;
  }
  return EJ_OK;
}
static ej_err lg_declare(const void *config, int dim, ej_decl *d)
{
  (void)config, (void)dim;
  static const ej_field_decl tl = {.name = "t_light", .kind = EJ_SCALAR, .unit = "s", .flags = EJ_FIELD_OUTPUT,
                                   .doc = "lighting time"};
  return ej_decl_field(d, &tl);
}
static ej_err lg_setup(const void *state, ej_set *set)
{
  const lg_config *c = state;
  ej_real *tl = ej_set_field(set, "t_light"), *x = ej_set_field(set, "x");
  for (ej_idx i = 0; i < ej_set_count(set); ++i) tl[i] = x[3 * i] / c->speed;
  return EJ_OK;
}
static ej_err lg_evaluate_set(const void *state, ej_set *set, ej_range r, const ej_real *rho, const ej_real *e,
                              ej_real *p, ej_real *c)
{
  (void)state;
  const ej_real *tl = ej_set_field(set, "t_light"), t = ej_set_time(set);
  for (ej_idx k = 0; k < r.end - r.begin; ++k) {
    p[k] = t >= tl[r.begin + k] ? rho[k] * e[k] : 0;
    if (c) c[k] = 1;
  }
  return EJ_OK;
}
static void lg_destroy(void *state) { ej_free(state); }
static const ej_eos_ops lg_ops = {.struct_size = sizeof(ej_eos_ops), .name = "lit_gas", .summary = "test EOS",
                                  .params = lg_params, .config_size = sizeof(lg_config), .create = lg_create,
                                  .evaluate = lg_evaluate, .destroy = lg_destroy, .declare = lg_declare,
                                  .setup = lg_setup, .evaluate_set = lg_evaluate_set};

/* ------------------------------------------------------------------ a material with history */

typedef struct hm_config {
  ej_real G;
} hm_config;
static const ej_param hm_params[] = {
    EJ_PARAM_REAL(hm_config, G, "Pa", 1e9, 0, 0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN, "Shear modulus."), {0}};
static const char *const hm_hist[] = {"alpha", "beta"};
static ej_err hm_create(const void *config, void **state)
{
  hm_config *c = ej_malloc(sizeof *c);
  EJ_ENSURE(c, EJ_ERR_MEM, "oom");
  *c = *(const hm_config *)config;
  *state = c;
  return EJ_OK;
}
static ej_err hm_init_hist(const void *state, ej_idx n, ej_real *const *hist)
{
  (void)state;
  for (ej_idx i = 0; i < n; ++i) hist[0][i] = 7, hist[1][i] = -1;
  return EJ_OK;
}
static ej_err hm_update(const void *state, ej_mat_batch *b)
{
  (void)state, (void)b;
  return EJ_OK;
}
static ej_err hm_moduli(const void *state, ej_real *K, ej_real *G)
{
  *G = ((const hm_config *)state)->G;
  *K = 2 * *G;
  return EJ_OK;
}
static void hm_destroy(void *state) { ej_free(state); }
static const ej_material_ops hm_ops = {.struct_size = sizeof(ej_material_ops), .name = "hist_mat",
                                       .summary = "test material", .params = hm_params,
                                       .config_size = sizeof(hm_config), .n_hist = 2, .hist_names = hm_hist,
                                       .create = hm_create, .init_hist = hm_init_hist, .update = hm_update,
                                       .destroy = hm_destroy, .moduli = hm_moduli};

/* ------------------------------------------------------------------ interactions */

/* "push": one-set constant force per unit mass g_push along x on every particle; reports the
 * cumulative work (WORK role) so the energy balance stays zero. */
typedef struct push_config {
  ej_real accel;
} push_config;
static const ej_param push_params[] = {
    EJ_PARAM_REAL(push_config, accel, "m/s^2", 1, 0, 0, 0, "Acceleration along x."), {0}};
typedef struct push_state {
  push_config cfg;
  ej_real work;
  int64_t calls_b;
} push_state;
static ej_err push_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  (void)a;
  ck_assert_ptr_null(b);
  push_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "oom");
  s->cfg = *(const push_config *)config;
  *state = s;
  return EJ_OK;
}
static ej_err push_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  ck_assert_ptr_null(b);
  ck_assert_ptr_null(ab);
  ck_assert_int_eq(pass, 0);
  push_state *s = state;
  ej_real *acc = ej_set_field(a, "a");
  for (ej_idx i = r.begin; i < r.end; ++i) acc[3 * i] += s->cfg.accel;
  return EJ_OK;
}
/* Work over the step with the mid-step velocity (exact for a constant force under Verlet). */
static ej_err push_post_step(void *state, ej_set *a, ej_set *b)
{
  (void)b;
  push_state *s = state;
  const ej_real *vh = ej_set_field(a, "v_half"), *m = ej_set_field(a, "m");
  for (ej_idx i = 0; i < ej_set_count(a); ++i) s->work += m[i] * s->cfg.accel * vh[3 * i] * ej_set_dt(a);
  return EJ_OK;
}
static ej_err push_report(void *state, ej_series_value *out, int max, int *n)
{
  (void)max;
  out[0] = (ej_series_value){"work", ((push_state *)state)->work, EJ_SERIES_WORK};
  *n = 1;
  return EJ_OK;
}
static void push_destroy(void *state) { ej_free(state); }
static const ej_interaction_ops push_ops = {.struct_size = sizeof(ej_interaction_ops), .name = "push",
                                            .summary = "test push", .params = push_params,
                                            .config_size = sizeof(push_config), .create = push_create,
                                            .compute = push_compute, .destroy = push_destroy,
                                            .post_step = push_post_step, .report = push_report};

/* "pair": both ways; counts list entries seen from each side (they must be equal). */
typedef struct pair_state {
  ej_set *a, *b;
  int64_t ab, ba;
} pair_state;
static const ej_param pair_params[] = {{0}};
static ej_err pair_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  (void)config;
  pair_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "oom");
  s->a = a, s->b = b;
  *state = s;
  return EJ_OK;
}
static ej_err pair_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  (void)b, (void)pass;
  pair_state *s = state;
  int64_t n = ab->off[r.end] - ab->off[r.begin];
  if (a == s->a) s->ab += n;
  else s->ba += n;
  return EJ_OK;
}
static void pair_destroy(void *state) { ej_free(state); }
static const ej_interaction_ops pair_ops = {.struct_size = sizeof(ej_interaction_ops), .name = "pair",
                                            .summary = "test pair", .params = pair_params, .config_size = 1,
                                            .create = pair_create, .compute = pair_compute,
                                            .destroy = pair_destroy, .both_ways = true};

static ej_err t11_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &pm_ops));
  EJ_TRY(ej_register_eos(reg, &lg_ops));
  EJ_TRY(ej_register_material(reg, &hm_ops));
  EJ_TRY(ej_register_interaction(reg, &push_ops));
  return ej_register_interaction(reg, &pair_ops);
}
EJ_PLUGIN_DEFINE(t11, "1.0", "MIT", "ABI 1.1 test plugins", t11_register)

/* ------------------------------------------------------------------ harness */

typedef struct run {
  char dir[64], scene[128], out[128];
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
} run;

static void run_open(run *r, const char *text, const char *restart)
{
  if (!restart) {
    memset(r, 0, sizeof *r);
    ej_test_tmpdir(r->dir, sizeof r->dir, "abi11");
    snprintf(r->scene, sizeof r->scene, "%s/s.yaml", r->dir);
    snprintf(r->out, sizeof r->out, "%s/out.h5", r->dir);
    FILE *f = fopen(r->scene, "w");
    ck_assert_ptr_nonnull(f);
    fprintf(f, text, r->out);
    fclose(f);
  }
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_t11_info()), EJ_OK);
  ej_err rc = ej_scene_load(r->scene, r->reg, &r->sc);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  char out2[160];
  snprintf(out2, sizeof out2, "%s/restarted.h5", r->dir);
  ej_run_opts o = {.threads = 1, .restart = restart, .output = restart ? out2 : NULL};
  rc = ej_sim_create(r->sc, r->reg, &o, &r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static void run_close(run *r)
{
  ej_sim_destroy(r->sim);
  ej_scene_destroy(r->sc);
  ej_registry_destroy(r->reg);
  r->sim = NULL, r->sc = NULL, r->reg = NULL;
}

static double series_last(const char *path, const char *name)
{
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  ck_assert_msg(d >= 0, "no dataset %s", name);
  hid_t sp = H5Dget_space(d);
  hssize_t n = H5Sget_simple_extent_npoints(sp);
  double *v = malloc(sizeof *v * (size_t)n);
  H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
  double last = v[n - 1];
  free(v);
  H5Sclose(sp);
  H5Dclose(d);
  H5Fclose(f);
  return last;
}

static const char scene_burn[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 0.25, dt: 0.01}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 2, eos: {model: lit_gas, speed: 1}, model: hist_mat, G: 3e9}\n"
    "sets:\n  bar: {method: pm, material: g, shape: {box: {min: [0], max: [1]}}, spacing: 0.1, e: 5}\n";

START_TEST(test_eos_state_and_history)
{
  run r;
  run_open(&r, scene_burn, NULL);
  ej_set *s = r.sim->sets[0];
  const ej_real *tl = ej_set_field(s, "t_light"), *x = ej_set_field(s, "x");
  ck_assert_ptr_nonnull(tl);
  for (ej_idx i = 0; i < s->n; ++i) ck_assert_double_eq_tol(tl[i], x[3 * i], 1e-15);
  ej_real *hist[4];
  ck_assert_int_eq(ej_set_hist(s, hist, 4), 2);
  ck_assert_ptr_eq(hist[0], ej_set_field(s, "alpha"));
  for (ej_idx i = 0; i < s->n; ++i) ck_assert(hist[0][i] == 7 && hist[1][i] == -1);
  ej_real K, G;
  ck_assert_int_eq(ej_material_moduli(ej_model_material(s->model), &K, &G), EJ_OK);
  ck_assert(G == 3e9 && K == 6e9);
  ck_assert_int_eq(ej_sim_run(r.sim), EJ_OK);
  /* at t = 0.25 particles with x <= 0.25 are lit: p = rho e = 10, the others 0 */
  const ej_real *p = ej_set_field(s, "p");
  x = ej_set_field(s, "x");
  tl = ej_set_field(s, "t_light");
  for (ej_idx i = 0; i < s->n; ++i) ck_assert_double_eq(p[i], x[3 * i] <= 0.25 + 1e-12 ? 10.0 : 0.0);
  ck_assert_double_eq_tol(series_last(r.out, "/series/bar/time_seen"), 0.25, 1e-12);
  run_close(&r);
}
END_TEST

static const char scene_push[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 0.1, dt: 0.001}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 2, eos: {model: lit_gas}}\n"
    "sets:\n  a: {method: pm, material: g, shape: {box: {min: [0], max: [1]}}, spacing: 0.1, velocity: [0.5]}\n"
    "  b: {method: pm, material: g, shape: {box: {min: [1], max: [2]}}, spacing: 0.1}\n"
    "interactions:\n  - {model: push, sets: [a], accel: 3}\n  - {model: pair, sets: [a, b]}\n";

START_TEST(test_interactions_and_work)
{
  run r;
  run_open(&r, scene_push, NULL);
  ck_assert_int_eq(ej_sim_run(r.sim), EJ_OK);
  /* v = 0.5 + 3 t everywhere in a; the work of the push balances the kinetic energy */
  ej_set *a = r.sim->sets[0];
  const ej_real *v = ej_set_field(a, "v");
  for (ej_idx i = 0; i < a->n; ++i) ck_assert_double_eq_tol(v[3 * i], 0.5 + 3 * 0.1, 1e-12);
  const double work = series_last(r.out, "/series/push_0/work");
  const double mass = 2.0 * 1.0; /* rho0 * length */
  ck_assert_double_eq_tol(work, 0.5 * mass * (0.8 * 0.8 - 0.5 * 0.5), 1e-12);
  ck_assert_double_lt(fabs(series_last(r.out, "/series/energy/balance")), 1e-12);
  ck_assert_double_eq_tol(series_last(r.out, "/series/energy/external"), work, 1e-15);
  /* both ways: the pair interaction saw the same number of pairs from each side */
  pair_state *ps = r.sim->inter[1].state;
  ck_assert_int_gt(ps->ab, 0);
  ck_assert_int_eq(ps->ab, ps->ba);
  run_close(&r);
}
END_TEST

static const char scene_ref[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 0.02, dt: 0.001}\noutput: {file: %s, checkpoint_every: 0.01}\n"
    "materials:\n  g: {rho0: 2, eos: {model: lit_gas}}\n"
    "sets:\n  plate: {method: pm, material: g, ref: true, radius: 1.5, "
    "shape: {box: {min: [0, 0], max: [1, 1]}}, spacing: 0.1}\n"
    "boundaries:\n  - symmetry: {point: [0, 0], normal: [1, 0]}\n";

START_TEST(test_reference_ghosts_and_bond_flags)
{
  run r;
  run_open(&r, scene_ref, NULL);
  ck_assert_int_eq(ej_sim_run(r.sim), EJ_OK);
  pm_state *ps = r.sim->sets[0]->mstate;
  /* 10 x 10 lattice, radius 1.5 h: 8 neighbours inside; the mirror adds the column x < 0 */
  ck_assert_int_gt(ps->ghost_bonds, 0);
  ck_assert_int_eq(ps->ghost_bonds, 10 + 2 * 9); /* the 10 particles at x = 0.05: 1 + 2 diagonal each */
  const double flagged = series_last(r.out, "/series/plate/flagged");
  ck_assert_double_gt(flagged, 0);
  run_close(&r);
  /* restart from the checkpoint: the flags come back */
  char cp[160];
  snprintf(cp, sizeof cp, "%s/out.h5", r.dir);
  run_open(&r, NULL, cp);
  ck_assert_ptr_nonnull(ej_set_bond_flags(r.sim->sets[0]));
  int64_t f = 0;
  for (ej_off k = 0; k < r.sim->sets[0]->n_bonds; ++k) f += ej_set_bond_flags(r.sim->sets[0])[k] & 1u;
  ck_assert_int_eq(f, (int64_t)flagged);
  run_close(&r);
}
END_TEST

/* A piston (prescribed velocity) compressing a gas: the constraint's work enters the budget. */
const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_ideal_gas_info(void);

START_TEST(test_prescribed_velocity_work)
{
  run r;
  memset(&r, 0, sizeof r);
  ej_test_tmpdir(r.dir, sizeof r.dir, "abi11");
  snprintf(r.scene, sizeof r.scene, "%s/s.yaml", r.dir);
  snprintf(r.out, sizeof r.out, "%s/out.h5", r.dir);
  FILE *f = fopen(r.scene, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f,
          "ejecta: 1\ndimension: 1\ntime: {end: 2e-3, cfl: 0.3}\noutput: {file: %s}\n"
          "materials:\n  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
          "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0], max: [1]}}, spacing: 0.01, p: 1e5}\n"
          "boundaries:\n  - {set: gas, region: {box: {min: [0], max: [0.05]}}, velocity: [20]}\n"
          "  - symmetry: {point: [1], normal: [-1]}\n",
          r.out);
  fclose(f);
  ck_assert_int_eq(ej_registry_create(&r.reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r.reg, ej_plugin_ideal_gas_info()), EJ_OK);
  ck_assert_int_eq(ej_scene_load(r.scene, r.reg, &r.sc), EJ_OK);
  ej_run_opts o = {.threads = 1};
  ck_assert_int_eq(ej_sim_create(r.sc, r.reg, &o, &r.sim), EJ_OK);
  ck_assert_int_eq(ej_sim_run(r.sim), EJ_OK);
  const ej_energy *E = &r.sim->energy;
  /* the piston pushes at 20 m/s against ~1e5 Pa: work ~ p A v t = 1e5 * 20 * 2e-3 = 4e3 J/m^2 */
  fprintf(stderr, "piston: external work %.6g J, balance %.3e J\n", E->external, E->balance);
  ck_assert_double_gt(E->external, 3e3);
  ck_assert_double_lt(fabs(E->balance), 1e-3 * E->external);
  run_close(&r);
}
END_TEST

static Suite *abi11_suite(void)
{
  Suite *s = suite_create("abi11");
  TCase *tc = tcase_create("core");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_eos_state_and_history);
  tcase_add_test(tc, test_interactions_and_work);
  tcase_add_test(tc, test_reference_ghosts_and_bond_flags);
  tcase_add_test(tc, test_prescribed_velocity_work);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(abi11_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
