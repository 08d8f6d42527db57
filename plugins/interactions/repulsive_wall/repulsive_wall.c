/* Interaction `repulsive_wall`: Monaghan's repulsive boundary force between a set of boundary
 * particles (second set; a line or plane of particles at spacing dp) and the particles of a first
 * set (SPH or any method with a smoothing length).
 *
 * J. J. Monaghan, "Simulating free surface flows with SPH", J. Comput. Phys. 110 (1994) 399-406,
 * introduced boundary particles that exert a central repulsive force; the form used here is the
 * later one with a kernel-like normal profile, a hat function along the wall and the pair factor
 * m_w / (m_i + m_w) (Monaghan & Kos 1999, J. Waterway Port Coastal Ocean Eng. 125, 145-154), as
 * PySPH implements it in `MonaghanBoundaryForce` (pysph/sph/boundary_equations.py, read for the
 * constants; neither paper is in hand here, so no equation numbers are quoted). For an SPH
 * particle i and a boundary particle w with the wall normal n (a parameter, pointing into the
 * material) and x_iw = x_i - x_w:
 *   y = x_iw . n                     (distance from the wall line, > 0 on the material side)
 *   t = |x_iw - y n|                 (distance along the wall; PySPH's |x_iw . t| in 2D)
 *   q = y / h_i
 *   Gamma(q) = 2/3                   0 < q <= 2/3
 *            = 2 q (1 - 3 q / 4)     2/3 < q <= 1
 *            = (2 - q)^2 / 2         1 < q < 2,    0 otherwise (and for y <= 0)
 *   chi(t)   = 1 - t / dp            t < dp,       0 otherwise
 *   and only pairs closer than |x_iw| < 2 h_i (the SPH support; PySPH's neighbour search, whose
 *   plate particles have h = 0, gives the same cut): the window's corners, y > sqrt(4 h^2 - dp^2),
 *   where Gamma < (2 - sqrt(4 - (dp/h)^2))^2 / 2 (0.002 for dp = h/2), are left out
 *   beta(y)  = coefficient c_s^2 / max(y, guard h_i)   (Monaghan: 0.02 c_s^2 / y)
 *   F_iw     = m_i m_w / (m_i + m_w) Gamma(q) chi(t) beta(y) n,   F_wi = -F_iw
 * i.e. the acceleration m_w/(m_i + m_w) Gamma chi beta n of PySPH on i, and the reaction on w
 * (momentum conserved if the boundary set can move). Along a straight row of boundary particles
 * at spacing dp the hats sum to one, so the total force on i depends on y only: no tangential
 * force and no lattice ripple along the wall. The guard bounds the 1/y singularity (PySPH's
 * 0.02 c^2 / y times Gamma(0) = 0 is 0/0 at y = 0); at and behind the wall line (y <= 0) there is
 * no force, as in PySPH.
 *
 * Both sets are called (both_ways): the pair force is computed from the same operands in the same
 * order on either side, so F_wi = -F_iw bitwise. Energy: the work of the pair forces on both sets,
 * sum F_iw . (v_i - v_w), integrated with the trapezoid rule, is reported as the series `work`
 * (role WORK), so the core's energy budget closes (the force is conservative along a straight
 * row: the work is minus the change of a potential). Stable step: 1/omega with
 * omega_i^2 = sum_w chi coefficient c_s^2 |d(Gamma / max(y, guard h)) / dy| (the pair stiffness
 * over the reduced mass), the core applies its cfl. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"

typedef struct rw_config {
  ej_real normal[3];
  ej_real spacing;
  ej_real coefficient;
  ej_real sound_speed;
  ej_real h;
  ej_real guard;
} rw_config;

static const ej_param rw_params[] = {
    EJ_PARAM_ARRAY(rw_config, normal, 3, "1", EJ_PF_REQUIRED,
                   "Wall normal n (normalised here), pointing from the boundary particles into the material: the "
                   "force acts along n on particles with y = (x_i - x_w) . n > 0 (one flat wall per interaction)."),
    EJ_PARAM_REAL(rw_config, spacing, "m", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Boundary particle spacing dp of the tangential hat chi = 1 - t/dp (Monaghan's Delta p); 0 takes "
                  "each boundary particle's vol0^(1/dim)."),
    EJ_PARAM_REAL(rw_config, coefficient, "1", 0.02, 0.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Strength: beta = coefficient c_s^2 / y (Monaghan's 0.02)."),
    EJ_PARAM_REAL(rw_config, sound_speed, "m/s", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Sound speed c_s of beta: 0 takes the particle's current sound speed (field c); a positive value "
                  "is a constant reference speed (Monaghan's weakly compressible c_s, PySPH's constant cs)."),
    EJ_PARAM_REAL(rw_config, h, "m", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Length scale of the normal profile, q = y / h, range 2 h: 0 takes the particle's smoothing "
                  "length (field h, the SPH set's)."),
    EJ_PARAM_REAL(rw_config, guard, "1", 0.01, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Smallest distance in beta's 1/y, as a fraction of h: particles closer than guard h to the wall "
                  "line feel the force of y = guard h (no singularity at y = 0)."),
    {0}};

#define RW_NSERIES 5

typedef struct rw_state {
  rw_config cfg;
  ej_real n[3];
  const ej_set *a; /* the material set; b is the boundary set */
  int dim;
  ej_idx n_a;
  ej_real *power; /* [n_a] sum_w F_iw . (v_i - v_w) of a's particles, W */
  ej_real *force; /* [n_a][3] force of the wall on a's particles, N */
  ej_real *omega2; /* [n_a] stiffness / reduced mass of a's wall pairs, 1/s^2 */
  int32_t *npair;
  ej_real work, power_prev, f_tot[3];
  int64_t pairs;
  bool started;
} rw_state;

static void rw_destroy(void *state)
{
  rw_state *s = state;
  if (!s) return;
  ej_free(s->power), ej_free(s->force), ej_free(s->omega2), ej_free(s->npair);
  ej_free(s);
}

static ej_err rw_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  EJ_ENSURE(config && a && state, EJ_ERR_ARG, "repulsive_wall: NULL argument to create");
  EJ_ENSURE(b && b != a, EJ_ERR_UNSUPPORTED,
            "repulsive_wall acts between a material set and a set of boundary particles (sets: [material, wall])");
  const rw_config *c = config;
  const ej_real nl = sqrt(c->normal[0] * c->normal[0] + c->normal[1] * c->normal[1] + c->normal[2] * c->normal[2]);
  if (!(nl > 0) || !isfinite(nl))
    EJ_FAIL(EJ_ERR_INPUT, "repulsive_wall: normal must be a nonzero vector (it points from the wall into set '%s')",
            ej_set_name(a));
  if (c->h <= 0 && !ej_set_field(a, "h"))
    EJ_FAIL(EJ_ERR_INPUT, "repulsive_wall: set '%s' has no smoothing length field h; give the parameter h",
            ej_set_name(a));
  if (c->sound_speed <= 0 && !ej_set_field(a, "c"))
    EJ_FAIL(EJ_ERR_INPUT, "repulsive_wall: set '%s' has no sound speed field c; give the parameter sound_speed",
            ej_set_name(a));
  rw_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "repulsive_wall: out of memory");
  s->cfg = *c;
  for (int q = 0; q < 3; ++q) s->n[q] = c->normal[q] / nl;
  s->a = a;
  s->dim = ej_set_dim(a);
  s->n_a = ej_set_count(a);
  const size_t n = (size_t)s->n_a + 1;
  s->power = ej_calloc(n, sizeof *s->power);
  s->force = ej_calloc(3 * n, sizeof *s->force);
  s->omega2 = ej_calloc(n, sizeof *s->omega2);
  s->npair = ej_calloc(n, sizeof *s->npair);
  if (!s->power || !s->force || !s->omega2 || !s->npair) {
    rw_destroy(s);
    EJ_FAIL(EJ_ERR_MEM, "repulsive_wall: out of memory");
  }
  *state = s;
  return EJ_OK;
}

static inline ej_real rw_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }

/* Monaghan's normal profile Gamma(q) and its derivative dGamma/dq. */
static inline ej_real rw_gamma(ej_real q, ej_real *dg)
{
  if (q <= 0 || q >= 2) return *dg = 0, 0.0;
  if (q <= 2.0 / 3.0) return *dg = 0, 2.0 / 3.0;
  if (q <= 1.0) return *dg = 2.0 - 3.0 * q, 2.0 * q * (1.0 - 0.75 * q);
  return *dg = -(2.0 - q), 0.5 * (2.0 - q) * (2.0 - q);
}

/* Pair force of wall particle w on material particle i (N) along n, its stiffness over the reduced
 * mass (1/s^2), false outside the range. The operands are the same whichever side calls. */
static inline bool rw_pair(const rw_state *s, const ej_real *xi, const ej_real *xw, ej_real hi, ej_real ci,
                           ej_real mi, ej_real mw, ej_real dp, ej_real *F, ej_real *om2)
{
  const ej_real d[3] = {xi[0] - xw[0], xi[1] - xw[1], xi[2] - xw[2]};
  const ej_real y = d[0] * s->n[0] + d[1] * s->n[1] + d[2] * s->n[2];
  const ej_real r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  /* pairs beyond the support 2 h_i are cut whatever the list's skin holds (as PySPH's neighbour
   * search: r < 2 h_i, the plate particles have h = 0) */
  if (!(y > 0) || !(hi > 0) || !(r2 < 4.0 * hi * hi)) return false;
  const ej_real tv[3] = {d[0] - y * s->n[0], d[1] - y * s->n[1], d[2] - y * s->n[2]};
  const ej_real t = sqrt(tv[0] * tv[0] + tv[1] * tv[1] + tv[2] * tv[2]);
  if (!(t < dp)) return false;
  const ej_real chi = 1.0 - t / dp;
  ej_real dg;
  const ej_real g = rw_gamma(y / hi, &dg);
  const ej_real ymin = s->cfg.guard * hi, ye = y > ymin ? y : ymin;
  const ej_real k = s->cfg.coefficient * ci * ci * chi; /* chi beta = k / ye */
  *F = (mi * mw / (mi + mw)) * g * k / ye;
  /* |d(Gamma/ye)/dy| <= |Gamma'|/(h ye) + Gamma/ye^2 (the second only where ye = y) */
  *om2 = k * (fabs(dg) / (hi * ye) + (y > ymin ? g / (ye * ye) : 0.0));
  return true;
}

static ej_err rw_compute(void *state, ej_set *self, ej_set *other, const ej_nbr *nbr, int pass, ej_range r)
{
  (void)pass;
  rw_state *s = state;
  const bool primary = self == s->a;
  ej_set *mat = primary ? self : other, *wall = primary ? other : self;
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "repulsive_wall: list has %d rows, range ends at %d",
            nbr ? (int)nbr->n_rows : -1, (int)r.end);
  EJ_ENSURE(!primary || ej_set_count(self) == s->n_a, EJ_ERR_INTERNAL, "repulsive_wall: set '%s' changed size",
            ej_set_name(self));
  const rw_config *c = &s->cfg;
  const ej_real *xm = ej_set_field(mat, "x"), *vm = ej_set_field(mat, "v"), *mm = ej_set_field(mat, "m");
  const ej_real *hm = c->h > 0 ? NULL : ej_set_field(mat, "h");
  const ej_real *cm = c->sound_speed > 0 ? NULL : ej_set_field(mat, "c");
  const ej_real *xw = ej_set_field(wall, "x"), *vw = ej_set_field(wall, "v"), *mw = ej_set_field(wall, "m");
  const ej_real *V0w = ej_set_field(wall, "vol0");
  ej_real *acc = ej_set_field(self, "a");
  EJ_ENSURE(xm && vm && mm && xw && vw && mw && V0w && acc && (hm || c->h > 0) && (cm || c->sound_speed > 0),
            EJ_ERR_INTERNAL, "repulsive_wall: fields missing");
  const int dim = s->dim;
  for (ej_idx p = r.begin; p < r.end; ++p) {
    ej_real f[3] = {0, 0, 0}, pw = 0, om2 = 0;
    int32_t np = 0;
    for (ej_off k = nbr->off[p]; k < nbr->off[p + 1]; ++k) {
      const ej_idx o = nbr->idx[k];
      const ej_idx i = primary ? p : o, w = primary ? o : p;
      const ej_real hi = hm ? hm[i] : c->h, ci = cm ? cm[i] : c->sound_speed;
      const ej_real dp = c->spacing > 0 ? c->spacing : rw_root(dim, V0w[w]);
      ej_real F, o2;
      if (!rw_pair(s, xm + 3 * (size_t)i, xw + 3 * (size_t)w, hi, ci, mm[i], mw[w], dp, &F, &o2)) continue;
      const ej_real Fs = primary ? F : -F;
      for (int q = 0; q < 3; ++q) f[q] += Fs * s->n[q];
      if (primary) {
        ej_real vn = 0;
        for (int q = 0; q < 3; ++q) vn += (vm[3 * i + q] - vw[3 * w + q]) * s->n[q];
        pw += F * vn;
        om2 += o2;
        ++np;
      }
    }
    const ej_real *ms = primary ? mm : mw;
    const ej_real im = 1.0 / ms[p];
    for (int q = 0; q < dim; ++q) acc[3 * p + q] += f[q] * im;
    if (primary) {
      s->power[p] = pw;
      s->omega2[p] = om2;
      s->npair[p] = np;
      for (int q = 0; q < 3; ++q) s->force[3 * p + q] = f[q];
    }
  }
  return EJ_OK;
}

/* Sums over a's particles in index order (the same for any thread count). */
static ej_real rw_sums(rw_state *s)
{
  ej_real P = 0, F[3] = {0, 0, 0};
  int64_t np = 0;
  for (ej_idx i = 0; i < s->n_a; ++i) {
    P += s->power[i];
    np += s->npair[i];
    for (int q = 0; q < 3; ++q) F[q] += s->force[3 * i + q];
  }
  memcpy(s->f_tot, F, sizeof F);
  s->pairs = np;
  return P;
}

static ej_err rw_post_step(void *state, ej_set *a, ej_set *b)
{
  (void)b;
  rw_state *s = state;
  const ej_real P = rw_sums(s);
  s->work += 0.5 * ej_set_dt(a) * (s->power_prev + P); /* trapezoid over the step */
  s->power_prev = P;
  return EJ_OK;
}

static ej_err rw_report(void *state, ej_series_value *out, int max, int *n)
{
  rw_state *s = state;
  *n = 0;
  if (!s->started) { /* t = 0: the initial evaluation, before any post_step */
    s->power_prev = rw_sums(s);
    s->started = true;
  }
  if (max < RW_NSERIES) return EJ_OK;
  out[0] = (ej_series_value){.name = "force_x", .value = s->f_tot[0], .role = EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){.name = "force_y", .value = s->f_tot[1], .role = EJ_SERIES_PLAIN};
  out[2] = (ej_series_value){.name = "force_z", .value = s->f_tot[2], .role = EJ_SERIES_PLAIN};
  out[3] = (ej_series_value){.name = "pairs", .value = (ej_real)s->pairs, .role = EJ_SERIES_PLAIN};
  out[4] = (ej_series_value){.name = "work", .value = s->work, .role = EJ_SERIES_WORK};
  *n = RW_NSERIES;
  return EJ_OK;
}

static ej_err rw_stable_dt(void *state, const ej_set *a, const ej_set *b, ej_real *dt)
{
  (void)a, (void)b;
  const rw_state *s = state;
  ej_real w2 = 0;
  for (ej_idx i = 0; i < s->n_a; ++i) w2 = s->omega2[i] > w2 ? s->omega2[i] : w2;
  *dt = w2 > 0 ? 1.0 / sqrt(w2) : HUGE_VAL;
  return EJ_OK;
}

/* Checkpointed state (ABI 1.8): the wall work summed so far and the power at the end of
 * the last step (the trapezoid's left end), so that a restarted run's energy budget continues. */
static ej_err rw_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const rw_state *s = state;
  EJ_ENSURE(max >= 3, EJ_ERR_INTERNAL, "repulsive_wall: %d state slots, needs 3", max);
  buf[0] = s->work;
  buf[1] = s->power_prev;
  buf[2] = (ej_real)s->started;
  *n = 3;
  return EJ_OK;
}

static ej_err rw_load_state(void *state, const ej_real *buf, int n)
{
  rw_state *s = state;
  EJ_ENSURE(n == 3, EJ_ERR_INPUT, "repulsive_wall: %d state values in the checkpoint, expected 3", n);
  s->work = buf[0];
  s->power_prev = buf[1];
  s->started = buf[2] != 0;
  return EJ_OK;
}

/* The wall forces go into a of the set whose rows are summed; nothing else is written (ABI 1.11) */
static int rw_pass_writes(const void *state, int pass, int side, const char **names, int max)
{
  (void)state, (void)pass, (void)side;
  if (max < 1) return -1;
  names[0] = "a";
  return 1;
}

static const ej_interaction_ops rw_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "repulsive_wall",
    .summary = "Monaghan's repulsive boundary force of a row of boundary particles on a set (SPH)",
    .doc = "Boundary particles (second set) push the particles of the first set away along the wall normal n with "
           "the force m_i m_w/(m_i + m_w) Gamma(y/h_i) (1 - t/dp) coefficient c_s^2 / y, y the distance from the "
           "wall line along n, t along it, Gamma Monaghan's kernel-like profile (2/3 up to q = 2/3, zero from "
           "q = 2) (Monaghan, JCP 110 (1994); Monaghan & Kos 1999; PySPH's MonaghanBoundaryForce). The reaction "
           "acts on the boundary particles (both_ways, antisymmetric bitwise); the work of the pair forces is the "
           "series `work` (role WORK) of the energy budget. See plugins/interactions/repulsive_wall/README.md.",
    .params = rw_params,
    .config_size = sizeof(rw_config),
    .check_config = NULL,
    .create = rw_create,
    .compute = rw_compute,
    .stable_dt = rw_stable_dt,
    .destroy = rw_destroy,
    .both_ways = true,
    .n_passes = 1,
    .post_step = rw_post_step,
    .post_step_sums_only = true, /* work and force sums only: no particle field written */
    .report = rw_report,
    .n_sets = 2,
    .save_state = rw_save_state,
    .load_state = rw_load_state,
    .pass_writes = rw_pass_writes,
};

static ej_err rw_register(ej_registry *reg) { return ej_register_interaction(reg, &rw_ops); }

EJ_PLUGIN_DEFINE(repulsive_wall, "0.1.0", "BSD-3-Clause", "Monaghan repulsive boundary force", rw_register)
