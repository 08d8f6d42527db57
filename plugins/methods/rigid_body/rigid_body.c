/* rigid_body method: the particles of a set move as one rigid body (projectiles, impactors).
 *
 * Design (README.md): the core integrates every particle with velocity Verlet; interactions
 * (kernel_contact, continuum, ...) and gravity put their forces into `a` AFTER the method's
 * compute, so the rigid projection is done in post_step, once the core has completed the step:
 *
 *   X_n+1 = sum m x / M            (the core's drift moved the centre of mass with V_half exactly)
 *   P_n+1 = sum m v                (= P_n + dt/2 (F_n + F_n+1): linear momentum exact)
 *   L_h   = sum m (x - X) x (v - dt/2 a)   (half-step angular momentum; invariant under the drift)
 *   T     = sum (x - X) x m a,  F = sum m a
 *   W_h   = I_n^-1 L_h,  q_n+1 = exp(dt W_h / 2) q_n   (orientation, unit quaternion)
 *   x_i   = X_n+1 + R(q_n+1) r0_i                       (positions reset: rigid to round-off)
 *   L_n+1 = L_h + dt/2 T,  W = I_n+1^-1 L_n+1,  alpha = I_n+1^-1 T,  I = R I0 R^T
 *   v_i   = V + W x r_i,  a_i = A + alpha x r_i,  A = F / M
 *
 * With this a_i the core's next half kick gives v_half_i = (V + dt/2 A) + (W + dt/2 alpha) x r_i,
 * a rigid field whose angular momentum is exactly L_n+1 + dt/2 T: the body is integrated by
 * velocity Verlet in (P, L) (the drift conserves sum m x x v exactly). The centripetal part of
 * the particle accelerations is left out of `a` on purpose (it does no work and the position
 * reset takes care of the rotation). The reductions run in the post_step call of the chunk that
 * begins at particle 0, which then writes every particle of the set; the other chunks' calls do
 * nothing (no race: the core calls each chunk once), so the result does not depend on threads.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"

typedef struct rb_config {
  ej_real modulus;
  ej_real fix_translation[3];
  ej_real fix_rotation[3];
  ej_real omega[3];
  bool normals;
} rb_config;

static const ej_param rb_params[] = {
    EJ_PARAM_REAL(rb_config, modulus, "Pa", 200e9, 0.0, 0.0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Modulus that sets the body's wave speed c = sqrt(modulus/rho0), read by contact plugins "
                  "(kernel_contact penalty rho c^2) only; the body itself is rigid."),
    EJ_PARAM_ARRAY(rb_config, fix_translation, 3, "1", 0,
                   "Per axis 1 to lock the body's translation (symmetry planes of a quarter model), 0 free."),
    EJ_PARAM_ARRAY(rb_config, fix_rotation, 3, "1", 0,
                   "Per axis 1 to lock the body's rotation about that axis (1 1 1 in a quarter model), 0 free."),
    EJ_PARAM_ARRAY(rb_config, omega, 3, "1/s", 0,
                   "Initial angular velocity about the centre of mass (rad/s), added to the scene's velocity."),
    EJ_PARAM_BOOL(rb_config, normals, 0,
                  "Outward surface normal of every point (field rb_n, turning with the body), for kernel_contact's "
                  "normal: body (the level-set normal of the body): a surface point's from the gradient of the "
                  "body's colour function (its mirror and periodic images included), an interior point's that of "
                  "its nearest surface point. Builds a neighbour list of the body (support 2 spacings)."),
    {0},
};

typedef struct rb_state {
  rb_config cfg;
  int dim;
  ej_real rho0, c0;
  ej_real M, I0[9];        /* mass and inertia tensor about the centre, body frame */
  ej_real q[4];            /* orientation, unit quaternion (w, x, y, z) */
  ej_real X[3], V[3], W[3], L[3], F[3], T[3];
  ej_real lock_t[3], lock_r[3]; /* 1 free, 0 locked */
  ej_real z_min, rigid_err;
  int64_t steps;
  int64_t n_surface; /* points found on the surface (normals: true) */
} rb_state;

static ej_err rb_check_config(const void *config, ej_diag *diag)
{
  const rb_config *c = config;
  for (int k = 0; k < 3; ++k) {
    if (c->fix_translation[k] != 0 && c->fix_translation[k] != 1)
      return ej_diag_error(diag, "fix_translation", "each entry must be 0 (free) or 1 (locked), got %g",
                           c->fix_translation[k]);
    if (c->fix_rotation[k] != 0 && c->fix_rotation[k] != 1)
      return ej_diag_error(diag, "fix_rotation", "each entry must be 0 (free) or 1 (locked), got %g",
                           c->fix_rotation[k]);
  }
  return EJ_OK;
}

static ej_err rb_declare(const void *config, int dim, ej_decl *d)
{
  (void)config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "rigid_body: dimension %d not in 1..3", dim);
  static const ej_field_decl fields[] = {
      {.name = "rho", .kind = EJ_SCALAR, .flags = 0, .unit = "kg/m^3",
       .doc = "Density (constant rho0: the body is rigid), read by contact plugins."},
      {.name = "c", .kind = EJ_SCALAR, .flags = 0, .unit = "m/s",
       .doc = "Wave speed sqrt(modulus/rho0) that contact plugins use for their penalty stiffness."},
      {.name = "rb_r0", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "m",
       .doc = "Position of the particle relative to the centre of mass in the body frame (initial "
              "configuration)."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  const rb_config *cfg = config;
  if (cfg && cfg->normals) {
    static const ej_field_decl nf[] = {
        {.name = "rb_n", .kind = EJ_VEC3, .flags = EJ_FIELD_OUTPUT, .unit = "1",
         .doc = "Outward unit surface normal of the body at the point (an interior point: that of its nearest "
                "surface point), turning with the body (normals: true)."},
        {.name = "rb_n0", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
         .doc = "rb_n in the body frame (normals: true)."},
        {.name = "rb_depth", .kind = EJ_SCALAR, .flags = 0, .unit = "m",
         .doc = "Depth of the point below the body's surface (0 on the surface; inside, the distance to its "
                "nearest surface point along the body's points), so that depth - (x - x_p).rb_n samples the "
                "body's signed distance (level set) near x (normals: true)."},
    };
    for (size_t k = 0; k < sizeof nf / sizeof nf[0]; ++k) EJ_TRY(ej_decl_field(d, &nf[k]));
    EJ_TRY(ej_decl_neighbours(d, EJ_NBR_CURRENT));
  } else {
    EJ_TRY(ej_decl_neighbours(d, EJ_NBR_NONE));
  }
  return EJ_OK;
}

static ej_err rb_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  rb_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "out of memory");
  s->cfg = *(const rb_config *)config;
  s->dim = ej_set_dim(set);
  s->rho0 = ej_model_rho0(model);
  if (!(s->rho0 > 0)) {
    ej_free(s);
    EJ_FAIL(EJ_ERR_INPUT, "rigid_body: set '%s' needs rho0 > 0", ej_set_name(set));
  }
  s->c0 = sqrt(s->cfg.modulus / s->rho0);
  for (int k = 0; k < 3; ++k) {
    s->lock_t[k] = s->cfg.fix_translation[k] != 0 || k >= s->dim ? 0 : 1;
    /* In 2D only the rotation about z exists; in 1D none. */
    const bool plane_ok = s->dim == 3 || (s->dim == 2 && k == 2);
    s->lock_r[k] = s->cfg.fix_rotation[k] != 0 || !plane_ok ? 0 : 1;
  }
  s->q[0] = 1;
  *state = s;
  return EJ_OK;
}

static void rb_destroy(void *state) { ej_free(state); }

static inline void rb_cross(ej_real c[3], const ej_real a[3], const ej_real b[3])
{
  const ej_real x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
  c[0] = x, c[1] = y, c[2] = z;
}

/* Rotation matrix of a unit quaternion (w, x, y, z). */
static void rb_quat_m3(ej_real R[9], const ej_real q[4])
{
  const ej_real w = q[0], x = q[1], y = q[2], z = q[3];
  R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
  R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
  R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

/* q <- exp(th/2) q for the rotation vector th (world frame), renormalised. */
static void rb_quat_rotate(ej_real q[4], const ej_real th[3])
{
  const ej_real a = sqrt(th[0] * th[0] + th[1] * th[1] + th[2] * th[2]);
  ej_real dq[4] = {1, 0, 0, 0};
  if (a > 0) {
    const ej_real s = sin(0.5 * a) / a;
    dq[0] = cos(0.5 * a), dq[1] = s * th[0], dq[2] = s * th[1], dq[3] = s * th[2];
  }
  const ej_real w = dq[0] * q[0] - dq[1] * q[1] - dq[2] * q[2] - dq[3] * q[3];
  const ej_real x = dq[0] * q[1] + dq[1] * q[0] + dq[2] * q[3] - dq[3] * q[2];
  const ej_real y = dq[0] * q[2] - dq[1] * q[3] + dq[2] * q[0] + dq[3] * q[1];
  const ej_real z = dq[0] * q[3] + dq[1] * q[2] - dq[2] * q[1] + dq[3] * q[0];
  const ej_real n = sqrt(w * w + x * x + y * y + z * z);
  q[0] = w / n, q[1] = x / n, q[2] = y / n, q[3] = z / n;
}

/* World inertia I = R I0 R^T restricted to the free rotation axes; W = I^-1 L on those axes
 * (locked axes: W = 0). Returns false when the free block is singular (a line of points). */
static bool rb_solve_inertia(const rb_state *s, const ej_real R[9], const ej_real L[3], ej_real W[3])
{
  ej_real tmp[9], I[9], Ii[9];
  ej_m3_mul(tmp, R, s->I0);
  ej_m3_mul_bt(I, tmp, R);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!s->lock_r[i] || !s->lock_r[j]) I[3 * i + j] = i == j ? 1 : 0;
  W[0] = W[1] = W[2] = 0;
  if (!s->lock_r[0] && !s->lock_r[1] && !s->lock_r[2]) return true;
  const ej_real rc = ej_m3_inverse(Ii, I);
  if (!(rc > 1e-12)) return false;
  ej_real Lm[3] = {L[0] * s->lock_r[0], L[1] * s->lock_r[1], L[2] * s->lock_r[2]};
  ej_m3_apply(W, Ii, Lm);
  for (int k = 0; k < 3; ++k) W[k] *= s->lock_r[k];
  return true;
}

static ej_err rb_setup(void *state, ej_set *set)
{
  rb_state *s = state;
  const ej_idx n = ej_set_count(set);
  EJ_ENSURE(n > 0, EJ_ERR_INPUT, "rigid_body: set '%s' is empty", ej_set_name(set));
  ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *m = ej_set_field(set, "m");
  ej_real *r0 = ej_set_field(set, "rb_r0"), *rho = ej_set_field(set, "rho"), *c = ej_set_field(set, "c");
  EJ_ENSURE(x && v && m && r0 && rho && c, EJ_ERR_INTERNAL, "rigid_body: fields missing");
  ej_real M = 0, X[3] = {0, 0, 0}, P[3] = {0, 0, 0};
  for (ej_idx i = 0; i < n; ++i) {
    M += m[i];
    for (int d = 0; d < 3; ++d) X[d] += m[i] * x[3 * i + d], P[d] += m[i] * v[3 * i + d];
  }
  EJ_ENSURE(M > 0, EJ_ERR_INPUT, "rigid_body: set '%s' has no mass", ej_set_name(set));
  s->M = M;
  ej_real L[3] = {0, 0, 0};
  for (int d = 0; d < 3; ++d) X[d] /= M, s->X[d] = X[d], s->V[d] = P[d] / M * s->lock_t[d];
  ej_m3_zero(s->I0);
  for (ej_idx i = 0; i < n; ++i) {
    ej_real r[3], lv[3];
    for (int d = 0; d < 3; ++d) r[d] = x[3 * i + d] - X[d], r0[3 * i + d] = r[d];
    const ej_real rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) s->I0[3 * a + b] += m[i] * ((a == b ? rr : 0) - r[a] * r[b]);
    rb_cross(lv, r, &v[3 * i]);
    for (int d = 0; d < 3; ++d) L[d] += m[i] * lv[d];
    rho[i] = s->rho0, c[i] = s->c0;
  }
  ej_real R[9];
  ej_m3_identity(R);
  EJ_ENSURE(rb_solve_inertia(s, R, L, s->W), EJ_ERR_INPUT,
            "rigid_body: set '%s' has a singular inertia tensor (points on a line?): lock its rotation "
            "with fix_rotation",
            ej_set_name(set));
  for (int d = 0; d < 3; ++d) s->W[d] += s->cfg.omega[d] * s->lock_r[d];
  ej_m3_apply(s->L, s->I0, s->W);
  /* Initial velocities projected on the rigid motion (momentum and angular momentum kept). */
  for (ej_idx i = 0; i < n; ++i) {
    ej_real wr[3];
    rb_cross(wr, s->W, &r0[3 * i]);
    for (int d = 0; d < 3; ++d) v[3 * i + d] = s->V[d] + wr[d];
  }
  return EJ_OK;
}

static ej_err rb_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  const rb_state *s = state;
  /* normals: the colour gradient's support, 2 spacings (also the reach of the ghost layer) */
  const ej_real h = (s->cfg.normals ? 2.0 : 1.0) * ej_set_spacing_min(set);
  for (ej_idx i = r.begin; i < r.end; ++i) radius[i - r.begin] = h;
  return EJ_OK;
}

/* dW/dq of the cubic spline with support 2 (unnormalised: only directions are used). */
static inline ej_real rb_spline_dq(ej_real q)
{
  return q < 1 ? -3.0 * q + 2.25 * q * q : q < 2 ? -0.75 * (2 - q) * (2 - q) : 0;
}

/* The body's surface normals (normals: true), once, in the first force evaluation, when the list and
 * the mirror and periodic images exist. A point is on the surface when fewer points (images
 * included) lie within 1.5 spacings of it than around the most surrounded point of the body (a
 * lattice's interior count; the first layer under a face has it, the face layer lacks its outer
 * neighbour). Its outward normal is -grad C / |grad C| with C = sum_j vol0_j W(|x - x_j|, h = s)
 * (images included, so a symmetry plane is no surface). An interior point takes the normal of the
 * surface point nearest along the list's edges (relaxed in index order until nothing changes:
 * deterministic). The normals are stored in the body frame (rb_n0) and turned with the body
 * (rb_n). Serial: run by the chunk that begins at 0 (the others have nothing to do). */
static ej_err rb_normals_work(rb_state *s, ej_set *set, const ej_nbr *nbr, int *cnt, ej_idx *src, ej_real *dist,
                             ej_real *nw)
{
  const ej_idx n = ej_set_count(set);
  const ej_real *x = ej_set_field(set, "x"), *V = ej_set_field(set, "vol0");
  ej_real *un = ej_set_field(set, "rb_n"), *u0 = ej_set_field(set, "rb_n0"), *depth = ej_set_field(set, "rb_depth");
  EJ_ENSURE(x && V && un && u0 && depth && nbr, EJ_ERR_INTERNAL, "rigid_body: normal fields or list missing");
  const ej_real sp = ej_set_spacing_min(set), r15 = 1.5 * sp;
  int cmax = 0;
  for (ej_idx i = 0; i < n; ++i) {
    for (ej_off q = nbr->off[i]; q < nbr->off[i + 1]; ++q) {
      const ej_idx j = nbr->idx[q];
      ej_real d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += (x[3 * j + k] - x[3 * i + k]) * (x[3 * j + k] - x[3 * i + k]);
      cnt[i] += d2 < r15 * r15;
    }
    cmax = cnt[i] > cmax ? cnt[i] : cmax;
  }
  s->n_surface = 0;
  for (ej_idx i = 0; i < n; ++i) {
    dist[i] = INFINITY, src[i] = -1;
    if (cnt[i] >= cmax) continue;
    ej_real G[3] = {0, 0, 0};
    for (ej_off q = nbr->off[i]; q < nbr->off[i + 1]; ++q) {
      const ej_idx j = nbr->idx[q];
      ej_real d[3], r2 = 0;
      for (int k = 0; k < 3; ++k) d[k] = x[3 * i + k] - x[3 * j + k], r2 += d[k] * d[k];
      const ej_real r = sqrt(r2);
      if (!(r > 0) || r >= 2 * sp) continue;
      const ej_real f = V[j] * rb_spline_dq(r / sp) / r; /* grad_i W = W'(q)/s d/r, up to 1/s */
      for (int k = 0; k < 3; ++k) G[k] += f * d[k];
    }
    const ej_real g = sqrt(G[0] * G[0] + G[1] * G[1] + G[2] * G[2]);
    if (!(g > 0)) continue; /* a symmetric surface point (a lone point, a thin line): no normal */
    for (int k = 0; k < 3; ++k) nw[3 * i + k] = -G[k] / g;
    dist[i] = 0, src[i] = i;
    s->n_surface++;
  }
  EJ_ENSURE(s->n_surface > 0, EJ_ERR_INPUT,
            "rigid_body: set '%s' has no surface point with a normal (normals: true needs a body with an inside)",
            ej_set_name(set));
  for (bool changed = true; changed;) {
    changed = false;
    for (ej_idx i = 0; i < n; ++i)
      for (ej_off q = nbr->off[i]; q < nbr->off[i + 1]; ++q) {
        const ej_idx j = nbr->idx[q];
        if (j >= n || src[j] < 0) continue; /* owned points only: an image's source is owned */
        ej_real d2 = 0;
        for (int k = 0; k < 3; ++k) d2 += (x[3 * j + k] - x[3 * i + k]) * (x[3 * j + k] - x[3 * i + k]);
        const ej_real dd = dist[j] + sqrt(d2);
        if (dd < dist[i]) dist[i] = dd, src[i] = src[j], changed = true;
      }
  }
  ej_real R[9];
  rb_quat_m3(R, s->q);
  for (ej_idx i = 0; i < n; ++i) {
    EJ_ENSURE(src[i] >= 0, EJ_ERR_INPUT,
              "rigid_body: point %ld of set '%s' is not connected to the body's surface (normals: true)", (long)i,
              ej_set_name(set));
    const ej_real *w = &nw[3 * src[i]];
    depth[i] = dist[i];
    for (int k = 0; k < 3; ++k) un[3 * i + k] = w[k];
    for (int k = 0; k < 3; ++k) u0[3 * i + k] = R[k] * w[0] + R[3 + k] * w[1] + R[6 + k] * w[2]; /* R^T w */
  }
  return EJ_OK;
}

static ej_err rb_normals(rb_state *s, ej_set *set, const ej_nbr *nbr)
{
  const size_t n = (size_t)ej_set_count(set);
  int *cnt = ej_calloc(n, sizeof *cnt);
  ej_idx *src = ej_calloc(n, sizeof *src);
  ej_real *dist = ej_calloc(n, sizeof *dist), *nw = ej_calloc(3 * n, sizeof *nw);
  const ej_err rc = cnt && src && dist && nw ? rb_normals_work(s, set, nbr, cnt, src, dist, nw) : EJ_ERR_MEM;
  ej_free(cnt), ej_free(src), ej_free(dist), ej_free(nw);
  EJ_ENSURE(rc != EJ_ERR_MEM, EJ_ERR_MEM, "rigid_body: out of memory");
  return rc;
}

/* Nothing per particle: the body's accelerations are set in post_step (see the top comment). With
 * normals: true the first evaluation computes the
 * surface normals. */
static ej_err rb_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  (void)pass;
  rb_state *s = state;
  if (!s->cfg.normals || r.begin != 0 || ej_set_count(set) == 0) return EJ_OK;
  const ej_real *u0 = ej_set_field(set, "rb_n0");
  EJ_ENSURE(u0, EJ_ERR_INTERNAL, "rigid_body: field rb_n0 missing");
  if (u0[0] != 0 || u0[1] != 0 || u0[2] != 0) return EJ_OK; /* known (a unit vector at every point) */
  return rb_normals(s, set, nbr);
}

static ej_err rb_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  (void)state, (void)set, (void)r;
  *dt = INFINITY; /* a rigid body has no internal wave: the contact or the partner sets the step */
  return EJ_OK;
}

static ej_err rb_post_step(void *state, ej_set *set, ej_range r)
{
  rb_state *s = state;
  if (r.begin != 0) return EJ_OK; /* the whole body is handled by the chunk that starts at 0 */
  const ej_idx n = ej_set_count(set);
  const ej_real dt = ej_set_dt(set);
  ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *a = ej_set_field(set, "a");
  const ej_real *m = ej_set_field(set, "m"), *r0 = ej_set_field(set, "rb_r0");
  EJ_ENSURE(x && v && a && m && r0, EJ_ERR_INTERNAL, "rigid_body: fields missing");
  const ej_real M = s->M;
  ej_real X[3] = {0, 0, 0}, P[3] = {0, 0, 0}, F[3] = {0, 0, 0}, Lh[3] = {0, 0, 0}, T[3] = {0, 0, 0};
  for (ej_idx i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d)
      X[d] += m[i] * x[3 * i + d], P[d] += m[i] * v[3 * i + d], F[d] += m[i] * a[3 * i + d];
  for (int d = 0; d < 3; ++d) X[d] /= M;
  for (ej_idx i = 0; i < n; ++i) {
    ej_real rr[3], vh[3], fi[3], c1[3], c2[3];
    for (int d = 0; d < 3; ++d)
      rr[d] = x[3 * i + d] - X[d], vh[d] = v[3 * i + d] - 0.5 * dt * a[3 * i + d], fi[d] = m[i] * a[3 * i + d];
    rb_cross(c1, rr, vh);
    rb_cross(c2, rr, fi);
    for (int d = 0; d < 3; ++d) Lh[d] += m[i] * c1[d], T[d] += c2[d];
  }
  /* Orientation from the half-step angular velocity W_h = I(t_n+1/2)^-1 L_h: fixed-point iteration
   * on the mid-step orientation q_n+1/2 = exp(dt W_h / 4) q_n (implicit midpoint; with the inertia
   * at t_n instead the rotation would be first order and an asymmetric top's energy drifts at O(dt)). */
  ej_real Rm[9], Wh[3], th[3], qm[4];
  rb_quat_m3(Rm, s->q);
  EJ_ENSURE(rb_solve_inertia(s, Rm, Lh, Wh), EJ_ERR_NUMERIC, "rigid_body: singular inertia tensor");
  for (int it = 0; it < 4; ++it) {
    memcpy(qm, s->q, sizeof qm);
    for (int d = 0; d < 3; ++d) th[d] = 0.5 * dt * Wh[d];
    rb_quat_rotate(qm, th);
    rb_quat_m3(Rm, qm);
    EJ_ENSURE(rb_solve_inertia(s, Rm, Lh, Wh), EJ_ERR_NUMERIC, "rigid_body: singular inertia tensor");
  }
  for (int d = 0; d < 3; ++d) th[d] = dt * Wh[d];
  rb_quat_rotate(s->q, th);
  ej_real R[9];
  rb_quat_m3(R, s->q);
  /* Locked translation: the centre stays where it was on those axes. */
  for (int d = 0; d < 3; ++d) {
    if (!s->lock_t[d]) X[d] = s->X[d], P[d] = 0, F[d] = 0;
    s->X[d] = X[d], s->V[d] = P[d] / M, s->F[d] = F[d], s->T[d] = T[d] * s->lock_r[d];
    s->L[d] = (Lh[d] + 0.5 * dt * T[d]) * s->lock_r[d];
  }
  ej_real alpha[3];
  EJ_ENSURE(rb_solve_inertia(s, R, s->L, s->W) && rb_solve_inertia(s, R, T, alpha), EJ_ERR_NUMERIC,
            "rigid_body: singular inertia tensor");
  if (s->cfg.normals) {
    ej_real *un = ej_set_field(set, "rb_n");
    const ej_real *u0 = ej_set_field(set, "rb_n0");
    EJ_ENSURE(un && u0, EJ_ERR_INTERNAL, "rigid_body: normal fields missing");
    for (ej_idx i = 0; i < n; ++i) ej_m3_apply(&un[3 * i], R, &u0[3 * i]);
  }
  ej_real zmin = INFINITY, err = 0;
  const int zc = s->dim - 1; /* "down" is -y in 2D, -z in 3D (gravity's usual axis) */
  for (ej_idx i = 0; i < n; ++i) {
    ej_real ri[3], wr[3], ar[3];
    ej_m3_apply(ri, R, &r0[3 * i]);
    rb_cross(wr, s->W, ri);
    rb_cross(ar, alpha, ri);
    for (int d = 0; d < 3; ++d) {
      const ej_real xn = X[d] + ri[d];
      err = fmax(err, fabs(xn - x[3 * i + d]));
      x[3 * i + d] = xn;
      v[3 * i + d] = s->V[d] + wr[d];
      a[3 * i + d] = F[d] / M + ar[d];
    }
    zmin = fmin(zmin, x[3 * i + zc]);
  }
  s->z_min = zmin;
  s->rigid_err = err;
  s->steps++;
  return EJ_OK;
}

static ej_err rb_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  rb_state *s = state;
  (void)set;
  EJ_ENSURE(max >= 14, EJ_ERR_INTERNAL, "rigid_body: too few series slots");
  static const char *const names[14] = {"force_x", "force_y", "force_z", "v_x",     "v_y",     "v_z",   "x_cm",
                                        "y_cm",    "z_cm",    "omega_x", "omega_y", "omega_z", "low", "mass"};
  const ej_real vals[14] = {s->F[0], s->F[1], s->F[2], s->V[0], s->V[1], s->V[2], s->X[0],
                            s->X[1], s->X[2], s->W[0], s->W[1], s->W[2], s->steps ? s->z_min : NAN, s->M};
  for (int k = 0; k < 14; ++k) out[k] = (ej_series_value){.name = names[k], .value = vals[k], .role = EJ_SERIES_PLAIN};
  *n = 14;
  return EJ_OK;
}

static ej_err rb_counters(void *state, ej_counter *out, int max, int *n)
{
  rb_state *s = state;
  *n = 0;
  if (max < 1) return EJ_OK;
  /* Largest correction of a position by the rigid reset in the last step, in nanometres:
   * the size of the core's linearised drift error (dt |W|)^2 |r| / 2. */
  out[0] = (ej_counter){.name = "rigid reset (nm, last step)", .value = (int64_t)llround(s->rigid_err * 1e9)};
  *n = 1;
  return EJ_OK;
}

/* Checkpointed state (ABI 1.8): the orientation, which the position reset of post_step uses every
 * step and which the particle positions alone give only up to round-off (a restart from the
 * identity turned the body back to its initial orientation). The rest is derivable: setup gives
 * the mass, inertia and the centre on locked axes, post_step the rest from the particles. */
static ej_err rb_save_state(const void *state, ej_real *buf, int max, int *n)
{
  const rb_state *s = state;
  EJ_ENSURE(max >= 4, EJ_ERR_INTERNAL, "rigid_body: %d state slots, needs 4", max);
  memcpy(buf, s->q, sizeof s->q);
  *n = 4;
  return EJ_OK;
}

static ej_err rb_load_state(void *state, const ej_real *buf, int n)
{
  rb_state *s = state;
  EJ_ENSURE(n == 4, EJ_ERR_INPUT, "rigid_body: %d state values in the checkpoint, expected 4", n);
  memcpy(s->q, buf, sizeof s->q);
  return EJ_OK;
}

static const ej_method_ops rb_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "rigid_body",
    .summary = "The set's particles move as one rigid body driven by the interactions' forces and gravity",
    .doc = "Rigid body (Newton-Euler) for impactors: after each step the forces that interactions and gravity "
           "put on the particles are summed into the force and torque about the centre of mass, linear and "
           "angular momentum are advanced by velocity Verlet, the orientation by a unit quaternion, and the "
           "particles' positions, velocities and accelerations are reset to the rigid motion (rigid to "
           "round-off). No neighbours and no internal forces; the material needs only rho0. Translations and "
           "rotations can be locked per axis (symmetry planes). Series: resultant force (with gravity), "
           "centre velocity and position, angular velocity, lowest point, mass.",
    .params = rb_params,
    .config_size = sizeof(rb_config),
    .check_config = rb_check_config,
    .declare = rb_declare,
    .create = rb_create,
    .setup = rb_setup,
    .support = rb_support,
    .n_passes = 1,
    .compute = rb_compute,
    .stable_dt = rb_stable_dt,
    .post_step = rb_post_step,
    .counters = rb_counters,
    .destroy = rb_destroy,
    .report = rb_report,
    .self_constitutive = true,
    .save_state = rb_save_state,
    .load_state = rb_load_state,
};

static ej_err rb_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &rb_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(rigid_body, "0.1.0", "BSD-3-Clause", "Rigid-body method for impactors", rb_register)
