/* Point-to-point frictional contact between two particle sets, detected by kernel overlap.
 *
 * Digest 003 section 1.9: the report (Chi et al., SERDP MR-2628) adopts the kernel contact of
 * Guan et al. (IJIE 38 (2011) 1033) and Chi et al. (IJNME 2015) but gives no contact equation,
 * penalty or friction coefficient. This plugin implements the idea in its simplest
 * momentum-conserving form: two points of different bodies are in contact when their
 * distance r is below the contact distance delta = distance * (h_i + h_j) / 2 (h = nodal
 * spacing vol0^(1/dim); with distance <= support the kernel supports overlap), and then
 *   normal:   N = max(0, k_ij g - c_ij v_n),  g = delta - r,  v_n = (v_j - v_i).n,  n = (x_j - x_i)/r
 *             k_ij = harmonic mean of k_i = penalty rho_i c_i^2 h_i^(dim-2) (P-wave modulus x
 *             spacing: a spring as stiff as the material across one spacing),
 *             c_ij = 2 damping sqrt(k_ij m_ij), m_ij = m_i m_j / (m_i + m_j);
 *   tangential (Coulomb): T = min(mu N, stick m_ij |v_t| / dt), v_t = v_rel - v_n n,
 *             acting on i along +v_t/|v_t| (it drags i with j), on j opposite.
 * The force on i is f_i = -N n + T t. Every factor is symmetric in i and j and every vector
 * antisymmetric, bitwise, so the force computed on j's side (both_ways: compute(b, a)) is
 * exactly -f_i: momentum is conserved to round-off without scatter.
 * Energy: the penalty potential U = sum k g^2 / 2 is reported as work -U (role WORK) and the
 * energy removed by friction and damping, D = int sum [T |v_t| + (k g - N) v_n] dt, as role
 * DISSIPATED, so that the core's balance KE + IE + U + D = const closes. */
#include <math.h>
#include <string.h>

#include "ejecta/plugin.h"

typedef struct kc_config {
  ej_real mu;
  ej_real distance;
  ej_real penalty;
  ej_real damping;
  ej_real stick;
  ej_real modulus;
  int normal;
} kc_config;

enum { KC_NORMAL_PAIR = 0, KC_NORMAL_BODY = 1 };
static const char *const kc_normal_names[] = {"pair", "body", NULL};

static const ej_param kc_params[] = {
    EJ_PARAM_REAL(kc_config, mu, "1", 0.0, 0.0, 2.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Coulomb friction coefficient between the two bodies."),
    EJ_PARAM_REAL(kc_config, distance, "1", 1.0, 0.0, 1.5, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Contact distance in mean nodal spacings (h_i + h_j)/2: points closer than this repel."),
    EJ_PARAM_REAL(kc_config, penalty, "1", 1.0, 0.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN,
                  "Normal stiffness as a multiple of rho c^2 h^(dim-2) (the material's P-wave modulus across one "
                  "spacing)."),
    EJ_PARAM_REAL(kc_config, damping, "1", 0.0, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Normal damping as a fraction of the critical damping of one contact pair."),
    EJ_PARAM_REAL(kc_config, stick, "1", 0.2, 0.0, 1.0,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_MIN_OPEN | EJ_PF_EXPERT,
                  "Largest tangential force per pair as a fraction of the force that stops the relative sliding "
                  "of the pair in one step (regularises sticking below the Coulomb limit)."),
    EJ_PARAM_REAL(kc_config, modulus, "Pa", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Modulus for the penalty instead of rho c^2 (needed when a set's method has no rho and c "
                  "fields); 0 takes rho c^2 per particle."),
    EJ_PARAM_ENUM(kc_config, normal, kc_normal_names, "pair",
                  "Contact normal: pair, the direction between the two points; body, the outward surface normal of "
                  "a rigid_body set with normals: true (the level-set normal of Chi et al. 2015): the gap is "
                  "measured along it, so a point that slips between two points of the other body is still pushed "
                  "out, and the force is weighted down smoothly with the lateral offset."),
    {0}};

#define KC_NSERIES 6

typedef struct kc_state {
  kc_config cfg;
  ej_set *a, *b;
  const ej_set *body; /* normal: body, the set whose rb_n gives the normals */
  int dim;
  ej_idx n_a;
  ej_real *drate; /* [n_a] dissipation rate of a's pairs, W */
  ej_real *upot;  /* [n_a] penalty potential of a's pairs, J */
  ej_real *force; /* [n_a][3] contact force on a's particles, N */
  ej_real dissipated, drate_prev, potential;
  ej_real f_tot[3];
  int64_t pairs_step;
  int32_t *npair; /* [n_a] pairs in contact */
  bool started;
} kc_state;

static inline ej_real kc_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }

static ej_err kc_create(const void *config, ej_set *a, ej_set *b, void **state)
{
  EJ_ENSURE(config && a && state, EJ_ERR_ARG, "kernel_contact: NULL argument to create");
  EJ_ENSURE(b, EJ_ERR_UNSUPPORTED, "kernel_contact acts between two sets (sets: [a, b]); set '%s' alone given",
            ej_set_name(a));
  const kc_config *cfg = config;
  const ej_set *sets[2] = {a, b};
  for (int k = 0; k < 2; ++k)
    if (cfg->modulus <= 0)
      EJ_ENSURE(ej_set_field(sets[k], "rho") && ej_set_field(sets[k], "c"), EJ_ERR_UNSUPPORTED,
                "kernel_contact: set '%s' has no rho and c fields for the penalty stiffness; give `modulus`",
                ej_set_name(sets[k]));
  const ej_set *body = NULL;
  if (cfg->normal == KC_NORMAL_BODY) {
    body = ej_set_field(b, "rb_n") ? b : ej_set_field(a, "rb_n") ? a : NULL;
    EJ_ENSURE(body, EJ_ERR_INPUT,
              "kernel_contact: normal: body needs a rigid_body set with normals: true, and neither '%s' nor '%s' "
              "has surface normals (field rb_n)",
              ej_set_name(a), ej_set_name(b));
  }
  kc_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "kernel_contact: out of memory");
  s->cfg = *cfg;
  s->body = body;
  s->a = a;
  s->b = b;
  s->dim = ej_set_dim(a);
  s->n_a = ej_set_count(a);
  const size_t n = (size_t)(s->n_a > 0 ? s->n_a : 1);
  s->drate = ej_calloc(n, sizeof *s->drate);
  s->upot = ej_calloc(n, sizeof *s->upot);
  s->force = ej_calloc(3 * n, sizeof *s->force);
  s->npair = ej_calloc(n, sizeof *s->npair);
  if (!s->drate || !s->upot || !s->force || !s->npair) {
    ej_free(s->drate), ej_free(s->upot), ej_free(s->force), ej_free(s->npair), ej_free(s);
    EJ_FAIL(EJ_ERR_MEM, "kernel_contact: out of memory");
  }
  *state = s;
  return EJ_OK;
}

static void kc_destroy(void *state)
{
  kc_state *s = state;
  if (!s) return;
  ej_free(s->drate);
  ej_free(s->upot);
  ej_free(s->force);
  ej_free(s->npair);
  ej_free(s);
}

/* Penalty stiffness k_i of one particle. */
static inline ej_real kc_k(const kc_config *cfg, int dim, ej_real rho, ej_real c, ej_real h)
{
  const ej_real M = cfg->modulus > 0 ? cfg->modulus : rho * c * c;
  const ej_real hp = dim == 3 ? h : dim == 2 ? 1.0 : 1.0 / h;
  return cfg->penalty * M * hp;
}

/* normal: body, a kernel-sampled level set of the rigid body. Each body point b carries the
 * outward normal u_b of its nearest surface point and its depth D_b below the surface (rigid_body
 * normals: true), so that phi(x) = (x - x_b).u_b - D_b estimates the signed distance of x to the
 * body's surface near b. For the pair (p of self, q of other), n is the direction from self into
 * the contact: +u_p if self is the body, -u_q otherwise, so that the pair's two evaluations see
 * n and -n exactly. With d = x_q - x_p and r = |d| < delta, the penetration is g = delta - d.n +
 * D_b (delta minus the other point's phi) and the pair's potential U = k g^2 psi / 2 with psi =
 * (1 - r^2 / delta^2)^2: it vanishes smoothly where a pair enters or leaves (no jump in the force),
 * and it grows with the depth a point has reached inside the body, which its points all push out
 * through the nearest surface (their normals agree), where the pair directions of the pair form
 * cancel and let it through. The force on p is -dU/dx_p = -k g psi n - 2 k g^2 (1 - r^2/delta^2) /
 * delta^2 d (with n held: exact for a body that translates; its turning is not differentiated).
 * Per point of the other body, the weights psi of a flat face of the body sum to about S = int psi
 * dA / s_b^(dim-1) = (16/15) delta / s_b (2D), (pi/3) (delta / s_b)^2 (3D): the pair stiffness is
 * divided by it (at least 1), so that a point resting on a face feels about k, as one head-on pair
 * of the pair form does, and the pair time step holds. The pair form is the same loop with n =
 * d / r, g = delta - r, psi = 1, no radial term and S = 1 (the same arithmetic as before the body
 * form: multiplications by 1 and additions of 0 are exact). Damping and friction act along n in both. */
static ej_err kc_compute(void *state, ej_set *self, ej_set *other, const ej_nbr *nbr, int pass, ej_range r)
{
  (void)pass;
  kc_state *s = state;
  const bool primary = self == s->a, body = s->body != NULL, self_body = self == s->body;
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "kernel_contact: list has %d rows, range ends at %d",
            nbr ? (int)nbr->n_rows : -1, (int)r.end);
  EJ_ENSURE(!primary || ej_set_count(self) == s->n_a, EJ_ERR_INTERNAL, "kernel_contact: set '%s' changed size",
            ej_set_name(self));
  const ej_real *xi = ej_set_field(self, "x"), *vi = ej_set_field(self, "v"), *mi = ej_set_field(self, "m");
  const ej_real *V0i = ej_set_field(self, "vol0"), *rhoi = ej_set_field(self, "rho"), *ci = ej_set_field(self, "c");
  const ej_real *xj = ej_set_field(other, "x"), *vj = ej_set_field(other, "v"), *mj = ej_set_field(other, "m");
  const ej_real *V0j = ej_set_field(other, "vol0"), *rhoj = ej_set_field(other, "rho"), *cj = ej_set_field(other, "c");
  const ej_real *un = body ? ej_set_field(s->body, "rb_n") : NULL, *dep = body ? ej_set_field(s->body, "rb_depth") : NULL;
  ej_real *acc = ej_set_field(self, "a");
  EJ_ENSURE(xi && vi && mi && V0i && xj && vj && mj && V0j && acc, EJ_ERR_INTERNAL, "kernel_contact: base fields missing");
  EJ_ENSURE(!body || (un && dep), EJ_ERR_INTERNAL, "kernel_contact: the body's rb_n or rb_depth is missing");
  const kc_config *cfg = &s->cfg;
  const bool own_mod = cfg->modulus > 0;
  EJ_ENSURE(own_mod || (rhoi && ci && rhoj && cj), EJ_ERR_INTERNAL, "kernel_contact: rho or c missing");
  const int dim = s->dim;
  const ej_real dt = ej_set_dt(self);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real hi = kc_root(dim, V0i[i]);
    const ej_real ki = kc_k(cfg, dim, own_mod ? 0 : rhoi[i], own_mod ? 0 : ci[i], hi);
    ej_real f[3] = {0, 0, 0}, drate = 0, upot = 0;
    int32_t np = 0;
    for (ej_off q = nbr->off[i]; q < nbr->off[i + 1]; ++q) {
      const ej_idx j = nbr->idx[q];
      const ej_real hj = kc_root(dim, V0j[j]);
      const ej_real delta = cfg->distance * (0.5 * (hi + hj));
      ej_real d[3], n[3];
      for (int k = 0; k < 3; ++k) d[k] = xj[3 * j + k] - xi[3 * i + k];
      const ej_real r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      if (r2 >= delta * delta || !(r2 > 0)) continue;
      ej_real g, psi = 1, rad = 0, S = 1;
      if (body) {
        for (int k = 0; k < 3; ++k) n[k] = self_body ? un[3 * i + k] : -un[3 * j + k];
        g = delta - (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) + dep[self_body ? i : j];
        if (!(g > 0)) continue;
        const ej_real om = 1 - r2 / (delta * delta), rb = delta / (self_body ? hi : hj);
        psi = om * om;
        S = dim == 3 ? 1.0471975511965976 /* pi/3 */ * rb * rb : dim == 2 ? (16.0 / 15.0) * rb : 1.0;
        rad = 2.0 * om / (delta * delta); /* times k g^2 below: the radial term of -grad U */
      } else {
        const ej_real rr = sqrt(r2);
        for (int k = 0; k < 3; ++k) n[k] = d[k] / rr;
        g = delta - rr;
      }
      const ej_real kj = kc_k(cfg, dim, own_mod ? 0 : rhoj[j], own_mod ? 0 : cj[j], hj);
      const ej_real kij = 2.0 * (ki * kj) / (ki + kj) / (S > 1 ? S : 1);
      const ej_real mij = (mi[i] * mj[j]) / (mi[i] + mj[j]);
      ej_real vr[3];
      for (int k = 0; k < 3; ++k) vr[k] = vj[3 * j + k] - vi[3 * i + k];
      const ej_real vn = vr[0] * n[0] + vr[1] * n[1] + vr[2] * n[2];
      const ej_real cd = 2.0 * cfg->damping * sqrt(kij * mij);
      const ej_real Nel = kij * g * psi;
      ej_real N = Nel - cd * vn;
      if (N < 0) N = 0;
      const ej_real lat = rad * kij * g * g;
      ej_real vt[3];
      for (int k = 0; k < 3; ++k) vt[k] = vr[k] - vn * n[k];
      const ej_real vt_norm = sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2]);
      ej_real T = 0;
      if (cfg->mu > 0 && vt_norm > 0 && dt > 0) {
        const ej_real stick = cfg->stick * mij * vt_norm / dt, slide = cfg->mu * N;
        T = stick < slide ? stick : slide;
      }
      const ej_real tf = vt_norm > 0 ? T / vt_norm : 0;
      for (int k = 0; k < 3; ++k) f[k] += -N * n[k] - lat * d[k] + tf * vt[k];
      if (primary) {
        drate += T * vt_norm + (Nel - N) * vn;
        upot += 0.5 * kij * g * g * psi;
        ++np;
      }
    }
    const ej_real inv_m = 1.0 / mi[i];
    for (int k = 0; k < dim; ++k) acc[3 * i + k] += f[k] * inv_m;
    if (primary) {
      s->drate[i] = drate;
      s->upot[i] = upot;
      s->npair[i] = np;
      for (int k = 0; k < 3; ++k) s->force[3 * i + k] = f[k];
    }
  }
  return EJ_OK;
}

/* Sums of a's per-particle values, in index order (deterministic). */
static void kc_sums(kc_state *s, ej_real *drate)
{
  ej_real d = 0, u = 0, f[3] = {0, 0, 0};
  int64_t np = 0;
  for (ej_idx i = 0; i < s->n_a; ++i) {
    d += s->drate[i];
    u += s->upot[i];
    np += s->npair[i];
    for (int k = 0; k < 3; ++k) f[k] += s->force[3 * i + k];
  }
  *drate = d;
  s->potential = u;
  s->pairs_step = np;
  memcpy(s->f_tot, f, sizeof f);
}

/* Trapezoid in time of the dissipation rate (rates at t_n and t_n+1 with the step's dt). */
static ej_err kc_post_step(void *state, ej_set *a, ej_set *b)
{
  (void)b;
  kc_state *s = state;
  ej_real dnow;
  kc_sums(s, &dnow);
  s->dissipated += 0.5 * ej_set_dt(a) * (s->drate_prev + dnow);
  s->drate_prev = dnow;
  return EJ_OK;
}

static ej_err kc_report(void *state, ej_series_value *out, int max, int *n)
{
  kc_state *s = state;
  *n = 0;
  if (!s->started) { /* t = 0: the initial force evaluation, before any post_step */
    kc_sums(s, &s->drate_prev);
    s->started = true;
  }
  if (max < KC_NSERIES) return EJ_OK;
  const ej_real fn = sqrt(s->f_tot[0] * s->f_tot[0] + s->f_tot[1] * s->f_tot[1] + s->f_tot[2] * s->f_tot[2]);
  out[0] = (ej_series_value){.name = "force", .value = fn, .role = EJ_SERIES_PLAIN};
  out[1] = (ej_series_value){.name = "force_x", .value = s->f_tot[0], .role = EJ_SERIES_PLAIN};
  out[2] = (ej_series_value){.name = "force_z", .value = s->f_tot[2], .role = EJ_SERIES_PLAIN};
  out[3] = (ej_series_value){.name = "pairs", .value = (ej_real)s->pairs_step, .role = EJ_SERIES_PLAIN};
  out[4] = (ej_series_value){.name = "work_penalty", .value = -s->potential, .role = EJ_SERIES_WORK};
  out[5] = (ej_series_value){.name = "dissipated", .value = s->dissipated, .role = EJ_SERIES_DISSIPATED};
  *n = KC_NSERIES;
  return EJ_OK;
}

/* A pair is a spring-mass oscillator with omega^2 = k_ij / m_ij <= 2 max_i (k_i / m_i) (for
 * the harmonic k_ij and the reduced mass); 1/omega is returned, the core applies cfl. */
static ej_err kc_stable_dt(void *state, const ej_set *a, const ej_set *b, ej_real *dt)
{
  const kc_state *s = state;
  ej_real wmax = 0;
  const ej_set *sets[2] = {a, b};
  for (int q = 0; q < 2; ++q) {
    const ej_set *t = sets[q];
    const ej_real *m = ej_set_field(t, "m"), *V0 = ej_set_field(t, "vol0");
    const ej_real *rho = ej_set_field(t, "rho"), *c = ej_set_field(t, "c");
    const bool own = s->cfg.modulus > 0;
    for (ej_idx i = 0; i < ej_set_count(t); ++i) {
      const ej_real k = kc_k(&s->cfg, s->dim, own ? 0 : rho[i], own ? 0 : c[i], kc_root(s->dim, V0[i]));
      const ej_real w = k / m[i];
      wmax = w > wmax ? w : wmax;
    }
  }
  *dt = wmax > 0 ? 1.0 / sqrt(2.0 * wmax) : HUGE_VAL;
  return EJ_OK;
}

/* Checkpointed state (ABI 1.8): the dissipation summed so far and the rate at the end of the
 * last step (the trapezoid's left end), so that a restarted run's energy budget continues. */
static ej_err kc_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const kc_state *s = state;
  EJ_ENSURE(max >= 3, EJ_ERR_INTERNAL, "kernel_contact: %d state slots, needs 3", max);
  buf[0] = s->dissipated, buf[1] = s->drate_prev, buf[2] = s->started;
  *n = 3;
  return EJ_OK;
}

static ej_err kc_load_state(void *state, const ej_real *buf, int n)
{
  kc_state *s = state;
  EJ_ENSURE(n == 3, EJ_ERR_INPUT, "kernel_contact: %d state values in the checkpoint, expected 3", n);
  s->dissipated = buf[0], s->drate_prev = buf[1], s->started = buf[2] != 0;
  return EJ_OK;
}

/* The contact forces go into a of the set whose rows are summed; nothing else is written (ABI 1.11) */
static int kc_pass_writes(const void *state, int pass, int side, const char **names, int max)
{
  (void)state, (void)pass, (void)side;
  if (max < 1) return -1;
  names[0] = "a";
  return 1;
}

static const ej_interaction_ops kc_ops = {
    .struct_size = sizeof(ej_interaction_ops),
    .name = "kernel_contact",
    .summary = "Frictional point-to-point contact between two sets detected by kernel overlap",
    .doc = "Penalty contact between the points of two bodies closer than `distance` mean nodal spacings (the "
           "kernel contact idea of Guan 2011 / Chi 2015 cited by digest 003 section 1.9, in a momentum-"
           "conserving pairwise form): normal force k g (+ optional damping), Coulomb friction mu N regularised "
           "by a sticking limit. Pair forces are antisymmetric bitwise and applied to both sets in gather form "
           "(both_ways). Reports the total force on the first set, the number of pairs, the penalty work and the "
           "dissipated energy (energy budget roles WORK and DISSIPATED). Works between sets of any method.",
    .params = kc_params,
    .config_size = sizeof(kc_config),
    .check_config = NULL,
    .create = kc_create,
    .compute = kc_compute,
    .stable_dt = kc_stable_dt,
    .destroy = kc_destroy,
    .both_ways = true,
    .needs_images = true, /* a rigid_body without normals next to a symmetry plane (README) */
    .n_passes = 1,
    .post_step = kc_post_step,
    .post_step_sums_only = true, /* work and force sums only: no particle field written */
    .report = kc_report,
    .save_state = kc_save_state,
    .load_state = kc_load_state,
    .pass_writes = kc_pass_writes,
};

static ej_err kc_register(ej_registry *reg)
{
  EJ_TRY(ej_register_interaction(reg, &kc_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(kernel_contact, "0.1.0", "BSD-3-Clause", "Frictional kernel contact between two particle sets",
                 kc_register)
