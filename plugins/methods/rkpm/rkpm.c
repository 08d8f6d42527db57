/* Reproducing kernel particle method (RKPM) for solids, explicit dynamics.
 *
 * Sources: Chi et al., SERDP MR-2628 final report (2017), digest 003 (Eqs 1-5 the RK
 * approximation, Eqs 7/11/16 the Galerkin weak form with G, Gbar dropped, Eqs 26-29 central
 * difference; errata of Eq 9 (Psi'' pairs with d, not d-dot) irrelevant here because the
 * kernel-rate matrices are dropped, as in the report). What the report leaves out (digest 003
 * section 7, items 6, 7, 27) is chosen here and documented in README.md:
 *  - kernel: cubic B-spline phi(z), z = |x - x_I| / a_I, isotropic support a_I = support * h_I,
 *    h_I = vol0_I^(1/dim) the nodal spacing (digest 003 section 1.2, [EXTERNAL]);
 *  - derivatives: the implicit ("synchronized") RK gradient of the linear basis,
 *      Psi_I^,k(x) = -[M^-1(x) H(x - x_I)]_{k+1} phi_a(x - x_I) / l,
 *    which satisfies sum_I Psi_I^,k(x) x_I^beta = d/dx_k x^beta for |beta| <= 1 at every point,
 *    so the gradient of a linear field is exact at every node including boundary nodes
 *    (Li & Liu 1998; Chen, Hillman & Rueter, IJNME 95 (2013) 387) -- no kernel derivative;
 *  - domain integration (`integration`): MSNNI (default) of 003 Eqs 42-46 -- smoothed
 *    gradients over each node's box (003 Eq 42, midpoint rule on 24 outer quarter faces in 3D)
 *    and the sub-box stabilisation (003 Eq 46 applied incrementally as a stabilisation stress
 *    per octant, digest 003 section 1.7; errata item 5: forces, not a matrix added to M; item 6:
 *    box, sub-boxes and face quadrature chosen here); `scni_box` (box smoothing only); `dni`
 *    (direct nodal integration at the nodes with V_L = m_L / rho_L). All three can add the
 *    pairwise viscous velocity-mode control (`stabilization`).
 *
 * Three passes per step (the core refreshes ghosts between passes):
 *  pass 0: moment matrix M(x_I) = sum_J H H^T phi_J (003 Eq 5), its inverse with the
 *          singularity guard (fallback to the constant basis), a copy of the mid-step
 *          velocity for neighbours (v_half is not ghosted); MSNNI Lagrangian: M at the face
 *          points (semi-Lagrangian: in pass 1, rk_box_fused_node);
 *  pass 1: velocity gradients (implicit RK gradient, or MSNNI smoothed box gradients),
 *          Hughes-Winget rotation of the stress, material update (ej_mat_batch), p, c, rho_dot,
 *          e_dot; MSNNI: sub-box stresses and face tractions;
 *  pass 2: Galerkin nodal forces in gather form, f_I = -sum_L V_L sigma_L grad Psi_I(x_L)
 *          (003 Eq 16 with nodal quadrature) or the MSNNI face-traction form, and the
 *          viscous stabilisation forces. */
/* The face-point loops must vectorise: GCC only if-converts the branch-free kernel (and
 * vectorises sqrt) without trapping-math semantics, which this file does not rely on. No FMA
 * contraction (-std=c11): native and portable builds give the same results (2026-11-28: FMA
 * would gain ~6 % at round-off differences, not taken). */
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("no-trapping-math")
#endif
#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "ejecta/plugin.h"
#include "ejecta/tensor.h"
#include "rk_essential.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#if defined(__GNUC__)
#define RK_ALWAYS_INLINE __attribute__((always_inline))
#else
#define RK_ALWAYS_INLINE
#endif

enum { RK_SEMI_LAGRANGIAN = 0, RK_LAGRANGIAN = 1 };
static const char *const rk_formulations[] = {"semi_lagrangian", "lagrangian", NULL};
enum { RK_MSNNI = 0, RK_SCNI_BOX = 1, RK_DNI = 2 };
static const char *const rk_integrations[] = {"msnni", "scni_box", "dni", NULL};
enum { RK_STAB_MATERIAL = 0, RK_STAB_ELASTIC = 1 };
static const char *const rk_stab_stress[] = {"material", "elastic", NULL};
enum { RK_PART_FULL = 0, RK_PART_DEVIATORIC = 1 };
static const char *const rk_stab_part[] = {"full", "deviatoric", NULL};
enum { RK_ESS_COEFFICIENTS = 0, RK_ESS_TRANSFORMATION = 1 };
static const char *const rk_essentials[] = {"coefficients", "transformation", NULL};

#define RK_MAX_HIST 32
#define RK_NF_MAX 36 /* face quadrature points of a nodal box (3D: 24 outer + 12 inner) */
#define RK_NS_MAX 8  /* sub-boxes (octants) of a nodal box */
#define RK_HB_MIN 0.5 /* box edge h_L = (m/rho)^(1/dim) clamped to [RK_HB_MIN, RK_HB_MAX] h0 */
#define RK_HB_MAX 1.2
#define RK_FACE_RCOND 3e-2 /* smallest relative pivot of a face-point moment matrix */
static inline ej_real rk_face_tol(ej_real tol) { return tol > RK_FACE_RCOND ? tol : RK_FACE_RCOND; }
/* Smallest spread of a node's neighbour cloud (rk_spread) below which the node's moment matrix
 * is not used for the Taylor form of flagged face points. Measured rk_spread, 2D lattice with
 * support 1.75: interior 0.036, straight edge 0.024, 90 deg corner 0.017, 45 deg wedge 3.3e-3;
 * 3D lattice: interior 0.029, face 0.021, edge 0.017, corner 0.015; the node that blew up in
 * validation/penetration (45 deg, a filament of 4 nodes): 2.1e-6. */
#define RK_SPREAD_MIN 1e-3
#define RK_QMAX 0.6124 /* farthest face point from the node, in box edges: sqrt(6)/4 (3D) */
#define RK_CHUNK 64    /* neighbours per chunk of the face-point sweeps (stack scratch) */
#define RK_NB_FUSE 192 /* neighbours (with the node itself) of the fused sweep (stack scratch) */
#define RK_CHUNK2 16   /* nodes L per chunk of the force sweep (stack scratch ~32 kB) */
#define RK_IT_FUSE 1024 /* (neighbour, group) pairs whose kernel values the fused sweep keeps (32 kB) */
#define RK_BLOCK_SL 16  /* nodes per pass-1 block with the force scatter (keep arena of 16 nodes) */

/* What the fused sweep of node L (rk_box_fused_node) keeps for L's force scatter
 * (rk_box_scatter_node): its neighbours' per-group lists and kernel values phi_J(x_f), which the
 * interpolation replaces by Psi_J(x_f) in every group it sums by list (all but the groups with a
 * flagged face of a Taylor node). */
typedef struct rk_keep {
  int fused, nn;
  int cnt[RK_NF_MAX / 4];
  int lst[RK_NF_MAX / 4][RK_NB_FUSE];
  ej_real wk[RK_IT_FUSE][4];
} rk_keep;

typedef struct rk_config {
  ej_real support;
  int formulation;
  int integration;
  ej_real msnni_w;
  int msnni_stress;
  int msnni_part;
  ej_real stabilization;
  ej_real rcond_min;
  bool force_scatter;
  int essential;
  ej_initial_stress initial_stress; /* pre-stressed / geostatic start (core, ABI 1.13) */
} rk_config;

static const ej_param rk_params[] = {
    EJ_PARAM_REAL(rk_config, support, "1", 1.75, 1.5, 2.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Normalised support a/h of the cubic B-spline kernel, in nodal spacings h = vol0^(1/dim)."),
    EJ_PARAM_ENUM(rk_config, formulation, rk_formulations, "semi_lagrangian",
                  "semi_lagrangian: kernels centred on the moving points with a support fixed in the current "
                  "configuration, neighbours and shape functions rebuilt every step (003 section 1.3); "
                  "lagrangian: kernels and moment matrices in the reference configuration, computed once."),
    EJ_PARAM_ENUM(rk_config, integration, rk_integrations, "msnni",
                  "Domain integration: msnni = smoothed gradients over each node's box with the sub-box "
                  "stabilisation stress (003 Eqs 42-46); scni_box = the same box smoothing without the "
                  "sub-box term; dni = direct nodal integration (implicit RK gradients at the nodes)."),
    EJ_PARAM_REAL(rk_config, msnni_w, "1", 0.5, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Weight w of the MSNNI sub-box stabilisation (003 Eq 46, w in [0, 1]): the sub-box "
                  "stabilisation stress grows by w E : (strain increment of the sub-box - of the box)."),
    EJ_PARAM_ENUM(rk_config, msnni_stress, rk_stab_stress, "material",
                  "How the MSNNI sub-box stress is updated (003 Eq 46 applied incrementally): material = each "
                  "sub-box stress goes through the set's own strength model with the sub-box strain rate, "
                  "and the stabilisation stress is w (sub-box stress - node stress), so it yields with the "
                  "material; elastic = w E : (sub-box - box strain increment) with the initial elastic "
                  "moduli, no yield limit (Lagrangian formulation and EOS-only fluids: always elastic)."),
    EJ_PARAM_ENUM(rk_config, msnni_part, rk_stab_part, "deviatoric",
                  "Which part of the sub-box strain difference the MSNNI stabilisation resists: deviatoric = the "
                  "sub-boxes take the node's volumetric strain rate and the stabilisation stress is deviatoric "
                  "(B-bar-like; the volumetric part locked isochoric plastic flow: validation/sphere_drop); "
                  "full = 003 Eq 46 literally (volumetric and deviatoric). EOS-only fluids always use full."),
    EJ_PARAM_REAL(rk_config, stabilization, "1", 0.1, 0.0, 1.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "Coefficient of the pairwise stabilisation of nodal integration: damps the part of the "
                  "relative velocity of two nodes that the nodal velocity gradients do not explain "
                  "(zero for linear fields), at a rate of about stabilization * c / h. Across a velocity jump dv it "
                  "transmits a traction 0.051 stabilization rho c dv whatever the spacing: set 0 for slow "
                  "granular flow at low confinement (README \"Scale of the stabilisation\")."),
    EJ_PARAM_REAL(rk_config, rcond_min, "1", 1e-6, 0.0, 0.1,
                  EJ_PF_HAS_MIN | EJ_PF_HAS_MAX | EJ_PF_EXPERT,
                  "Smallest relative Cholesky pivot of the scaled moment matrix; below it the node falls "
                  "back to the constant basis (Shepard value, zero gradient) and is counted."),
    EJ_PARAM_BOOL(rk_config, force_scatter, 1,
                  "Semi-Lagrangian msnni and scni_box: each node writes its share of its neighbours' forces in "
                  "pass 1 from the shape-function values its gradient sweep computed, instead of a second "
                  "evaluation of them in the force pass (README \"Force scatter\"): about 1.2-1.3x faster "
                  "steps for about 28 bytes more per neighbour-list entry (+65 % memory on a 3D block). "
                  "The same forces to round-off; false saves the memory."),
    EJ_PARAM_ENUM(rk_config, essential, rk_essentials, "coefficients",
                  "How `fix` and `velocity` boundaries hold an RK field, whose shape functions are not "
                  "interpolating: coefficients = the core holds the nodal coefficients (the field at a held "
                  "node is off by O(h^2) where it is curved); transformation = the mixed transformation method "
                  "(Chen & Wang 2000): the held velocity is the field's value at the node, the held nodes' "
                  "coefficients solve Psi(x_B) d = v_B every step and their forces are transformed (T^T f) "
                  "onto their neighbours (README \"Essential boundary conditions\")."),
    EJ_PARAM_BLOCK(rk_config, initial_stress, ej_initial_stress_params, ej_initial_stress, 0,
                   "Initial Cauchy stress (like LS-DYNA *INITIAL_STRESS): uniform, per particle from a CSV file, or "
                   "geostatic from the overburden; the strength model integrates on from it (no strain energy is "
                   "booked for it in e). Not with an EOS (whose state gives the pressure)."),
    {0}};

static ej_err rk_check_config(const void *config, ej_diag *diag)
{
  return ej_initial_stress_check(&((const rk_config *)config)->initial_stress, diag);
}

typedef struct rk_state {
  rk_config cfg;
  ej_set *set;
  int dim;
  bool lagrangian;
  const ej_eos *eos;
  const ej_material *mat;
  ej_real K, G; /* initial moduli of the strength model (0 without) */
  const char *set_name;
  /* MSNNI nodal boxes (integration != dni). Face point f of the box of node L sits at
   * x_L + (h_L / 4) q_f; q has one coordinate +-2 and the others +-1 (outer quarter faces) or
   * one coordinate 0 and the others +-1 (inner faces between two sub-boxes). */
  bool box;          /* integration msnni or scni_box */
  bool sub;          /* msnni with w > 0: sub-box stabilisation stresses */
  bool smat;         /* sub-box stresses through the strength model (msnni_stress material) */
  bool sdev;         /* msnni_part deviatoric: sub-box stabilisation on the deviatoric part only */
  int nf, ns, nss;   /* face points, sub-boxes, TENSOR9 fields holding the sub-box stresses */
  ej_real q[RK_NF_MAX][3];
  int fnd[RK_NF_MAX];          /* axis of the face normal */
  int fout[RK_NF_MAX];         /* 1: outer face (part of the box boundary) */
  int fsub_m[RK_NF_MAX];       /* outer: its sub-box; inner: the sub-box on the -nd side */
  int fsub_p[RK_NF_MAX];       /* inner: the sub-box on the +nd side (-1 for outer faces) */
  ej_real fsgn[RK_NF_MAX];     /* outer: sign of the normal along nd */
  int flut[125];               /* face index of the offset q (base-5 code), -1 if none */
  /* Face groups for the sweeps over neighbours: the face points are processed in ng groups of
   * 4 lanes (padded position p = 4 g + lane; gpos[f] = p of face f, gperm[p] = f or -1 for a
   * padding lane); group g's points lie within gr[g] (offset units) of gc[g], so a neighbour
   * whose kernel support misses that ball contributes exact zeros to the whole group and is
   * skipped (3D: one group per octant with its 3 outer quarter faces and one inner face, plus
   * the 4 remaining inner faces). Pure bookkeeping: every computed term is the same. */
  int ng;
  int gpos[RK_NF_MAX], gperm[RK_NF_MAX];
  ej_real gq[3][RK_NF_MAX];    /* offsets by padded position (padding lanes: far away, w = 0) */
  ej_real gc[RK_NF_MAX / 4][3], gr[RK_NF_MAX / 4];
  int gmap[8][RK_NF_MAX]; /* mirror sign code (bit d: s_d = -1) -> padded position of the source's face */
  /* Face data keyed by particle id (ghosts read their source's row through the id and remap
   * the faces of a mirror image): first row of M^-1 at each face point (b0, b) and the face
   * traction T_f. Allocated in setup, written in gather form (row of an owned particle). */
  ej_idx nid;
  ej_real *fb; /* [nid][4][RK_NF_MAX]: by padded position p (face groups), padding lanes 0 */
  ej_real *ft; /* [nid][3][nf] */
  int32_t *fflag; /* [nid] number of flagged face points (Taylor form) */
  /* Force scatter (semi-Lagrangian box integration, README "Force scatter"): in pass 1, right
   * after its face tractions, node L writes c_J(L) = sum_f Psi_J(x_f(L)) T_f(L) for itself
   * (fself[L]) and for each owned neighbour J into J's row entry of L (fsc[off[J] + frev[k]], k
   * L's entry of J), with the values its fused sweep kept (keep: one arena of RK_BLOCK_SL nodes
   * per thread); pass 2 then sums f_I = -sum_L c_I(L) along I's own row instead of evaluating
   * every Psi_I(x_f(L)) again. fscat[L] = 1 when L's shares are there this step (0: a node over
   * the fused sweep's caps, which pass 2 evaluates as before). Every entry is written by one
   * thread (L's) and read after the pass: the results do not depend on the thread count. Sized
   * in pass 0 (serialised), never in pass 1 or 2. */
  ej_real *fsc;   /* [fsc_cap][3] */
  int32_t *frev;  /* [fsc_cap] entry k of row L (J = idx[k] owned) -> position of L in J's row */
  size_t fsc_cap;
  int64_t frev_build; /* the list build frev was made for (ej_set_list_builds), -1: none */
  ej_real *fself; /* [own_cap][3] */
  uint8_t *fscat; /* [own_cap] */
  size_t own_cap;
  rk_keep *keep;  /* [nkeep][RK_BLOCK_SL] */
  int nkeep;
  /* essential: transformation (README "Essential boundary conditions"): ess_on when this force
   * evaluation holds nodes, then passes 1 and 2 read the coefficients rk_vc (and rk_xc) */
  rk_ess *ess;
  bool ess_on;
} rk_state;

static inline int rk_qcode(const int q[3]) { return (q[0] + 2) + 5 * (q[1] + 2) + 25 * (q[2] + 2); }

/* Face points of the nodal box and the sub-boxes (2^dim octants) they bound. Midpoint rule on
 * each quarter face: exact for the linear fields that the linear RK basis reproduces, so the
 * smoothed gradients of 003 Eq 42 pass the linear patch test on any point cloud. */
static void rk_faces_init(rk_state *s)
{
  const int D = s->dim;
  s->nf = 0;
  s->ns = 1 << D;
  s->nss = (6 * s->ns + 8) / 9;
  for (int k = 0; k < 125; ++k) s->flut[k] = -1;
  for (int k = 0; k < 125; ++k) {
    const int q[3] = {k % 5 - 2, (k / 5) % 5 - 2, k / 25 - 2};
    bool ok = true;
    int n2 = 0, n0 = 0, nd = -1;
    for (int d = 0; d < 3; ++d) {
      const int a = q[d] < 0 ? -q[d] : q[d];
      if (d >= D) {
        ok &= a == 0;
        continue;
      }
      if (a == 2) ++n2, nd = d;
      else if (a == 0) ++n0, nd = d;
    }
    if (!ok || n2 + n0 != 1) continue;
    const int f = s->nf++;
    s->flut[k] = f;
    int bits = 0;
    for (int d = 0; d < D; ++d) {
      s->q[f][d] = q[d];
      if (d != nd && q[d] > 0) bits |= 1 << d;
    }
    for (int d = D; d < 3; ++d) s->q[f][d] = 0.0;
    s->fnd[f] = nd;
    if (n2) {
      s->fout[f] = 1;
      s->fsgn[f] = q[nd] > 0 ? 1.0 : -1.0;
      s->fsub_m[f] = bits | (q[nd] > 0 ? 1 << nd : 0);
      s->fsub_p[f] = -1;
    } else {
      s->fout[f] = 0;
      s->fsgn[f] = 0.0;
      s->fsub_m[f] = bits;
      s->fsub_p[f] = bits | 1 << nd;
    }
  }
  /* Groups: octant xi takes its outer quarter faces and the inner face whose zero axis is
   * (number of positive signs of xi) mod dim and whose other signs are xi's; the other inner
   * faces form the last group. Every group has at most 4 points (checked below). */
  const int nsub = s->ns;
  int gcount[RK_NS_MAX + 1] = {0}, gmem[RK_NS_MAX + 1][4];
  for (int f = 0; f < s->nf; ++f) {
    int g = nsub;
    if (s->fout[f]) {
      g = s->fsub_m[f];
    } else {
      for (int side = 0; side < 2; ++side) {
        const int xi = side ? s->fsub_p[f] : s->fsub_m[f];
        int np = 0;
        for (int d = 0; d < D; ++d) np += (xi >> d) & 1;
        if (np % D == s->fnd[f] && gcount[xi] < 4) {
          g = xi;
          break;
        }
      }
    }
    if (gcount[g] >= 4) g = nsub; /* cannot happen for dim 1-3; keeps the bookkeeping safe */
    gmem[g][gcount[g]++] = f;
  }
  s->ng = 0;
  for (int g = 0; g <= nsub; ++g) {
    if (!gcount[g]) continue;
    const int G = s->ng++;
    ej_real cen[3] = {0, 0, 0}, rad = 0.0;
    for (int l = 0; l < gcount[g]; ++l)
      for (int d = 0; d < 3; ++d) cen[d] += s->q[gmem[g][l]][d] / gcount[g];
    for (int l = 0; l < gcount[g]; ++l) {
      ej_real r2 = 0.0;
      for (int d = 0; d < 3; ++d) r2 += (s->q[gmem[g][l]][d] - cen[d]) * (s->q[gmem[g][l]][d] - cen[d]);
      rad = sqrt(r2) > rad ? sqrt(r2) : rad;
    }
    for (int d = 0; d < 3; ++d) s->gc[G][d] = cen[d];
    s->gr[G] = rad * (1.0 + 1e-9) + 1e-9; /* conservative against round-off in the ball test */
    for (int l = 0; l < 4; ++l) {
      const int pp = 4 * G + l, f = l < gcount[g] ? gmem[g][l] : -1;
      s->gperm[pp] = f;
      if (f >= 0) s->gpos[f] = pp;
      for (int d = 0; d < 3; ++d) s->gq[d][pp] = f >= 0 ? s->q[f][d] : (d == 0 ? 1e3 : 0.0);
    }
  }
  for (int sc = 0; sc < 8; ++sc)
    for (int pp = 0; pp < RK_NF_MAX; ++pp) {
      const int f = pp < 4 * s->ng ? s->gperm[pp] : -1;
      s->gmap[sc][pp] = -1;
      if (f < 0) continue;
      int qs[3];
      for (int d = 0; d < 3; ++d) qs[d] = ((sc >> d) & 1 ? -1 : 1) * (int)lrint(s->q[f][d]);
      const int g = s->flut[rk_qcode(qs)];
      s->gmap[sc][pp] = g >= 0 ? s->gpos[g] : -1;
    }
}

/* ------------------------------------------------------------------ kernel */

/* Cubic B-spline (normalisation irrelevant: the RK correction reproduces constants). */
static inline RK_ALWAYS_INLINE ej_real rk_phi(ej_real z)
{
  /* written as a select of the two pieces (each the value its branch returned) so that GCC
   * vectorises loops that call it */
  const ej_real t = 1.0 - z;
  const ej_real inner = 2.0 / 3.0 - 4.0 * z * z + 4.0 * z * z * z, outer = 4.0 / 3.0 * t * t * t;
  return z >= 1.0 ? 0.0 : z <= 0.5 ? inner : outer;
}
#define RK_PHI0 (2.0 / 3.0)

/* The same kernel without branches (zero for z >= 1), for loops that must vectorise. */
/* phi = 4/3 (1 - z)^3 - 16/3 (1/2 - z)^3 for z <= 1/2 (expands to 2/3 - 4 z^2 + 4 z^3). */
static inline RK_ALWAYS_INLINE ej_real rk_phi_bl(ej_real z)
{
  ej_real t = 1.0 - z, u = 0.5 - z;
  t = t > 0.0 ? t : 0.0;
  u = u > 0.0 ? u : 0.0;
  return 4.0 / 3.0 * t * t * t - 16.0 / 3.0 * u * u * u;
}

static inline ej_real rk_root(int dim, ej_real v) { return dim == 3 ? cbrt(v) : dim == 2 ? sqrt(v) : v; }

/* Inverse of the n x n (n = dim + 1 <= 4) symmetric positive definite moment matrix by
 * Cholesky. Returns 0 if a pivot falls below tol times its diagonal (singular or nearly:
 * too few neighbours, all on a line or a plane), leaving Ai untouched. */
/* Spread of the weighted neighbour cloud in units of the support, rotation invariant: with
 * C = Cov_w((x_I - x_J)/a) (from the scaled moment matrix M: C_ab = M_ab/M_00 - M_a0 M_b0/M_00^2),
 * q = det C / (tr C / (dim - 1))^(dim - 1), which lies between lambda_min(C)/2 and lambda_min(C)
 * in 2D (3D: within a factor of lambda_min for one small eigenvalue); dim 1: q = C. */
static inline RK_ALWAYS_INLINE ej_real rk_spread(const int dim, const ej_real M[4][4])
{
  const ej_real i0 = 1.0 / M[0][0];
  ej_real C[3][3];
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) C[a][b] = M[a + 1][b + 1] * i0 - M[a + 1][0] * M[b + 1][0] * i0 * i0;
  if (dim == 1) return C[0][0];
  if (dim == 2) {
    const ej_real tr = C[0][0] + C[1][1];
    return tr > 0.0 ? (C[0][0] * C[1][1] - C[0][1] * C[0][1]) / tr : 0.0;
  }
  const ej_real tr = 0.5 * (C[0][0] + C[1][1] + C[2][2]);
  const ej_real det = C[0][0] * (C[1][1] * C[2][2] - C[1][2] * C[2][1]) - C[0][1] * (C[1][0] * C[2][2] - C[1][2] * C[2][0]) +
                      C[0][2] * (C[1][0] * C[2][1] - C[1][1] * C[2][0]);
  return tr > 0.0 ? det / (tr * tr) : 0.0;
}

static inline RK_ALWAYS_INLINE int rk_inv_spd(const int n, const ej_real A[4][4], ej_real Ai[4][4], ej_real tol,
                                              ej_real *rpiv)
{
  ej_real L[4][4] = {{0}}, Li[4][4] = {{0}};
  *rpiv = 1.0; /* smallest relative pivot s_j / A_jj */
  for (int j = 0; j < n; ++j) {
    ej_real s = A[j][j];
    for (int k = 0; k < j; ++k) s -= L[j][k] * L[j][k];
    if (!(s > tol * A[j][j]) || !(s > 0.0)) return 0;
    if (s < *rpiv * A[j][j]) *rpiv = s / A[j][j];
    L[j][j] = sqrt(s);
    const ej_real inv = 1.0 / L[j][j];
    for (int i = j + 1; i < n; ++i) {
      ej_real t = A[i][j];
      for (int k = 0; k < j; ++k) t -= L[i][k] * L[j][k];
      L[i][j] = t * inv;
    }
  }
  for (int j = 0; j < n; ++j) {
    Li[j][j] = 1.0 / L[j][j];
    for (int i = j + 1; i < n; ++i) {
      ej_real t = 0.0;
      for (int k = j; k < i; ++k) t += L[i][k] * Li[k][j];
      Li[i][j] = -t / L[i][i];
    }
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) {
      ej_real t = 0.0;
      for (int k = i; k < n; ++k) t += Li[k][i] * Li[k][j];
      Ai[i][j] = Ai[j][i] = t;
    }
  return 1;
}

/* ------------------------------------------------------------------ declare / create */

static ej_err rk_declare(const void *config, int dim, ej_decl *d)
{
  const rk_config *cfg = config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "rkpm: dimension %d not in 1..3", dim);
  const bool lag = cfg->formulation == RK_LAGRANGIAN;
  /* Moment-matrix inverses are state in the Lagrangian formulation (computed once). */
  const unsigned mflags = lag ? 0u : EJ_FIELD_SCRATCH;
  const ej_field_decl fields[] = {
      {.name = "rho", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "kg/m^3", .rate = "rho_dot",
       .doc = "Density, from the continuity equation drho/dt = -rho tr(d)."},
      {.name = "e", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "J/kg", .rate = "e_dot",
       .energy = EJ_ENERGY_INTERNAL, .doc = "Specific internal energy, de/dt = sigma:d/rho + stabilisation heat."},
      {.name = "p", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "Pa",
       .doc = "Pressure -tr(sigma)/3 (compression positive)."},
      {.name = "c", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "Sound speed from the material (or EOS)."},
      {.name = "stress", .kind = EJ_SYM6, .flags = EJ_FIELD_OUTPUT, .unit = "Pa",
       .doc = "Cauchy stress (tension positive), Voigt xx yy zz xy yz zx."},
      {.name = "rk_a", .kind = EJ_SCALAR, .flags = 0, .unit = "m",
       .doc = "Kernel support radius a = support * vol0^(1/dim)."},
      {.name = "rk_m0", .kind = EJ_SCALAR, .flags = mflags, .unit = "1",
       .doc = "Inverse moment matrix, constant-constant entry (scaled basis)."},
      {.name = "rk_m1", .kind = EJ_VEC3, .flags = mflags, .unit = "1",
       .doc = "Inverse moment matrix, linear-constant entries (scaled basis)."},
      {.name = "rk_m2", .kind = EJ_SYM6, .flags = mflags, .unit = "1",
       .doc = "Inverse moment matrix, linear-linear block (scaled basis)."},
      {.name = "rk_s", .kind = EJ_SCALAR, .flags = mflags, .unit = "1",
       .doc = "Kernel sum sum_J phi_J(x_I) (stabilisation weights)."},
      {.name = "rk_vmid", .kind = EJ_VEC3, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
       .doc = "Mid-step velocity, copied so that ghosts have it."},
      {.name = "rk_gv", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "1/s",
       .doc = "Velocity gradient in the kernel configuration (L, or dF/dt in the Lagrangian form)."},
      {.name = "rk_d", .kind = EJ_SYM6, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1/s",
       .doc = "Mid-step rate of deformation handed to the material."},
      {.name = "rk_wpl", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .doc = "Plastic work increment of the step."},
      {.name = "w_plastic", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .energy = EJ_ENERGY_PLASTIC, .doc = "Specific plastic work (already part of e)."},
      {.name = "w_hg", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg", .rate = "w_hg_dot",
       .energy = EJ_ENERGY_HOURGLASS, .doc = "Specific work dissipated by the stabilisation (already part of e)."},
      {.name = "failed", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST | EJ_FIELD_OUTPUT, .unit = "1",
       .doc = "1 where the material reported failure (stress zero from then on)."},
      {.name = "rk_fallbacks", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "Steps in which the moment matrix was singular and the constant basis was used."},
      {.name = "rk_fb_step", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST | EJ_FIELD_SCRATCH, .unit = "1",
       .doc = "1 if the moment matrix fell back in this step."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  if (cfg->integration != RK_DNI) {
    static const ej_field_decl sig = {
        .name = "rk_sig", .kind = EJ_VEC3, .flags = EJ_FIELD_SCRATCH, .unit = "1",
        .doc = "(1, 1, 1) on owned particles: on a ghost, the signs of its image transform (mirror axes)."};
    EJ_TRY(ej_decl_field(d, &sig));
    static const ej_field_decl hb = {.name = "rk_hb", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m",
                                     .doc = "Edge of the node's MSNNI box (rk_hbox), set in pass 0."};
    EJ_TRY(ej_decl_field(d, &hb));
  }
  if (cfg->integration == RK_MSNNI) {
    /* Sub-box stabilisation stresses (2^dim Voigt tensors), packed into TENSOR9 fields. */
    static const char *const ssn[] = {"rk_ss0", "rk_ss1", "rk_ss2", "rk_ss3", "rk_ss4", "rk_ss5"};
    const int ns = 1 << dim, nss = (6 * ns + 8) / 9;
    for (int k = 0; k < nss; ++k) {
      const ej_field_decl f = {.name = ssn[k], .kind = EJ_TENSOR9, .flags = EJ_FIELD_NO_GHOST, .unit = "Pa",
                               .doc = "MSNNI sub-box stabilisation stresses (packed Voigt tensors, 003 Eq 46)."};
      EJ_TRY(ej_decl_field(d, &f));
    }
  }
  if (lag) {
    static const ej_field_decl lf[] = {
        {.name = "F", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "1",
         .doc = "Deformation gradient sum_J (x_J - x_I) (x) grad_X Psi_J(X_I)."},
        {.name = "rk_P", .kind = EJ_TENSOR9, .flags = EJ_FIELD_SCRATCH, .unit = "Pa",
         .doc = "First Piola-Kirchhoff stress J sigma F^-T."},
        {.name = "rk_ready", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
         .doc = "1 once the reference moment matrix of the node is computed."},
    };
    for (size_t k = 0; k < sizeof lf / sizeof lf[0]; ++k) EJ_TRY(ej_decl_field(d, &lf[k]));
  }
  if (cfg->essential == RK_ESS_TRANSFORMATION) {
    static const ej_field_decl ef[] = {
        {.name = "rk_vc", .kind = EJ_VEC3, .flags = EJ_FIELD_SCRATCH, .unit = "m/s",
         .doc = "Velocity coefficients (transformation method: v, with the held nodes' coefficients)."},
    };
    for (size_t k = 0; k < sizeof ef / sizeof ef[0]; ++k) EJ_TRY(ej_decl_field(d, &ef[k]));
    if (lag) {
      static const ej_field_decl xc = {
          .name = "rk_xc", .kind = EJ_VEC3, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_POSITION, .unit = "m",
          .doc = "Position coefficients x0 + d_u (transformation method, Lagrangian formulation)."};
      EJ_TRY(ej_decl_field(d, &xc));
    }
  }
  EJ_TRY(ej_decl_neighbours(d, lag ? EJ_NBR_REFERENCE : EJ_NBR_CURRENT));
  return EJ_OK;
}

static ej_err rk_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  EJ_ENSURE(config && set && model && state, EJ_ERR_ARG, "rkpm: NULL argument to create");
  const rk_config *cfg = config;
  const int dim = ej_set_dim(set);
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "rkpm: dimension %d not in 1..3", dim);
  const ej_material *mat = ej_model_material(model);
  const ej_eos *eos = ej_model_eos(model);
  EJ_ENSURE(mat || eos, EJ_ERR_UNSUPPORTED,
            "set '%s': rkpm needs a strength model or an equation of state, and material '%s' has neither",
            ej_set_name(set), ej_model_name(model));
  rk_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "rkpm: out of memory");
  s->cfg = *cfg;
  s->set = set;
  s->frev_build = -1;
  s->dim = dim;
  s->lagrangian = cfg->formulation == RK_LAGRANGIAN;
  s->eos = eos;
  s->mat = mat;
  s->set_name = ej_set_name(set);
  s->box = cfg->integration != RK_DNI;
  s->sub = cfg->integration == RK_MSNNI && cfg->msnni_w > 0.0;
  s->smat = s->sub && mat && !s->lagrangian && cfg->msnni_stress == RK_STAB_MATERIAL;
  /* An EOS-only fluid has no shear stiffness to stabilise with: it keeps the full (bulk) form. */
  s->sdev = s->sub && mat && cfg->msnni_part == RK_PART_DEVIATORIC;
  rk_faces_init(s);
  if (s->box && s->nf != (dim == 3 ? 36 : dim == 2 ? 12 : 3)) {
    ej_free(s);
    EJ_FAIL(EJ_ERR_INTERNAL, "rkpm: %d-D nodal box with a wrong number of face points", dim);
  }
  if (mat) {
    ej_err rc = ej_material_moduli(mat, &s->K, &s->G);
    if (rc != EJ_OK) {
      ej_free(s);
      EJ_TRY(rc);
    }
  }
  *state = s;
  return EJ_OK;
}

static void rk_destroy(void *state)
{
  rk_state *s = state;
  if (!s) return;
  ej_free(s->fb);
  ej_free(s->ft);
  ej_free(s->fflag);
  ej_free(s->fsc);
  ej_free(s->frev);
  ej_free(s->fself);
  ej_free(s->fscat);
  ej_free(s->keep);
  rk_ess_destroy(s->ess);
  ej_free(s);
}

/* Edge of the nodal box: the current spacing (m/rho)^(1/dim) for semi-Lagrangian kernels,
 * clamped to [RK_HB_MIN, RK_HB_MAX] h0 so that the face points stay inside the neighbour
 * reach; the reference spacing h0 = vol0^(1/dim) for Lagrangian kernels. */
static inline ej_real rk_hbox(const rk_state *s, ej_real m, ej_real rho, ej_real vol0)
{
  const ej_real h0 = rk_root(s->dim, vol0);
  if (s->lagrangian) return h0;
  const ej_real h = rk_root(s->dim, m / rho);
  return h < RK_HB_MIN * h0 ? RK_HB_MIN * h0 : h > RK_HB_MAX * h0 ? RK_HB_MAX * h0 : h;
}

static ej_err rk_bad(const rk_state *s, const ej_set *set, ej_idx i, const char *what, ej_real val)
{
  const ej_real *x = ej_set_field(set, "x");
  const int32_t *id = ej_set_field_int(set, "id");
  EJ_FAIL(EJ_ERR_NUMERIC, "set '%s': rkpm particle id %d at (%g, %g, %g): %s = %g", s->set_name,
          id ? (int)id[i] : (int)i, x ? x[3 * i] : NAN, x ? x[3 * i + 1] : NAN, x ? x[3 * i + 2] : NAN, what, val);
}

/* P-wave speed of the strength model's initial moduli at density rho (0 without one). */
static inline ej_real rk_c_moduli(const rk_state *s, ej_real rho)
{
  const ej_real M = s->K + 4.0 * s->G / 3.0;
  return (M > 0 && rho > 0) ? sqrt(M / rho) : 0.0;
}

static ej_err rk_setup(void *state, ej_set *set)
{
  rk_state *s = state;
  const ej_real *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0"), *rho = ej_set_field(set, "rho");
  ej_real *ra = ej_set_field(set, "rk_a"), *c = ej_set_field(set, "c"), *p = ej_set_field(set, "p");
  const ej_real *e = ej_set_field(set, "e");
  EJ_ENSURE(m && vol0 && rho && ra && c && p && e, EJ_ERR_INTERNAL, "set '%s': rkpm fields missing", s->set_name);
  const ej_idx n = ej_set_count(set);
  for (ej_idx i = 0; i < n; ++i) {
    if (!(m[i] > 0.0)) return rk_bad(s, set, i, "mass m", m[i]);
    if (!(vol0[i] > 0.0)) return rk_bad(s, set, i, "volume vol0", vol0[i]);
    if (!(rho[i] > 0.0)) return rk_bad(s, set, i, "density rho", rho[i]);
    ra[i] = s->cfg.support * rk_root(s->dim, vol0[i]);
    c[i] = rk_c_moduli(s, rho[i]);
  }
  if (s->box) {
    ej_free(s->fb);
    ej_free(s->ft);
    ej_free(s->fflag);
    s->nid = n;
    s->fflag = ej_calloc((size_t)(n > 0 ? n : 1), sizeof(int32_t));
    s->fb = ej_calloc((size_t)(n > 0 ? n : 1) * RK_NF_MAX * 4, sizeof(ej_real));
    s->ft = ej_calloc((size_t)(n > 0 ? n : 1) * RK_NF_MAX * 3, sizeof(ej_real));
    EJ_ENSURE(s->fb && s->ft && s->fflag, EJ_ERR_MEM, "set '%s': rkpm msnni face data: out of memory", s->set_name);
    ej_real *sig = ej_set_field(set, "rk_sig");
    EJ_ENSURE(sig, EJ_ERR_INTERNAL, "set '%s': rkpm field rk_sig missing", s->set_name);
    for (ej_idx i = 0; i < n; ++i) sig[3 * i] = sig[3 * i + 1] = sig[3 * i + 2] = 1.0;
  }
  if (s->cfg.essential == RK_ESS_TRANSFORMATION) {
    rk_ess_destroy(s->ess);
    s->ess = NULL;
    EJ_TRY(rk_ess_create(&s->ess, n));
  }
  const ej_initial_stress *is = &s->cfg.initial_stress;
  bool prestress = is->geostatic || (is->file && is->file[0]);
  for (int k = 0; k < 6; ++k) prestress |= is->uniform[k] != 0;
  if (prestress) {
    /* the EOS would replace the mean stress from (rho, e) at the first step */
    EJ_ENSURE(!s->eos, EJ_ERR_INPUT, "set '%s': rkpm initial_stress with an EOS: the EOS state (rho, e) gives the "
              "pressure; give the initial state through the density and energy instead", s->set_name);
    ej_real *sg = ej_set_field(set, "stress");
    EJ_ENSURE(sg, EJ_ERR_INTERNAL, "set '%s': rkpm field stress missing", s->set_name);
    EJ_TRY(ej_initial_stress_apply(is, set, sg));
  }
  /* An initial pressure state (EOS) gives the initial stress -p I. */
  if (s->eos && n > 0) {
    EJ_TRY(ej_eos_evaluate_set(s->eos, set, (ej_range){0, n}, rho, e, p, c));
    ej_real *sg = ej_set_field(set, "stress");
    for (ej_idx i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) sg[6 * i + k] = -p[i];
      if (s->mat) c[i] = fmax(c[i], rk_c_moduli(s, rho[i]));
    }
  }
  return EJ_OK;
}

static ej_err rk_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  const rk_state *s = state;
  const ej_real *ra = ej_set_field(set, "rk_a");
  EJ_ENSURE(ra, EJ_ERR_INTERNAL, "set '%s': rkpm field rk_a missing", s->set_name);
  if (!s->box) {
    for (ej_idx i = r.begin; i < r.end; ++i) radius[i - r.begin] = ra[i];
    return EJ_OK;
  }
  /* MSNNI: the face points of a neighbour's box lie up to RK_QMAX * RK_HB_MAX h0 from it, and
   * their moment matrices need every node whose kernel covers them. */
  const ej_real *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(vol0, EJ_ERR_INTERNAL, "set '%s': rkpm field vol0 missing", s->set_name);
  for (ej_idx i = r.begin; i < r.end; ++i)
    radius[i - r.begin] = ra[i] + RK_QMAX * RK_HB_MAX * rk_root(s->dim, vol0[i]);
  return EJ_OK;
}

/* ------------------------------------------------------------------ pass 0: moment matrices */

typedef struct rk_args {
  const ej_real *X;  /* kernel configuration: x (semi-Lagrangian) or x0 (Lagrangian) */
  const ej_real *x, *v, *vm, *ra, *m, *rho, *vol0, *c, *rs;
  ej_real *m0, *m1, *m2, *gv, *rk_s;
  const ej_real *stress, *P;
  ej_real *a, *e_dot, *w_dot;
  int32_t *fb, *fb_step;
  const int32_t *ready;
  const ej_off *off;
  const ej_idx *idx;
  ej_real tol, alpha, support;
  ej_real ttol; /* MSNNI semi-Lagrangian: nodes with a relative pivot below ttol are marked weak (2) */
  bool lag, galerkin;
} rk_args;

static inline RK_ALWAYS_INLINE void rk_moment_rows(const int dim, const rk_args *A, ej_range rg)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra;
  const int n = dim + 1;
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    if (A->lag && A->ready[i]) {
      /* computed once; the flag (a scratch field, not checkpointed) is read back from the moments,
       * which are: a node on the constant basis is the only one with m2 = 0 (rk_taylor_guard and the
       * fallback below zero it; a regular node's m2 is the inverse of a positive definite block), so a
       * restarted run finds its fallback nodes again (before, they came back to life and a restart
       * stopped at det F = 0 where the run itself did not) */
      const ej_real *c2 = A->m2 + 6 * i;
      A->fb_step[i] = c2[0] == 0.0 && c2[1] == 0.0 && c2[2] == 0.0 ? 1 : 0;
      continue;
    }
    const ej_real xi0 = X[3 * i], xi1 = dim > 1 ? X[3 * i + 1] : 0.0, xi2 = dim > 2 ? X[3 * i + 2] : 0.0;
    const ej_real inv_l = 1.0 / ra[i];
    /* Accumulate in the scaled basis H = [1, (x_I - x_J)/a_I]: O(1) entries, so the pivot test
     * is scale free. Self term: H = e1, phi(0). */
    ej_real s0 = RK_PHI0, s1 = 0, s2 = 0, s3 = 0, s11 = 0, s22 = 0, s33 = 0, s12 = 0, s23 = 0, s13 = 0;
    for (ej_off k = A->off[i]; k < A->off[i + 1]; ++k) {
      const ej_idx j = A->idx[k];
      const ej_real dx = xi0 - X[3 * j];
      const ej_real dy = dim > 1 ? xi1 - X[3 * j + 1] : 0.0;
      const ej_real dz = dim > 2 ? xi2 - X[3 * j + 2] : 0.0;
      const ej_real r2 = dx * dx + dy * dy + dz * dz, aj = ra[j];
      if (r2 >= aj * aj) continue;
      const ej_real w = rk_phi(sqrt(r2) / aj);
      const ej_real h1 = dx * inv_l, h2 = dy * inv_l, h3 = dz * inv_l;
      s0 += w;
      s1 += w * h1, s11 += w * h1 * h1;
      if (dim > 1) s2 += w * h2, s22 += w * h2 * h2, s12 += w * h1 * h2;
      if (dim > 2) s3 += w * h3, s33 += w * h3 * h3, s13 += w * h1 * h3, s23 += w * h2 * h3;
    }
    const ej_real M[4][4] = {{s0, s1, s2, s3}, {s1, s11, s12, s13}, {s2, s12, s22, s23}, {s3, s13, s23, s33}};
    ej_real Ai[4][4] = {{0}};
    A->rk_s[i] = s0;
    ej_real rpiv;
    if (rk_inv_spd(n, M, Ai, A->tol, &rpiv)) {
      /* Weak (2): invertible at rcond_min but with a relative pivot below the face-point
       * tolerance, or with a cloud flat in some direction (rk_spread: the relative pivots are
       * scale free per column and miss a noisy filament along an axis); resolved in
       * rk_pass_moment once the face points are known (rk_taylor_guard). */
      A->fb_step[i] = A->ttol > 0.0 && (rpiv < A->ttol || rk_spread(dim, M) < RK_SPREAD_MIN) ? 2 : 0;
    } else {
      /* Constant basis (Shepard): value phi_J / sum phi, zero gradient. A node that lost its
       * neighbours (a fragment) then carries no strain rate and no stress divergence. */
      memset(Ai, 0, sizeof Ai);
      Ai[0][0] = 1.0 / s0;
      A->fb_step[i] = 1;
      A->fb[i] += 1;
    }
    A->m0[i] = Ai[0][0];
    A->m1[3 * i] = Ai[1][0], A->m1[3 * i + 1] = Ai[2][0], A->m1[3 * i + 2] = Ai[3][0];
    ej_real *c2 = A->m2 + 6 * i;
    c2[0] = Ai[1][1], c2[1] = Ai[2][2], c2[2] = Ai[3][3], c2[3] = Ai[1][2], c2[4] = Ai[2][3], c2[5] = Ai[1][3];
  }
}

/* Node-level pieces of the Taylor fallback at a flagged face point of node L for node J:
 * with hv = (x_L - x_J)/l, Psi_J(x_L) = (m0 + m1.hv) phi_J and grad Psi_J(x_L) =
 * -(m1 + C hv) phi_J / l (the implicit gradient of the DNI path), so that
 * Psi_J(x_L + delta) ~ wn (ln - gn . delta). */
static inline RK_ALWAYS_INLINE void rk_taylor_parts(const int dim, ej_real m0, const ej_real *m1, const ej_real *c2,
                                                   const ej_real hv[3], ej_real inv_l, ej_real *ln, ej_real gn[3])
{
  const ej_real C[3][3] = {{c2[0], c2[3], c2[5]}, {c2[3], c2[1], c2[4]}, {c2[5], c2[4], c2[2]}};
  *ln = m0;
  for (int d = 0; d < dim; ++d) *ln += m1[d] * hv[d];
  for (int k = 0; k < 3; ++k) {
    ej_real t = m1[k];
    for (int d = 0; d < dim; ++d) t += C[k][d] * hv[d];
    gn[k] = k < dim ? t * inv_l : 0.0;
  }
}

/* The Taylor form of neighbour J at node L's flagged face points (rk_taylor_parts weighted by
 * phi_J(x_L)), scaled so that Psi_J(x_L + hq q) = *ln - gn . q: c = x_L - x_J, J's support aj
 * (inv_aj = 1/aj), l = a_L; zero where x_L is outside J's support. */
static inline RK_ALWAYS_INLINE void rk_taylor_piece(const int dim, const rk_args *A, ej_idx L, ej_real c0,
                                                   ej_real c1, ej_real c2, ej_real aj, ej_real inv_aj,
                                                   ej_real inv_l, ej_real hq, ej_real *ln_out, ej_real gn_out[3])
{
  const ej_real r2c = c0 * c0 + c1 * c1 + c2 * c2;
  *ln_out = gn_out[0] = gn_out[1] = gn_out[2] = 0.0;
  if (!(r2c < aj * aj)) return;
  const ej_real hv[3] = {c0 * inv_l, c1 * inv_l, c2 * inv_l};
  const ej_real wn = rk_phi(sqrt(r2c) * inv_aj);
  ej_real ln = 0.0, gn[3] = {0, 0, 0};
  rk_taylor_parts(dim, A->m0[L], A->m1 + 3 * L, A->m2 + 6 * L, hv, inv_l, &ln, gn);
  *ln_out = ln * wn, gn_out[0] = gn[0] * wn * hq, gn_out[1] = gn[1] * wn * hq, gn_out[2] = gn[2] * wn * hq;
}

/* Face-point moment accumulators of a node by padded position (face groups, rk_faces_init):
 * m0 = sum phi, m_a = sum phi h_a, m_ab = sum phi h_a h_b with h = (x_f - x_J)/l (003 Eq 5). */
enum { RK_M0, RK_M1, RK_M2, RK_M3, RK_M11, RK_M22, RK_M33, RK_M12, RK_M13, RK_M23, RK_NM };

/* One face group's 4 lanes: the moments over its listed neighbours lst[0..cnt), added in
 * neighbour order to a[RK_NM][4] (registers once inlined); the kernel values are kept in
 * wk[t][lane] when wk is not NULL. c*, ia: the neighbours' x_L - x_J and 1/a_J; o*: the lanes'
 * face-point offsets. */
static inline RK_ALWAYS_INLINE void rk_group_moments(const int dim, const int cnt, const int *restrict lst,
                                                    const ej_real *restrict cx, const ej_real *restrict cy,
                                                    const ej_real *restrict cz, const ej_real *restrict ia,
                                                    const ej_real o0[4], const ej_real o1[4], const ej_real o2[4],
                                                    const ej_real inv_l, ej_real a[RK_NM][4], ej_real (*restrict wk)[4])
{
#if defined(__AVX2__)
  /* 3D with AVX2: the same operations in the same order, written with intrinsics so that the ten
   * accumulators stay in registers (GCC 12 kept nine of them on the stack in the loop below: a
   * load, an add and a store per accumulator and neighbour). */
  if (dim == 3) {
    const __m256d O0 = _mm256_loadu_pd(o0), O1 = _mm256_loadu_pd(o1), O2 = _mm256_loadu_pd(o2);
    const __m256d IL = _mm256_set1_pd(inv_l), zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    const __m256d half = _mm256_set1_pd(0.5), k1 = _mm256_set1_pd(4.0 / 3.0), k2 = _mm256_set1_pd(16.0 / 3.0);
    __m256d s0 = _mm256_loadu_pd(a[RK_M0]), s1 = _mm256_loadu_pd(a[RK_M1]), s2 = _mm256_loadu_pd(a[RK_M2]);
    __m256d s3 = _mm256_loadu_pd(a[RK_M3]), s11 = _mm256_loadu_pd(a[RK_M11]), s22 = _mm256_loadu_pd(a[RK_M22]);
    __m256d s33 = _mm256_loadu_pd(a[RK_M33]), s12 = _mm256_loadu_pd(a[RK_M12]), s13 = _mm256_loadu_pd(a[RK_M13]);
    __m256d s23 = _mm256_loadu_pd(a[RK_M23]);
    for (int t = 0; t < cnt; ++t) {
      const int jn = lst[t];
      const __m256d d0 = _mm256_add_pd(_mm256_set1_pd(cx[jn]), O0), d1 = _mm256_add_pd(_mm256_set1_pd(cy[jn]), O1);
      const __m256d d2 = _mm256_add_pd(_mm256_set1_pd(cz[jn]), O2);
      const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(d1, d1)), _mm256_mul_pd(d2, d2));
      const __m256d z = _mm256_mul_pd(_mm256_sqrt_pd(r2), _mm256_set1_pd(ia[jn]));
      /* rk_phi_bl: max(x, 0) is x > 0 ? x : 0, NaN included (the second operand is returned). */
      const __m256d tt = _mm256_max_pd(_mm256_sub_pd(one, z), zero), uu = _mm256_max_pd(_mm256_sub_pd(half, z), zero);
      const __m256d w = _mm256_sub_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(k1, tt), tt), tt),
                                      _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(k2, uu), uu), uu));
      const __m256d h1 = _mm256_mul_pd(d0, IL), h2 = _mm256_mul_pd(d1, IL), h3 = _mm256_mul_pd(d2, IL);
      if (wk) _mm256_storeu_pd(wk[t], w);
      const __m256d w1 = _mm256_mul_pd(w, h1), w2 = _mm256_mul_pd(w, h2), w3 = _mm256_mul_pd(w, h3);
      s0 = _mm256_add_pd(s0, w), s1 = _mm256_add_pd(s1, w1), s11 = _mm256_add_pd(s11, _mm256_mul_pd(w1, h1));
      s2 = _mm256_add_pd(s2, w2), s22 = _mm256_add_pd(s22, _mm256_mul_pd(w2, h2));
      s12 = _mm256_add_pd(s12, _mm256_mul_pd(w1, h2));
      s3 = _mm256_add_pd(s3, w3), s33 = _mm256_add_pd(s33, _mm256_mul_pd(w3, h3));
      s13 = _mm256_add_pd(s13, _mm256_mul_pd(w1, h3)), s23 = _mm256_add_pd(s23, _mm256_mul_pd(w2, h3));
    }
    _mm256_storeu_pd(a[RK_M0], s0), _mm256_storeu_pd(a[RK_M1], s1), _mm256_storeu_pd(a[RK_M2], s2);
    _mm256_storeu_pd(a[RK_M3], s3), _mm256_storeu_pd(a[RK_M11], s11), _mm256_storeu_pd(a[RK_M22], s22);
    _mm256_storeu_pd(a[RK_M33], s33), _mm256_storeu_pd(a[RK_M12], s12), _mm256_storeu_pd(a[RK_M13], s13);
    _mm256_storeu_pd(a[RK_M23], s23);
    return;
  }
#endif
  for (int t = 0; t < cnt; ++t) {
    const int jn = lst[t];
    const ej_real c0 = cx[jn], c1 = cy[jn], c2 = cz[jn], inv_aj = ia[jn];
#pragma omp simd
    for (int l = 0; l < 4; ++l) {
      const ej_real d0 = c0 + o0[l], d1 = dim > 1 ? c1 + o1[l] : 0.0, d2 = dim > 2 ? c2 + o2[l] : 0.0;
      const ej_real w = rk_phi_bl(sqrt(d0 * d0 + d1 * d1 + d2 * d2) * inv_aj);
      const ej_real h1 = d0 * inv_l, h2 = d1 * inv_l, h3 = d2 * inv_l;
      if (wk) wk[t][l] = w;
      a[RK_M0][l] += w, a[RK_M1][l] += w * h1, a[RK_M11][l] += w * h1 * h1;
      if (dim > 1) a[RK_M2][l] += w * h2, a[RK_M22][l] += w * h2 * h2, a[RK_M12][l] += w * h1 * h2;
      if (dim > 2)
        a[RK_M3][l] += w * h3, a[RK_M33][l] += w * h3 * h3, a[RK_M13][l] += w * h1 * h3, a[RK_M23][l] += w * h2 * h3;
    }
  }
}

/* First row (b0, b) of M^-1 at the face points of a node from the accumulated moments (by
 * padded position), stored by padded position into b; returns the number of flagged points. */
static inline RK_ALWAYS_INLINE int rk_face_rows(const int n, const rk_state *s, const ej_real ftol,
                                               const ej_real *restrict A0, const ej_real *restrict A1,
                                               const ej_real *restrict A2, const ej_real *restrict A3,
                                               const ej_real *restrict A11, const ej_real *restrict A22,
                                               const ej_real *restrict A33, const ej_real *restrict A12,
                                               const ej_real *restrict A13, const ej_real *restrict A23,
                                               ej_real *restrict b)
{
  /* First row of M^-1 at every face point: the Cholesky of rk_row0_spd (same arithmetic),
   * written branch-free over the padded positions so that it vectorises; a point with a
   * pivot below ftol (or not covered) is flagged. */
  int nflag = 0;
  for (int p = 0; p < 4 * s->ng; ++p) {
    /* Cholesky M = Lc Lc^T column by column, Li = Lc^-1, r0 = first row of Li^T Li: the
     * arithmetic of rk_inv_spd written out with scalars (n = dim + 1 a compile-time constant)
     * so that the loop over the face points vectorises. Entries beyond n are never used. */
    const ej_real m00 = A0[p], m10 = A1[p], m20 = A2[p], m30 = A3[p];
    const ej_real m11 = A11[p], m21 = A12[p], m31 = A13[p], m22 = A22[p], m32 = A23[p], m33 = A33[p];
    int ok = m00 > 0.0;
    const ej_real s0 = m00;
    ok &= (s0 > ftol * m00) & (s0 > 0.0);
    const ej_real l00 = sqrt(s0), i00 = 1.0 / l00;
    const ej_real l10 = m10 * i00, l20 = m20 * i00, l30 = m30 * i00;
    ej_real l11 = 1.0, l21 = 0.0, l31 = 0.0, l22 = 1.0, l32 = 0.0, l33 = 1.0;
    if (n > 1) {
      const ej_real s1 = m11 - l10 * l10;
      ok &= (s1 > ftol * m11) & (s1 > 0.0);
      l11 = sqrt(s1);
      const ej_real i11 = 1.0 / l11;
      l21 = (m21 - l20 * l10) * i11, l31 = (m31 - l30 * l10) * i11;
    }
    if (n > 2) {
      const ej_real s2 = m22 - l20 * l20 - l21 * l21;
      ok &= (s2 > ftol * m22) & (s2 > 0.0);
      l22 = sqrt(s2);
      l32 = (m32 - l30 * l20 - l31 * l21) * (1.0 / l22);
    }
    if (n > 3) {
      const ej_real s3 = m33 - l30 * l30 - l31 * l31 - l32 * l32;
      ok &= (s3 > ftol * m33) & (s3 > 0.0);
      l33 = sqrt(s3);
    }
    const ej_real j00 = 1.0 / l00, j11 = 1.0 / l11, j22 = 1.0 / l22, j33 = 1.0 / l33;
    const ej_real j10 = -(l10 * j00) / l11;
    const ej_real j20 = -(l20 * j00 + l21 * j10) / l22, j21 = -(l21 * j11) / l22;
    const ej_real j30 = -(l30 * j00 + l31 * j10 + l32 * j20) / l33, j31 = -(l31 * j11 + l32 * j21) / l33;
    const ej_real j32 = -(l32 * j22) / l33;
    ej_real r0[4] = {j00 * j00, 0.0, 0.0, 0.0};
    if (n > 1) r0[0] += j10 * j10, r0[1] = j11 * j10;
    if (n > 2) r0[0] += j20 * j20, r0[1] += j21 * j20, r0[2] = j22 * j20;
    if (n > 3) r0[0] += j30 * j30, r0[1] += j31 * j30, r0[2] += j32 * j30, r0[3] = j33 * j30;
    /* Too few nodes cover a flagged face point (outside a free surface, a corner): b0 = -1
     * (M^-1 is positive definite so b0 > 0 otherwise) and the node's first order Taylor
     * expansion is used there, Psi_J(x_f) = Psi_J(x_L) + grad Psi_J(x_L).(x_f - x_L): still
     * a partition of unity that reproduces linear fields. Padding lanes: zeros. */
    const int valid = s->gperm[p] >= 0;
    nflag += valid & !ok;
    b[p] = ok ? r0[0] : valid ? -1.0 : 0.0;
    b[RK_NF_MAX + p] = ok ? r0[1] : 0.0;
    b[2 * RK_NF_MAX + p] = ok ? r0[2] : 0.0;
    b[3 * RK_NF_MAX + p] = ok ? r0[3] : 0.0;
  }
  return nflag;
}

/* The neighbours t < nn (offsets cx, cy, cz from the node, support radii aa) whose support
 * reaches the bounding ball of a face-point group (centre offset gx, gy, gz, radius gr): their
 * positions t, in neighbour order, into lst; returns how many. The ball test is vectorised over
 * the neighbours first, the list is compacted after. */
static inline RK_ALWAYS_INLINE int rk_group_list(int nn, const ej_real *restrict cx, const ej_real *restrict cy,
                                                 const ej_real *restrict cz, const ej_real *restrict aa, ej_real gx,
                                                 ej_real gy, ej_real gz, ej_real gr, int *restrict lst)
{
  int in[RK_NB_FUSE > RK_CHUNK ? RK_NB_FUSE : RK_CHUNK];
  for (int t = 0; t < nn; ++t) {
    const ej_real e0 = cx[t] + gx, e1 = cy[t] + gy, e2 = cz[t] + gz, rr = aa[t] + gr;
    in[t] = e0 * e0 + e1 * e1 + e2 * e2 < rr * rr;
  }
  int c = 0;
  for (int t = 0; t < nn; ++t) lst[c] = t, c += in[t];
  return c;
}

/* MSNNI pass 0: the moment matrix M(x_f) (003 Eq 5) at every face point of node L's box,
 * from L and its neighbours, and the first row (b0, b) of its inverse in the basis scaled by
 * l = a_L, so that Psi_J(x_f) = (b0 + b . (x_f - x_J) / l) phi_J(x_f - x_J) (003 Eq 4). A face
 * point with a singular (or ill-conditioned) M is flagged (b0 = -1) and takes the node's Taylor
 * form (rk_taylor_parts). Rows are stored face-major (b[c * nf + f]) so that the loops over the
 * face points vectorise; the kernel is evaluated branch-free (rk_phi_bl). */
static inline RK_ALWAYS_INLINE void rk_box_moment_rows(const int dim, const rk_state *s, const ej_real *restrict X,
                                                      const ej_real *restrict ra, const ej_real *restrict hb,
                                                      const int32_t *restrict id, const ej_off *off,
                                                      const ej_idx *nidx, ej_real tol, ej_range rg)
{
  const int n = dim + 1;
  /* Face points outside the cloud (edges, corners) can be covered by few nodes: a stricter
   * pivot test there sends ill-conditioned ones to the Taylor form. With the node limit 1e-6
   * (or 1e-3) the extrapolated shape functions at such points are large and a jittered (0.2 h)
   * 3D block blows up at cfl 0.25-0.4; with 3e-2 it is stable at cfl 0.5 (test_rkpm). */
  const ej_real ftol = rk_face_tol(tol);
  const ej_real *restrict q0 = s->gq[0], *restrict q1 = s->gq[1], *restrict q2 = s->gq[2];
  const int ng = s->ng;
  for (ej_idx L = rg.begin; L < rg.end; ++L) {
    const ej_real h = hb[L], hq = 0.25 * h;
    const ej_real inv_l = 1.0 / ra[L];
    ej_real gcx[RK_NF_MAX / 4][3], grx[RK_NF_MAX / 4];
    for (int g = 0; g < ng; ++g) {
      for (int d = 0; d < 3; ++d) gcx[g][d] = hq * s->gc[g][d];
      grx[g] = hq * s->gr[g];
    }
    ej_real Am[RK_NM][RK_NF_MAX] = {{0}}; /* accumulators by padded position (RK_M0 ...) */
    /* Face-point offsets hq q by padded position (the same products as before). */
    ej_real hq0[RK_NF_MAX], hq1[RK_NF_MAX], hq2[RK_NF_MAX];
    for (int p = 0; p < 4 * ng; ++p) hq0[p] = hq * q0[p], hq1[p] = hq * q1[p], hq2[p] = hq * q2[p];
    /* Neighbours in chunks (SoA): the ball tests of all (neighbour, group) pairs, then one list
     * of neighbours per group (the support of J misses the other groups: exact zeros), then per
     * group its 4 lanes accumulated in registers over the listed neighbours. Every face point
     * still sums its neighbours in neighbour order: bitwise the same sums as the (neighbour,
     * group)-ordered sweep, without the accumulators' round trips through memory. */
    for (ej_off k = off[L] - 1; k < off[L + 1];) {
      ej_real cx[RK_CHUNK], cy[RK_CHUNK], cz[RK_CHUNK], ia[RK_CHUNK], aa[RK_CHUNK];
      int lst[RK_NF_MAX / 4][RK_CHUNK], cnt[RK_NF_MAX / 4];
      int nn = 0;
      for (; k < off[L + 1] && nn < RK_CHUNK; ++k, ++nn) {
        const ej_idx j = k < off[L] ? L : nidx[k];
        cx[nn] = X[3 * L] - X[3 * j];
        cy[nn] = dim > 1 ? X[3 * L + 1] - X[3 * j + 1] : 0.0;
        cz[nn] = dim > 2 ? X[3 * L + 2] - X[3 * j + 2] : 0.0;
        aa[nn] = ra[j];
      }
      for (int t = 0; t < nn; ++t) ia[t] = 1.0 / aa[t];
      for (int g = 0; g < ng; ++g)
        cnt[g] = rk_group_list(nn, cx, cy, cz, aa, gcx[g][0], gcx[g][1], gcx[g][2], grx[g], lst[g]);
      for (int g = 0; g < ng; ++g) {
        const int p0 = 4 * g;
        ej_real o0[4], o1[4], o2[4], a[RK_NM][4];
        for (int l = 0; l < 4; ++l) {
          o0[l] = hq0[p0 + l], o1[l] = hq1[p0 + l], o2[l] = hq2[p0 + l];
          for (int m = 0; m < RK_NM; ++m) a[m][l] = Am[m][p0 + l];
        }
        rk_group_moments(dim, cnt[g], lst[g], cx, cy, cz, ia, o0, o1, o2, inv_l, a, NULL);
        for (int l = 0; l < 4; ++l)
          for (int m = 0; m < RK_NM; ++m) Am[m][p0 + l] = a[m][l];
      }
    }
    s->fflag[id[L]] = rk_face_rows(n, s, ftol, Am[RK_M0], Am[RK_M1], Am[RK_M2], Am[RK_M3], Am[RK_M11], Am[RK_M22],
                                   Am[RK_M33], Am[RK_M12], Am[RK_M13], Am[RK_M23],
                                   s->fb + (size_t)id[L] * RK_NF_MAX * 4);
  }
}

/* Taylor-form guard (semi-Lagrangian MSNNI). A flagged face point (too few nodes) takes the
 * node's first-order Taylor form, built from the node's own M^-1. When the node has itself
 * lost its support -- a filament one node wide in a splash or along a projectile's path, its
 * neighbours nearly on a line -- its M passes rcond_min (1e-6) but not the face tolerance:
 * the extrapolated gradient normal to the filament is then ~ 1/pivot times too large and the
 * node blows up within a few steps (validation/penetration, 45 deg: relative pivot 3.4e-4,
 * cond(M) 7e5, 3 neighbours; v 30 -> -908 m/s in one frame, rho < 0, then NaN in the box
 * size). Such a node (flagged face points and node pivot below the face tolerance) takes the
 * constant-basis fallback of an isolated node: no gradient, no stress divergence, counted in
 * rk_fallbacks. A weak node whose face points are all regular keeps its face-point rows. */
static void rk_taylor_guard(const rk_state *s, const rk_args *A, const int32_t *id, ej_range r)
{
  for (ej_idx i = r.begin; i < r.end; ++i) {
    if (A->fb_step[i] != 2) continue;
    if (s->fflag[id[i]] > 0) {
      A->fb_step[i] = 1;
      A->fb[i] += 1;
      A->m0[i] = 1.0 / A->rk_s[i];
      for (int d = 0; d < 3; ++d) A->m1[3 * i + d] = 0.0;
      for (int k = 0; k < 6; ++k) A->m2[6 * i + k] = 0.0;
    } else {
      A->fb_step[i] = 0;
    }
  }
}

/* Semi-Lagrangian MSNNI: the face-point moments of node L (as rk_box_moment_rows), their first
 * rows b, the Taylor guard of the node, and the interpolation of pass 1 in one sweep over the
 * neighbours: the kernel values phi_J(x_f) of the moment sums are kept on the stack (one per
 * (neighbour, group) pair and lane) and reused for Psi_J(x_f) = (b0 + b . (x_f - x_J)/l) phi_J
 * once b is known, instead of a second neighbour sweep that evaluated them again. Every sum is
 * the same sum in the same order (each face point sums its neighbours in neighbour order; the
 * node itself enters the interpolation with v_J - v_L = 0): bitwise the same results as the
 * separate sweeps. Returns 1 with up, um filled, or 0 when the caller interpolates with its own
 * sweep: more than RK_NB_FUSE neighbours or RK_IT_FUSE pairs (then the moments go through
 * rk_box_moment_rows). The lists and kernel values live in *K (kept for the force scatter when
 * K is the caller's arena slot; K->fused says whether they are valid). */
static inline RK_ALWAYS_INLINE int rk_box_fused_node(const int dim, const rk_state *s, const rk_args *A,
                                                    const ej_real *restrict hb, const int32_t *restrict id, ej_idx L,
                                                    ej_real up[3][RK_NF_MAX], ej_real um[3][RK_NF_MAX],
                                                    rk_keep *restrict K)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict v = A->v, *restrict vm = A->vm;
  const ej_off k0 = A->off[L] - 1, k1 = A->off[L + 1];
  const int ng = s->ng, n = dim + 1;
  const ej_real ftol = rk_face_tol(A->tol);
  const ej_real *restrict q0 = s->gq[0], *restrict q1 = s->gq[1], *restrict q2 = s->gq[2];
  const ej_range one = {L, L + 1};
  K->fused = 0;
  if (k1 - k0 > RK_NB_FUSE) {
    rk_box_moment_rows(dim, s, X, ra, hb, id, A->off, A->idx, A->tol, one);
    rk_taylor_guard(s, A, id, one);
    return 0;
  }
  const int nn = (int)(k1 - k0);
  const ej_real h = hb[L], hq = 0.25 * h;
  const ej_real inv_l = 1.0 / ra[L];
  ej_real cx[RK_NB_FUSE], cy[RK_NB_FUSE], cz[RK_NB_FUSE], ia[RK_NB_FUSE], aa[RK_NB_FUSE];
  ej_real dv[RK_NB_FUSE][3], dm[RK_NB_FUSE][3];
  int(*restrict lst)[RK_NB_FUSE] = K->lst, *restrict cnt = K->cnt;
  for (int t = 0; t < nn; ++t) {
    const ej_idx j = t == 0 ? L : A->idx[k0 + t];
    cx[t] = X[3 * L] - X[3 * j];
    cy[t] = dim > 1 ? X[3 * L + 1] - X[3 * j + 1] : 0.0;
    cz[t] = dim > 2 ? X[3 * L + 2] - X[3 * j + 2] : 0.0;
    aa[t] = ra[j];
    for (int c = 0; c < 3; ++c) dv[t][c] = v[3 * j + c] - v[3 * L + c], dm[t][c] = vm[3 * j + c] - vm[3 * L + c];
  }
  for (int t = 0; t < nn; ++t) ia[t] = 1.0 / aa[t];
  int nit = 0;
  for (int g = 0; g < ng; ++g) {
    cnt[g] = rk_group_list(nn, cx, cy, cz, aa, hq * s->gc[g][0], hq * s->gc[g][1], hq * s->gc[g][2], hq * s->gr[g],
                           lst[g]);
    nit += cnt[g];
  }
  if (nit > RK_IT_FUSE) {
    rk_box_moment_rows(dim, s, X, ra, hb, id, A->off, A->idx, A->tol, one);
    rk_taylor_guard(s, A, id, one);
    return 0;
  }
  ej_real Am[RK_NM][RK_NF_MAX]; /* moments by padded position (RK_M0 ...) */
  ej_real hq0[RK_NF_MAX], hq1[RK_NF_MAX], hq2[RK_NF_MAX];
  for (int p = 0; p < 4 * ng; ++p) hq0[p] = hq * q0[p], hq1[p] = hq * q1[p], hq2[p] = hq * q2[p];
  ej_real(*restrict wk)[4] = K->wk; /* kernel values by (group, list position) and lane */
  for (int g = 0, it = 0; g < ng; it += cnt[g], ++g) {
    const int p0 = 4 * g;
    ej_real o0[4], o1[4], o2[4], a[RK_NM][4] = {{0}};
    for (int l = 0; l < 4; ++l) o0[l] = hq0[p0 + l], o1[l] = hq1[p0 + l], o2[l] = hq2[p0 + l];
    rk_group_moments(dim, cnt[g], lst[g], cx, cy, cz, ia, o0, o1, o2, inv_l, a, wk + it);
    for (int l = 0; l < 4; ++l)
      for (int m = 0; m < RK_NM; ++m) Am[m][p0 + l] = a[m][l];
  }
  ej_real *row = s->fb + (size_t)id[L] * RK_NF_MAX * 4;
  s->fflag[id[L]] = rk_face_rows(n, s, ftol, Am[RK_M0], Am[RK_M1], Am[RK_M2], Am[RK_M3], Am[RK_M11], Am[RK_M22],
                                 Am[RK_M33], Am[RK_M12], Am[RK_M13], Am[RK_M23], row);
  rk_taylor_guard(s, A, id, one);
  /* Interpolation (pass 1, rk_box_grad_rows), b scaled by 1/l as there. A flagged face point
   * (b0 = -1 in the row) takes the node's Taylor form with the pieces of rk_box_grad_rows; its
   * group sums every neighbour (the Taylor term does not vanish outside the kernel supports),
   * with the kept kernel value where the ball test passed and 0 (what phi gives) elsewhere. */
  const bool taylor = s->fflag[id[L]] > 0;
  ej_real lnn[RK_NB_FUSE], gnn[RK_NB_FUSE][3];
  if (taylor)
    for (int t = 0; t < nn; ++t) { /* the node itself is skipped (v_J - v_L = 0) */
      rk_taylor_piece(dim, A, L, cx[t], cy[t], cz[t], aa[t], ia[t], inv_l, hq, &lnn[t], gnn[t]);
      if (t == 0) lnn[0] = gnn[0][0] = gnn[0][1] = gnn[0][2] = 0.0;
    }
  for (int g = 0, it = 0; g < ng; it += cnt[g], ++g) {
    const int p0 = 4 * g;
    ej_real o0[4], o1[4], o2[4], e0[4], e1[4], e2[4], e3[4], ef[4], r0[4], r1[4], r2[4];
    ej_real u0[4], u1[4], u2[4], n0[4], n1[4], n2[4];
    int gf = 0;
    for (int l = 0; l < 4; ++l) {
      const int f = p0 + l;
      const bool flg = row[f] < 0.0;
      gf |= flg;
      o0[l] = hq0[f], o1[l] = hq1[f], o2[l] = hq2[f];
      r0[l] = q0[f], r1[l] = q1[f], r2[l] = q2[f];
      e0[l] = flg ? 0.0 : row[f], ef[l] = flg ? 1.0 : 0.0;
      e1[l] = row[RK_NF_MAX + f] * inv_l, e2[l] = row[2 * RK_NF_MAX + f] * inv_l, e3[l] = row[3 * RK_NF_MAX + f] * inv_l;
      u0[l] = u1[l] = u2[l] = n0[l] = n1[l] = n2[l] = 0.0;
    }
    if (!(taylor && gf)) {
      for (int t = 0; t < cnt[g]; ++t) {
        const int jn = lst[g][t];
        const ej_real c0 = cx[jn], c1 = cy[jn], c2 = cz[jn];
        const ej_real dv0 = dv[jn][0], dv1 = dv[jn][1], dv2 = dv[jn][2];
        const ej_real dm0 = dm[jn][0], dm1 = dm[jn][1], dm2 = dm[jn][2];
        ej_real *restrict wt = wk[it + t];
#pragma omp simd
        for (int l = 0; l < 4; ++l) {
          const ej_real d0 = c0 + o0[l], d1 = dim > 1 ? c1 + o1[l] : 0.0, d2 = dim > 2 ? c2 + o2[l] : 0.0;
          const ej_real psi = (e0[l] + e1[l] * d0 + (dim > 1 ? e2[l] * d1 : 0.0) + (dim > 2 ? e3[l] * d2 : 0.0)) * wt[l];
          u0[l] += psi * dv0, u1[l] += psi * dv1, u2[l] += psi * dv2;
          n0[l] += psi * dm0, n1[l] += psi * dm1, n2[l] += psi * dm2;
          wt[l] = psi; /* kept for the force scatter: Psi_J(x_f) itself from here on */
        }
      }
    } else {
      static const ej_real zero4[4] = {0.0, 0.0, 0.0, 0.0};
      int q = cnt[g] > 0 && lst[g][0] == 0; /* position in the group's list (the node itself skipped) */
      for (int t = 1; t < nn; ++t) {
        const int hit = q < cnt[g] && lst[g][q] == t;
        const ej_real *restrict wl = hit ? wk[it + q] : zero4;
        q += hit;
        const ej_real c0 = cx[t], c1 = cy[t], c2 = cz[t];
        const ej_real ln = lnn[t], gn0 = gnn[t][0], gn1 = gnn[t][1], gn2 = gnn[t][2];
        const ej_real dv0 = dv[t][0], dv1 = dv[t][1], dv2 = dv[t][2];
        const ej_real dm0 = dm[t][0], dm1 = dm[t][1], dm2 = dm[t][2];
#pragma omp simd
        for (int l = 0; l < 4; ++l) {
          const ej_real d0 = c0 + o0[l], d1 = dim > 1 ? c1 + o1[l] : 0.0, d2 = dim > 2 ? c2 + o2[l] : 0.0;
          ej_real psi = (e0[l] + e1[l] * d0 + (dim > 1 ? e2[l] * d1 : 0.0) + (dim > 2 ? e3[l] * d2 : 0.0)) * wl[l];
          psi += ef[l] * (ln - gn0 * r0[l] - gn1 * r1[l] - gn2 * r2[l]);
          u0[l] += psi * dv0, u1[l] += psi * dv1, u2[l] += psi * dv2;
          n0[l] += psi * dm0, n1[l] += psi * dm1, n2[l] += psi * dm2;
        }
      }
    }
    for (int l = 0; l < 4; ++l) {
      const int f = p0 + l;
      up[0][f] = u0[l], up[1][f] = u1[l], up[2][f] = u2[l];
      um[0][f] = n0[l], um[1][f] = n1[l], um[2][f] = n2[l];
    }
  }
  K->nn = nn;
  K->fused = 1;
  return 1;
}

/* Out of line per dimension: inlined into the large pass-1 function, GCC left its lane loops
 * scalar. */
#if defined(__GNUC__)
#define RK_NOINLINE __attribute__((noinline))
#else
#define RK_NOINLINE
#endif
#define RK_FUSED_DIM(D)                                                                                          \
  static RK_NOINLINE int rk_box_fused_node##D(const rk_state *s, const rk_args *A, const ej_real *hb,           \
                                              const int32_t *id, ej_idx L, ej_real up[3][RK_NF_MAX],            \
                                              ej_real um[3][RK_NF_MAX], rk_keep *K)                             \
  {                                                                                                              \
    return rk_box_fused_node(D, s, A, hb, id, L, up, um, K);                                                     \
  }
RK_FUSED_DIM(1)
RK_FUSED_DIM(2)
RK_FUSED_DIM(3)

/* Storage of the force scatter (rk_state.fsc ...), for the list of this step and the team that
 * runs the passes: grown here, in pass 0, which neither reads nor writes it (pass 1 writes it,
 * pass 2 reads it; the core separates the passes), serialised between the threads. It grows only
 * when a rebuilt list outgrows it (by 1/16 more than needed), so not in a normal step. */
static ej_err rk_scatter_reserve(rk_state *s, const ej_nbr *nbr)
{
  const size_t nnz = (size_t)nbr->off[nbr->n_rows], nrow = (size_t)nbr->n_rows;
#ifdef _OPENMP
  const int nt = omp_get_num_threads() > omp_get_max_threads() ? omp_get_num_threads() : omp_get_max_threads();
#else
  const int nt = 1;
#endif
  bool oom = false;
#ifdef _OPENMP
#pragma omp critical(rk_scatter_reserve)
#endif
  {
    if (nnz > s->fsc_cap) {
      const size_t cap = nnz + nnz / 16 + 64;
      ej_free(s->fsc);
      ej_free(s->frev);
      s->fsc = ej_calloc(cap * 3, sizeof(ej_real));
      s->frev = ej_calloc(cap, sizeof(int32_t));
      s->fsc_cap = s->fsc && s->frev ? cap : 0;
      s->frev_build = -1;
      oom |= !s->fsc_cap;
    }
    if (nrow > s->own_cap || !s->fself) {
      const size_t cap = nrow > 0 ? nrow : 1;
      ej_free(s->fself);
      ej_free(s->fscat);
      s->fself = ej_calloc(cap * 3, sizeof(ej_real));
      s->fscat = ej_calloc(cap, sizeof(uint8_t));
      s->own_cap = s->fself && s->fscat ? cap : 0;
      oom |= !s->own_cap;
    }
    if (nt > s->nkeep) {
      ej_free(s->keep);
      s->keep = ej_calloc((size_t)nt * RK_BLOCK_SL, sizeof(rk_keep));
      s->nkeep = s->keep ? nt : 0;
      oom |= !s->keep;
    }
  }
  EJ_ENSURE(!oom, EJ_ERR_MEM, "set '%s': rkpm force scatter: out of memory (%zu list entries, %d threads)",
            s->set_name, nnz, nt);
  return EJ_OK;
}

static ej_err rk_pass_moment(rk_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': rkpm neighbour list too short", s->set_name);
  if (s->box && !s->lagrangian && s->cfg.force_scatter) EJ_TRY(rk_scatter_reserve(s, nbr));
  ej_real *vm = ej_set_field(set, "rk_vmid");
  const ej_real *vh = ej_set_field(set, "v_half");
  EJ_ENSURE(vm && vh, EJ_ERR_INTERNAL, "set '%s': rkpm velocity fields missing", s->set_name);
  memcpy(vm + 3 * (size_t)r.begin, vh + 3 * (size_t)r.begin, 3 * sizeof(ej_real) * (size_t)(r.end - r.begin));
  rk_args A = {.X = ej_set_field(set, s->lagrangian ? "x0" : "x"),
               .ra = ej_set_field(set, "rk_a"),
               .m0 = ej_set_field(set, "rk_m0"),
               .m1 = ej_set_field(set, "rk_m1"),
               .m2 = ej_set_field(set, "rk_m2"),
               .rk_s = ej_set_field(set, "rk_s"),
               .fb = ej_set_field_int(set, "rk_fallbacks"),
               .fb_step = ej_set_field_int(set, "rk_fb_step"),
               .ready = ej_set_field_int(set, "rk_ready"),
               .off = nbr->off,
               .idx = nbr->idx,
               .tol = s->cfg.rcond_min,
               .ttol = s->box && !s->lagrangian ? rk_face_tol(s->cfg.rcond_min) : 0.0,
               .lag = s->lagrangian};
  EJ_ENSURE(A.X && A.ra && A.m0 && A.m1 && A.m2 && A.rk_s && A.fb && A.fb_step && (!A.lag || A.ready),
            EJ_ERR_INTERNAL, "set '%s': rkpm moment fields missing", s->set_name);
  switch (s->dim) {
  case 1: rk_moment_rows(1, &A, r); break;
  case 2: rk_moment_rows(2, &A, r); break;
  default: rk_moment_rows(3, &A, r); break;
  }
  if (s->box) {
    const ej_real *m = ej_set_field(set, "m"), *rho = ej_set_field(set, "rho"), *vol0 = ej_set_field(set, "vol0");
    const int32_t *id = ej_set_field_int(set, "id");
    ej_real *sig = ej_set_field(set, "rk_sig");
    EJ_ENSURE(m && rho && vol0 && id && sig, EJ_ERR_INTERNAL, "set '%s': rkpm msnni fields missing", s->set_name);
    ej_real *hb = ej_set_field(set, "rk_hb");
    EJ_ENSURE(hb, EJ_ERR_INTERNAL, "set '%s': rkpm field rk_hb missing", s->set_name);
    for (ej_idx i = r.begin; i < r.end; ++i) {
      if (id[i] < 0 || id[i] >= s->nid) return rk_bad(s, set, i, "particle id outside the setup range", id[i]);
      /* (m/rho)^(1/dim) of a non-positive density is NaN: stop with the cause, not a NaN later. */
      if (!s->lagrangian && !(rho[i] > 0.0)) return rk_bad(s, set, i, "density rho (box size)", rho[i]);
      sig[3 * i] = sig[3 * i + 1] = sig[3 * i + 2] = 1.0;
      hb[i] = rk_hbox(s, m[i], rho[i], vol0[i]);
    }
    /* Semi-Lagrangian: the face-point moments, rows and the Taylor guard are computed in pass 1
     * together with the interpolation (rk_box_fused_node); weak nodes stay marked until then. */
    if (!s->lagrangian) return EJ_OK;
    switch (s->dim) {
    case 1: rk_box_moment_rows(1, s, A.X, A.ra, hb, id, A.off, A.idx, A.tol, r); break;
    case 2: rk_box_moment_rows(2, s, A.X, A.ra, hb, id, A.off, A.idx, A.tol, r); break;
    default: rk_box_moment_rows(3, s, A.X, A.ra, hb, id, A.off, A.idx, A.tol, r); break;
    }
    rk_taylor_guard(s, &A, id, r);
  }
  for (ej_idx i = r.begin; i < r.end; ++i) /* DNI, Lagrangian: weak nodes keep their inverse */
    if (A.fb_step[i] == 2) A.fb_step[i] = 0;
  if (A.lag) {
    /* ready is set only after the row is complete; the fallback flag of a Lagrangian node
     * stays as computed once. */
    int32_t *ready = ej_set_field_int(set, "rk_ready");
    for (ej_idx i = r.begin; i < r.end; ++i) ready[i] = 1;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ pass 1: kinematics, material */

/* Velocity gradients at node I (and the deformation gradient in the Lagrangian form):
 *   G_ik = sum_J (u_J - u_I)_i Psi_J^,k(X_I),
 *   Psi_J^,k(X_I) = -(1/a_I) [Minv_I H((X_I - X_J)/a_I)]_{k+1} phi_J(X_I - X_J)
 * so G = -(1/a_I) (A0 (x) m1 + A1 C) with A0 = sum phi du, A1 = sum phi du (x) xi. Relative
 * values u_J - u_I: the partition of unity makes the self term vanish and keeps round-off small. */
static inline RK_ALWAYS_INLINE void rk_grad_rows(const int dim, const bool lag, const rk_args *A, ej_range rg,
                                                 ej_real *restrict Gp, ej_real *restrict Gm, ej_real *restrict Fx)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict v = A->v, *restrict vm = A->vm;
  const ej_real *restrict x = A->x;
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi[3] = {X[3 * i], dim > 1 ? X[3 * i + 1] : 0.0, dim > 2 ? X[3 * i + 2] : 0.0};
    const ej_real inv_l = 1.0 / ra[i];
    ej_real p0[3] = {0}, p1[3][3] = {{0}}, q0[3] = {0}, q1[3][3] = {{0}}, f0[3] = {0}, f1[3][3] = {{0}};
    for (ej_off k = A->off[i]; k < A->off[i + 1]; ++k) {
      const ej_idx j = A->idx[k];
      ej_real h[3];
      for (int d = 0; d < 3; ++d) h[d] = d < dim ? xi[d] - X[3 * j + d] : 0.0;
      const ej_real r2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2], aj = ra[j];
      if (r2 >= aj * aj) continue;
      const ej_real w = rk_phi(sqrt(r2) / aj);
      for (int d = 0; d < dim; ++d) h[d] *= inv_l;
      for (int c = 0; c < 3; ++c) {
        const ej_real dv = w * (v[3 * j + c] - v[3 * i + c]), dm = w * (vm[3 * j + c] - vm[3 * i + c]);
        p0[c] += dv, q0[c] += dm;
        for (int d = 0; d < dim; ++d) p1[c][d] += dv * h[d], q1[c][d] += dm * h[d];
        if (lag) {
          const ej_real dx = w * (x[3 * j + c] - x[3 * i + c]);
          f0[c] += dx;
          for (int d = 0; d < dim; ++d) f1[c][d] += dx * h[d];
        }
      }
    }
    const ej_real *m1 = A->m1 + 3 * i, *c2 = A->m2 + 6 * i;
    const ej_real C[3][3] = {{c2[0], c2[3], c2[5]}, {c2[3], c2[1], c2[4]}, {c2[5], c2[4], c2[2]}};
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) {
        ej_real gp = p0[c] * m1[k], gm = q0[c] * m1[k], gf = f0[c] * m1[k];
        for (int d = 0; d < dim; ++d) {
          gp += p1[c][d] * C[d][k];
          gm += q1[c][d] * C[d][k];
          if (lag) gf += f1[c][d] * C[d][k];
        }
        Gp[9 * i + 3 * c + k] = -inv_l * gp;
        Gm[9 * (i - rg.begin) + 3 * c + k] = -inv_l * gm;
        if (lag) Fx[9 * i + 3 * c + k] = -inv_l * gf;
      }
    if (lag) {
      /* Directions outside the dimension do not deform (plane strain, uniaxial strain); a node on the
       * constant basis (fb_step 1: m1 = C = 0, no gradient) does not deform at all, as in the box path
       * (before, its in-plane F was 0 and the run stopped at det F = 0: a plate one node thick) */
      for (int c = A->fb_step[i] == 1 ? 0 : dim; c < 3; ++c) Fx[9 * i + 4 * c] = 1.0;
    }
  }
}

#define RK_BLOCK 64 /* particles per material batch: bounded stack scratch, no allocation */

/* MSNNI pass 1 at node L (003 Eqs 42-43): interpolate the velocities (and, Lagrangian, the
 * positions) at the face points, v^h(x_f) - v_L = sum_J Psi_J(x_f) (v_J - v_L), and take the
 * smoothed gradients over the box and over each sub-box with the midpoint rule per quarter face:
 *   G_L = (1/V_L) sum_{outer f} (v^h(x_f) - v_L) (x) n_f A_f,   A_f / V_L = 1 / (2^(dim-1) h),
 *   G_xi = (1/V_xi) sum_{f in dxi} (v^h(x_f) - v_L) (x) n_f^xi A_f,  V_xi = V_L / 2^dim.
 * Gp (from v, into the rk_gv field), Gm (from the mid-step velocity, block scratch), dGp, dGm =
 * G_xi - G_L per sub-box (block scratch, sub-box stabilisation) and, Lagrangian, F. keep: the
 * block's arena slots (node rg.begin + k in keep[k]) for the force scatter, or NULL. */
static inline RK_ALWAYS_INLINE void rk_box_grad_rows(const int dim, const bool lag, const rk_state *s,
                                                    const rk_args *A, const ej_real *restrict hb,
                                                    const int32_t *restrict id, const int32_t *fbs,
                                                    ej_range rg, ej_real *restrict Gp, ej_real *restrict Gm,
                                                    ej_real *restrict Fx, ej_real *restrict dGp,
                                                    ej_real *restrict dGm, rk_keep *keep)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict v = A->v, *restrict vm = A->vm;
  const ej_real *restrict x = A->x;
  const int nf = s->nf, ns = s->ns, ng = s->ng;
  const ej_real *restrict q0 = s->gq[0], *restrict q1 = s->gq[1], *restrict q2 = s->gq[2];
  rk_keep loc; /* without an arena: the fused sweep's scratch */
  for (ej_idx L = rg.begin; L < rg.end; ++L) {
    const ej_idx kb = L - rg.begin;
    const ej_real h = hb[L], hq = 0.25 * h;
    const ej_real inv_l = 1.0 / ra[L];
    ej_real up[3][RK_NF_MAX] = {{0}}, um[3][RK_NF_MAX] = {{0}}, ux[3][RK_NF_MAX] = {{0}};
    /* Semi-Lagrangian: face moments, rows, guard (and mostly the interpolation) here. */
    rk_keep *K = keep ? keep + kb : &loc;
    const int fused = lag        ? 0
                      : dim == 1 ? rk_box_fused_node1(s, A, hb, id, L, up, um, K)
                      : dim == 2 ? rk_box_fused_node2(s, A, hb, id, L, up, um, K)
                                 : rk_box_fused_node3(s, A, hb, id, L, up, um, K);
    const ej_real *row = s->fb + (size_t)id[L] * RK_NF_MAX * 4;
    const bool taylor = s->fflag[id[L]] > 0;
    /* Local copies by padded position p: b scaled by 1/l; a flagged face has b = 0 and fl = 1
     * (Taylor form); padding lanes have b = 0, fl = 0. A group with a flagged face is never
     * skipped (its Taylor term does not vanish outside the kernel support). */
    ej_real b0[RK_NF_MAX], b1[RK_NF_MAX], b2[RK_NF_MAX], b3[RK_NF_MAX], fl[RK_NF_MAX];
    ej_real gcx[RK_NF_MAX / 4][3], grx[RK_NF_MAX / 4];
    int gfl[RK_NF_MAX / 4];
    for (int g = 0; g < ng; ++g) {
      for (int d = 0; d < 3; ++d) gcx[g][d] = hq * s->gc[g][d];
      grx[g] = hq * s->gr[g];
      gfl[g] = 0;
    }
    for (int p = 0; p < 4 * ng; ++p) { /* padding lanes: row entries 0 */
      const bool flg = row[p] < 0.0;
      fl[p] = flg ? 1.0 : 0.0;
      gfl[p / 4] |= flg;
      b0[p] = flg ? 0.0 : row[p];
      b1[p] = row[RK_NF_MAX + p] * inv_l, b2[p] = row[2 * RK_NF_MAX + p] * inv_l, b3[p] = row[3 * RK_NF_MAX + p] * inv_l;
    }
    ej_real hq0[RK_NF_MAX], hq1[RK_NF_MAX], hq2[RK_NF_MAX];
    for (int p = 0; p < 4 * ng; ++p) hq0[p] = hq * q0[p], hq1[p] = hq * q1[p], hq2[p] = hq * q2[p];
    /* Chunks of neighbours (the self term has v_J - v_L = 0): one list per group of the
     * neighbours whose ball test passes (or all of them for a group holding a flagged face of
     * a Taylor node), then per group its 4 lanes accumulated in registers over the list
     * (as rk_box_moment_rows: each face point sums its neighbours in neighbour order). */
    for (ej_off k = fused ? A->off[L + 1] : A->off[L]; k < A->off[L + 1];) {
      ej_real cx[RK_CHUNK], cy[RK_CHUNK], cz[RK_CHUNK], ia[RK_CHUNK], aa[RK_CHUNK];
      ej_real dv[RK_CHUNK][3], dm[RK_CHUNK][3], dx[RK_CHUNK][3];
      ej_real lnn[RK_CHUNK], gnn[RK_CHUNK][3];
      int lst[RK_NF_MAX / 4][RK_CHUNK], cnt[RK_NF_MAX / 4];
      int nn = 0;
      for (; k < A->off[L + 1] && nn < RK_CHUNK; ++k, ++nn) {
        const ej_idx j = A->idx[k];
        ej_real c0 = X[3 * L] - X[3 * j], c1 = 0.0, c2 = 0.0;
        if (dim > 1) c1 = X[3 * L + 1] - X[3 * j + 1];
        if (dim > 2) c2 = X[3 * L + 2] - X[3 * j + 2];
        const ej_real aj = ra[j], inv_aj = 1.0 / aj;
        cx[nn] = c0, cy[nn] = c1, cz[nn] = c2, ia[nn] = inv_aj, aa[nn] = aj;
        for (int c = 0; c < 3; ++c) {
          dv[nn][c] = v[3 * j + c] - v[3 * L + c];
          dm[nn][c] = vm[3 * j + c] - vm[3 * L + c];
          dx[nn][c] = lag ? x[3 * j + c] - x[3 * L + c] : 0.0;
        }
        lnn[nn] = gnn[nn][0] = gnn[nn][1] = gnn[nn][2] = 0.0;
        if (taylor) rk_taylor_piece(dim, A, L, c0, c1, c2, aj, inv_aj, inv_l, hq, &lnn[nn], gnn[nn]);
      }
      for (int g = 0; g < ng; ++g) {
        const ej_real gx = gcx[g][0], gy = gcx[g][1], gz = gcx[g][2], gr = grx[g];
        const int all = taylor & gfl[g];
        int in[RK_CHUNK];
        for (int t = 0; t < nn; ++t) {
          const ej_real e0 = cx[t] + gx, e1 = cy[t] + gy, e2 = cz[t] + gz, rr = aa[t] + gr;
          in[t] = all | (e0 * e0 + e1 * e1 + e2 * e2 < rr * rr);
        }
        int c = 0;
        for (int t = 0; t < nn; ++t) lst[g][c] = t, c += in[t];
        cnt[g] = c;
      }
      for (int g = 0; g < ng; ++g) {
        const int p0 = 4 * g;
        ej_real o0[4], o1[4], o2[4], e0[4], e1[4], e2[4], e3[4], ef[4], r0[4], r1[4], r2[4];
        ej_real u0[4], u1[4], u2[4], n0[4], n1[4], n2[4], x0[4], x1[4], x2[4];
        for (int l = 0; l < 4; ++l) {
          const int f = p0 + l;
          o0[l] = hq0[f], o1[l] = hq1[f], o2[l] = hq2[f];
          e0[l] = b0[f], e1[l] = b1[f], e2[l] = b2[f], e3[l] = b3[f], ef[l] = fl[f];
          r0[l] = q0[f], r1[l] = q1[f], r2[l] = q2[f];
          u0[l] = up[0][f], u1[l] = up[1][f], u2[l] = up[2][f];
          n0[l] = um[0][f], n1[l] = um[1][f], n2[l] = um[2][f];
          x0[l] = ux[0][f], x1[l] = ux[1][f], x2[l] = ux[2][f];
        }
        for (int t = 0; t < cnt[g]; ++t) {
          const int jn = lst[g][t];
          const ej_real c0 = cx[jn], c1 = cy[jn], c2 = cz[jn], inv_aj = ia[jn];
          const ej_real ln = lnn[jn], gn0 = gnn[jn][0], gn1 = gnn[jn][1], gn2 = gnn[jn][2];
          const ej_real dv0 = dv[jn][0], dv1 = dv[jn][1], dv2 = dv[jn][2];
          const ej_real dm0 = dm[jn][0], dm1 = dm[jn][1], dm2 = dm[jn][2];
          const ej_real dx0 = dx[jn][0], dx1 = dx[jn][1], dx2 = dx[jn][2];
#pragma omp simd
          for (int l = 0; l < 4; ++l) {
            const ej_real d0 = c0 + o0[l], d1 = dim > 1 ? c1 + o1[l] : 0.0, d2 = dim > 2 ? c2 + o2[l] : 0.0;
            const ej_real w = rk_phi_bl(sqrt(d0 * d0 + d1 * d1 + d2 * d2) * inv_aj);
            ej_real psi = (e0[l] + e1[l] * d0 + (dim > 1 ? e2[l] * d1 : 0.0) + (dim > 2 ? e3[l] * d2 : 0.0)) * w;
            if (taylor) psi += ef[l] * (ln - gn0 * r0[l] - gn1 * r1[l] - gn2 * r2[l]);
            u0[l] += psi * dv0, u1[l] += psi * dv1, u2[l] += psi * dv2;
            n0[l] += psi * dm0, n1[l] += psi * dm1, n2[l] += psi * dm2;
            if (lag) x0[l] += psi * dx0, x1[l] += psi * dx1, x2[l] += psi * dx2;
          }
        }
        for (int l = 0; l < 4; ++l) {
          const int f = p0 + l;
          up[0][f] = u0[l], up[1][f] = u1[l], up[2][f] = u2[l];
          um[0][f] = n0[l], um[1][f] = n1[l], um[2][f] = n2[l];
          ux[0][f] = x0[l], ux[1][f] = x1[l], ux[2][f] = x2[l];
        }
      }
    }
    ej_real *gp = Gp + 9 * L, *gm = Gm + 9 * kb;
    ej_real gpx[RK_NS_MAX][9], gmx[RK_NS_MAX][9], fx[9];
    memset(gpx, 0, sizeof gpx);
    memset(gmx, 0, sizeof gmx);
    for (int q = 0; q < 9; ++q) gp[q] = gm[q] = fx[q] = 0.0;
    const ej_real cb = 1.0 / ((ej_real)(1 << (dim - 1)) * h), cs = 2.0 / h; /* A_f/V_L, A_f/V_xi */
    for (int f = 0; f < nf; ++f) {
      const int nd = s->fnd[f], p = s->gpos[f];
      if (s->fout[f]) {
        const ej_real sg = s->fsgn[f];
        const int xi = s->fsub_m[f];
        for (int c = 0; c < 3; ++c) {
          gp[3 * c + nd] += cb * sg * up[c][p];
          gm[3 * c + nd] += cb * sg * um[c][p];
          if (lag) fx[3 * c + nd] += cb * sg * ux[c][p];
          gpx[xi][3 * c + nd] += cs * sg * up[c][p];
          gmx[xi][3 * c + nd] += cs * sg * um[c][p];
        }
      } else {
        const int xm = s->fsub_m[f], xp = s->fsub_p[f];
        for (int c = 0; c < 3; ++c) {
          gpx[xm][3 * c + nd] += cs * up[c][p];
          gmx[xm][3 * c + nd] += cs * um[c][p];
          gpx[xp][3 * c + nd] -= cs * up[c][p];
          gmx[xp][3 * c + nd] -= cs * um[c][p];
        }
      }
    }
    if (fbs[L]) { /* fallback: no gradient, no deformation */
      for (int q = 0; q < 9; ++q) gp[q] = gm[q] = fx[q] = 0.0;
      memset(gpx, 0, sizeof gpx);
      memset(gmx, 0, sizeof gmx);
      if (lag)
        for (int c = 0; c < 3; ++c) fx[4 * c] = 1.0;
    }
    if (dGp)
      for (int xi = 0; xi < ns; ++xi)
        for (int q = 0; q < 9; ++q) {
          dGp[(size_t)(kb * RK_NS_MAX + xi) * 9 + q] = fbs[L] ? 0.0 : gpx[xi][q] - gp[q];
          dGm[(size_t)(kb * RK_NS_MAX + xi) * 9 + q] = fbs[L] ? 0.0 : gmx[xi][q] - gm[q];
        }
    if (lag) {
      for (int q = 0; q < 9; ++q) Fx[9 * L + q] = fx[q];
      /* x^h - x_L is a relative position: its gradient is F itself (sum_outer n_f A_f = 0). */
      for (int c = dim; c < 3; ++c) Fx[9 * L + 4 * c] = 1.0;
    }
  }
}

/* Packed sub-box stresses: Voigt component k of sub-box xi is entry 6 xi + k of the nss
 * TENSOR9 fields rk_ss0.. (9 entries each). */
static inline void rk_ss_get(ej_real *const *ssf, ej_idx i, int ns, ej_real out[RK_NS_MAX][6])
{
  for (int xi = 0; xi < ns; ++xi)
    for (int k = 0; k < 6; ++k) {
      const int e = 6 * xi + k;
      out[xi][k] = ssf[e / 9][9 * i + e % 9];
    }
}
static inline void rk_ss_put(ej_real *const *ssf, ej_idx i, int ns, ej_real in[RK_NS_MAX][6])
{
  for (int xi = 0; xi < ns; ++xi)
    for (int k = 0; k < 6; ++k) {
      const int e = 6 * xi + k;
      ssf[e / 9][9 * i + e % 9] = in[xi][k];
    }
}

/* MSNNI end of pass 1 at node L: stress power, sub-box stabilisation stresses and face
 * tractions.
 * Sub-box stabilisation (003 Eq 46 applied incrementally, digest 003 section 1.7 and errata
 * item 5: a force term, not a matrix added to M): per sub-box xi a stabilisation stress,
 *   sigma_s,xi <- Q sigma_s,xi Q^T + w E : sym(G_xi - G_L) dt   (semi-Lagrangian, Hughes-Winget Q)
 *   sigma_s,xi <- sigma_s,xi + w E : sym(Fdot_xi - Fdot_L) dt    (Lagrangian, reference frame),
 * E isotropic elastic (K, G). The internal force of node I is then
 *   f_I = -sum_L [V_L S_L Gbar_I(L) + sum_xi V_xi sigma_s,xi (Gbar_I(xi) - Gbar_I(L))]
 *       = -sum_L sum_f Psi_I(x_f) T_f(L),   (S = sigma, or P = J sigma F^-T Lagrangian)
 *   outer f: T_f = A_f (S_L - mean_xi sigma_s,xi + sigma_s,xi(f)) n_f,
 *   inner f: T_f = A_f (sigma_s,xi- - sigma_s,xi+) e_nd,
 * and the power of T against the interpolated velocities is V_L S:G_L + sum_xi V_xi
 * sigma_s,xi : (G_xi - G_L): that is e_dot, so energy is conserved by the semi-discrete system,
 * and sum_I f_I = -sum_L sum_f T_f = 0 (closed box and sub-boxes, partition of unity). */
static inline void rk_box_close(const rk_state *s, ej_idx i, ej_idx kb, const ej_real *t6, const ej_real *Pl,
                                const ej_real *G, const ej_real *dGp, const ej_real *dGm, const ej_real *Q,
                                ej_real *const *ssf, ej_real m, ej_real rho, ej_real vol0, ej_real c, int32_t id,
                                int dead, ej_real dt, ej_real w, ej_real *e_dot, ej_real *w_dot)
{
  const int D = s->dim, ns = s->ns, nf = s->nf;
  const ej_real h = rk_hbox(s, m, rho, vol0);
  const ej_real V = D == 3 ? h * h * h : D == 2 ? h * h : h, Af = V / ((ej_real)(1 << (D - 1)) * h);
  ej_real S[9];
  if (Pl) ej_m3_copy(S, Pl);
  else ej_s6_to_m3(S, t6);
  ej_real *T = s->ft + (size_t)id * RK_NF_MAX * 3;
  if (dead) { /* fallback or failed: no stress divergence from this node */
    for (int q = 0; q < 3 * RK_NF_MAX; ++q) T[q] = 0.0;
    return;
  }
  ej_real pw = 0.0;
  for (int q = 0; q < 9; ++q) pw += S[q] * G[q];
  *e_dot += V * pw / m;
  ej_real ss[RK_NS_MAX][6], sm[9] = {0};
  if (s->sub) {
    rk_ss_get(ssf, i, ns, ss);
    ej_real K = s->K, Gs = s->G;
    if (!s->mat) K = rho * c * c, Gs = 0.0;
    const ej_real lam = K - 2.0 * Gs / 3.0;
    ej_real ps = 0.0;
    for (int xi = 0; xi < ns; ++xi) {
      ej_real dp[6];
      ej_m3_sym(dp, dGp + (size_t)(kb * RK_NS_MAX + xi) * 9);
      if (s->smat) { /* stored: D_xi = sub-box stress - node stress (rk_subbox_material) */
        for (int k = 0; k < 6; ++k) ss[xi][k] *= w;
      } else {
        if (!s->lagrangian) ej_s6_rotate(ss[xi], Q, ss[xi]);
        ej_real de[6];
        ej_m3_sym(de, dGm + (size_t)(kb * RK_NS_MAX + xi) * 9);
        if (s->sdev) { /* deviatoric part only: 2 G dev(de) */
          ej_real dd[6];
          ej_s6_dev(dd, de);
          for (int k = 0; k < 6; ++k) ss[xi][k] += w * dt * 2.0 * Gs * dd[k];
        } else {
          const ej_real tr = ej_s6_trace(de);
          for (int k = 0; k < 6; ++k) ss[xi][k] += w * dt * (2.0 * Gs * de[k] + (k < 3 ? lam * tr : 0.0));
        }
      }
      ps += ej_s6_ddot(ss[xi], dp);
      ej_real sx[9];
      ej_s6_to_m3(sx, ss[xi]);
      for (int q = 0; q < 9; ++q) sm[q] += sx[q] / ns;
    }
    if (!s->smat) rk_ss_put(ssf, i, ns, ss);
    ps *= V / ns / m;
    *e_dot += ps;
    *w_dot += ps;
  }
  for (int f = 0; f < nf; ++f) {
    const int nd = s->fnd[f];
    ej_real tf[3];
    if (s->fout[f]) {
      const ej_real sc = Af * s->fsgn[f];
      for (int c = 0; c < 3; ++c) tf[c] = sc * (S[3 * c + nd] - sm[3 * c + nd]);
      if (s->sub) {
        const ej_real *x6 = ss[s->fsub_m[f]];
        const ej_real col[3] = {nd == 0 ? x6[0] : nd == 1 ? x6[3] : x6[5], nd == 0 ? x6[3] : nd == 1 ? x6[1] : x6[4],
                                nd == 0 ? x6[5] : nd == 1 ? x6[4] : x6[2]};
        for (int c = 0; c < 3; ++c) tf[c] += sc * col[c];
      }
    } else {
      for (int c = 0; c < 3; ++c) tf[c] = 0.0;
      if (s->sub) {
        const ej_real *a6 = ss[s->fsub_m[f]], *b6 = ss[s->fsub_p[f]];
        ej_real dd6[6];
        for (int k = 0; k < 6; ++k) dd6[k] = a6[k] - b6[k];
        const ej_real col[3] = {nd == 0 ? dd6[0] : nd == 1 ? dd6[3] : dd6[5],
                                nd == 0 ? dd6[3] : nd == 1 ? dd6[1] : dd6[4],
                                nd == 0 ? dd6[5] : nd == 1 ? dd6[4] : dd6[2]};
        for (int c = 0; c < 3; ++c) tf[c] = Af * col[c];
      }
    }
    for (int c = 0; c < 3; ++c) T[c * RK_NF_MAX + s->gpos[f]] = tf[c]; /* padded position */
  }
}

/* MSNNI sub-box stresses through the strength model (msnni_stress: material, semi-Lagrangian).
 * 003 Eq 46 adds w sum_xi V_xi (Bbar_I(xi) - Bbar_I(L))^T E (eps_xi - eps_L); applied
 * incrementally (digest 003 section 1.7) with a fixed elastic E this is a spring that no yield
 * surface limits: in a flowing granular bed it stores a large part of the impact energy and
 * gives it back (validation/sphere_drop: the ball was thrown out). Here each sub-box xi carries
 * its own stress sigma_xi, updated by the set's strength model from the rotated
 *   sigma_xi^n = Q (sigma_L^n + D_xi^n) Q^T
 * with the sub-box rate of deformation d_xi = sym(G_L + (G_xi - G_L)) (mid-step velocities),
 * the node's density, energy, EOS pressure and copies of its history variables at t_n;
 * D_xi^n+1 = sigma_xi^n+1 - sigma_L^n+1 is stored (fields rk_ss*, unweighted) and the
 * stabilisation stress is sigma_s,xi = w D_xi. For a linear elastic material this is exactly the
 * incremental Eq 46 (sigma_xi - sigma_L grows by E : (d_xi - d_L) dt); for a yielding material the
 * sub-box stress stays on the yield surface, so the stabilisation is bounded by the strength and
 * dissipates in plastic flow (its power goes to w_hg as before: the energy budget is exact).
 * Approximation: the sub-boxes share the node's hardening/damage history (not stored per
 * sub-box: the core has 64 fields per set).
 * msnni_part deviatoric (default): d_xi = d_L + dev(sym(G_xi - G_L)) and D_xi is stored trace-free,
 * so the stabilisation resists only the deviatoric sub-box modes (B-bar-like selective treatment,
 * Hughes IJNME 15 (1980) 1413). With the full Eq 46 the 8 sub-boxes per node each carry a
 * volumetric constraint; under isochoric plastic flow (dp_damage with psi = 0) their pressure
 * grows elastically (K) with no yield limit and locks the bed: validation/sphere_drop h = 300 mm,
 * 15 ms: 3.5 mm (full) vs 13.3 mm (deviatoric). */
/* Position of i in a sorted list row of n entries, or -1. */
static inline ej_idx rk_row_find(const ej_idx *restrict row, ej_idx n, ej_idx i)
{
  ej_idx lo = 0, hi = n; /* rows are sorted ascending (plugin.h) */
  while (lo < hi) {
    const ej_idx mid = lo + (hi - lo) / 2;
    if (row[mid] < i) lo = mid + 1;
    else hi = mid;
  }
  return lo < n && row[lo] == i ? lo : -1;
}

/* Force scatter of a fused node L (semi-Lagrangian box integration), right after its face
 * tractions T_f(L) are known (rk_box_close): its share of every nodal force,
 *   c_J(L) = sum_f Psi_J(x_f(L)) T_f(L),  Psi_J(x_f) = (b0_f + b_f . (x_f - x_J)/l) phi_J(x_f - x_J),
 * for J = L (t = 0, into self) and for the owned neighbours J of its list row (t >= 1, into the
 * entry of L in J's row, fsc[off[J] + frev[k]], so that pass 2 reads its own row in order), from
 * the kernel values and group lists its fused sweep kept (K). A flagged
 * face point takes the node's Taylor form (rk_taylor_parts), whose group sums every neighbour, as
 * in the fused interpolation. The same Psi_J(x_f) as the gather of rk_box_force_rows: pass 2 then
 * sums f_I = -sum_L c_I(L) (sums in another order: results differ from the gather at round-off). */
static inline RK_ALWAYS_INLINE void rk_box_scatter_node(const int dim, const rk_state *s, const rk_args *A,
                                                      const ej_real *restrict hb, const int32_t *restrict id,
                                                      ej_idx L, const rk_keep *restrict K, ej_idx n_owned)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra;
  const ej_off k0 = A->off[L] - 1;
  const int ng = s->ng, nn = K->nn;
  const ej_real hq = 0.25 * hb[L], inv_l = 1.0 / ra[L];
  const ej_real *restrict q0 = s->gq[0], *restrict q1 = s->gq[1], *restrict q2 = s->gq[2];
  const ej_real *restrict row = s->fb + (size_t)id[L] * RK_NF_MAX * 4;
  const ej_real *restrict T = s->ft + (size_t)id[L] * RK_NF_MAX * 3;
  const bool taylor = s->fflag[id[L]] > 0;
  ej_real cx[RK_NB_FUSE], cy[RK_NB_FUSE], cz[RK_NB_FUSE];
  ej_real F[RK_NB_FUSE][3][4]; /* lane-wise partial sums (vertical SIMD), reduced at the end */
  ej_real lnn[RK_NB_FUSE], gnn[RK_NB_FUSE][3];
  for (int t = 0; t < nn; ++t) {
    const ej_idx j = t == 0 ? L : A->idx[k0 + t];
    cx[t] = X[3 * L] - X[3 * j];
    cy[t] = dim > 1 ? X[3 * L + 1] - X[3 * j + 1] : 0.0;
    cz[t] = dim > 2 ? X[3 * L + 2] - X[3 * j + 2] : 0.0;
    for (int c = 0; c < 3; ++c)
      for (int l = 0; l < 4; ++l) F[t][c][l] = 0.0;
    lnn[t] = gnn[t][0] = gnn[t][1] = gnn[t][2] = 0.0;
    if (taylor) rk_taylor_piece(dim, A, L, cx[t], cy[t], cz[t], ra[j], 1.0 / ra[j], inv_l, hq, &lnn[t], gnn[t]);
  }
  for (int g = 0, it = 0; g < ng; it += K->cnt[g], ++g) {
    const int p0 = 4 * g;
    ej_real o0[4], o1[4], o2[4], e0[4], e1[4], e2[4], e3[4], ef[4], r0[4], r1[4], r2[4], t0[4], t1[4], t2[4];
    int gf = 0;
    for (int l = 0; l < 4; ++l) {
      const int f = p0 + l;
      const bool flg = row[f] < 0.0;
      gf |= flg;
      o0[l] = hq * q0[f], o1[l] = hq * q1[f], o2[l] = hq * q2[f];
      r0[l] = q0[f], r1[l] = q1[f], r2[l] = q2[f];
      e0[l] = flg ? 0.0 : row[f], ef[l] = flg ? 1.0 : 0.0;
      e1[l] = row[RK_NF_MAX + f] * inv_l, e2[l] = row[2 * RK_NF_MAX + f] * inv_l, e3[l] = row[3 * RK_NF_MAX + f] * inv_l;
      t0[l] = T[f], t1[l] = T[RK_NF_MAX + f], t2[l] = T[2 * RK_NF_MAX + f];
    }
    if (!(taylor && gf)) {
      /* The fused interpolation left Psi_J(x_f) itself in the kept values of these groups. */
      const int *restrict lg = K->lst[g];
      for (int t = 0; t < K->cnt[g]; ++t) {
        const int jn = lg[t];
        const ej_real *restrict psi = K->wk[it + t];
        ej_real *restrict F0 = F[jn][0], *restrict F1 = F[jn][1], *restrict F2 = F[jn][2];
#pragma omp simd
        for (int l = 0; l < 4; ++l) F0[l] += psi[l] * t0[l], F1[l] += psi[l] * t1[l], F2[l] += psi[l] * t2[l];
      }
    } else {
      static const ej_real zero4[4] = {0.0, 0.0, 0.0, 0.0};
      int q = 0; /* position in the group's list */
      for (int t = 0; t < nn; ++t) {
        const int hit = q < K->cnt[g] && K->lst[g][q] == t;
        const ej_real *restrict w = hit ? K->wk[it + q] : zero4;
        q += hit;
        const ej_real c0 = cx[t], c1 = cy[t], c2 = cz[t];
        const ej_real ln = lnn[t], gn0 = gnn[t][0], gn1 = gnn[t][1], gn2 = gnn[t][2];
        ej_real *restrict F0 = F[t][0], *restrict F1 = F[t][1], *restrict F2 = F[t][2];
#pragma omp simd
        for (int l = 0; l < 4; ++l) {
          const ej_real d0 = c0 + o0[l], d1 = dim > 1 ? c1 + o1[l] : 0.0, d2 = dim > 2 ? c2 + o2[l] : 0.0;
          ej_real psi = (e0[l] + e1[l] * d0 + (dim > 1 ? e2[l] * d1 : 0.0) + (dim > 2 ? e3[l] * d2 : 0.0)) * w[l];
          psi += ef[l] * (ln - gn0 * r0[l] - gn1 * r1[l] - gn2 * r2[l]);
          F0[l] += psi * t0[l], F1[l] += psi * t1[l], F2[l] += psi * t2[l];
        }
      }
    }
  }
  ej_real *restrict self = s->fself + 3 * (size_t)L, *restrict fsc = s->fsc;
  const int32_t *restrict frev = s->frev;
  for (int c = 0; c < 3; ++c) self[c] = (F[0][c][0] + F[0][c][1]) + (F[0][c][2] + F[0][c][3]);
  for (int t = 1; t < nn; ++t) {
    const ej_off k = k0 + t;
    const ej_idx J = A->idx[k];
    if (J >= n_owned) continue; /* a ghost image: its source gathers through the image of L */
    ej_real *restrict dst = fsc + 3 * ((size_t)A->off[J] + (size_t)frev[k]);
    for (int c = 0; c < 3; ++c) dst[c] = (F[t][c][0] + F[t][c][1]) + (F[t][c][2] + F[t][c][3]);
  }
}

/* frev of row L after a list build: for each owned neighbour J = idx[k], the position of L in
 * J's row (binary search; the lists are symmetric, plugin.h). Returns 0 if one is missing. */
static int rk_frev_row(const rk_args *A, int32_t *restrict frev, ej_idx L, ej_idx n_owned)
{
  for (ej_off k = A->off[L]; k < A->off[L + 1]; ++k) {
    const ej_idx J = A->idx[k];
    if (J >= n_owned) continue;
    const ej_idx pos = rk_row_find(A->idx + A->off[J], (ej_idx)(A->off[J + 1] - A->off[J]), L);
    if (pos < 0) return 0;
    frev[k] = (int32_t)pos;
  }
  return 1;
}

#define RK_SCATTER_DIM(D)                                                                                        \
  static RK_NOINLINE void rk_box_scatter_node##D(const rk_state *s, const rk_args *A, const ej_real *hb,        \
                                                 const int32_t *id, ej_idx L, const rk_keep *K, ej_idx n_owned) \
  {                                                                                                              \
    rk_box_scatter_node(D, s, A, hb, id, L, K, n_owned);                                                         \
  }
RK_SCATTER_DIM(1)
RK_SCATTER_DIM(2)
RK_SCATTER_DIM(3)

#define RK_SB_NODES 8 /* nodes per sub-box material batch (stack scratch) */
static ej_err rk_subbox_material(const rk_state *s, ej_range rb, const ej_real *sgn, const ej_real *sg,
                                 const ej_real *Gm, const ej_real *dGm, const ej_real *Qs, ej_real *const *ssf,
                                 const ej_real *rho, const ej_real *e, const ej_real *peos,
                                 const ej_real hsn[RK_MAX_HIST][RK_BLOCK], int nh,
                                 const int32_t *failed, const int32_t *fbs, ej_real dt)
{
  enum { NP = RK_SB_NODES * RK_NS_MAX };
  const int ns = s->ns;
  for (ej_idx n0 = rb.begin; n0 < rb.end; n0 += RK_SB_NODES) {
    const ej_idx n1 = n0 + RK_SB_NODES < rb.end ? n0 + RK_SB_NODES : rb.end;
    ej_real st[NP * 6], dx[NP * 6], rh[NP], ee[NP], pp[NP], cc[NP];
    ej_real hv[RK_MAX_HIST][NP];
    ej_real *hp[RK_MAX_HIST];
    int32_t fl[NP];
    for (int k = 0; k < nh; ++k) hp[k] = hv[k];
    for (ej_idx i = n0; i < n1; ++i) {
      const ej_idx kb = i - rb.begin;
      ej_real ss[RK_NS_MAX][6];
      rk_ss_get(ssf, i, ns, ss);
      for (int xi = 0; xi < ns; ++xi) {
        const int j = (int)(i - n0) * ns + xi;
        ej_real t[6], g[9];
        ej_s6_rotate(t, Qs + 9 * kb, ss[xi]);
        for (int k = 0; k < 6; ++k) st[6 * j + k] = sgn[6 * kb + k] + t[k];
        const ej_real *dg = dGm + (size_t)(kb * RK_NS_MAX + xi) * 9;
        if (s->sdev) { /* d_xi = d_L + dev(sym(G_xi - G_L)): the node's volumetric rate */
          ej_real dl[6], dd6[6];
          ej_m3_sym(dl, Gm + 9 * kb);
          ej_m3_sym(dd6, dg);
          const ej_real tr3 = (dd6[0] + dd6[1] + dd6[2]) / 3.0;
          for (int k = 0; k < 6; ++k) dx[6 * j + k] = dl[k] + dd6[k] - (k < 3 ? tr3 : 0.0);
        } else {
          for (int q = 0; q < 9; ++q) g[q] = Gm[9 * kb + q] + dg[q];
          ej_m3_sym(dx + 6 * j, g);
        }
        rh[j] = rho[i], ee[j] = e[i], pp[j] = s->eos ? peos[kb] : 0.0, fl[j] = failed[i]; /* the node's EOS pressure */
        for (int k = 0; k < nh; ++k) hv[k][j] = hsn[k][kb]; /* node history at t_n */
      }
    }
    ej_mat_batch b = {.n = (n1 - n0) * ns,
                      .dt = dt,
                      .rho = rh,
                      .e = ee,
                      .d = dx,
                      .F = NULL,
                      .p = s->eos ? pp : NULL,
                      .stress = st,
                      .hist = hp,
                      .c = cc,
                      .w_plastic = NULL,
                      .failed = fl};
    EJ_TRY(ej_material_update(s->mat, &b));
    for (ej_idx i = n0; i < n1; ++i) {
      ej_real ss[RK_NS_MAX][6];
      const bool dead = failed[i] || fbs[i];
      for (int xi = 0; xi < ns; ++xi) {
        const int j = (int)(i - n0) * ns + xi;
        for (int k = 0; k < 6; ++k) ss[xi][k] = dead ? 0.0 : st[6 * j + k] - sg[6 * i + k];
        if (s->sdev) ej_s6_dev(ss[xi], ss[xi]); /* keep the deviator of D_xi (a dilatant return can shift the mean stress) */
      }
      rk_ss_put(ssf, i, ns, ss);
    }
  }
  return EJ_OK;
}

static ej_err rk_pass_material(rk_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': rkpm neighbour list too short", s->set_name);
  rk_args A = {.X = ej_set_field(set, s->lagrangian ? "x0" : "x"),
               .x = ej_set_field(set, s->ess_on && s->lagrangian ? "rk_xc" : "x"),
               .v = ej_set_field(set, s->ess_on ? "rk_vc" : "v"),
               .vm = ej_set_field(set, "rk_vmid"),
               .ra = ej_set_field(set, "rk_a"),
               .m0 = ej_set_field(set, "rk_m0"),
               .m1 = ej_set_field(set, "rk_m1"),
               .m2 = ej_set_field(set, "rk_m2"),
               .gv = ej_set_field(set, "rk_gv"),
               .rk_s = ej_set_field(set, "rk_s"),
               .fb = ej_set_field_int(set, "rk_fallbacks"),
               .fb_step = ej_set_field_int(set, "rk_fb_step"),
               .off = nbr->off,
               .idx = nbr->idx,
               .tol = s->cfg.rcond_min,
               .lag = s->lagrangian};
  ej_real *rho = ej_set_field(set, "rho"), *e = ej_set_field(set, "e"), *p = ej_set_field(set, "p");
  ej_real *c = ej_set_field(set, "c"), *sg = ej_set_field(set, "stress"), *dd = ej_set_field(set, "rk_d");
  ej_real *rho_dot = ej_set_field(set, "rho_dot"), *e_dot = ej_set_field(set, "e_dot");
  ej_real *w_dot = ej_set_field(set, "w_hg_dot");
  ej_real *wpl_inc = ej_set_field(set, "rk_wpl"), *wpl = ej_set_field(set, "w_plastic");
  ej_real *F = ej_set_field(set, "F"), *P = ej_set_field(set, "rk_P");
  int32_t *failed = ej_set_field_int(set, "failed");
  const ej_real *m = ej_set_field(set, "m");
  EJ_ENSURE(A.X && A.x && A.v && A.vm && A.ra && A.m0 && A.m1 && A.m2 && A.gv && A.rk_s && A.fb && A.fb_step && rho && e &&
                p && c && sg && dd && rho_dot &&
                e_dot && w_dot && wpl_inc && wpl && failed && m && (!s->lagrangian || (F && P)),
            EJ_ERR_INTERNAL, "set '%s': rkpm fields missing", s->set_name);
  const ej_real dt = ej_set_dt(set);
  ej_real *hist[RK_MAX_HIST];
  const int nh = ej_set_hist(set, hist, RK_MAX_HIST);
  EJ_ENSURE(nh <= RK_MAX_HIST, EJ_ERR_UNSUPPORTED, "set '%s': %d history variables (rkpm handles %d)", s->set_name,
            nh, RK_MAX_HIST);
  const int32_t *id = ej_set_field_int(set, "id"), *fbs = ej_set_field_int(set, "rk_fb_step");
  const ej_real *vol0 = ej_set_field(set, "vol0"), *hb = ej_set_field(set, "rk_hb");
  ej_real *ssf[6] = {NULL};
  if (s->box) {
    static const char *const ssn[] = {"rk_ss0", "rk_ss1", "rk_ss2", "rk_ss3", "rk_ss4", "rk_ss5"};
    EJ_ENSURE(id && fbs && vol0 && hb, EJ_ERR_INTERNAL, "set '%s': rkpm msnni fields missing", s->set_name);
    if (s->sub)
      for (int k = 0; k < s->nss; ++k) {
        ssf[k] = ej_set_field(set, ssn[k]);
        EJ_ENSURE(ssf[k], EJ_ERR_INTERNAL, "set '%s': rkpm field %s missing", s->set_name, ssn[k]);
      }
  }
  /* Elastic part of the tangent for the sub-box stabilisation (003 Eq 46: "E"): the strength
   * model's initial moduli, or the EOS bulk modulus rho c^2 of a fluid (no shear). */
  const ej_real wst = s->cfg.msnni_w;
  /* Force scatter (semi-Lagrangian box integration): this thread's keep arena, sized in pass 0
   * for the team; blocks of RK_BLOCK_SL nodes so that the kept kernel values stay in cache. */
  const bool scat = s->box && !s->lagrangian && s->cfg.force_scatter;
  rk_keep *keep = NULL;
  if (scat) {
#ifdef _OPENMP
    const int tid = omp_get_thread_num();
#else
    const int tid = 0;
#endif
    EJ_ENSURE(s->fscat && s->fself && nbr->off[r.end] <= (ej_off)s->fsc_cap && (size_t)r.end <= s->own_cap,
              EJ_ERR_INTERNAL, "set '%s': rkpm force scatter not sized in pass 0", s->set_name);
    keep = tid < s->nkeep ? s->keep + (size_t)tid * RK_BLOCK_SL : NULL;
    /* A team larger than pass 0's (not done by the core): these rows take the gather of pass 2. */
    if (!keep) memset(s->fscat + r.begin, 0, (size_t)(r.end - r.begin));
    /* After a list build (or a regrow) the rows' frev is made again, every row of the range. */
    if (s->frev_build != ej_set_list_builds(set))
      for (ej_idx L = r.begin; L < r.end; ++L)
        EJ_ENSURE(rk_frev_row(&A, s->frev, L, nbr->n_rows), EJ_ERR_INTERNAL,
                  "set '%s': rkpm force scatter: neighbour list not symmetric at row %ld", s->set_name, (long)L);
  }
  const ej_idx blk = scat ? RK_BLOCK_SL : RK_BLOCK;
  for (ej_idx b0 = r.begin; b0 < r.end; b0 += blk) {
    const ej_range rb = {b0, b0 + blk < r.end ? b0 + blk : r.end};
    const ej_idx nb = rb.end - rb.begin;
    ej_real Gm[9 * RK_BLOCK], Qs[9 * RK_BLOCK];
    ej_real dGp[RK_BLOCK * RK_NS_MAX * 9], dGm[RK_BLOCK * RK_NS_MAX * 9];
    if (s->box) {
      ej_real *dp = s->sub ? dGp : NULL, *dmm = s->sub ? dGm : NULL;
      switch (s->dim * 2 + (int)s->lagrangian) {
      case 2: rk_box_grad_rows(1, false, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, keep); break;
      case 3: rk_box_grad_rows(1, true, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, NULL); break;
      case 4: rk_box_grad_rows(2, false, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, keep); break;
      case 5: rk_box_grad_rows(2, true, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, NULL); break;
      case 6: rk_box_grad_rows(3, false, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, keep); break;
      default: rk_box_grad_rows(3, true, s, &A, hb, id, fbs, rb, A.gv, Gm, F, dp, dmm, NULL); break;
      }
    } else {
      switch (s->dim * 2 + (int)s->lagrangian) {
      case 2: rk_grad_rows(1, false, &A, rb, A.gv, Gm, F); break;
      case 3: rk_grad_rows(1, true, &A, rb, A.gv, Gm, F); break;
      case 4: rk_grad_rows(2, false, &A, rb, A.gv, Gm, F); break;
      case 5: rk_grad_rows(2, true, &A, rb, A.gv, Gm, F); break;
      case 6: rk_grad_rows(3, false, &A, rb, A.gv, Gm, F); break;
      default: rk_grad_rows(3, true, &A, rb, A.gv, Gm, F); break;
      }
    }
    /* Spatial velocity gradients: L = G (semi-Lagrangian) or dF/dt F^-1 (Lagrangian). */
    ej_real Lp[9 * RK_BLOCK], sgn[6 * RK_BLOCK], hsn[RK_MAX_HIST][RK_BLOCK];
    for (ej_idx i = rb.begin; i < rb.end; ++i) {
      const ej_idx k = i - rb.begin;
      ej_real *lp = Lp + 9 * k, *lm = Gm + 9 * k;
      if (s->lagrangian) {
        ej_real Fi[9], T[9];
        const ej_real rc = ej_m3_inverse(Fi, F + 9 * i);
        const ej_real J = ej_m3_det(F + 9 * i);
        if (rc == 0 || !(J > 0)) return rk_bad(s, set, i, "det F", J);
        ej_m3_mul(lp, A.gv + 9 * i, Fi);
        ej_m3_mul(T, lm, Fi);
        ej_m3_copy(lm, T);
      } else {
        ej_m3_copy(lp, A.gv + 9 * i);
      }
      /* Hughes-Winget rotation of the stress at t_n with the mid-step spin (tensor.h). */
      ej_real w[9], Q[9];
      ej_m3_skew(w, lm);
      if (!ej_hughes_winget(Q, w, dt)) return rk_bad(s, set, i, "Hughes-Winget factor, spin norm", ej_m3_norm(w));
      ej_s6_rotate(sg + 6 * i, Q, sg + 6 * i);
      for (int q = 0; q < 6; ++q) sgn[6 * k + q] = sg[6 * i + q];
      ej_m3_copy(Qs + 9 * k, Q);
      ej_m3_sym(dd + 6 * i, lm);
    }
    if (s->eos) EJ_TRY(ej_eos_evaluate_set(s->eos, set, rb, rho + rb.begin, e + rb.begin, p + rb.begin, c + rb.begin));
    /* the EOS pressure, for the sub-box updates (p is the node's -tr(sigma)/3 once the material has run:
     * a strength model that adds to it, jh2's bulking, would otherwise count twice there) */
    ej_real peos[RK_BLOCK];
    if (s->smat && s->eos) /* read only there: with an EOS (the sub-boxes pass .p = NULL without one) */
      for (ej_idx i = rb.begin; i < rb.end; ++i) peos[i - rb.begin] = p[i];
    if (s->mat) {
      ej_real *hb[RK_MAX_HIST];
      for (int k = 0; k < nh; ++k) hb[k] = hist[k] + rb.begin;
      ej_real cm[RK_BLOCK];
      ej_mat_batch b = {.n = nb,
                        .dt = dt,
                        .rho = rho + rb.begin,
                        .e = e + rb.begin,
                        .d = dd + 6 * (size_t)rb.begin,
                        .F = s->lagrangian ? F + 9 * (size_t)rb.begin : NULL,
                        .p = s->eos ? p + rb.begin : NULL,
                        .stress = sg + 6 * (size_t)rb.begin,
                        .hist = hb,
                        .c = cm,
                        .w_plastic = wpl_inc + rb.begin,
                        .failed = failed + rb.begin};
      for (ej_idx k = 0; k < nb; ++k) wpl_inc[rb.begin + k] = 0.0;
      if (s->smat) /* history at t_n: the start state of the sub-box updates */
        for (int k = 0; k < nh; ++k)
          for (ej_idx q = 0; q < nb; ++q) hsn[k][q] = hist[k][rb.begin + q];
      /* A point that failed earlier stays failed: the material is told by the flag. */
      EJ_TRY(ej_material_update(s->mat, &b));
      for (ej_idx k = 0; k < nb; ++k) {
        const ej_idx i = rb.begin + k;
        c[i] = s->eos ? fmax(c[i], cm[k]) : cm[k];
        wpl[i] += wpl_inc[i];
      }
    } else {
      for (ej_idx i = rb.begin; i < rb.end; ++i) {
        ej_real *t = sg + 6 * i;
        t[0] = t[1] = t[2] = -p[i];
        t[3] = t[4] = t[5] = 0.0;
      }
    }
    for (ej_idx i = rb.begin; i < rb.end; ++i) {
      ej_real *t = sg + 6 * i;
      if (failed[i]) {
        for (int q = 0; q < 6; ++q) t[q] = 0.0;
      }
      p[i] = -ej_s6_trace(t) / 3.0;
      const ej_real *lp = Lp + 9 * (i - rb.begin);
      ej_real d6[6];
      ej_m3_sym(d6, lp);
      /* Continuity and stress power with the velocities the forces see (the core's predicted
       * v at t_n+1): sum_I f_I.v_I = -sum_L V_L sigma_L : d_L for the semi-discrete system. */
      rho_dot[i] += -rho[i] * ej_s6_trace(d6);
      if (!s->box) e_dot[i] += ej_s6_ddot(t, d6) / rho[i];
      if (s->lagrangian) {
        /* P = J sigma F^-T, J = det F (the nodal volume V0 J). */
        ej_real Fi[9], S[9];
        ej_m3_identity(Fi);
        ej_m3_inverse(Fi, F + 9 * i); /* regular: checked above */
        const ej_real J = ej_m3_det(F + 9 * i);
        ej_s6_to_m3(S, t);
        ej_m3_mul_bt(P + 9 * i, S, Fi);
        for (int q = 0; q < 9; ++q) P[9 * i + q] *= J;
      }
      if (!isfinite(c[i])) return rk_bad(s, set, i, "sound speed c", c[i]);
    }
    if (s->smat)
      EJ_TRY(rk_subbox_material(s, rb, sgn, sg, Gm, dGm, Qs, ssf, rho, e, peos, hsn, nh, failed, fbs, dt));
    for (ej_idx i = rb.begin; i < rb.end && s->box; ++i) {
      rk_box_close(s, i, i - rb.begin, sg + 6 * i, s->lagrangian ? P + 9 * i : NULL, A.gv + 9 * i, dGp, dGm,
                   Qs + 9 * (i - rb.begin), ssf, m[i], rho[i], vol0[i], c[i], id[i], fbs[i] || failed[i], dt, wst,
                   e_dot + i, w_dot + i);
    }
    for (ej_idx L = rb.begin; L < rb.end && keep; ++L) {
      const rk_keep *K = keep + (L - rb.begin);
      s->fscat[L] = (uint8_t)K->fused;
      if (!K->fused) continue;
      switch (s->dim) {
      case 1: rk_box_scatter_node1(s, &A, hb, id, L, K, nbr->n_rows); break;
      case 2: rk_box_scatter_node2(s, &A, hb, id, L, K, nbr->n_rows); break;
      default: rk_box_scatter_node3(s, &A, hb, id, L, K, nbr->n_rows); break;
      }
    }
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ pass 2: forces */

/* Gather form of the Galerkin nodal force (003 Eq 16, nodal quadrature, G and Gbar dropped):
 *   f_I = -sum_L V_L sigma_L grad Psi_I(x_L),
 *   grad Psi_I(x_L) = -(1/a_L) [m1_L + C_L (x_L - x_I)/a_L] phi_I(x_L - x_I)
 * (L = I included). Sum over I of grad Psi_I(x_L) = 0 by the reproducing conditions, so
 * internal forces conserve momentum to round-off.
 * Stabilisation: z_IJ = (v_J - v_I) - (G_I + G_J)/2 (X_J - X_I) vanishes for linear fields;
 *   f_I += sum_J c_IJ z_IJ, c_IJ = alpha rho_ij c_ij h_ij^(dim-1) phi(r/a_ij) 2 / (S_I + S_J),
 * antisymmetric in I, J; its power heats the pair: m_I de_I/dt += 1/2 sum_J c_IJ z_IJ.(v_J - v_I). */
/* The pairwise viscous stabilisation's term of pair (I, J) (rk_force_rows, rk_stab_rows): z = (v_J -
 * v_I) - mean(G) h, h = X_J - X_I, summed from 0 over d; returns the coefficient c_IJ (kernel on the
 * mean support abar). G_J's entry c is Gj[c * gs]. */
static inline RK_ALWAYS_INLINE ej_real rk_stab_pair(const int dim, const ej_real alpha, const ej_real inv_sup,
                                                   const ej_real ai, const ej_real aj, const ej_real r,
                                                   const ej_real rho_sum, const ej_real c_sum, const ej_real rs_sum,
                                                   const ej_real *restrict Gi, const ej_real *restrict Gj, const int gs,
                                                   const ej_real h0, const ej_real h1, const ej_real h2,
                                                   const ej_real dv0, const ej_real dv1, const ej_real dv2,
                                                   ej_real *z0, ej_real *z1, ej_real *z2)
{
  const ej_real abar = 0.5 * (ai + aj);
  const ej_real ws = rk_phi(r / abar);
  /* written out per component (no loop): GCC vectorises rk_stab_rows' pair loop only then */
#define RK_STAB_Z(c, dvc)                                                                                    \
  ((dvc) - ((0.0 + 0.5 * (Gi[3 * (c)] + Gj[3 * (c) * gs]) * h0) +                                            \
            (dim > 1 ? 0.5 * (Gi[3 * (c) + 1] + Gj[(3 * (c) + 1) * gs]) * h1 : 0.0) +                        \
            (dim > 2 ? 0.5 * (Gi[3 * (c) + 2] + Gj[(3 * (c) + 2) * gs]) * h2 : 0.0)))
  *z0 = RK_STAB_Z(0, dv0), *z1 = RK_STAB_Z(1, dv1), *z2 = RK_STAB_Z(2, dv2);
#undef RK_STAB_Z
  const ej_real hb = abar * inv_sup;
  const ej_real hp = dim == 3 ? hb * hb : dim == 2 ? hb : 1.0;
  return alpha * 0.25 * rho_sum * c_sum * hp * ws * 2.0 / rs_sum;
}

static inline RK_ALWAYS_INLINE void rk_force_rows(const int dim, const bool lag, const rk_args *A, ej_range rg)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict v = A->v, *restrict m = A->m;
  const ej_real *restrict rho = A->rho, *restrict vol0 = A->vol0, *restrict cs = A->c, *restrict rs = A->rs;
  const ej_real *restrict m1 = A->m1, *restrict m2 = A->m2, *restrict gv = A->gv;
  const ej_real *restrict S = lag ? A->P : A->stress;
  const ej_real alpha = A->alpha, inv_sup = 1.0 / A->support;
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi[3] = {X[3 * i], dim > 1 ? X[3 * i + 1] : 0.0, dim > 2 ? X[3 * i + 2] : 0.0};
    const ej_real ai = ra[i], inv_ai = 1.0 / ai;
    const ej_real *Gi = gv + 9 * i;
    ej_real f[3] = {0}, heat = 0.0;
    /* Self term: grad Psi_I(x_I) = -(1/a_I) m1_I phi(0). */
    if (A->galerkin) {
      const ej_real Vi = lag ? vol0[i] : m[i] / rho[i];
      const ej_real g[3] = {m1[3 * i] * RK_PHI0 * inv_ai, m1[3 * i + 1] * RK_PHI0 * inv_ai,
                            m1[3 * i + 2] * RK_PHI0 * inv_ai};
      for (int c = 0; c < 3; ++c) {
        ej_real t;
        if (lag) {
          const ej_real *Pl = S + 9 * i;
          t = Pl[3 * c] * g[0] + Pl[3 * c + 1] * g[1] + Pl[3 * c + 2] * g[2];
        } else {
          const ej_real *s6 = S + 6 * i;
          const ej_real row[3][3] = {{s6[0], s6[3], s6[5]}, {s6[3], s6[1], s6[4]}, {s6[5], s6[4], s6[2]}};
          t = row[c][0] * g[0] + row[c][1] * g[1] + row[c][2] * g[2];
        }
        f[c] += Vi * t;
      }
    }
    for (ej_off k = A->off[i]; k < A->off[i + 1]; ++k) {
      const ej_idx j = A->idx[k];
      ej_real h[3];
      for (int d = 0; d < 3; ++d) h[d] = d < dim ? X[3 * j + d] - xi[d] : 0.0; /* X_J - X_I */
      const ej_real r2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
      const ej_real aj = ra[j], abar = 0.5 * (ai + aj);
      const ej_real amax = ai > abar ? ai : abar;
      if (r2 >= amax * amax) continue;
      const ej_real r = sqrt(r2);
      /* Galerkin term: evaluation point x_J, kernel of node I. */
      const ej_real w = A->galerkin ? rk_phi(r * inv_ai) : 0.0;
      if (w > 0.0) {
        const ej_real inv_aj = 1.0 / aj;
        const ej_real *mj = m1 + 3 * j, *c2 = m2 + 6 * j;
        const ej_real s1 = h[0] * inv_aj, s2 = h[1] * inv_aj, s3 = h[2] * inv_aj;
        const ej_real sc = w * inv_aj;
        const ej_real g[3] = {sc * (mj[0] + c2[0] * s1 + c2[3] * s2 + c2[5] * s3),
                              sc * (mj[1] + c2[3] * s1 + c2[1] * s2 + c2[4] * s3),
                              sc * (mj[2] + c2[5] * s1 + c2[4] * s2 + c2[2] * s3)};
        const ej_real Vj = lag ? vol0[j] : m[j] / rho[j];
        if (lag) {
          const ej_real *Pl = S + 9 * j;
          for (int c = 0; c < 3; ++c) f[c] += Vj * (Pl[3 * c] * g[0] + Pl[3 * c + 1] * g[1] + Pl[3 * c + 2] * g[2]);
        } else {
          const ej_real *s6 = S + 6 * j;
          f[0] += Vj * (s6[0] * g[0] + s6[3] * g[1] + s6[5] * g[2]);
          f[1] += Vj * (s6[3] * g[0] + s6[1] * g[1] + s6[4] * g[2]);
          f[2] += Vj * (s6[5] * g[0] + s6[4] * g[1] + s6[2] * g[2]);
        }
      }
      /* Stabilisation, symmetric kernel weight on the mean support. */
      if (alpha > 0.0 && r2 < abar * abar) {
        const ej_real dv[3] = {v[3 * j] - v[3 * i], v[3 * j + 1] - v[3 * i + 1], v[3 * j + 2] - v[3 * i + 2]};
        ej_real z[3];
        const ej_real cij = rk_stab_pair(dim, alpha, inv_sup, ai, aj, r, rho[i] + rho[j], cs[i] + cs[j], rs[i] + rs[j],
                                         Gi, gv + 9 * j, 1, h[0], h[1], h[2], dv[0], dv[1], dv[2], &z[0], &z[1], &z[2]);
        for (int c = 0; c < 3; ++c) {
          f[c] += cij * z[c];
          heat += cij * z[c] * dv[c];
        }
      }
    }
    const ej_real inv_m = 1.0 / m[i];
    for (int c = 0; c < dim; ++c) A->a[3 * i + c] += f[c] * inv_m;
    A->e_dot[i] += 0.5 * heat * inv_m;
    A->w_dot[i] += 0.5 * heat * inv_m;
  }
}

/* The pairwise viscous stabilisation alone (the box integrations: no Galerkin term in
 * rk_force_rows), blocked: per block of list entries the neighbours' positions and supports are
 * copied and the pairs inside the mean support compacted (a vectorised test), the kept pairs'
 * fields copied, their terms computed in a vectorised loop (rk_phi if-converted: the same value
 * from the same branch), then summed in list order. The expressions and sums are those of
 * rk_force_rows in the same order: bitwise the same accelerations and heat. */
#define RK_SBLK 128
static inline RK_ALWAYS_INLINE void rk_stab_rows(const int dim, const rk_args *A, ej_range rg)
{
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict v = A->v, *restrict m = A->m;
  const ej_real *restrict rho = A->rho, *restrict cs = A->c, *restrict rs = A->rs, *restrict gv = A->gv;
  const ej_real alpha = A->alpha, inv_sup = 1.0 / A->support;
  ej_real hb0[RK_SBLK], hb1[RK_SBLK], hb2[RK_SBLK], r2b[RK_SBLK], ajb[RK_SBLK];
  int64_t keep[RK_SBLK];
  int kp[RK_SBLK];
  ej_real kh[3][RK_SBLK], kr2[RK_SBLK], kaj[RK_SBLK], kdv[3][RK_SBLK], kG[9][RK_SBLK], kro[RK_SBLK], kc[RK_SBLK];
  ej_real krs[RK_SBLK], tf[3][RK_SBLK], th[3][RK_SBLK];
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real xi[3] = {X[3 * i], dim > 1 ? X[3 * i + 1] : 0.0, dim > 2 ? X[3 * i + 2] : 0.0};
    const ej_real vi[3] = {v[3 * i], v[3 * i + 1], v[3 * i + 2]};
    const ej_real ai = ra[i], rhoi = rho[i], csi = cs[i], rsi = rs[i];
    ej_real Gi[9];
    for (int c = 0; c < 9; ++c) Gi[c] = gv[9 * i + c];
    ej_real f[3] = {0}, heat = 0.0;
    for (ej_off k0 = A->off[i]; k0 < A->off[i + 1]; k0 += RK_SBLK) {
      const int nb = A->off[i + 1] - k0 < RK_SBLK ? (int)(A->off[i + 1] - k0) : RK_SBLK;
      const ej_idx *restrict jx = A->idx + k0;
      for (int t = 0; t < nb; ++t) {
        const ej_idx j = jx[t];
        hb0[t] = X[3 * j] - xi[0]; /* X_J - X_I */
        hb1[t] = dim > 1 ? X[3 * j + 1] - xi[1] : 0.0;
        hb2[t] = dim > 2 ? X[3 * j + 2] - xi[2] : 0.0;
        ajb[t] = ra[j];
      }
#pragma omp simd
      for (int t = 0; t < nb; ++t) {
        const ej_real r2 = hb0[t] * hb0[t] + hb1[t] * hb1[t] + hb2[t] * hb2[t];
        const ej_real abar = 0.5 * (ai + ajb[t]);
        r2b[t] = r2;
        /* rk_force_rows skips r2 >= max(a_i, abar)^2 and adds the term only for r2 < abar^2: the
         * second test implies the first */
        keep[t] = (int64_t)(r2 < abar * abar);
      }
      int nk = 0;
      for (int t = 0; t < nb; ++t) kp[nk] = t, nk += keep[t];
      for (int q = 0; q < nk; ++q) {
        const int t = kp[q];
        const ej_idx j = jx[t];
        kh[0][q] = hb0[t], kh[1][q] = hb1[t], kh[2][q] = hb2[t], kr2[q] = r2b[t], kaj[q] = ajb[t];
        for (int c = 0; c < 3; ++c) kdv[c][q] = v[3 * j + c] - vi[c];
        for (int c = 0; c < 9; ++c) kG[c][q] = gv[9 * j + c];
        kro[q] = rho[j], kc[q] = cs[j], krs[q] = rs[j];
      }
#pragma omp simd
      for (int q = 0; q < nk; ++q) {
        ej_real z0, z1, z2;
        const ej_real cij = rk_stab_pair(dim, alpha, inv_sup, ai, kaj[q], sqrt(kr2[q]), rhoi + kro[q], csi + kc[q],
                                         rsi + krs[q], Gi, &kG[0][q], RK_SBLK, kh[0][q], kh[1][q], kh[2][q], kdv[0][q],
                                         kdv[1][q], kdv[2][q], &z0, &z1, &z2);
        tf[0][q] = cij * z0, th[0][q] = cij * z0 * kdv[0][q];
        tf[1][q] = cij * z1, th[1][q] = cij * z1 * kdv[1][q];
        tf[2][q] = cij * z2, th[2][q] = cij * z2 * kdv[2][q];
      }
      for (int q = 0; q < nk; ++q)
        for (int c = 0; c < 3; ++c) f[c] += tf[c][q], heat += th[c][q];
    }
    const ej_real inv_m = 1.0 / m[i];
    for (int c = 0; c < dim; ++c) A->a[3 * i + c] += f[c] * inv_m;
    A->e_dot[i] += 0.5 * heat * inv_m;
    A->w_dot[i] += 0.5 * heat * inv_m;
  }
}

/* MSNNI pass 2 (gather form): f_I = -sum_{L in {I} + neighbours} sum_f Psi_I(x_f(L)) T_f(L),
 * Psi_I(x_f) = (b0_f + b_f . (x_f - x_I) / a_L) phi_I(x_f - x_I), with L's face data read from
 * its id's row. A ghost L (index >= n) is an image of its source: periodic (same faces) or
 * mirrored about axis planes (signature s_d = -1: its face point q is the source's s.q, and the
 * vectors b, T flip their d components). An owned L whose pass 1 scattered its shares
 * (fscat[L], rk_box_scatter_node) wrote c_I(L) into I's own row entry of L (fself for L = I):
 * it is read in list order, sum_f Psi_I(x_f(L)) T_f(L) is not evaluated again. */
static inline RK_ALWAYS_INLINE ej_err rk_box_force_rows(const int dim, const rk_state *s, const ej_set *set,
                                                      const rk_args *A, const ej_real *restrict hb,
                                                      const int32_t *restrict id, const ej_real *restrict sig,
                                                      ej_idx n_owned, ej_range rg)
{
  const ej_real *restrict fsc = s->fsc, *restrict fself = s->fself;
  const uint8_t *restrict fscat = !s->lagrangian && s->cfg.force_scatter ? s->fscat : NULL;
  const ej_real *restrict X = A->X, *restrict ra = A->ra, *restrict m = A->m;
  const int ng = s->ng;
  const ej_real *restrict q0 = s->gq[0], *restrict q1 = s->gq[1], *restrict q2 = s->gq[2];
  ej_real gc0[RK_NF_MAX / 4], gc1[RK_NF_MAX / 4], gc2[RK_NF_MAX / 4], gr0[RK_NF_MAX / 4];
  for (int g = 0; g < ng; ++g) gc0[g] = s->gc[g][0], gc1[g] = s->gc[g][1], gc2[g] = s->gc[g][2], gr0[g] = s->gr[g];
  for (ej_idx i = rg.begin; i < rg.end; ++i) {
    const ej_real ai = ra[i], inv_ai = 1.0 / ai;
    ej_real fo[3] = {0, 0, 0}, fs[3] = {0, 0, 0}; /* fs: the scattered shares, in list order */
    /* Traction sum in 4 lane-wise partial sums, in (L, group) order: thread-count independent. */
    ej_real s0[4] = {0, 0, 0, 0}, s1[4] = {0, 0, 0, 0}, s2[4] = {0, 0, 0, 0};
    for (ej_off k = A->off[i] - 1; k < A->off[i + 1];) {
      /* Chunk of nodes L: their face data (own row, or for a ghost image the source's row
       * mapped: mirror face q of the image is the source's s.q, b and T flip their mirrored
       * components; periodic: identity), the Taylor pieces, and the list of (L, group) pairs
       * whose ball meets I's support (or that hold a flagged face of L), without branches. */
      const ej_real *Bp[RK_CHUNK2], *Tp[RK_CHUNK2];
      ej_real cc[RK_CHUNK2][3], hqs[RK_CHUNK2], il[RK_CHUNK2], lnn[RK_CHUNK2], gnn[RK_CHUNK2][3];
      ej_real gbt[RK_CHUNK2][7 * RK_NF_MAX];
      int item[RK_CHUNK2 * (RK_NF_MAX / 4)], tay[RK_CHUNK2], nit = 0, nn = 0;
      for (; k < A->off[i + 1] && nn < RK_CHUNK2; ++k) {
        const ej_idx L = k < A->off[i] ? i : A->idx[k];
        if (fscat && L < n_owned && fscat[L]) {
          const ej_real *c = L == i ? fself + 3 * (size_t)i : fsc + 3 * (size_t)k; /* written by L */
          fs[0] += c[0], fs[1] += c[1], fs[2] += c[2];
          continue;
        }

        const ej_real h = hb[L], hq = 0.25 * h;
        ej_real c0 = X[3 * L] - X[3 * i], c1 = 0.0, c2 = 0.0; /* x_L - x_I */
        if (dim > 1) c1 = X[3 * L + 1] - X[3 * i + 1];
        if (dim > 2) c2 = X[3 * L + 2] - X[3 * i + 2];
        const ej_real inv_l = 1.0 / ra[L];
        const ej_real *b = s->fb + (size_t)id[L] * RK_NF_MAX * 4, *T = s->ft + (size_t)id[L] * RK_NF_MAX * 3;
        const bool taylor = s->fflag[id[L]] > 0;
        cc[nn][0] = c0, cc[nn][1] = c1, cc[nn][2] = c2, hqs[nn] = hq, il[nn] = inv_l, tay[nn] = taylor;
        lnn[nn] = gnn[nn][0] = gnn[nn][1] = gnn[nn][2] = 0.0;
        if (taylor) /* Taylor pieces (flagged face points), in L's own frame */
          rk_taylor_piece(dim, A, L, c0, c1, c2, ai, inv_ai, inv_l, hq, &lnn[nn], gnn[nn]);
        Bp[nn] = b, Tp[nn] = T;
        if (L >= n_owned) {
          ej_real sg[3];
          int sc = 0;
          for (int d = 0; d < 3; ++d) {
            const ej_real t = sig[3 * L + d];
            if (t != 1.0 && t != -1.0)
              return rk_bad(s, set, i,
                            "msnni: neighbour image of a symmetry plane that is not axis-aligned, signature", t);
            sg[d] = t;
            sc |= (t < 0.0) << d;
          }
          const int *mp = s->gmap[sc];
          ej_real *gb = gbt[nn];
          for (int p = 0; p < RK_NF_MAX; ++p) {
            const int g = mp[p];
            if (g < 0) {
              for (int c = 0; c < 7; ++c) gb[c * RK_NF_MAX + p] = 0.0;
              continue;
            }
            gb[p] = b[g];
            for (int d = 0; d < 3; ++d) gb[(1 + d) * RK_NF_MAX + p] = sg[d] * b[(1 + d) * RK_NF_MAX + g];
            for (int c = 0; c < 3; ++c) gb[(4 + c) * RK_NF_MAX + p] = sg[c] * T[c * RK_NF_MAX + g];
          }
          Bp[nn] = gb, Tp[nn] = gb + 4 * RK_NF_MAX;
        }
        int in[RK_NF_MAX / 4]; /* ball tests over the groups (SoA copies: vectorised) */
        for (int g = 0; g < ng; ++g) {
          const ej_real e0 = c0 + hq * gc0[g], e1 = c1 + hq * gc1[g], e2 = c2 + hq * gc2[g];
          const ej_real rr = ai + hq * gr0[g];
          in[g] = e0 * e0 + e1 * e1 + e2 * e2 < rr * rr;
        }
        if (taylor)
          for (int g = 0; g < ng; ++g) {
            const ej_real *bg = Bp[nn] + 4 * g;
            in[g] |= (bg[0] < 0.0) | (bg[1] < 0.0) | (bg[2] < 0.0) | (bg[3] < 0.0);
          }
        for (int g = 0; g < ng; ++g) item[nit] = 16 * nn + g, nit += in[g];
        ++nn;
      }
      for (int t = 0; t < nit; ++t) {
        const int jn = item[t] >> 4, g = item[t] & 15;
        const ej_real *restrict B0 = Bp[jn], *restrict B1 = B0 + RK_NF_MAX, *restrict B2 = B0 + 2 * RK_NF_MAX,
                      *restrict B3 = B0 + 3 * RK_NF_MAX;
        const ej_real *restrict T0 = Tp[jn], *restrict T1 = T0 + RK_NF_MAX, *restrict T2 = T0 + 2 * RK_NF_MAX;
        const ej_real c0 = cc[jn][0], c1 = cc[jn][1], c2 = cc[jn][2], hq = hqs[jn], inv_l = il[jn];
        const ej_real ln = lnn[jn], gn0 = gnn[jn][0], gn1 = gnn[jn][1], gn2 = gnn[jn][2];
        const bool taylor = tay[jn];
        for (int l = 0; l < 4; ++l) {
          const int p = 4 * g + l;
          const ej_real d0 = c0 + hq * q0[p], d1 = dim > 1 ? c1 + hq * q1[p] : 0.0, d2 = dim > 2 ? c2 + hq * q2[p] : 0.0;
          const ej_real w = rk_phi_bl(sqrt(d0 * d0 + d1 * d1 + d2 * d2) * inv_ai);
          const ej_real lin =
              B0[p] + (B1[p] * d0 + (dim > 1 ? B2[p] * d1 : 0.0) + (dim > 2 ? B3[p] * d2 : 0.0)) * inv_l;
          ej_real psi = lin * w;
          if (taylor) psi = B0[p] < 0.0 ? ln - gn0 * q0[p] - gn1 * q1[p] - gn2 * q2[p] : psi;
          s0[l] += psi * T0[p], s1[l] += psi * T1[p], s2[l] += psi * T2[p];
        }
      }
    }
    fo[0] -= (s0[0] + s0[1]) + (s0[2] + s0[3]) + fs[0];
    fo[1] -= (s1[0] + s1[1]) + (s1[2] + s1[3]) + fs[1];
    fo[2] -= (s2[0] + s2[1]) + (s2[2] + s2[3]) + fs[2];
    const ej_real inv_m = 1.0 / m[i];
    for (int c = 0; c < dim; ++c) A->a[3 * i + c] += fo[c] * inv_m;
  }
  return EJ_OK;
}

static ej_err rk_pass_force(rk_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_ENSURE(nbr && nbr->n_rows >= r.end, EJ_ERR_INTERNAL, "set '%s': rkpm neighbour list too short", s->set_name);
  rk_args A = {.X = ej_set_field(set, s->lagrangian ? "x0" : "x"),
               .v = ej_set_field(set, s->ess_on ? "rk_vc" : "v"),
               .ra = ej_set_field(set, "rk_a"),
               .m = ej_set_field(set, "m"),
               .rho = ej_set_field(set, "rho"),
               .vol0 = ej_set_field(set, "vol0"),
               .c = ej_set_field(set, "c"),
               .rs = ej_set_field(set, "rk_s"),
               .m0 = ej_set_field(set, "rk_m0"),
               .m1 = ej_set_field(set, "rk_m1"),
               .m2 = ej_set_field(set, "rk_m2"),
               .gv = ej_set_field(set, "rk_gv"),
               .stress = ej_set_field(set, "stress"),
               .P = ej_set_field(set, "rk_P"),
               .a = ej_set_field(set, "a"),
               .e_dot = ej_set_field(set, "e_dot"),
               .w_dot = ej_set_field(set, "w_hg_dot"),
               .off = nbr->off,
               .idx = nbr->idx,
               .alpha = s->cfg.stabilization,
               .support = s->cfg.support,
               .lag = s->lagrangian,
               .galerkin = !s->box};
  EJ_ENSURE(A.X && A.v && A.ra && A.m && A.rho && A.vol0 && A.c && A.rs && A.m0 && A.m1 && A.m2 && A.gv && A.stress &&
                (!A.lag || A.P) && A.a && A.e_dot && A.w_dot,
            EJ_ERR_INTERNAL, "set '%s': rkpm fields missing", s->set_name);
  if (s->box) {
    const int32_t *id = ej_set_field_int(set, "id");
    const ej_real *sig = ej_set_field(set, "rk_sig"), *hb = ej_set_field(set, "rk_hb");
    EJ_ENSURE(id && sig && hb, EJ_ERR_INTERNAL, "set '%s': rkpm msnni fields missing", s->set_name);
    const ej_idx n = ej_set_count(set);
    if (!s->lagrangian && s->cfg.force_scatter) { /* pass 1 made frev for this build in every row (the same value from every thread) */
#ifdef _OPENMP
#pragma omp atomic write
#endif
      s->frev_build = ej_set_list_builds(set);
    }
    switch (s->dim) {
    case 1: EJ_TRY(rk_box_force_rows(1, s, set, &A, hb, id, sig, n, r)); break;
    case 2: EJ_TRY(rk_box_force_rows(2, s, set, &A, hb, id, sig, n, r)); break;
    default: EJ_TRY(rk_box_force_rows(3, s, set, &A, hb, id, sig, n, r)); break;
    }
    if (A.alpha <= 0.0) return EJ_OK;
  }
  if (A.galerkin == false && !s->lagrangian) { /* the box integrations: the stabilisation alone */
    switch (s->dim) {
    case 1: rk_stab_rows(1, &A, r); break;
    case 2: rk_stab_rows(2, &A, r); break;
    default: rk_stab_rows(3, &A, r); break;
    }
    return EJ_OK;
  }
  switch (s->dim * 2 + (int)s->lagrangian) {
  case 2: rk_force_rows(1, false, &A, r); break;
  case 3: rk_force_rows(1, true, &A, r); break;
  case 4: rk_force_rows(2, false, &A, r); break;
  case 5: rk_force_rows(2, true, &A, r); break;
  case 6: rk_force_rows(3, false, &A, r); break;
  default: rk_force_rows(3, true, &A, r); break;
  }
  return EJ_OK;
}

static ej_err rk_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  rk_state *s = state;
  switch (pass) {
  case 0: EJ_TRY(rk_pass_moment(s, set, nbr, r)); break;
  case 1: EJ_TRY(rk_pass_material(s, set, nbr, r)); break;
  case 2: EJ_TRY(rk_pass_force(s, set, nbr, r)); break;
  default: EJ_FAIL(EJ_ERR_INTERNAL, "rkpm: pass %d of 3", pass);
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ essential boundaries */

/* Rows Lambda_KJ = Psi_J(X_K) of the held nodes K from the moments of pass 0: with
 * h = (X_K - X_J)/a_K, Psi_J(X_K) = (m0_K + m1_K . h) phi(|X_K - X_J|/a_J), the self entry
 * m0_K phi(0) first (the sums of rk_moment_rows, so the row sums to 1 to round-off). A ghost J
 * stands for its source with the mirror's sign per component; a mirror that is not along the
 * axes mixes the components and is refused. */
static ej_err rk_ess_rows(rk_state *s, const ej_set *set, const ej_nbr *nbr)
{
  rk_ess *e = s->ess;
  const int dim = s->dim;
  const ej_real *X = ej_set_field(set, s->lagrangian ? "x0" : "x"), *ra = ej_set_field(set, "rk_a");
  const ej_real *m0 = ej_set_field(set, "rk_m0"), *m1 = ej_set_field(set, "rk_m1");
  EJ_ENSURE(X && ra && m0 && m1 && nbr, EJ_ERR_INTERNAL, "set '%s': rkpm moment fields missing", s->set_name);
  size_t nnz = 0;
  for (ej_idx k = 0; k < e->nb; ++k) nnz += 1 + (size_t)(nbr->off[e->blist[k] + 1] - nbr->off[e->blist[k]]);
  EJ_TRY(rk_ess_reserve(e, nnz));
  ej_off q = 0;
  for (ej_idx k = 0; k < e->nb; ++k) {
    const ej_idx K = e->blist[k];
    const ej_real inv_l = 1.0 / ra[K];
    e->rsrc[q] = K, e->rval[q] = m0[K] * RK_PHI0;
    e->rsgn[3 * q] = e->rsgn[3 * q + 1] = e->rsgn[3 * q + 2] = 1;
    ++q;
    for (ej_off p = nbr->off[K]; p < nbr->off[K + 1]; ++p) {
      const ej_idx J = nbr->idx[p];
      ej_real h[3] = {0, 0, 0}, r2 = 0;
      for (int d = 0; d < dim; ++d) h[d] = X[3 * K + d] - X[3 * J + d], r2 += h[d] * h[d];
      if (r2 >= ra[J] * ra[J]) continue;
      ej_real Q[9], lin = m0[K];
      for (int d = 0; d < dim; ++d) lin += m1[3 * K + d] * h[d] * inv_l;
      e->rsrc[q] = ej_set_image_source(set, J, Q);
      e->rval[q] = lin * rk_phi(sqrt(r2) / ra[J]);
      for (int c = 0; c < 3; ++c) {
        const ej_real d = Q[4 * c];
        const bool axis = (d == 1.0 || d == -1.0) && Q[3 * c + (c + 1) % 3] == 0.0 && Q[3 * c + (c + 2) % 3] == 0.0;
        EJ_ENSURE(axis, EJ_ERR_UNSUPPORTED,
                  "set '%s': rkpm `essential: transformation` needs symmetry planes along the axes (an image "
                  "mixes the velocity components)",
                  s->set_name);
        e->rsgn[3 * q + c] = (int8_t)d;
      }
      ++q;
    }
    e->roff[k + 1] = q;
  }
  return rk_ess_rows_done(e);
}

/* ABI 1.12 serial stages: after pass 0 (moments known), the held nodes' coefficients of v and of
 * the mid-step velocity (and, Lagrangian, of the displacement); after the interactions, the
 * transformed forces. */
static ej_err rk_serial(void *state, ej_set *set, const ej_nbr *nbr, int stage)
{
  rk_state *s = state;
  if (!s->ess) return EJ_OK;
  if (stage == EJ_STAGE_FORCES) {
    if (!s->ess_on) return EJ_OK;
    const ej_real *m = ej_set_field(set, "m");
    ej_real *a = ej_set_field(set, "a");
    EJ_ENSURE(m && a, EJ_ERR_INTERNAL, "set '%s': rkpm fields missing", s->set_name);
    return rk_ess_forces(s->ess, s->set_name, m, a);
  }
  if (stage != 0) return EJ_OK;
  s->ess_on = false;
  EJ_TRY(rk_ess_held(s->ess, set));
  if (s->ess->nb == 0) return EJ_OK;
  EJ_TRY(rk_ess_rows(s, set, nbr));
  const ej_real *v = ej_set_field(set, "v");
  ej_real *vc = ej_set_field(set, "rk_vc"), *vm = ej_set_field(set, "rk_vmid");
  EJ_ENSURE(v && vc && vm, EJ_ERR_INTERNAL, "set '%s': rkpm velocity fields missing", s->set_name);
  EJ_TRY(rk_ess_coefficients(s->ess, s->set_name, v, vc));
  EJ_TRY(rk_ess_coefficients(s->ess, s->set_name, vm, vm));
  if (s->lagrangian) {
    const ej_real *x = ej_set_field(set, "x"), *x0 = ej_set_field(set, "x0");
    ej_real *xc = ej_set_field(set, "rk_xc");
    EJ_ENSURE(x && x0 && xc, EJ_ERR_INTERNAL, "set '%s': rkpm position fields missing", s->set_name);
    const ej_idx n = ej_set_count(set);
    for (ej_idx i = 0; i < 3 * n; ++i) xc[i] = x[i] - x0[i];
    EJ_TRY(rk_ess_coefficients(s->ess, s->set_name, xc, xc));
    for (ej_idx i = 0; i < 3 * n; ++i) xc[i] += x0[i];
  }
  s->ess_on = true;
  return EJ_OK;
}

/* ------------------------------------------------------------------ time step, counters */

/* dt_I = h_I / c_I with h_I the current nodal spacing (m/rho)^(1/dim) and c_I the larger of the
 * material's sound speed and the P-wave speed of its initial moduli (ej_material_moduli): the
 * CFL bound of digest 003 section 1.6 ([EXTERNAL], the report gives no formula). The core
 * multiplies by cfl. */
static ej_err rk_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  const rk_state *s = state;
  const ej_real *m = ej_set_field(set, "m"), *rho = ej_set_field(set, "rho"), *c = ej_set_field(set, "c");
  const ej_real *v = ej_set_field(set, "v"), *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(m && rho && c && v && vol0, EJ_ERR_INTERNAL, "set '%s': rkpm fields missing", s->set_name);
  ej_real best = HUGE_VAL;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real hcur = rk_root(s->dim, m[i] / rho[i]), h0 = rk_root(s->dim, vol0[i]);
    const ej_real h = hcur < h0 ? hcur : h0;
    /* The sub-box stabilisation stiffens the sub-box modes by up to w E: c sqrt(1 + w). */
    const ej_real ci = fmax(c[i], rk_c_moduli(s, rho[i])) * (s->sub ? sqrt(1.0 + s->cfg.msnni_w) : 1.0);
    if (ci > 0.0) best = fmin(best, h / ci);
  }
  *dt = best;
  return EJ_OK;
}

static ej_err rk_counters(void *state, ej_counter *out, int max, int *n)
{
  const rk_state *s = state;
  *n = 0;
  const int32_t *fb = ej_set_field_int(s->set, "rk_fallbacks");
  if (!fb || max < 1) return EJ_OK;
  int64_t total = 0;
  for (ej_idx i = 0; i < ej_set_count(s->set); ++i) total += fb[i];
  out[0] = (ej_counter){.name = "moment matrix fallbacks to the constant basis (node-steps)", .value = total};
  *n = 1;
  if (s->ess && max >= 4) {
    out[1] = (ej_counter){.name = "transformation method: held-node solves (component and right-hand side)",
                          .value = s->ess->solves};
    out[2] = (ej_counter){.name = "transformation method: BiCGSTAB iterations, total", .value = s->ess->iters};
    out[3] = (ej_counter){.name = "transformation method: BiCGSTAB iterations, most in one solve", .value = s->ess->maxit};
    *n = 4;
    if (max >= 5 && s->ess->degenerate) {
      out[4] = (ej_counter){.name = "transformation method: held components dropped (symmetry plane, node-steps)",
                            .value = s->ess->degenerate};
      *n = 5;
    }
  }
  return EJ_OK;
}

static ej_err rk_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  const rk_state *s = state;
  *n = 0;
  const int32_t *fb = ej_set_field_int(set, "rk_fb_step");
  if (!fb || max < 1) return EJ_OK;
  int64_t k = 0;
  for (ej_idx i = 0; i < ej_set_count(set); ++i) k += fb[i];
  (void)s;
  out[0] = (ej_series_value){.name = "moment_fallbacks", .value = (ej_real)k, .role = EJ_SERIES_PLAIN};
  *n = 1;
  return EJ_OK;
}

/* ------------------------------------------------------------------ registration */

static const ej_method_ops rk_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "rkpm",
    .summary = "Reproducing kernel particle method for solids (linear basis, MSNNI nodal integration)",
    .doc = "Galerkin RKPM after Chi et al. (SERDP MR-2628, digest 003 Eqs 1-5, 11, 16): linear-basis reproducing "
           "kernel shape functions with a cubic B-spline kernel of support `support` nodal spacings, implicit RK "
           "gradients (exact for linear fields at every node), semi-Lagrangian (current-configuration kernels "
           "rebuilt every step) or Lagrangian (reference kernels computed once) formulation, MSNNI domain "
           "integration (smoothed gradients over nodal boxes with the sub-box stabilisation stress, 003 Eqs 42-46; "
           "or box smoothing only, or direct nodal integration) plus an optional pairwise viscous stabilisation, "
           "Hughes-Winget objective stress "
           "update through the set's strength model (and EOS), explicit central difference. A singular moment "
           "matrix falls back to the constant basis and is counted.",
    .params = rk_params,
    .config_size = sizeof(rk_config),
    .check_config = rk_check_config,
    .declare = rk_declare,
    .create = rk_create,
    .setup = rk_setup,
    .support = rk_support,
    .n_passes = 3,
    .compute = rk_compute,
    .stable_dt = rk_stable_dt,
    .post_step = NULL,
    .counters = rk_counters,
    .destroy = rk_destroy,
    .pass_count = NULL,
    .report = rk_report,
    .serial = rk_serial,
};

static ej_err rk_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &rk_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(rkpm, "0.1.0", "BSD-3-Clause", "Reproducing kernel particle method for solids", rk_register)
