/* A kinematic rigid indenter acting on one set, with the force law of LAMMPS fix indent:
 * F(r) = K (R - r)^2 for r < R, directed away from the indenter (sphere: along x - c; plane:
 * along the plane's normal), zero outside. The indenter moves with a prescribed velocity,
 * c(t) = c0 + v t (LAMMPS examples: a variable centre y0 + step dt vy).
 *
 * LAMMPS applies the force to f; for atom_style peri, f is a force density and the "mass" is the
 * density, so there K (R - r)^2 is a force per unit volume. per_volume: true reproduces that
 * convention (F_i = vol0_i K (R - r)^2, K in N/m^5); false gives a plain force in N (K in N/m^2).
 *
 * Energy budget: the work done on the particles is accumulated with the trapezoid
 * W += dt/2 (F_n . v_{n+1/2} + F_{n+1} . v_{n+1/2}), the velocity-Verlet-consistent work of a
 * position-dependent external force (exact for a constant force), where
 * F_n . v_{n+1/2} = F_n . v_n + dt/2 F_n . a_n is carried over from the previous step as two
 * scalars (no per-particle storage). Reported with role WORK. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"

enum { RI_SPHERE = 0, RI_PLANE = 1 };
static const char *const ri_shape_names[] = {"sphere", "plane", NULL};

typedef struct ri_config {
  int shape;
  ej_real center[3];
  ej_real velocity[3];
  ej_real normal[3];
  ej_real radius;
  ej_real K;
  bool per_volume;
} ri_config;

static const ej_param ri_params[] = {
    EJ_PARAM_ENUM(ri_config, shape, ri_shape_names, "sphere",
                  "Indenter shape: sphere (centre, radius) or plane (a point on it and its normal)."),
    EJ_PARAM_ARRAY(ri_config, center, 3, "m", EJ_PF_REQUIRED,
                   "Centre of the sphere (or a point of the plane) at t = 0."),
    EJ_PARAM_ARRAY(ri_config, velocity, 3, "m/s", 0, "Prescribed constant velocity of the indenter."),
    EJ_PARAM_ARRAY(ri_config, normal, 3, "1", 0,
                   "Plane only: normal pointing towards the particles; particles behind the plane are pushed "
                   "along it."),
    EJ_PARAM_REAL(ri_config, radius, "m", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Sphere radius R (required for a sphere)."),
    EJ_PARAM_REAL(ri_config, K, "N/m^2", 0.0, 0.0, 0.0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Force constant K of F = K (R - r)^2 (LAMMPS fix indent K); in N/m^5 with per_volume."),
    EJ_PARAM_BOOL(ri_config, per_volume, 0,
                  "Treat K (R - r)^2 as a force density and multiply it by the particle volume, the convention "
                  "of LAMMPS fix indent on atom_style peri particles."),
    {0}};

typedef struct ri_state {
  ri_config cfg;
  ej_set *set;
  ej_real n[3];
  ej_real work;
  ej_real force[3]; /* force on the indenter (reaction), N */
  ej_real P_prev, Q_prev; /* sum F_n . v_n and sum F_n . a_n */
  bool primed;
  /* Written by compute for each range r it is given: span[r.begin] = r.end if a particle of r may
   * touch the indenter, -r.end if none does (0: not computed yet). The serial sums of post_step
   * then visit only the touched ranges, in index order (the same sums as a full sweep). */
  ej_idx n_span;
  ej_idx *span;
} ri_state;

static ej_err ri_check(const void *config, ej_diag *diag)
{
  const ri_config *c = config;
  if (c->shape == RI_SPHERE && !(c->radius > 0))
    return ej_diag_error(diag, "radius", "a sphere indenter needs radius > 0");
  if (c->shape == RI_PLANE) {
    const ej_real l = sqrt(c->normal[0] * c->normal[0] + c->normal[1] * c->normal[1] + c->normal[2] * c->normal[2]);
    if (!(l > 0)) return ej_diag_error(diag, "normal", "a plane indenter needs a non-zero normal");
  }
  return EJ_OK;
}

static ej_err ri_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  EJ_ENSURE(config && a && state, EJ_ERR_ARG, "rigid_indenter: NULL argument to create");
  EJ_ENSURE(!b, EJ_ERR_INPUT, "rigid_indenter acts on one set (sets: [name]), got two");
  ri_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "rigid_indenter: out of memory");
  s->cfg = *(const ri_config *)config;
  s->set = a;
  const ej_real *nn = s->cfg.normal;
  const ej_real l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
  for (int k = 0; k < 3; ++k) s->n[k] = l > 0 ? nn[k] / l : 0.0;
  s->n_span = ej_set_count(a);
  s->span = ej_calloc((size_t)s->n_span + 1, sizeof *s->span);
  if (!s->span) {
    ej_free(s);
    EJ_FAIL(EJ_ERR_MEM, "rigid_indenter: out of memory");
  }
  *state = s;
  return EJ_OK;
}

static void ri_destroy(void *state)
{
  ri_state *s = state;
  if (s) ej_free(s->span);
  ej_free(s);
}

/* Force on particle at p (fix_indent.cpp: dr = r - R, fmag = K dr^2 for dr < 0). */
static inline void ri_force(const ri_state *s, const ej_real c[3], const ej_real *p, ej_real vol, ej_real F[3])
{
  F[0] = F[1] = F[2] = 0;
  const ej_real K = s->cfg.per_volume ? s->cfg.K * vol : s->cfg.K;
  if (s->cfg.shape == RI_SPHERE) {
    const ej_real dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
    const ej_real r = sqrt(dx * dx + dy * dy + dz * dz), dr = r - s->cfg.radius;
    if (dr >= 0.0 || !(r > 0.0)) return;
    const ej_real fr = K * dr * dr / r;
    F[0] = dx * fr, F[1] = dy * fr, F[2] = dz * fr;
  } else {
    const ej_real d = (p[0] - c[0]) * s->n[0] + (p[1] - c[1]) * s->n[1] + (p[2] - c[2]) * s->n[2];
    if (d >= 0.0) return;
    const ej_real fm = K * d * d;
    F[0] = fm * s->n[0], F[1] = fm * s->n[1], F[2] = fm * s->n[2];
  }
}

/* Cheap pre-test: false only where ri_force certainly gives 0 (sphere: |x - c|^2 clearly beyond
 * R^2, no square root), so skipping those particles changes no result. */
static inline bool ri_near(const ri_state *s, const ej_real c[3], const ej_real *p)
{
  if (s->cfg.shape != RI_SPHERE) return true;
  const ej_real dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2], R = s->cfg.radius;
  return dx * dx + dy * dy + dz * dz <= R * R * (1.0 + 1e-9);
}

static inline void ri_center(const ri_state *s, ej_real t, ej_real c[3])
{
  for (int k = 0; k < 3; ++k) c[k] = s->cfg.center[k] + s->cfg.velocity[k] * t;
}

static ej_err ri_compute(void *state, ej_set *a, ej_set *b, const ej_nbr *ab, int pass, ej_range r)
{
  (void)b, (void)ab, (void)pass;
  const ri_state *s = state;
  const ej_real *x = ej_set_field(a, "x"), *m = ej_set_field(a, "m"), *vol0 = ej_set_field(a, "vol0");
  ej_real *acc = ej_set_field(a, "a");
  EJ_ENSURE(x && m && vol0 && acc, EJ_ERR_INTERNAL, "rigid_indenter: base fields missing");
  ej_real c[3];
  ri_center(s, ej_set_time(a), c);
  bool touched = false;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    if (!ri_near(s, c, x + 3 * i)) continue;
    touched = true;
    ej_real F[3];
    ri_force(s, c, x + 3 * i, vol0[i], F);
    const ej_real im = 1.0 / m[i];
    acc[3 * i] += F[0] * im, acc[3 * i + 1] += F[1] * im, acc[3 * i + 2] += F[2] * im;
  }
  if (r.begin < s->n_span && r.end > r.begin) ((ri_state *)state)->span[r.begin] = touched ? r.end : -r.end;
  return EJ_OK;
}

/* Sums over the set at the current configuration: total force on the particles, F.v, F.a and
 * F.v_half. Serial (called once per step). */
static void ri_sums(const ri_state *s, ej_real Ft[3], ej_real *P, ej_real *Q, ej_real *H)
{
  const ej_set *a = s->set;
  const ej_idx n = ej_set_count(a);
  const ej_real *x = ej_set_field(a, "x"), *v = ej_set_field(a, "v"), *acc = ej_set_field(a, "a");
  const ej_real *vh = ej_set_field(a, "v_half"), *vol0 = ej_set_field(a, "vol0");
  ej_real c[3];
  ri_center(s, ej_set_time(a), c);
  Ft[0] = Ft[1] = Ft[2] = 0, *P = *Q = *H = 0;
  ej_idx stop = 0; /* end of the current range; particles before it of an untouched range are skipped */
  for (ej_idx i = 0; i < n; ++i) {
    if (i >= stop) {
      /* a range compute has seen: skip it when no particle touched the indenter */
      const ej_idx e = n == s->n_span ? s->span[i] : 0;
      if (e < 0 && -e > i) {
        i = -e - 1;
        continue;
      }
      stop = e > i ? e : i + 1;
    }
    if (!ri_near(s, c, x + 3 * i)) continue;
    ej_real F[3];
    ri_force(s, c, x + 3 * i, vol0[i], F);
    if (F[0] == 0 && F[1] == 0 && F[2] == 0) continue;
    for (int k = 0; k < 3; ++k) {
      Ft[k] += F[k];
      *P += F[k] * v[3 * i + k];
      *Q += F[k] * acc[3 * i + k];
      if (vh) *H += F[k] * vh[3 * i + k];
    }
  }
}

static ej_err ri_post_step(void *state, ej_set *a, ej_set *b)
{
  (void)a, (void)b;
  ri_state *s = state;
  const ej_real dt = ej_set_dt(s->set);
  ej_real Ft[3], P, Q, H;
  ri_sums(s, Ft, &P, &Q, &H);
  /* previous force along this step's mid velocity v_{n+1/2} = v_n + dt/2 a_n */
  const ej_real old = s->P_prev + 0.5 * dt * s->Q_prev;
  s->work += 0.5 * dt * (old + H);
  s->P_prev = P, s->Q_prev = Q;
  for (int k = 0; k < 3; ++k) s->force[k] = -Ft[k];
  s->primed = true;
  return EJ_OK;
}

static ej_err ri_report(void *state, ej_series_value *out, int max, int *n)
{
  ri_state *s = state;
  *n = 0;
  if (!s->primed) {
    /* the initial state (called once before the first step): F_0 . v_0 and F_0 . a_0 */
    ej_real Ft[3], H;
    ri_sums(s, Ft, &s->P_prev, &s->Q_prev, &H);
    for (int k = 0; k < 3; ++k) s->force[k] = -Ft[k];
    s->primed = true;
  }
  if (max < 8) return EJ_OK;
  ej_real c[3];
  ri_center(s, ej_set_time(s->set), c);
  const ej_real fm = sqrt(s->force[0] * s->force[0] + s->force[1] * s->force[1] + s->force[2] * s->force[2]);
  out[0] = (ej_series_value){.name = "force_x", .value = s->force[0]};
  out[1] = (ej_series_value){.name = "force_y", .value = s->force[1]};
  out[2] = (ej_series_value){.name = "force_z", .value = s->force[2]};
  out[3] = (ej_series_value){.name = "force", .value = fm};
  out[4] = (ej_series_value){.name = "work", .value = s->work, .role = EJ_SERIES_WORK};
  out[5] = (ej_series_value){.name = "center_x", .value = c[0]};
  out[6] = (ej_series_value){.name = "center_y", .value = c[1]};
  out[7] = (ej_series_value){.name = "center_z", .value = c[2]};
  *n = 8;
  return EJ_OK;
}

/* Checkpointed state (ABI 1.8): the indenter's work summed so far and the sums F.v and F.a
 * at the end of the last step (the left end of its work rule), so that a restarted run's energy
 * budget continues. */
static ej_err ri_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const ri_state *s = state;
  EJ_ENSURE(max >= 4, EJ_ERR_INTERNAL, "rigid_indenter: %d state slots, needs 4", max);
  buf[0] = s->work;
  buf[1] = s->P_prev;
  buf[2] = s->Q_prev;
  buf[3] = (ej_real)s->primed;
  *n = 4;
  return EJ_OK;
}

static ej_err ri_load_state(void *state, const ej_real *buf, int n)
{
  ri_state *s = state;
  EJ_ENSURE(n == 4, EJ_ERR_INPUT, "rigid_indenter: %d state values in the checkpoint, expected 4", n);
  s->work = buf[0];
  s->P_prev = buf[1];
  s->Q_prev = buf[2];
  s->primed = buf[3] != 0;
  return EJ_OK;
}

/* The indenter's force goes into a of the target; nothing else is written (ABI 1.11) */
static int ri_pass_writes(const void *state, int pass, int side, const char **names, int max)
{
  (void)state, (void)pass, (void)side;
  if (max < 1) return -1;
  names[0] = "a";
  return 1;
}

static const ej_interaction_ops ri_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "rigid_indenter",
    .summary = "Kinematic rigid sphere or plane with LAMMPS fix indent's force law F = K (R - r)^2",
    .doc = "A rigid indenter moving at a prescribed velocity pushes the particles of one set with the force "
           "law of LAMMPS fix indent, F = K (R - r)^2 inside the indenter (sphere) or K d^2 behind it (plane). "
           "Reports the reaction force on the indenter and the cumulative work done on the particles (role "
           "WORK, so the energy budget balances). per_volume reproduces LAMMPS's atom_style peri convention.",
    .params = ri_params,
    .config_size = sizeof(ri_config),
    .check_config = ri_check,
    .create = ri_create,
    .compute = ri_compute,
    .stable_dt = NULL,
    .destroy = ri_destroy,
    .both_ways = false,
    .n_passes = 1,
    .post_step = ri_post_step,
    .post_step_sums_only = true, /* work and force sums only: no particle field written */
    .report = ri_report,
    .save_state = ri_save_state,
    .load_state = ri_load_state,
    .pass_writes = ri_pass_writes,
};

static ej_err ri_register(ej_registry *reg)
{
  EJ_TRY(ej_register_interaction(reg, &ri_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(rigid_indenter, "0.1.0", "BSD-3-Clause", "Rigid indenter (LAMMPS fix indent force law)", ri_register)
