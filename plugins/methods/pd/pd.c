/* Bond-based (PMB) and ordinary state-based (LPS) peridynamics, matching LAMMPS's pair styles
 * peri/pmb and peri/lps (PERI package, M. Parks) operation for operation.
 *
 * Sources:
 *  - PMB: Silling & Askari, "A meshfree method based on the peridynamic model of solid
 *    mechanics", Comput. Struct. 83 (2005) 1526: pairwise force f = c s (Eq 2, 4), critical
 *    stretch with the s0 = s00 - alpha s_min history (Eq 11 as used by LAMMPS), time step
 *    (Eq 16), micromodulus c = 18 K / (pi delta^4) (Eq 18).
 *  - LPS: Silling, Epton, Weckner, Xu, Askari, "Peridynamic states and constitutive
 *    modeling", J. Elasticity 88 (2007) 151, section 15: theta = (3/m) sum w x e V,
 *    t = (3 K theta / m) w x + (15 G / m) w e^d, W = K theta^2 / 2 + (15 G / 2m) sum w (e^d)^2 V,
 *    influence function w = 1/|xi| (LAMMPS's choice).
 *  - LAMMPS conventions reproduced here (src/PERI/pair_peri_pmb.cpp, pair_peri_lps.cpp,
 *    fix_peri_neigh.cpp, compute_damage_atom.cpp):
 *      * a bond exists for |xi| <= delta in the reference configuration;
 *      * partial volume of a neighbour near the horizon: V_j scaled by
 *        (delta + lc/2 - |xi|) / lc when | |xi| - delta | <= lc/2 (lc = lattice constant);
 *      * stretch s = (r - r0)/r0 with |r - r0| < 2.2204e-16 m set to 0 (round-off guard);
 *      * a bond breaks after its force was applied in the step where s > min(s0_i, s0_j),
 *        s0 of the previous evaluation; s0_i is then set to max_j (s00 - alpha s_ij) over the
 *        unbroken bonds (DBL_MAX before the first evaluation and for a particle without bonds);
 *      * short-range contact over every CURRENT pair closer than d_ij = min(0.9 |xi|, 1.35 lc):
 *        force density 15 c_s V_j (d_ij - r) / delta along the pair, c_s = c (PMB) or
 *        18 K / (pi delta^4) (LPS);
 *      * damage = 1 - sum_{intact} V_j / sum_{initial} V_j (no partial-volume scaling).
 *    LAMMPS stores a force density f and the density as the "mass" (atom_style peri); ejecta
 *    integrates a = F / m with F = V_i f and m = rho V_i: the same accelerations.
 *
 * Layout: the core builds the fixed families (EJ_NBR_REFERENCE) once and owns one flag byte per
 * bond (checkpointed): bit 0 = broken. This plugin keeps per-bond r0 and c V_j scale (folded, 0 for
 * a broken bond), aligned with the CSR entries and recomputed from x0, vol0 and the flags on the
 * first compute (the families do not exist before: setup runs before the core sorts the set), so a
 * restarted run continues with the same broken bonds.
 * Contact of family pairs (within the horizon in the reference: bonded, broken or notch-cut) is
 * tested in the bond loop, which visits them anyway. The other pairs need the current
 * configuration, which a reference-family method does not get from the core: a dense cell grid
 * and a Verlet list of the NON-family pairs (empty for an intact lattice), rebuilt inside the
 * plugin when a particle has moved more than half the skin (grid serial, row searches per chunk).
 *
 * Two passes per step: pass 0 checks displacements for the contact list, packs x, y, z, s0 for the
 * AVX2 PMB loop (and, LPS, computes the dilatation theta); pass 1 (re)builds the contact rows when
 * due, computes forces, energies, breaks bonds and the new s0. Gather form: each particle sums over
 * its own bonds and contacts and writes only itself. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "ejecta/plugin.h"

#if defined(__AVX2__)
#include <immintrin.h>
#define PD_AVX2 1
#else
#define PD_AVX2 0
#endif

#define PD_NEAR_ZERO 2.2204e-16 /* LAMMPS's round-off guard on r - r0 (pair_peri_*.cpp) */
#define PD_PI 3.141592653589793 /* the literal LAMMPS uses in peri/lps */
#define PD_CCAP 8               /* stored non-family contact candidates per particle            */
#define PD_CBIG 512             /* a row with more is searched each step, more than this fails  */

enum { PD_PMB = 0, PD_LPS = 1 };
static const char *const pd_model_names[] = {"pmb", "lps", NULL};

typedef struct pd_config {
  int model;
  ej_real horizon;
  ej_real c;
  ej_real bulk, shear;
  ej_real s00, alpha;
  ej_real lattice_spacing;
  bool volume_scaling;
  bool contact;
  ej_real contact_skin;
  ej_real notch_a[3], notch_b[3];
} pd_config;

static const ej_param pd_params[] = {
    EJ_PARAM_ENUM(pd_config, model, pd_model_names, "pmb",
                  "Constitutive model: pmb (prototype microelastic brittle, bond-based, LAMMPS peri/pmb) or lps "
                  "(linear peridynamic solid, ordinary state-based, LAMMPS peri/lps; 3D only)."),
    EJ_PARAM_REAL(pd_config, horizon, "m", 0.0, 0.0, 0.0, EJ_PF_REQUIRED | EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN,
                  "Horizon delta: bonds join particles with |x0_j - x0_i| <= delta (LAMMPS pair_coeff cutoff)."),
    EJ_PARAM_REAL(pd_config, c, "N/m^6", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "PMB micromodulus c in N/m^6 (LAMMPS peri/pmb c); 0 takes c = 18 K / (pi delta^4) from bulk "
                  "(Silling & Askari 2005 Eq 18, 3D)."),
    EJ_PARAM_REAL(pd_config, bulk, "Pa", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Bulk modulus K (LPS; PMB when c is 0); 0 takes the material's elastic bulk modulus."),
    EJ_PARAM_REAL(pd_config, shear, "Pa", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Shear modulus G (LPS); 0 takes the material's elastic shear modulus."),
    EJ_PARAM_REAL(pd_config, s00, "1", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Critical stretch s00 of an unstretched neighbourhood; a bond breaks when its stretch exceeds "
                  "min(s0_i, s0_j) with s0 = s00 - alpha s_min; 0 disables bond breaking."),
    EJ_PARAM_REAL(pd_config, alpha, "1", 0.0, 0.0, 0.0, 0,
                  "Dependence of the critical stretch on the smallest (most compressive) bond stretch of the "
                  "particle, s0 = s00 - alpha s_min (LAMMPS alpha, typically 0.25)."),
    EJ_PARAM_REAL(pd_config, lattice_spacing, "m", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "Lattice constant lc of the partial-volume correction and the contact distance 1.35 lc; 0 "
                  "takes the set's smallest particle spacing."),
    EJ_PARAM_BOOL(pd_config, volume_scaling, 1,
                  "Scale V_j of neighbours within lc/2 of the horizon by (delta + lc/2 - |xi|)/lc as LAMMPS does "
                  "(makes the discrete modulus match the continuum one)."),
    EJ_PARAM_BOOL(pd_config, contact, 1,
                  "Short-range repulsion of LAMMPS peri between any two particles closer than "
                  "min(0.9 |xi|, 1.35 lc), bonded or not (current-configuration search)."),
    EJ_PARAM_REAL(pd_config, contact_skin, "1", 0.35, 0.0, 0.0, EJ_PF_HAS_MIN | EJ_PF_MIN_OPEN | EJ_PF_EXPERT,
                  "Verlet skin of the contact list in lattice spacings; the list is rebuilt when a particle has "
                  "moved half of it."),
    EJ_PARAM_ARRAY(pd_config, notch_a, 3, "m", 0,
                   "First end of a pre-notch: a segment in the x-y plane (through the thickness in 3D) that no bond "
                   "may cross; bonds crossing it are left out of the families (no force, no damage). Unused when "
                   "equal to notch_b."),
    EJ_PARAM_ARRAY(pd_config, notch_b, 3, "m", 0, "Second end of the pre-notch segment (see notch_a)."),
    {0}};

typedef struct pd_state {
  pd_config cfg;
  const char *set_name;
  int dim;
  ej_real delta, lc;
  ej_real c_bond;    /* PMB micromodulus c                                  */
  ej_real c_contact; /* micromodulus of the contact force (c or 18K/pi d^4) */
  ej_real K, G;
  bool failure;
  /* Per bond, aligned with the reference CSR. The only per-bond state that must survive a
   * restart is the broken flag: it lives in the core's bond flags (bit 0, checkpointed). r0 and
   * wc are recomputed from x0, vol0 and the flags when the plugin starts (also after a restart). */
  int ready; /* 0 until the lazy initialisation is done (read atomically) */
  ej_off nnz;
  ej_idx n_rows;
  const ej_off *off; /* the core's fixed families (never rebuilt) */
  const ej_idx *idx;
  uint8_t *flags;  /* the core's bond flags: PD_BROKEN, PD_NOT_BOND         */
  ej_real *r0;     /* reference length                                     */
  ej_real *wc;     /* c V_j scale (PMB) or V_j scale (LPS); 0 for a broken bond or a non-bond */
  ej_real *vinter; /* [n] initial sum of V_j (damage denominator)          */
  ej_real *vint;   /* [n] intact sum of V_j, always summed in row order    */
  int64_t n_bonds;
  /* contact: dense cell grid + Verlet list of the NON-family pairs over owned + ghost particles
   * (family pairs are tested in the bond loop) */
  int64_t epoch;  /* steps completed (post_step of the chunk that starts the set)        */
  int64_t due_t;  /* epoch of the step whose pass 1 rebuilds the list (written in pass 0) */
  int64_t grid_t; /* epoch the grid was last built in (in the critical section; atomic)  */
  int64_t claim_t; /* epoch whose grid build a chunk has claimed (pd_pass1; atomic)      */
  ej_real rc, skin;
  ej_idx n_all_cap;
  ej_real *xcb;     /* [n] positions at the last contact build */
  ej_real *xq;      /* [4 n_all] x, y, z, s0 packed (PMB with AVX2: one load per neighbour) */
  ej_idx xq_n;
  /* dense cell grid over the bounding box, cells of size gh >= rc, x fastest */
  ej_real glo[3], gh;
  int64_t gn[3], gr;
  size_t ncell_cap;
  uint32_t *cstart; /* [ncell + 1] counting-sort offsets        */
  uint32_t *cellof; /* [n_all] cell of each particle            */
  ej_idx *order;    /* [n_all] particles in cell order          */
  ej_real *xss;     /* [3 n_all] positions in cell order        */
  int32_t *ccnt; /* [n] non-family pairs within rc of i at the build (> PD_CCAP: searched each step) */
  ej_idx *cidx;  /* [n PD_CCAP] their indices, ascending */
  int64_t n_contact_builds;
  ej_err init_rc;
  /* report sums per post_step range, so that report adds a few numbers instead of a serial sweep:
   * rsum[3 r.begin ..] = damage, m w_frac and broken-bond sums over r, rend[r.begin] = r.end
   * (0: not summed yet, then report sweeps the particles) */
  ej_real *rsum;
  ej_idx *rend;
} pd_state;

/* bits of the core's per-bond flags (ej_set_bond_flags) */
#define PD_BROKEN 1u   /* broken (irreversible): the only per-bond state, checkpointed by the core */
#define PD_NOT_BOND 2u /* in the family list but beyond the horizon: recomputed at start        */

/* ------------------------------------------------------------------ declare / create */

static ej_err pd_declare(const void *config, int dim, ej_decl *d)
{
  const pd_config *cfg = config;
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "pd: dimension %d not in 1..3", dim);
  static const ej_field_decl fields[] = {
      {.name = "damage", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT | EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "Damage 1 - (intact bond volume)/(initial bond volume) (LAMMPS compute damage/atom)."},
      {.name = "s0", .kind = EJ_SCALAR, .flags = 0, .unit = "1",
       .doc = "Critical stretch of the particle from the previous evaluation (LAMMPS s0)."},
      {.name = "s0_new", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "Critical stretch for the next step, max over intact bonds of s00 - alpha s."},
      {.name = "e_pd", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_NO_GHOST | EJ_FIELD_OUTPUT,
       .unit = "J/kg", .energy = EJ_ENERGY_INTERNAL,
       .doc = "Specific elastic energy of the intact bonds and the contact springs."},
      {.name = "w_frac", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "J/kg",
       .doc = "Specific energy taken out by broken bonds: their elastic energy when they broke plus the work of "
              "their last force over the next half step (reported as fracture_energy, role DISSIPATED)."},
      {.name = "f_brk", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "N/m^3",
       .doc = "Force density of the bonds that broke in the last evaluation (still in a): its work over the "
              "next half step is booked in w_frac by the next step's pass 0."},
      {.name = "n_broken", .kind = EJ_INT, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "Bonds of this particle broken so far."},
  };
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k) EJ_TRY(ej_decl_field(d, &fields[k]));
  if (cfg->model == PD_LPS) {
    static const ej_field_decl lps[] = {
        {.name = "theta", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "1",
         .doc = "Dilatation theta = (3/m) sum w |xi| e V_j (LPS)."},
        {.name = "lps_im", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m^-5",
         .doc = "1 / m, the inverse weighted volume m = sum w |xi|^2 V_j (LPS)."},
        {.name = "lps_tm", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "m^-5",
         .doc = "theta / m, read by the neighbours' bond loops (LPS)."},
    };
    for (size_t k = 0; k < sizeof lps / sizeof lps[0]; ++k) EJ_TRY(ej_decl_field(d, &lps[k]));
  }
  EJ_TRY(ej_decl_neighbours(d, EJ_NBR_REFERENCE));
  return EJ_OK;
}

static void pd_free_arrays(pd_state *s)
{
  ej_free(s->r0), ej_free(s->wc), ej_free(s->vinter), ej_free(s->vint);
  ej_free(s->xcb), ej_free(s->cstart), ej_free(s->cellof), ej_free(s->order), ej_free(s->xss);
  ej_free(s->ccnt), ej_free(s->cidx), ej_free(s->xq);
  ej_free(s->rsum), ej_free(s->rend);
}

static void pd_destroy(void *state)
{
  pd_state *s = state;
  if (!s) return;
  pd_free_arrays(s);
  ej_free(s);
}

static ej_err pd_create(const void *config, ej_set *set, const ej_model *model, void **state)
{
  EJ_ENSURE(config && set && model && state, EJ_ERR_ARG, "pd: NULL argument to create");
  const pd_config *cfg = config;
  const char *name = ej_set_name(set);
  const int dim = ej_set_dim(set);
  EJ_ENSURE(cfg->model != PD_LPS || dim == 3, EJ_ERR_UNSUPPORTED,
            "set '%s': pd model lps is implemented in 3D only (LAMMPS peri/lps is 3D)", name);
  ej_real K = cfg->bulk, G = cfg->shear;
  const ej_material *mat = ej_model_material(model);
  if ((K <= 0 || G <= 0) && mat) {
    ej_real Km = 0, Gm = 0;
    EJ_TRY(ej_material_moduli(mat, &Km, &Gm));
    if (K <= 0) K = Km;
    if (G <= 0) G = Gm;
  }
  const ej_real delta = cfg->horizon;
  ej_real c = cfg->c;
  if (cfg->model == PD_PMB && c <= 0) {
    EJ_ENSURE(K > 0, EJ_ERR_INPUT,
              "set '%s': pd model pmb needs the micromodulus 'c' or a bulk modulus ('bulk' or a material with "
              "elastic moduli)",
              name);
    EJ_ENSURE(dim == 3, EJ_ERR_INPUT, "set '%s': c = 18 K/(pi delta^4) holds in 3D only; give 'c' in %dD", name, dim);
    c = 18.0 * K / (PD_PI * delta * delta * delta * delta);
  }
  if (cfg->model == PD_LPS)
    EJ_ENSURE(K > 0 && G > 0, EJ_ERR_INPUT,
              "set '%s': pd model lps needs 'bulk' and 'shear' (or a material with elastic moduli)", name);
  pd_state *s = ej_calloc(1, sizeof *s);
  EJ_ENSURE(s, EJ_ERR_MEM, "pd: out of memory");
  s->cfg = *cfg;
  s->set_name = name;
  s->dim = dim;
  s->delta = delta;
  s->lc = cfg->lattice_spacing > 0 ? cfg->lattice_spacing : ej_set_spacing_min(set);
  s->K = K, s->G = G;
  s->c_bond = c;
  /* peri/lps: kshort = 15 * 18 K / (pi delta^4), i.e. the PMB micromodulus of the same K */
  s->c_contact = cfg->model == PD_PMB ? c : 18.0 * K / (PD_PI * delta * delta * delta * delta);
  s->failure = cfg->s00 > 0;
  s->skin = cfg->contact_skin * s->lc;
  s->rc = 1.35 * s->lc + s->skin;
  s->grid_t = -1; /* no grid yet */
  s->claim_t = -1;
  if (!(s->lc > 0) || !isfinite(s->lc)) {
    pd_destroy(s);
    EJ_FAIL(EJ_ERR_INPUT, "set '%s': pd needs a lattice spacing (give 'lattice_spacing')", name);
  }
  *state = s;
  return EJ_OK;
}

static ej_err pd_setup(void *state, ej_set *set)
{
  pd_state *s = state;
  const ej_idx n = ej_set_count(set);
  ej_real *s0 = ej_set_field(set, "s0"), *wf = ej_set_field(set, "w_frac"), *dmg = ej_set_field(set, "damage");
  ej_real *e = ej_set_field(set, "e_pd"), *fb = ej_set_field(set, "f_brk");
  int32_t *nb = ej_set_field_int(set, "n_broken");
  const ej_real *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(s0 && wf && dmg && e && nb && m && vol0 && fb, EJ_ERR_INTERNAL, "set '%s': pd fields missing",
            s->set_name);
  for (ej_idx i = 0; i < n; ++i) {
    EJ_ENSURE(m[i] > 0 && vol0[i] > 0, EJ_ERR_INPUT, "set '%s': pd particle %d has mass %g, volume %g", s->set_name,
              (int)i, m[i], vol0[i]);
    /* LAMMPS creates peri atoms with s0 = DBL_MAX: no bond can break before one evaluation */
    s0[i] = DBL_MAX;
    wf[i] = 0, dmg[i] = 0, e[i] = 0, nb[i] = 0;
    fb[3 * i] = fb[3 * i + 1] = fb[3 * i + 2] = 0;
  }
  return EJ_OK;
}

static ej_err pd_support(void *state, const ej_set *set, ej_range r, ej_real *radius)
{
  (void)set;
  const pd_state *s = state;
  /* the list holds |xi| < R; bonds are |xi| <= delta (LAMMPS): reach a hair further, filter later */
  for (ej_idx i = r.begin; i < r.end; ++i) radius[i - r.begin] = s->delta * (1 + 1e-9);
  return EJ_OK;
}

/* ------------------------------------------------------------------ lazy bond initialisation */

/* LAMMPS partial volume (fix_peri_neigh.cpp): linear from 1 at delta - lc/2 to 0 at delta + lc/2. */
static inline ej_real pd_vscale(const pd_state *s, ej_real r0)
{
  if (!s->cfg.volume_scaling) return 1.0;
  const ej_real half = 0.5 * s->lc;
  if (fabs(r0 - s->delta) <= half) return (-1.0 / (2 * half)) * r0 + (1.0 + (s->delta - half) / (2 * half));
  return 1.0;
}

/* Whether the reference bond p-q crosses the notch segment a-b, in the x-y plane (proper crossing:
 * strict orientation tests, so a bond ending exactly on the notch line is kept). */
static bool pd_crosses(const ej_real *p, const ej_real *q, const ej_real *a, const ej_real *b)
{
  const ej_real d1 = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
  const ej_real d2 = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
  const ej_real d3 = (q[0] - p[0]) * (a[1] - p[1]) - (q[1] - p[1]) * (a[0] - p[0]);
  const ej_real d4 = (q[0] - p[0]) * (b[1] - p[1]) - (q[1] - p[1]) * (b[0] - p[0]);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

/* Per-bond constants from x0 and vol0, and the intact state from the core's bond flags (bit 0 set
 * by a break, restored from a checkpoint on restart). Idempotent: a restarted run computes the
 * same r0, wc and intact sums as the uninterrupted one (vint is always the row-order sum). */
static ej_err pd_init_bonds(pd_state *s, ej_set *set, const ej_nbr *nbr)
{
  const ej_idx n = ej_set_count(set);
  EJ_ENSURE(nbr && nbr->n_rows == n, EJ_ERR_INTERNAL, "set '%s': pd family list has %d rows for %d particles",
            s->set_name, nbr ? (int)nbr->n_rows : -1, (int)n);
  uint8_t *flags = ej_set_bond_flags(set);
  EJ_ENSURE(flags, EJ_ERR_INTERNAL, "set '%s': pd needs the core's bond flags", s->set_name);
  const ej_off nnz = nbr->off[n];
  s->n_rows = n;
  s->nnz = nnz;
  s->off = nbr->off;
  s->idx = nbr->idx;
  s->flags = flags;
  s->r0 = ej_malloc((size_t)(nnz ? nnz : 1) * sizeof *s->r0);
  s->wc = ej_malloc((size_t)(nnz ? nnz : 1) * sizeof *s->wc);
  s->vinter = ej_calloc((size_t)(n ? n : 1), sizeof *s->vinter);
  s->vint = ej_calloc((size_t)(n ? n : 1), sizeof *s->vint);
  s->rsum = ej_calloc(3 * (size_t)(n ? n : 1), sizeof *s->rsum);
  s->rend = ej_calloc((size_t)(n ? n : 1), sizeof *s->rend);
  EJ_ENSURE(s->r0 && s->wc && s->vinter && s->vint && s->rsum && s->rend, EJ_ERR_MEM,
            "pd: out of memory for %lld bonds", (long long)nnz);
  const ej_real *x0 = ej_set_field(set, "x0"), *vol0 = ej_set_field(set, "vol0");
  ej_real *im = ej_set_field(set, "lps_im");
  EJ_ENSURE(x0 && vol0, EJ_ERR_INTERNAL, "set '%s': pd needs x0 and vol0", s->set_name);
  const ej_real d2 = s->delta * s->delta;
  const ej_real cw = s->cfg.model == PD_PMB ? s->c_bond : 1.0;
  int64_t nb = 0;
  const ej_real *na_ = s->cfg.notch_a, *nb_ = s->cfg.notch_b;
  const bool notch = na_[0] != nb_[0] || na_[1] != nb_[1];
  for (ej_idx i = 0; i < n; ++i) {
    ej_real wvol = 0, vi = 0;
    for (ej_off k = nbr->off[i]; k < nbr->off[i + 1]; ++k) {
      const ej_idx j = nbr->idx[k];
      const ej_real dx = x0[3 * i] - x0[3 * j], dy = x0[3 * i + 1] - x0[3 * j + 1], dz = x0[3 * i + 2] - x0[3 * j + 2];
      const ej_real rsq = dx * dx + dy * dy + dz * dz;
      const ej_real r0 = sqrt(rsq);
      s->r0[k] = r0 > 0 ? r0 : 1.0;
      if (rsq <= d2 && r0 > 0 && !(notch && pd_crosses(x0 + 3 * i, x0 + 3 * (size_t)j, na_, nb_))) {
        const ej_real sc = pd_vscale(s, r0);
        const bool intact = !(flags[k] & PD_BROKEN);
        flags[k] &= (uint8_t)~PD_NOT_BOND;
        s->wc[k] = intact ? cw * vol0[j] * sc : 0.0;
        s->vinter[i] += vol0[j];
        if (intact) vi += vol0[j];
        /* m = sum w |xi|^2 V_j scale with w = 1/|xi| (fix_peri_neigh.cpp, LPS): the reference
         * weighted volume, counting broken bonds too (LAMMPS never updates wvolume) */
        wvol += (1.0 / r0) * rsq * vol0[j] * sc;
        ++nb;
      } else {
        s->wc[k] = 0;
        flags[k] |= PD_NOT_BOND;
      }
    }
    s->vint[i] = vi;
    if (im) im[i] = wvol != 0 ? 1.0 / wvol : 0.0;
  }
  s->n_bonds = nb;
  if (PD_AVX2 && s->cfg.model == PD_PMB) {
    const ej_idx na = ej_set_count_all(set);
    s->xq = ej_malloc(4 * (size_t)(na ? na : 1) * sizeof *s->xq);
    EJ_ENSURE(s->xq, EJ_ERR_MEM, "pd: out of memory");
    s->xq_n = na;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ contact list */

/* The contact grid (serial, once per rebuild): a dense grid of cells of size gh >= rc over the
 * bounding box of every particle (owned and ghost), counting-sorted (stable: ascending index
 * within a cell) with a contiguous copy of the positions, so a row search reads three
 * consecutive cells at a time, in memory order. When fragments spread the box so far that the
 * cells would outnumber 4 n_all, the cells grow (more candidates per search, same result). */
__attribute__((noinline)) static ej_err pd_build_grid(pd_state *s, ej_set *set)
{
  const ej_idx n = ej_set_count(set), na = ej_set_count_all(set);
  const ej_real *x = ej_set_field(set, "x");
  EJ_ENSURE(x, EJ_ERR_INTERNAL, "set '%s': pd needs x", s->set_name);
  if (na > s->n_all_cap || !s->order) {
    ej_free(s->cellof), ej_free(s->order), ej_free(s->xss);
    s->cellof = ej_malloc((size_t)(na ? na : 1) * sizeof *s->cellof);
    s->order = ej_malloc((size_t)(na ? na : 1) * sizeof *s->order);
    s->xss = ej_malloc((size_t)(na ? na : 1) * 3 * sizeof *s->xss);
    EJ_ENSURE(s->cellof && s->order && s->xss, EJ_ERR_MEM, "pd: out of memory (contact grid)");
    s->n_all_cap = na;
  }
  if (!s->cidx) {
    s->xcb = ej_malloc((size_t)(n ? n : 1) * 3 * sizeof *s->xcb);
    s->ccnt = ej_calloc((size_t)(n ? n : 1), sizeof *s->ccnt);
    s->cidx = ej_malloc((size_t)(n ? n : 1) * PD_CCAP * sizeof *s->cidx);
    EJ_ENSURE(s->xcb && s->ccnt && s->cidx, EJ_ERR_MEM, "pd: out of memory (contact list)");
  }
  const int dim = s->dim;
  ej_real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim; ++d) lo[d] = HUGE_VAL, hi[d] = -HUGE_VAL;
  for (ej_idx p = 0; p < na; ++p)
    for (int d = 0; d < dim; ++d) {
      const ej_real v = x[3 * (size_t)p + d];
      EJ_ENSURE(isfinite(v), EJ_ERR_NUMERIC, "set '%s': pd particle %d has a non-finite position", s->set_name, (int)p);
      lo[d] = v < lo[d] ? v : lo[d];
      hi[d] = v > hi[d] ? v : hi[d];
    }
  const size_t limit = 4 * (size_t)(na ? na : 1) + 64;
  ej_real h = s->rc;
  size_t nc;
  for (;;) {
    nc = 1;
    for (int d = 0; d < 3; ++d) {
      s->gn[d] = d < dim && na ? (int64_t)floor((hi[d] - lo[d]) / h) + 1 : 1;
      nc *= (size_t)s->gn[d];
    }
    if (nc <= limit) break;
    h *= 1.25;
  }
  s->gh = h;
  s->gr = (int64_t)ceil(s->rc / h - 1e-9); /* cells searched either side: 2, or 1 once grown */
  memcpy(s->glo, lo, sizeof lo);
  if (nc + 1 > s->ncell_cap) {
    ej_free(s->cstart);
    s->ncell_cap = limit + 1;
    s->cstart = ej_malloc(s->ncell_cap * sizeof *s->cstart);
    EJ_ENSURE(s->cstart, EJ_ERR_MEM, "pd: out of memory (contact grid)");
  }
  memset(s->cstart, 0, (nc + 1) * sizeof *s->cstart);
  const ej_real inv_h = 1.0 / h;
  for (ej_idx p = 0; p < na; ++p) {
    int64_t c = 0;
    for (int d = dim - 1; d >= 0; --d) {
      int64_t k = (int64_t)((x[3 * (size_t)p + d] - lo[d]) * inv_h);
      k = k < 0 ? 0 : k >= s->gn[d] ? s->gn[d] - 1 : k;
      c = c * s->gn[d] + k;
    }
    s->cellof[p] = (uint32_t)c;
    s->cstart[c + 1]++;
  }
  for (size_t c = 0; c < nc; ++c) s->cstart[c + 1] += s->cstart[c];
  for (ej_idx p = 0; p < na; ++p) {
    const uint32_t q = s->cstart[s->cellof[p]]++;
    s->order[q] = p;
    memcpy(s->xss + 3 * (size_t)q, x + 3 * (size_t)p, 3 * sizeof *x);
  }
  for (size_t c = nc; c > 0; --c) s->cstart[c] = s->cstart[c - 1];
  s->cstart[0] = 0;
  s->n_contact_builds++;
  return EJ_OK;
}

/* Whether j is in i's reference family (the core's rows are sorted ascending: binary search). */
static inline bool pd_in_family(const pd_state *s, ej_idx i, ej_idx j)
{
  ej_off lo = s->off[i], hi = s->off[i + 1];
  while (lo < hi) {
    const ej_off mid = lo + (hi - lo) / 2;
    if (s->idx[mid] < j) lo = mid + 1;
    else hi = mid;
  }
  return lo < s->off[i + 1] && s->idx[lo] == j;
}

/* Row search of particle i in the grid, all at the positions of the build (i's in xcb, the others'
 * in xss): the particles (owned or ghost) within rc of i that are NOT in i's family (family pairs
 * get their contact force in the bond loop, which visits them anyway), ascending j. Stores the
 * first cap in buf; returns the count (PD_CBIG + 1 when there are more than PD_CBIG - 1
 * candidates). Pairs that come within d_ij <= 1.35 lc before the next rebuild were within
 * rc = 1.35 lc + skin at the build (every particle has moved less than skin/2 since), so the same
 * search repeated later gives the same list (an overflowing row is searched again at every step).
 * Family test: an owned j whose reference distance is clearly inside (outside) the family radius
 * R is (is not) in the family; the rest, and ghosts, by binary search in the core's sorted row.
 * Reads only. */
__attribute__((noinline)) static ej_idx pd_row_search(const pd_state *s, const ej_real *x0, ej_idx i, ej_idx *buf,
                                                      ej_idx cap)
{
  const ej_real *pi = s->xcb + 3 * (size_t)i;
  const ej_real xi = pi[0], yi = pi[1], zi = pi[2], rc2 = s->rc * s->rc;
  const ej_real ax = x0[3 * i], ay = x0[3 * i + 1], az = x0[3 * i + 2];
  const ej_real R = s->delta * (1 + 1e-9); /* the radius of pd_support */
  const ej_real rin2 = 0.99 * 0.99 * R * R, rout2 = 1.01 * 1.01 * R * R;
  const ej_idx n = s->n_rows;
  const int64_t nx = s->gn[0], ny = s->gn[1], nz = s->gn[2], gr = s->gr;
  const int64_t c = s->cellof[i], cx = c % nx, cy = (c / nx) % ny, cz = c / (nx * ny);
  const ej_real *restrict xs = s->xss;
  const ej_idx *restrict order = s->order;
  ej_idx tmp[PD_CBIG];
  ej_idx m = 0;
  const int64_t xl = cx - gr > 0 ? cx - gr : 0, xh = cx + gr < nx ? cx + gr : nx - 1;
  for (int64_t z = cz - gr; z <= cz + gr; ++z) {
    if (z < 0 || z >= nz) continue;
    for (int64_t y = cy - gr; y <= cy + gr; ++y) {
      if (y < 0 || y >= ny) continue;
      const int64_t base = (z * ny + y) * nx;
      const uint32_t q0 = s->cstart[base + xl], q1 = s->cstart[base + xh + 1];
      if (m + (ej_idx)(q1 - q0) >= PD_CBIG) return PD_CBIG + 1;
      /* branch-free append: the test fails for most candidates, unpredictably */
      for (uint32_t q = q0; q < q1; ++q) {
        const ej_idx j = order[q];
        const ej_real dx = xs[3 * (size_t)q] - xi, dy = xs[3 * (size_t)q + 1] - yi, dz = xs[3 * (size_t)q + 2] - zi;
        tmp[m] = j;
        m += (dx * dx + dy * dy + dz * dz < rc2) & (j != i);
      }
    }
  }
  ej_idx cnt = 0;
  for (ej_idx q = 0; q < m; ++q) {
    const ej_idx j = tmp[q];
    if (j < n) {
      const ej_real ex = x0[3 * (size_t)j] - ax, ey = x0[3 * (size_t)j + 1] - ay, ez = x0[3 * (size_t)j + 2] - az;
      const ej_real e2 = ex * ex + ey * ey + ez * ez;
      if (e2 < rin2 || (e2 < rout2 && pd_in_family(s, i, j))) continue;
    } else if (pd_in_family(s, i, j)) {
      continue;
    }
    /* insertion in ascending j: the contact sum then does not depend on the cell-scan order,
     * i.e. on when the list was built (restart, skin) */
    ej_idx p = cnt;
    for (; p > 0 && tmp[p - 1] > j; --p) tmp[p] = tmp[p - 1];
    tmp[p] = j;
    ++cnt;
  }
  for (ej_idx q = 0; q < cnt && q < cap; ++q) buf[q] = tmp[q];
  return cnt;
}

/* ------------------------------------------------------------------ passes */

/* Runs once, on the first compute, inside a critical section; every chunk then sees ready = 1. */
static ej_err pd_ensure_ready(pd_state *s, ej_set *set, const ej_nbr *nbr)
{
  int ready;
#pragma omp atomic read seq_cst
  ready = s->ready;
  if (ready) return s->init_rc == EJ_OK ? EJ_OK : ej_error_push(s->init_rc, __FILE__, __LINE__, __func__, "pd: initialisation failed");
  ej_err rc = EJ_OK;
#pragma omp critical(pd_lazy_init)
  {
    if (!s->ready) {
      rc = pd_init_bonds(s, set, nbr);
      s->init_rc = rc;
      if (rc == EJ_OK) {
#pragma omp atomic write seq_cst
        s->due_t = s->epoch;
      }
#pragma omp atomic write seq_cst
      s->ready = 1;
    } else {
      rc = s->init_rc;
    }
  }
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);
  return EJ_OK;
}

/* Pass 0: contact displacement check; LPS dilatation theta_i = (3/m_i) sum w r0 dr V_j scale
 * (pair_peri_lps.cpp compute_dilatation; w r0 = 1 for w = 1/r0) and tm_i = theta_i / m_i, which
 * pass 1 reads for every neighbour (one gather instead of two and a product). */
static ej_err pd_pass0(pd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  EJ_TRY(pd_ensure_ready(s, set, nbr));
  const ej_real *restrict x = ej_set_field(set, "x");
  if (s->cfg.contact) {
    const int64_t t = s->epoch;
    int64_t due_t;
#pragma omp atomic read seq_cst
    due_t = s->due_t;
    if (due_t != t) {
      const ej_real lim2 = 0.25 * s->skin * s->skin;
      bool far = false;
      for (ej_idx i = r.begin; i < r.end && !far; ++i) {
        const ej_real dx = x[3 * i] - s->xcb[3 * i], dy = x[3 * i + 1] - s->xcb[3 * i + 1],
                      dz = x[3 * i + 2] - s->xcb[3 * i + 2];
        far = dx * dx + dy * dy + dz * dz > lim2;
      }
      if (far) {
#pragma omp atomic write seq_cst
        s->due_t = t;
      }
    }
  }
  {
    /* The bonds that broke in the last evaluation were broken after their force was applied
     * (LAMMPS), so that force is still in a_n and acts over this step's first half kick and drift
     * (x_n+1 - x_n = dt v_half), with no potential energy left to pay for it: its work
     * 1/2 V_i f_brk . dt v_half (trapezoid, force 0 at the end of the step) leaves the mechanical
     * energy and is booked with the released bond energy, so the budget closes. */
    ej_real *fb = ej_set_field(set, "f_brk"), *wf = ej_set_field(set, "w_frac");
    const ej_real *vh = ej_set_field(set, "v_half"), *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0");
    EJ_ENSURE(fb && wf && m && vol0, EJ_ERR_INTERNAL, "set '%s': pd fields missing", s->set_name);
    const ej_real hdt = 0.5 * ej_set_dt(set);
    for (ej_idx i = r.begin; i < r.end; ++i) {
      ej_real *f = fb + 3 * (size_t)i;
      if (f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0) continue;
      if (vh) wf[i] -= hdt * vol0[i] / m[i] * (f[0] * vh[3 * i] + f[1] * vh[3 * i + 1] + f[2] * vh[3 * i + 2]);
      f[0] = f[1] = f[2] = 0.0;
    }
  }
  if (s->xq) {
    /* positions and s0 of this step packed for pass 1; ghosts by the chunk that ends the set */
    const ej_real *s0 = ej_set_field(set, "s0");
    const ej_idx n = ej_set_count(set), na = ej_set_count_all(set);
    EJ_ENSURE(s0 && na <= s->xq_n, EJ_ERR_INTERNAL, "set '%s': pd packed positions", s->set_name);
    for (ej_idx i = r.begin; i < r.end; ++i) {
      ej_real *q = s->xq + 4 * (size_t)i;
      q[0] = x[3 * i], q[1] = x[3 * i + 1], q[2] = x[3 * i + 2], q[3] = s0[i];
    }
    if (r.end == n)
      for (ej_idx i = n; i < na; ++i) {
        ej_real *q = s->xq + 4 * (size_t)i;
        q[0] = x[3 * i], q[1] = x[3 * i + 1], q[2] = x[3 * i + 2], q[3] = s0[i];
      }
  }
  if (s->cfg.model != PD_LPS) return EJ_OK;
  ej_real *restrict theta = ej_set_field(set, "theta"), *restrict tm = ej_set_field(set, "lps_tm");
  const ej_real *restrict im = ej_set_field(set, "lps_im");
  EJ_ENSURE(theta && tm && im, EJ_ERR_INTERNAL, "set '%s': pd lps fields missing", s->set_name);
  const ej_off *restrict off = nbr->off;
  const ej_idx *restrict idx = nbr->idx;
  const ej_real *restrict r0 = s->r0, *restrict wc = s->wc;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real xi = x[3 * i], yi = x[3 * i + 1], zi = x[3 * i + 2];
    ej_real th = 0;
    const ej_off k0 = off[i], k1 = off[i + 1];
#pragma omp simd reduction(+ : th)
    for (ej_off k = k0; k < k1; ++k) {
      const ej_idx j = idx[k];
      const ej_real dx = x[3 * j] - xi, dy = x[3 * j + 1] - yi, dz = x[3 * j + 2] - zi;
      ej_real dr = sqrt(dx * dx + dy * dy + dz * dz) - r0[k];
      dr = fabs(dr) < PD_NEAR_ZERO ? 0.0 : dr;
      th += dr * wc[k]; /* wc = 0 for broken bonds and non-bonds */
    }
    theta[i] = im[i] != 0 ? 3.0 * im[i] * th : 0.0;
    tm[i] = theta[i] * im[i];
  }
  return EJ_OK;
}

/* Pass 1 of a step whose pass 0 found a particle moved more than skin/2 since the last build (or
 * the first step): the first chunk builds the grid (serial, O(n)), then every chunk searches the
 * rows of its own particles (parallel; each writes only its rows). */
static ej_err pd_contact_ready(pd_state *s, ej_set *set, ej_range r)
{
  const int64_t t = s->epoch;
  int64_t due_t;
#pragma omp atomic read seq_cst
  due_t = s->due_t;
  if (due_t != t) return EJ_OK;
  ej_err rc = EJ_OK;
#pragma omp critical(pd_contact_build)
  {
    if (s->grid_t != t) {
      rc = pd_build_grid(s, set);
      if (rc == EJ_OK) {
#pragma omp atomic write seq_cst
        s->grid_t = t;
      }
    }
  }
  if (rc != EJ_OK) EJ_FAIL(rc, NULL);
  const ej_real *x = ej_set_field(set, "x"), *x0 = ej_set_field(set, "x0");
  EJ_ENSURE(x && x0, EJ_ERR_INTERNAL, "set '%s': pd needs x and x0", s->set_name);
  for (ej_idx i = r.begin; i < r.end; ++i) {
    memcpy(s->xcb + 3 * (size_t)i, x + 3 * (size_t)i, 3 * sizeof *x);
    const ej_idx cnt = pd_row_search(s, x0, i, s->cidx + (size_t)i * PD_CCAP, PD_CCAP);
    s->ccnt[i] = (int32_t)cnt;
  }
  return EJ_OK;
}

typedef struct pd_args {
  const ej_real *x, *x0, *m, *vol0, *s0, *theta, *im, *tm;
  ej_real *a, *s0n, *e, *wf, *vint, *fb;
  int32_t *nbk;
  const ej_off *off;
  const ej_idx *idx;
  const ej_real *r0;
  ej_real *wc;
  uint8_t *flags;
  ej_real dmax; /* contact distance cap 1.35 lc; 0 without contact */
} pd_args;

/* What a row's vector sweep returns: force density, sum of the bond energy terms (intact bonds,
 * including those that break now), the extreme stretches over the intact bonds and whether some
 * bond breaks in this evaluation. */
typedef struct pd_row {
  ej_real f[3], en, smin, smax, nbrk, hits;
} pd_row;

/* Bond forces of PMB (pair_peri_pmb.cpp): f_i += c V_j scale s (x_j - x_i)/r; energy per bond
 * and side c s^2 r0 V_j scale / 4 (W_i = 1/2 sum_j w(xi) V_j with w = c s^2 |xi| / 2; the 1/4
 * is applied to the row sum, exact for a power of two). Branch-free so that GCC vectorises it
 * (-fopt-info-vec: 32-byte vectors): broken bonds and non-bonds carry wc = 0, the flags are not
 * read here, and nothing is written; the rare rows where a bond breaks are settled afterwards
 * (pd_settle). One division per bond: q = 1/(r0 r) gives both s = dr/r0 = dr r q and the force
 * factor wc dr q (LAMMPS divides twice; equal to rounding). r = 0 means dr = -r0, s = -1. */
static inline void pd_row_pmb(const pd_args *A, ej_idx i, bool fail, pd_row *o)
{
  const ej_real *restrict x = A->x, *restrict r0 = A->r0, *restrict wc = A->wc, *restrict s0 = A->s0;
  const ej_idx *restrict idx = A->idx;
  const ej_real xi = x[3 * i], yi = x[3 * i + 1], zi = x[3 * i + 2], s0i = s0[i];
  const ej_real dmax = A->dmax;
  ej_real fx = 0, fy = 0, fz = 0, en = 0, smin = HUGE_VAL, smax = -HUGE_VAL, nbrk = 0, hits = 0;
  const ej_off k0 = A->off[i], k1 = A->off[i + 1];
#pragma omp simd reduction(+ : fx, fy, fz, en, nbrk, hits) reduction(min : smin) reduction(max : smax)
  for (ej_off k = k0; k < k1; ++k) {
    const ej_idx j = idx[k];
    const ej_real dx = x[3 * j] - xi, dy = x[3 * j + 1] - yi, dz = x[3 * j + 2] - zi;
    const ej_real r2 = dx * dx + dy * dy + dz * dz;
    const ej_real r = sqrt(r2);
    const ej_real rr0 = r0[k];
    ej_real dr = r - rr0;
    dr = fabs(dr) < PD_NEAR_ZERO ? 0.0 : dr;
    /* contact of this family pair (bonded or not), d = min(0.9 |xi|, 1.35 lc): counted here,
     * summed by pd_contacts for the rare row with a hit */
    const ej_real dc0 = 0.9 * rr0, dc = dc0 < dmax ? dc0 : dmax;
    hits += r2 < dc * dc ? 1.0 : 0.0;
    const ej_real qq = 1.0 / (rr0 * r); /* unconditional: GCC does not if-convert a division */
    const ej_real q = r > 0.0 ? qq : 0.0;
    const ej_real st = r > 0.0 ? dr * r * q : -1.0;
    const ej_real w = wc[k];
    const ej_real fb = w * dr * q;
    fx += dx * fb, fy += dy * fb, fz += dz * fb;
    en += w * st * dr;
    /* no && and no if: control flow stops the vectoriser */
    const int al = w > 0.0;
    const ej_real s0j = s0[j];
    const ej_real lim = s0i < s0j ? s0i : s0j;
    nbrk += (al & (st > lim)) ? 1.0 : 0.0;
    const ej_real sa = al ? st : HUGE_VAL, sb = al ? st : -HUGE_VAL;
    smin = sa < smin ? sa : smin;
    smax = sb > smax ? sb : smax;
  }
  o->f[0] = fx, o->f[1] = fy, o->f[2] = fz;
  o->en = 0.25 * en;
  o->smin = smin, o->smax = smax, o->nbrk = fail ? nbrk : 0.0, o->hits = hits;
}

#if PD_AVX2
/* pd_row_pmb with AVX2 intrinsics: the same operations lane by lane (no FMA), the neighbour's
 * x, y, z, s0 read with one 32-byte load from the packed copy xq and transposed (GCC emulates the
 * gathers of x[3j..3j+2] and s0[j] with 16 scalar loads per 4 bonds). Only the order of the
 * row sums differs from the portable loop (four lanes, then a fixed horizontal sum). */
static inline void pd_row_pmb_avx2(const pd_args *A, const ej_real *xq, ej_idx i, bool fail, pd_row *o)
{
  const ej_real *restrict r0 = A->r0, *restrict wc = A->wc;
  const ej_idx *restrict idx = A->idx;
  const ej_real *qi = xq + 4 * (size_t)i;
  const __m256d xi = _mm256_set1_pd(qi[0]), yi = _mm256_set1_pd(qi[1]), zi = _mm256_set1_pd(qi[2]);
  const __m256d s0i = _mm256_set1_pd(qi[3]), vdmax = _mm256_set1_pd(A->dmax);
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0), c09 = _mm256_set1_pd(0.9);
  const __m256d near = _mm256_set1_pd(PD_NEAR_ZERO), sign = _mm256_set1_pd(-0.0), m1 = _mm256_set1_pd(-1.0);
  const __m256d pinf = _mm256_set1_pd(HUGE_VAL), minf = _mm256_set1_pd(-HUGE_VAL);
  __m256d fx = zero, fy = zero, fz = zero, en = zero, nb = zero, ht = zero, smin = pinf, smax = minf;
  const ej_off k0 = A->off[i], k1 = A->off[i + 1];
  ej_off k = k0;
  for (; k + 4 <= k1; k += 4) {
    const __m256d a0 = _mm256_loadu_pd(xq + 4 * (size_t)idx[k]), a1 = _mm256_loadu_pd(xq + 4 * (size_t)idx[k + 1]);
    const __m256d a2 = _mm256_loadu_pd(xq + 4 * (size_t)idx[k + 2]), a3 = _mm256_loadu_pd(xq + 4 * (size_t)idx[k + 3]);
    const __m256d t0 = _mm256_unpacklo_pd(a0, a1), t1 = _mm256_unpackhi_pd(a0, a1);
    const __m256d t2 = _mm256_unpacklo_pd(a2, a3), t3 = _mm256_unpackhi_pd(a2, a3);
    const __m256d xj = _mm256_permute2f128_pd(t0, t2, 0x20), yj = _mm256_permute2f128_pd(t1, t3, 0x20);
    const __m256d zj = _mm256_permute2f128_pd(t0, t2, 0x31), s0j = _mm256_permute2f128_pd(t1, t3, 0x31);
    const __m256d dx = _mm256_sub_pd(xj, xi), dy = _mm256_sub_pd(yj, yi), dz = _mm256_sub_pd(zj, zi);
    const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
    const __m256d r = _mm256_sqrt_pd(r2);
    const __m256d rr0 = _mm256_loadu_pd(r0 + k);
    __m256d dr = _mm256_sub_pd(r, rr0);
    dr = _mm256_andnot_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, dr), near, _CMP_LT_OQ), dr);
    const __m256d dc = _mm256_min_pd(_mm256_mul_pd(c09, rr0), vdmax);
    ht = _mm256_add_pd(ht, _mm256_and_pd(_mm256_cmp_pd(r2, _mm256_mul_pd(dc, dc), _CMP_LT_OQ), one));
    const __m256d qq = _mm256_div_pd(one, _mm256_mul_pd(rr0, r));
    const __m256d pos = _mm256_cmp_pd(r, zero, _CMP_GT_OQ);
    const __m256d q = _mm256_and_pd(pos, qq);
    const __m256d st = _mm256_blendv_pd(m1, _mm256_mul_pd(_mm256_mul_pd(dr, r), q), pos);
    const __m256d w = _mm256_loadu_pd(wc + k);
    const __m256d fb = _mm256_mul_pd(_mm256_mul_pd(w, dr), q);
    fx = _mm256_add_pd(fx, _mm256_mul_pd(dx, fb));
    fy = _mm256_add_pd(fy, _mm256_mul_pd(dy, fb));
    fz = _mm256_add_pd(fz, _mm256_mul_pd(dz, fb));
    en = _mm256_add_pd(en, _mm256_mul_pd(_mm256_mul_pd(w, st), dr));
    const __m256d al = _mm256_cmp_pd(w, zero, _CMP_GT_OQ);
    const __m256d lim = _mm256_min_pd(s0i, s0j);
    nb = _mm256_add_pd(nb, _mm256_and_pd(_mm256_and_pd(al, _mm256_cmp_pd(st, lim, _CMP_GT_OQ)), one));
    smin = _mm256_min_pd(_mm256_blendv_pd(pinf, st, al), smin);
    smax = _mm256_max_pd(_mm256_blendv_pd(minf, st, al), smax);
  }
  double v[8][4];
  _mm256_storeu_pd(v[0], fx), _mm256_storeu_pd(v[1], fy), _mm256_storeu_pd(v[2], fz), _mm256_storeu_pd(v[3], en);
  _mm256_storeu_pd(v[4], nb), _mm256_storeu_pd(v[5], ht), _mm256_storeu_pd(v[6], smin), _mm256_storeu_pd(v[7], smax);
  ej_real sfx = (v[0][0] + v[0][1]) + (v[0][2] + v[0][3]), sfy = (v[1][0] + v[1][1]) + (v[1][2] + v[1][3]);
  ej_real sfz = (v[2][0] + v[2][1]) + (v[2][2] + v[2][3]), sen = (v[3][0] + v[3][1]) + (v[3][2] + v[3][3]);
  ej_real snb = (v[4][0] + v[4][1]) + (v[4][2] + v[4][3]), sht = (v[5][0] + v[5][1]) + (v[5][2] + v[5][3]);
  ej_real mn = v[6][0], mx = v[7][0];
  for (int l = 1; l < 4; ++l) mn = v[6][l] < mn ? v[6][l] : mn, mx = v[7][l] > mx ? v[7][l] : mx;
  /* the remaining bonds: the portable loop's operations */
  const ej_real xs = qi[0], ys = qi[1], zs = qi[2], s0s = qi[3], dmax = A->dmax;
  for (; k < k1; ++k) {
    const ej_real *qj = xq + 4 * (size_t)idx[k];
    const ej_real dx = qj[0] - xs, dy = qj[1] - ys, dz = qj[2] - zs;
    const ej_real r2 = dx * dx + dy * dy + dz * dz;
    const ej_real r = sqrt(r2);
    const ej_real rr0 = r0[k];
    ej_real dr = r - rr0;
    dr = fabs(dr) < PD_NEAR_ZERO ? 0.0 : dr;
    const ej_real dc0 = 0.9 * rr0, dc = dc0 < dmax ? dc0 : dmax;
    sht += r2 < dc * dc ? 1.0 : 0.0;
    const ej_real q = r > 0.0 ? 1.0 / (rr0 * r) : 0.0;
    const ej_real st = r > 0.0 ? dr * r * q : -1.0;
    const ej_real w = wc[k];
    const ej_real fb = w * dr * q;
    sfx += dx * fb, sfy += dy * fb, sfz += dz * fb;
    sen += w * st * dr;
    const int al = w > 0.0;
    const ej_real lim = s0s < qj[3] ? s0s : qj[3];
    snb += (al & (st > lim)) ? 1.0 : 0.0;
    if (al) mn = st < mn ? st : mn, mx = st > mx ? st : mx;
  }
  o->f[0] = sfx, o->f[1] = sfy, o->f[2] = sfz;
  o->en = 0.25 * sen;
  o->smin = mn, o->smax = mx, o->nbrk = fail ? snb : 0.0, o->hits = sht;
}
#endif

/* Bond forces of LPS (pair_peri_lps.cpp): with w r0 = 1 for w = 1/r0,
 *   rk = (3K - 5G) V_j scale (theta_i/m_i + theta_j/m_j) + 15 G V_j scale (1/m_i + 1/m_j) dr / r0;
 * energy (Silling et al. 2007 sec. 15) W_i = K theta_i^2/2 + (15 G / 2 m_i) sum w (e^d)^2 V_j scale,
 * e^d = dr - theta_i r0 / 3 (the 1/2 applied to the row sum). */
static inline void pd_row_lps(const pd_state *s, const pd_args *A, ej_idx i, bool fail, pd_row *o)
{
  const ej_real *restrict x = A->x, *restrict tm = A->tm, *restrict im = A->im;
  const ej_real *restrict r0 = A->r0, *restrict wc = A->wc, *restrict s0 = A->s0;
  const ej_idx *restrict idx = A->idx;
  const ej_real xi = x[3 * i], yi = x[3 * i + 1], zi = x[3 * i + 2], s0i = s0[i];
  const ej_real A35 = 3.0 * s->K - 5.0 * s->G, G15 = 15.0 * s->G;
  const ej_real ti = tm[i], imi = im[i], th3 = A->theta[i] / 3.0, gi = G15 * imi;
  const ej_real dmax = A->dmax;
  ej_real fx = 0, fy = 0, fz = 0, en = 0, smin = HUGE_VAL, smax = -HUGE_VAL, nbrk = 0, hits = 0;
  const ej_off k0 = A->off[i], k1 = A->off[i + 1];
#pragma omp simd reduction(+ : fx, fy, fz, en, nbrk, hits) reduction(min : smin) reduction(max : smax)
  for (ej_off k = k0; k < k1; ++k) {
    const ej_idx j = idx[k];
    const ej_real dx = x[3 * j] - xi, dy = x[3 * j + 1] - yi, dz = x[3 * j + 2] - zi;
    const ej_real r2 = dx * dx + dy * dy + dz * dz;
    const ej_real r = sqrt(r2);
    const ej_real rr0 = r0[k];
    ej_real dr = r - rr0;
    dr = fabs(dr) < PD_NEAR_ZERO ? 0.0 : dr;
    const ej_real dc0 = 0.9 * rr0, dc = dc0 < dmax ? dc0 : dmax;
    hits += r2 < dc * dc ? 1.0 : 0.0;
    const ej_real inv_r0 = 1.0 / rr0;
    const ej_real w = wc[k];
    const ej_real rk = A35 * w * (ti + tm[j]) + G15 * w * (imi + im[j]) * dr * inv_r0;
    const ej_real fq = rk / r; /* unconditional: GCC does not if-convert a division */
    const ej_real fb = r > 0.0 ? fq : 0.0;
    fx += dx * fb, fy += dy * fb, fz += dz * fb;
    const ej_real ed = dr - th3 * rr0;
    en += gi * ed * ed * w * inv_r0;
    const ej_real st = dr * inv_r0;
    /* no && and no if: control flow stops the vectoriser */
    const int al = w > 0.0;
    const ej_real s0j = s0[j];
    const ej_real lim = s0i < s0j ? s0i : s0j;
    nbrk += (al & (st > lim)) ? 1.0 : 0.0;
    const ej_real sa = al ? st : HUGE_VAL, sb = al ? st : -HUGE_VAL;
    smin = sa < smin ? sa : smin;
    smax = sb > smax ? sb : smax;
  }
  o->f[0] = fx, o->f[1] = fy, o->f[2] = fz;
  o->en = 0.5 * en + 0.5 * s->K * A->theta[i] * A->theta[i];
  o->smin = smin, o->smax = smax, o->nbrk = fail ? nbrk : 0.0, o->hits = hits;
}

/* A row where some bond breaks (rare): mark the breaking bonds broken in the core's flags (bit 0,
 * checkpointed) and zero their wc, move their energy from the elastic to the released energy,
 * and recompute the intact volume sum in row order. The stretch is recomputed with exactly the
 * operations of the vector sweep (no FMA contraction in ISO C mode), so the decisions agree. */
static void pd_settle(const pd_state *s, const pd_args *A, ej_idx i, pd_row *o, ej_real *e_brk, int *nbroken,
                      ej_real f_brk[3])
{
  const ej_real *x = A->x, *r0 = A->r0, *s0 = A->s0, *vol0 = A->vol0;
  const bool lps = s->cfg.model == PD_LPS;
  const ej_real xi = x[3 * i], yi = x[3 * i + 1], zi = x[3 * i + 2], s0i = s0[i];
  const ej_real gi = lps ? 15.0 * s->G * A->im[i] : 0.0, th3 = lps ? A->theta[i] / 3.0 : 0.0;
  ej_real en = 0, eb = 0, vi = 0, fbx = 0, fby = 0, fbz = 0;
  int nb = 0;
  for (ej_off k = A->off[i]; k < A->off[i + 1]; ++k) {
    const ej_real w = A->wc[k];
    if (!(w > 0.0)) continue;
    const ej_idx j = A->idx[k];
    const ej_real dx = x[3 * j] - xi, dy = x[3 * j + 1] - yi, dz = x[3 * j + 2] - zi;
    const ej_real r = sqrt(dx * dx + dy * dy + dz * dz);
    const ej_real rr0 = r0[k];
    ej_real dr = r - rr0;
    dr = fabs(dr) < PD_NEAR_ZERO ? 0.0 : dr;
    ej_real st, term, fq;
    if (lps) {
      const ej_real inv_r0 = 1.0 / rr0, ed = dr - th3 * rr0;
      st = dr * inv_r0;
      term = gi * ed * ed * w * inv_r0;
      /* the bond's force as in pd_row_lps */
      const ej_real rk = (3.0 * s->K - 5.0 * s->G) * w * (A->tm[i] + A->tm[j]) +
                         15.0 * s->G * w * (A->im[i] + A->im[j]) * dr * inv_r0;
      fq = r > 0.0 ? rk / r : 0.0;
    } else {
      const ej_real q = r > 0.0 ? 1.0 / (rr0 * r) : 0.0;
      st = r > 0.0 ? dr * r * q : -1.0;
      term = w * st * dr;
      fq = w * dr * q;
    }
    const ej_real s0j = s0[j];
    if (st > (s0i < s0j ? s0i : s0j)) {
      A->flags[k] |= PD_BROKEN;
      A->wc[k] = 0.0;
      eb += term;
      fbx += fq * dx, fby += fq * dy, fbz += fq * dz;
      ++nb;
    } else {
      en += term;
      vi += vol0[j];
    }
  }
  const ej_real h = lps ? 0.5 : 0.25;
  o->en = h * en + (lps ? 0.5 * s->K * A->theta[i] * A->theta[i] : 0.0);
  *e_brk = h * eb;
  *nbroken = nb;
  f_brk[0] = fbx, f_brk[1] = fby, f_brk[2] = fbz;
  A->vint[i] = vi;
}

/* Contact (pair_peri_*.cpp "short-range forces"): force density on i 15 c_s V_j (d - r)/delta
 * away from j; energy per side 15 c_s V_j (d - r)^2 / (4 delta); d = min(0.9 |xi|, 1.35 lc).
 * Family pairs (only when the bond loop counted a hit) in row order, then the non-family pairs of
 * the list, ascending j: the sum does not depend on when the list was built (restart, skin). */
static inline void pd_contact_pair(const pd_args *A, ej_real k15, ej_idx i, ej_idx j, ej_real d, ej_real acc[4])
{
  const ej_real *x = A->x;
  const ej_real dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1], dz = x[3 * i + 2] - x[3 * j + 2];
  const ej_real rsq = dx * dx + dy * dy + dz * dz;
  if (rsq >= d * d) return;
  const ej_real r = sqrt(rsq), dr = r - d;
  const ej_real rk = k15 * A->vol0[j] * dr;
  const ej_real fp = r > 0.0 ? -rk / r : 0.0;
  acc[0] += dx * fp, acc[1] += dy * fp, acc[2] += dz * fp;
  acc[3] += 0.25 * rk * dr;
}

__attribute__((noinline)) static ej_err pd_contacts(const pd_state *s, const pd_args *A, ej_idx i, bool family, ej_real f[3], ej_real *en)
{
  const ej_real k15 = 15.0 * s->c_contact / s->delta, dmax = A->dmax;
  ej_real acc[4] = {0, 0, 0, 0};
  if (family)
    for (ej_off k = A->off[i]; k < A->off[i + 1]; ++k) {
      const ej_real dc0 = 0.9 * A->r0[k];
      pd_contact_pair(A, k15, i, A->idx[k], dc0 < dmax ? dc0 : dmax, acc);
    }
  ej_idx buf[PD_CBIG];
  const ej_idx *list = s->cidx + (size_t)i * PD_CCAP;
  ej_idx cnt = s->ccnt[i];
  if (cnt > PD_CCAP) { /* rare: compacted far beyond the lattice density; search the grid */
    cnt = pd_row_search(s, A->x0, i, buf, PD_CBIG);
    EJ_ENSURE(cnt < PD_CBIG, EJ_ERR_NUMERIC,
              "set '%s': pd particle %d has %d non-family particles within the contact reach (at most %d)",
              s->set_name, (int)i, (int)cnt, PD_CBIG - 1);
    list = buf;
  }
  const ej_real *x = A->x, *x0 = A->x0;
  for (ej_idx q = 0; q < cnt; ++q) {
    const ej_idx j = list[q];
    const ej_real dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1], dz = x[3 * i + 2] - x[3 * j + 2];
    if (dx * dx + dy * dy + dz * dz >= dmax * dmax) continue;
    const ej_real ex = x0[3 * i] - x0[3 * j], ey = x0[3 * i + 1] - x0[3 * j + 1], ez = x0[3 * i + 2] - x0[3 * j + 2];
    const ej_real d0 = 0.9 * sqrt(ex * ex + ey * ey + ez * ez);
    pd_contact_pair(A, k15, i, j, d0 < dmax ? d0 : dmax, acc);
  }
  f[0] = acc[0], f[1] = acc[1], f[2] = acc[2];
  *en = acc[3];
  return EJ_OK;
}

/* What pass 1 keeps of a row between its bond sweep and its contacts. */
typedef struct pd_rowres {
  pd_row o;
  ej_real e_brk, f_brk[3];
  int nbroken;
} pd_rowres;

/* The bond part of row i: forces, energy and stretch extremes, then the breaks settled. */
static inline void pd_row_bonds(const pd_state *s, const pd_args *A, ej_idx i, bool lps, bool fail, pd_rowres *w)
{
  w->e_brk = 0, w->f_brk[0] = w->f_brk[1] = w->f_brk[2] = 0, w->nbroken = 0;
  /* specialised calls: the vector loops carry no test of fail */
  if (lps) {
    if (fail) pd_row_lps(s, A, i, true, &w->o);
    else pd_row_lps(s, A, i, false, &w->o);
  } else {
#if PD_AVX2
    if (s->xq) {
      if (fail) pd_row_pmb_avx2(A, s->xq, i, true, &w->o);
      else pd_row_pmb_avx2(A, s->xq, i, false, &w->o);
    } else
#endif
    if (fail) pd_row_pmb(A, i, true, &w->o);
    else pd_row_pmb(A, i, false, &w->o);
  }
  if (w->o.nbrk > 0.0) pd_settle(s, A, i, &w->o, &w->e_brk, &w->nbroken, w->f_brk);
}

/* The rest of row i: its contacts (the list must be ready), then a, s0_new, e, w_frac, f_brk. */
static inline ej_err pd_row_finish(const pd_state *s, const pd_args *A, ej_idx i, bool contact, const pd_rowres *w)
{
  const ej_real s00 = s->cfg.s00, alpha = s->cfg.alpha;
  ej_real fc[3] = {0, 0, 0}, en = w->o.en;
  if (contact) {
    ej_real ec = 0;
    EJ_TRY(pd_contacts(s, A, i, w->o.hits > 0.0, fc, &ec));
    en += ec;
  }
  /* a = F/m with F = V_i f: the force density over the density */
  const ej_real inv_rho = A->vol0[i] / A->m[i];
  A->a[3 * i] += (w->o.f[0] + fc[0]) * inv_rho;
  A->a[3 * i + 1] += (w->o.f[1] + fc[1]) * inv_rho;
  A->a[3 * i + 2] += (w->o.f[2] + fc[2]) * inv_rho;
  /* s0_i = max_j (s00 - alpha s_ij) over the bonds intact before this step's breaks, i.e.
   * s00 - alpha s_min for alpha >= 0 (rounding is monotone, so the same double) */
  A->s0n[i] = !(w->o.smin <= w->o.smax) ? DBL_MAX : alpha >= 0.0 ? s00 - alpha * w->o.smin : s00 - alpha * w->o.smax;
  A->e[i] = en * inv_rho;
  if (w->nbroken) {
    A->wf[i] += w->e_brk * inv_rho;
    A->fb[3 * i] = w->f_brk[0], A->fb[3 * i + 1] = w->f_brk[1], A->fb[3 * i + 2] = w->f_brk[2];
    A->nbk[i] += w->nbroken;
  }
  return EJ_OK;
}

#define PD_SPLIT_ROWS 256 /* rows per block of a chunk whose contacts wait for the grid */

/* Pass 1. On a step that rebuilds the contact list, the first chunk to arrive claims the grid
 * build and does it at once (pd_contact_ready); a chunk that arrives while it is being built
 * sweeps the bonds of its rows first (blocks of PD_SPLIT_ROWS rows, results kept on the stack)
 * and only then waits for the grid, so the other threads work while one builds. Every row sees
 * the same operations either way: the results do not depend on who builds. */
static ej_err pd_pass1(pd_state *s, ej_set *set, const ej_nbr *nbr, ej_range r)
{
  pd_args A = {.x = ej_set_field(set, "x"), .m = ej_set_field(set, "m"), .vol0 = ej_set_field(set, "vol0"),
               .s0 = ej_set_field(set, "s0"), .theta = ej_set_field(set, "theta"), .im = ej_set_field(set, "lps_im"),
               .tm = ej_set_field(set, "lps_tm"), .a = ej_set_field(set, "a"), .s0n = ej_set_field(set, "s0_new"),
               .e = ej_set_field(set, "e_pd"), .wf = ej_set_field(set, "w_frac"), .vint = s->vint,
               .fb = ej_set_field(set, "f_brk"),
               .nbk = ej_set_field_int(set, "n_broken"), .off = nbr->off, .idx = nbr->idx, .r0 = s->r0, .wc = s->wc,
               .flags = s->flags, .x0 = ej_set_field(set, "x0"), .dmax = s->cfg.contact ? 1.35 * s->lc : 0.0};
  EJ_ENSURE(A.x && A.m && A.vol0 && A.s0 && A.a && A.s0n && A.e && A.wf && A.fb && A.nbk, EJ_ERR_INTERNAL,
            "set '%s': pd fields missing", s->set_name);
  const bool lps = s->cfg.model == PD_LPS, contact = s->cfg.contact, fail = s->failure;
  bool split = false;
  if (contact) {
    const int64_t t = s->epoch;
    int64_t due_t, grid_t;
#pragma omp atomic read seq_cst
    due_t = s->due_t;
#pragma omp atomic read seq_cst
    grid_t = s->grid_t;
    if (due_t == t && grid_t != t) {
      int64_t old;
#pragma omp atomic capture seq_cst
      {
        old = s->claim_t;
        s->claim_t = t;
      }
      split = old == t; /* another chunk has claimed this step's build */
    }
  }
  if (!split) {
    if (contact) EJ_TRY(pd_contact_ready(s, set, r));
    for (ej_idx i = r.begin; i < r.end; ++i) {
      pd_rowres w;
      pd_row_bonds(s, &A, i, lps, fail, &w);
      EJ_TRY(pd_row_finish(s, &A, i, contact, &w));
    }
    return EJ_OK;
  }
  pd_rowres w[PD_SPLIT_ROWS];
  for (ej_idx b = r.begin; b < r.end; b += PD_SPLIT_ROWS) {
    const ej_idx e = r.end - b > PD_SPLIT_ROWS ? b + PD_SPLIT_ROWS : r.end;
    for (ej_idx i = b; i < e; ++i) pd_row_bonds(s, &A, i, lps, fail, &w[i - b]);
    if (b == r.begin) EJ_TRY(pd_contact_ready(s, set, r)); /* waits for the build, searches r's rows */
    for (ej_idx i = b; i < e; ++i) EJ_TRY(pd_row_finish(s, &A, i, contact, &w[i - b]));
  }
  return EJ_OK;
}

static ej_err pd_compute(void *state, ej_set *set, const ej_nbr *nbr, int pass, ej_range r)
{
  pd_state *s = state;
  EJ_ENSURE(nbr && nbr->off, EJ_ERR_INTERNAL, "set '%s': pd called without its families", s->set_name);
  switch (pass) {
  case 0: return pd_pass0(s, set, nbr, r);
  case 1: return pd_pass1(s, set, nbr, r);
  default: EJ_FAIL(EJ_ERR_INTERNAL, "pd: pass %d of 2", pass);
  }
}

/* ------------------------------------------------------------------ after the step */

static ej_err pd_post_step(void *state, ej_set *set, ej_range r)
{
  pd_state *s = state;
  ej_real *s0 = ej_set_field(set, "s0"), *dmg = ej_set_field(set, "damage");
  const ej_real *s0n = ej_set_field(set, "s0_new");
  EJ_ENSURE(s0 && dmg && s0n, EJ_ERR_INTERNAL, "set '%s': pd fields missing", s->set_name);
  if (!s->ready) return EJ_OK;
  if (r.begin == 0) s->epoch++; /* read in the next step's passes, after the barrier */
  const ej_real *wf = ej_set_field(set, "w_frac"), *m = ej_set_field(set, "m");
  const int32_t *nb = ej_set_field_int(set, "n_broken");
  EJ_ENSURE(wf && m && nb, EJ_ERR_INTERNAL, "set '%s': pd fields missing", s->set_name);
  ej_real dsum = 0, efrac = 0, broken = 0;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    s0[i] = s0n[i];
    dmg[i] = s->vinter[i] != 0.0 ? 1.0 - s->vint[i] / s->vinter[i] : 0.0;
    dsum += dmg[i], efrac += m[i] * wf[i], broken += nb[i];
  }
  if (r.end > r.begin && s->rsum) {
    s->rsum[3 * (size_t)r.begin] = dsum, s->rsum[3 * (size_t)r.begin + 1] = efrac;
    s->rsum[3 * (size_t)r.begin + 2] = broken;
    s->rend[r.begin] = r.end;
  }
  return EJ_OK;
}

/* Silling & Askari 2005 Eq 16: dt < sqrt(2 rho_i / sum_j V_j C_ij) with C = c/|xi| (PMB); for LPS
 * the PMB micromodulus of the same bulk modulus. */
static ej_err pd_stable_dt(void *state, const ej_set *set, ej_range r, ej_real *dt)
{
  const pd_state *s = state;
  const ej_real *m = ej_set_field(set, "m"), *vol0 = ej_set_field(set, "vol0");
  ej_real best = HUGE_VAL;
  /* the core asks after the first compute, when the families exist */
  if (!s->ready) {
    *dt = best;
    return EJ_OK;
  }
  const ej_real cfac = s->cfg.model == PD_PMB ? 1.0 : s->c_contact; /* wc holds c V scale or V scale */
  for (ej_idx i = r.begin; i < r.end; ++i) {
    ej_real sum = 0;
    for (ej_off k = s->off[i]; k < s->off[i + 1]; ++k)
      sum += cfac * s->wc[k] / s->r0[k]; /* wc = 0: broken or not a bond */
    if (sum > 0) best = fmin(best, sqrt(2.0 * m[i] / vol0[i] / sum));
  }
  *dt = best;
  return EJ_OK;
}

static ej_err pd_report(void *state, const ej_set *set, ej_series_value *out, int max, int *n)
{
  const pd_state *s = state;
  *n = 0;
  if (max < 4) return EJ_OK;
  const ej_idx np = ej_set_count(set);
  const ej_real *dmg = ej_set_field(set, "damage"), *wf = ej_set_field(set, "w_frac"), *m = ej_set_field(set, "m");
  const int32_t *nb = ej_set_field_int(set, "n_broken");
  ej_real dsum = 0, efrac = 0, broken = 0;
  /* the ranges' sums of this step's post_step, in index order (the core's chunks depend on the
   * set's size only: the same sums for any thread count); particles no range summed (before the
   * first step) are swept here */
  for (ej_idx i = 0; i < np;) {
    const ej_idx e = s->rend && s->ready ? s->rend[i] : 0;
    if (e > i) {
      dsum += s->rsum[3 * (size_t)i], efrac += s->rsum[3 * (size_t)i + 1], broken += s->rsum[3 * (size_t)i + 2];
      i = e;
    } else {
      dsum += dmg[i], efrac += m[i] * wf[i], broken += nb[i];
      ++i;
    }
  }
  out[0] = (ej_series_value){.name = "damage_mean", .value = np ? dsum / np : 0};
  /* each broken bond is counted from both ends, like LAMMPS's partner lists */
  out[1] = (ej_series_value){.name = "broken_bonds", .value = (ej_real)broken};
  /* energy taken out by broken bonds: DISSIPATED, so that external = work - fracture_energy */
  out[2] = (ej_series_value){.name = "fracture_energy", .value = efrac, .role = EJ_SERIES_DISSIPATED};
  out[3] = (ej_series_value){.name = "contact_builds", .value = (ej_real)s->n_contact_builds};
  *n = 4;
  return EJ_OK;
}

static int pd_pass_count(const void *state)
{
  (void)state;
  return 2;
}

static ej_err pd_counters(void *state, ej_counter *out, int max, int *n)
{
  const pd_state *s = state;
  *n = 0;
  if (max < 2) return EJ_OK;
  out[0] = (ej_counter){.name = "peridynamic bonds (directed)", .value = s->n_bonds};
  out[1] = (ej_counter){.name = "contact list builds", .value = s->n_contact_builds};
  *n = 2;
  return EJ_OK;
}

/* ------------------------------------------------------------------ registration */

static const ej_method_ops pd_ops = {
    .struct_size = sizeof(ej_method_ops),
    .name = "pd",
    .summary = "Peridynamics: bond-based PMB and state-based LPS, as LAMMPS peri/pmb and peri/lps",
    .doc = "Total-Lagrangian peridynamics on fixed families built in the reference configuration. model: pmb "
           "(prototype microelastic brittle, Silling & Askari 2005) or lps (linear peridynamic solid, Silling et "
           "al. 2007). Reproduces LAMMPS's PERI package: partial-volume scaling near the horizon, critical "
           "stretch s0 = s00 - alpha s_min from the previous step, irreversible bond breaking after the force "
           "is applied, short-range contact repulsion between any close pair, damage from intact bond volume. "
           "Broken bonds are kept in the core's bond flags, so they survive a restart.",
    .params = pd_params,
    .config_size = sizeof(pd_config),
    .check_config = NULL,
    .declare = pd_declare,
    .create = pd_create,
    .setup = pd_setup,
    .support = pd_support,
    .n_passes = 2,
    .self_constitutive = true,
    .compute = pd_compute,
    .stable_dt = pd_stable_dt,
    .post_step = pd_post_step,
    .post_step_local = true, /* own rows: s0, damage and the range sums */
    .counters = pd_counters,
    .destroy = pd_destroy,
    .pass_count = pd_pass_count,
    .report = pd_report,
};

static ej_err pd_register(ej_registry *reg)
{
  EJ_TRY(ej_register_method(reg, &pd_ops));
  return EJ_OK;
}

EJ_PLUGIN_DEFINE(pd, "0.1.0", "BSD-3-Clause", "Peridynamics (PMB, LPS) as LAMMPS PERI", pd_register)
