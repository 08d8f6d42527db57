/* sph with a strength model (strength: true): a uniform strain rate gives the material's own
 * stress path (von Mises with hardening, through yield), a rigid rotation only rotates the
 * stress (Hughes-Winget exactly, Jaumann to O(dt^2)), momentum and total energy rates vanish to
 * round-off on a jittered, pre-stressed block (with and without artificial stress and gradient
 * correction), the artificial stress acts in tension only, and the configuration checks. */
#include "method_fix.h"
#include "validation_common.h"
#include "test_rng.h"
#include "ejecta/tensor.h"
#include "rate_sums.h"

const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_von_mises_info(void);

typedef method_fix sfix;

static void *param_ptr(const ej_param *t, void *cfg, const char *name)
{
  return (char *)cfg + find_param(t, name)->offset;
}

static int g_visc_switch; /* the sph visc_switch enum of the next fix_open: 0 none, 1 balsara */

/* sph (strength: true) with `material` ("elastic" E 200 GPa nu 0.3 or "von_mises" with
 * sigma_y 250 MPa, H 2 GPa), no EOS. */
static void fix_open(sfix *f, int dim, ej_idx n, const char *material, bool correction, bool art)
{
  memset(f, 0, sizeof *f);
  f->dim = dim;
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_von_mises_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_METHOD, "sph", NULL, &ops), EJ_OK);
  f->mops = ops;
  f->mcfg = ej_calloc(1, f->mops->config_size);
  ck_assert_int_eq(ej_params_defaults(f->mops->params, f->mcfg), EJ_OK);
  *(bool *)param_ptr(f->mops->params, f->mcfg, "strength") = true;
  *(bool *)param_ptr(f->mops->params, f->mcfg, "correction") = correction;
  *(bool *)param_ptr(f->mops->params, f->mcfg, "art_stress") = art;
  *(int *)param_ptr(f->mops->params, f->mcfg, "visc_switch") = g_visc_switch;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_MATERIAL, material, NULL, &ops), EJ_OK);
  f->matops = ops;
  f->matcfg = ej_calloc(1, f->matops->config_size);
  ck_assert_int_eq(ej_params_defaults(f->matops->params, f->matcfg), EJ_OK);
  *(ej_real *)param_ptr(f->matops->params, f->matcfg, "E") = 200e9;
  *(ej_real *)param_ptr(f->matops->params, f->matcfg, "nu") = 0.3;
  if (!strcmp(material, "von_mises")) {
    *(ej_real *)param_ptr(f->matops->params, f->matcfg, "yield_stress") = 250e6;
    *(ej_real *)param_ptr(f->matops->params, f->matcfg, "H") = 2e9;
  }
  ck_assert_int_eq(f->matops->create(f->matcfg, &f->matstate), EJ_OK);
  f->mat = (struct ej_material){.ops = f->matops, .state = f->matstate};
  f->model = (struct ej_model){.name = "steel", .rho0 = 7800.0, .eos = NULL, .mat = &f->mat};
  ck_assert_int_eq(ej_set_create("solid", 0, dim, &f->set), EJ_OK);
  f->set->t = &f->t;
  f->set->dt = &f->dt;
  f->set->model = &f->model;
  ck_assert_int_eq(ej_decl_probe(f->mops, f->mcfg, f->set), EJ_OK);
  for (int k = 0; k < f->matops->n_hist; ++k) {
    const ej_field_decl hd = {.name = f->matops->hist_names[k], .kind = EJ_SCALAR, .flags = 0, .unit = "1", .doc = "h"};
    ck_assert_int_eq(ej_set_add_field(f->set, &hd, &f->set->f_hist[k]), EJ_OK);
    f->set->n_hist = k + 1;
  }
  const char *want[] = {"stress", "w_plastic", "failed", "sigma_rho2", "art_stress"};
  for (size_t k = 0; k < sizeof want / sizeof want[0]; ++k)
    ck_assert_msg(ej_set_find_field(f->set, want[k]) >= 0, "field '%s' not declared", want[k]);
  ck_assert_int_eq(f->set->fields[ej_set_find_field(f->set, "stress")].kind, EJ_SYM6);
  ck_assert_int_eq(ej_set_reserve(f->set, n), EJ_OK);
  f->set->n = n;
  f->set->n_ghost = 0;
  int32_t *id = ej_set_field_int(f->set, "id");
  for (ej_idx i = 0; i < n; ++i) id[i] = (int32_t)i;
  ck_assert_int_eq(ej_nbrlist_create(&f->list), EJ_OK);
}

/* side^dim particles on a lattice of spacing dx centred on 0, optional jitter (fraction of dx). */
static ej_idx lattice(sfix *f, int dim, int side, ej_real dx, ej_real jitter, uint64_t seed, const char *material,
                      bool correction, bool art)
{
  ej_idx n = 1;
  for (int d = 0; d < dim; ++d) n *= side;
  fix_open(f, dim, n, material, correction, art);
  ej_real *x = ej_set_field(f->set, "x"), *m = ej_set_field(f->set, "m"), *vol0 = ej_set_field(f->set, "vol0");
  ej_real *r = ej_set_field(f->set, "rho");
  const ej_real vol = pow(dx, dim), half = 0.5 * (side - 1);
  for (ej_idx i = 0; i < n; ++i) {
    ej_idx k = i;
    for (int d = 0; d < 3; ++d) {
      x[3 * i + d] = d < dim ? ((ej_real)(k % side) - half + jitter * (rng_uniform(&seed) - 0.5)) * dx : 0.0;
      if (d < dim) k /= side;
    }
    vol0[i] = vol;
    m[i] = 7800.0 * vol;
    r[i] = 7800.0;
  }
  return n;
}

static bool interior(const ej_real *x, ej_idx i, int dim, ej_real lim)
{
  for (int d = 0; d < dim; ++d)
    if (fabs(x[3 * i + d]) > lim) return false;
  return true;
}

/* Uniform strain rate (symmetric, no spin), particles held in place: the stress of every
 * interior particle follows the material's own path step by step, through yield. */
START_TEST(test_stress_path)
{
  const ej_real dx = 1e-3;
  sfix f;
  const ej_idx n = lattice(&f, 3, 11, dx, 0.2, 7u, "von_mises", true, true);
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v");
  const ej_real A[9] = {100.0, 30.0, -20.0, 30.0, -50.0, 40.0, -20.0, 40.0, 70.0}; /* 1/s, symmetric */
  for (ej_idx i = 0; i < n; ++i) ej_m3_apply(v + 3 * i, A, x + 3 * i);
  mfix_start(&f);
  f.dt = 2e-6;
  /* the reference point: the material alone */
  ej_real d6[6], sref[6] = {0, 0, 0, 0, 0, 0}, hst = 0.0, cref = 0.0, wp = 0.0, rho = 7800.0, e = 0.0;
  ej_real *hp[1] = {&hst};
  int32_t fl = 0;
  ej_m3_sym(d6, A);
  const ej_real *sg = ej_set_field(f.set, "stress");
  const ej_real *eps_p = ej_set_field(f.set, "eps_p");
  ck_assert_ptr_nonnull(eps_p);
  int checked = 0;
  for (int step = 0; step < 40; ++step) {
    mfix_compute(&f, 2);
    ej_mat_batch b = {.n = 1, .dt = f.dt, .rho = &rho, .e = &e, .d = d6, .p = NULL, .stress = sref, .hist = hp,
                      .c = &cref, .w_plastic = &wp, .failed = &fl};
    ck_assert_int_eq(f.matops->update(f.matstate, &b), EJ_OK);
    checked = 0;
    for (ej_idx i = 0; i < n; ++i) {
      if (!interior(x, i, 3, 2.5 * dx)) continue; /* 3 spacings from the surface: full support */
      for (int k = 0; k < 6; ++k)
        ck_assert_msg(fabs(sg[6 * i + k] - sref[k]) < 1e-7 * 250e6, "step %d particle %d: stress[%d] %.10g vs %.10g",
                      step, (int)i, k, sg[6 * i + k], sref[k]);
      ck_assert_double_eq_tol(eps_p[i], hst, 1e-9);
      ++checked;
    }
  }
  ck_assert_int_gt(checked, 0);
  ck_assert_msg(hst > 1e-4, "the path should have yielded (eps_p %g)", hst);
  mfix_close(&f);
}
END_TEST

/* Rigid spin about z of a pre-stressed block: d = 0, the stress is carried by exactly the
 * Hughes-Winget rotation (and by Jaumann to O(dt^2)); no internal energy change. */
static void check_spin(int rate, ej_real jitter, bool corr)
{
  const ej_real dx = 1e-3;
  sfix f;
  const ej_idx n = lattice(&f, 3, 11, dx, jitter, 11u, "elastic", corr, false);
  *(int *)param_ptr(f.mops->params, f.mcfg, "stress_rate") = rate;
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v");
  const ej_real om = 200.0;
  const ej_real Wm[9] = {0, -om, 0, om, 0, 0, 0, 0, 0};
  for (ej_idx i = 0; i < n; ++i) ej_m3_apply(v + 3 * i, Wm, x + 3 * i);
  mfix_start(&f);
  ej_real *sg = ej_set_field(f.set, "stress");
  const ej_real s0[6] = {-1e8, 2e7, 3e7, 4e7, 0, -1e7};
  for (ej_idx i = 0; i < n; ++i) memcpy(sg + 6 * i, s0, sizeof s0);
  f.dt = 1e-4; /* om dt = 0.02 */
  mfix_compute(&f, 2);
  const ej_real *edot = ej_set_field(f.set, "e_dot");
  ej_real Q[9], want[6];
  ck_assert(ej_hughes_winget(Q, Wm, f.dt));
  ej_s6_rotate(want, Q, s0);
  int checked = 0;
  for (ej_idx i = 0; i < n; ++i) {
    if (!interior(x, i, 3, 2.5 * dx)) continue;
    const ej_real tol = rate == 0 ? 1e-6 * 1e8 : 1e-3 * 1e8; /* Jaumann: O((om dt)^2) = 4e-4 */
    /* without correction the lattice sum scales the spin by ~1.0065: invariants only */
    for (int k = 0; k < 6 && corr; ++k)
      ck_assert_msg(fabs(sg[6 * i + k] - want[k]) < tol, "rate %d: stress[%d] %.10g vs %.10g", rate, k, sg[6 * i + k],
                    want[k]);
    ck_assert_double_eq_tol(ej_s6_trace(sg + 6 * i), ej_s6_trace(s0), 1e-6 * 1e8);
    if (rate == 0) ck_assert_double_eq_tol(ej_s6_sqrt_j2(sg + 6 * i), ej_s6_sqrt_j2(s0), 1e-6 * 1e8);
    /* sigma : (sum_j v_ij (x) G_ij) vanishes exactly only where that sum is skew: on the regular
     * lattice with an isotropic support (|x| <= 2 dx); on the jittered block it is a
     * discretisation error (measured 2.6 % of |sigma| om / rho), not checked here. */
    if (jitter == 0.0 && interior(x, i, 3, 2.01 * dx))
      ck_assert_msg(fabs(edot[i]) < 1e-9 * 1e8 * om / 7800.0, "spin: e_dot %g", edot[i]);
    ++checked;
  }
  ck_assert_int_gt(checked, 0);
  mfix_close(&f);
}

START_TEST(test_objectivity)
{
  check_spin(0, 0.2, true);
  check_spin(1, 0.2, true);
  check_spin(0, 0.0, false);
}
END_TEST

/* Jittered, randomly moving, randomly pre-stressed block: sum m a = 0 and
 * sum m (v.a + de/dt) = 0 to round-off; viscous work >= 0. */
static void check_conservation(int dim, bool corr, bool art)
{
  const ej_real dx = 1e-3;
  const int side = dim == 3 ? 8 : dim == 2 ? 16 : 40;
  sfix f;
  const ej_idx n = lattice(&f, dim, side, dx, 0.4, 99u + (uint64_t)dim, "elastic", corr, art);
  *(ej_real *)param_ptr(f.mops->params, f.mcfg, "xsph") = 0.5;
  uint64_t seed = 5u;
  ej_real *v = ej_set_field(f.set, "v"), *m = ej_set_field(f.set, "m");
  for (ej_idx i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) v[3 * i + d] = 20.0 * (rng_uniform(&seed) - 0.5);
  mfix_start(&f);
  ej_real *sg = ej_set_field(f.set, "stress");
  for (ej_idx i = 0; i < n; ++i)
    for (int k = 0; k < 6; ++k) sg[6 * i + k] = 2e8 * (rng_uniform(&seed) - 0.4);
  f.dt = 1e-8;
  mfix_compute(&f, 2);
  const ej_real *a = ej_set_field(f.set, "a"), *edot = ej_set_field(f.set, "e_dot");
  const ej_real *wdot = ej_set_field(f.set, "w_visc_dot"), *R = ej_set_field(f.set, "art_stress");
  const rate_sums rs = rate_sums_of(n, m, v, a, edot);
  const double *P = rs.P, Pabs = rs.Pabs, E = rs.E, Eabs = rs.Eabs;
  double W = 0, Rabs = 0;
  for (ej_idx i = 0; i < n; ++i) {
    W += m[i] * wdot[i];
    for (int k = 0; k < 6; ++k) Rabs += fabs(R[6 * i + k]);
  }
  ck_assert(Pabs > 0 && Eabs > 0);
  for (int d = 0; d < 3; ++d)
    ck_assert_msg(fabs(P[d]) < 1e-13 * Pabs, "dim %d corr %d art %d: momentum rate %g (scale %g)", dim, corr, art,
                  P[d], Pabs);
  ck_assert_msg(fabs(E) < 1e-12 * Eabs, "dim %d corr %d art %d: energy rate %g (scale %g)", dim, corr, art, E, Eabs);
  ck_assert_msg(W >= 0.0, "viscous work %g", W);
  /* XSPH: the pair terms are antisymmetric, so sum m_i v_xsph_i = 0 (the centre of mass does not drift) */
  const ej_real *vx = ej_set_field(f.set, "v_xsph");
  double X[3] = {0, 0, 0}, Xabs = 0;
  for (ej_idx i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) X[d] += m[i] * vx[3 * i + d], Xabs += fabs(m[i] * vx[3 * i + d]);
  ck_assert(Xabs > 0);
  for (int d = 0; d < 3; ++d) ck_assert_msg(fabs(X[d]) < 1e-13 * Xabs, "XSPH momentum %g (scale %g)", X[d], Xabs);
  ck_assert_msg(art ? Rabs > 0.0 : Rabs == 0.0, "artificial stress sum %g (art %d)", Rabs, art);
  mfix_close(&f);
}

START_TEST(test_conservation)
{
  for (int dim = 1; dim <= 3; ++dim) {
    check_conservation(dim, false, true);
    check_conservation(dim, true, true);
    check_conservation(dim, false, false);
  }
}
END_TEST

/* Artificial stress: principal tension gives R = -eps sigma/rho^2 along it, compression none. */
START_TEST(test_art_stress_tension_only)
{
  const ej_real dx = 1e-3;
  sfix f;
  const ej_idx n = lattice(&f, 2, 12, dx, 0.0, 1u, "elastic", false, true);
  mfix_start(&f);
  ej_real *sg = ej_set_field(f.set, "stress");
  /* principal stresses +1e8 along (1,1)/sqrt2 and -2e8 along (1,-1)/sqrt2 */
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real s[6] = {-0.5e8, -0.5e8, 0.0, 1.5e8, 0.0, 0.0};
    memcpy(sg + 6 * i, s, sizeof s);
  }
  f.dt = 1e-12; /* the elastic increment is negligible */
  mfix_compute(&f, 2);
  const ej_real *R = ej_set_field(f.set, "art_stress"), *rho = ej_set_field(f.set, "rho");
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real want = -0.3 * 1e8 / (rho[i] * rho[i]) * 0.5; /* -eps s1/rho^2 n (x) n, n = (1,1)/sqrt2 */
    ck_assert_double_eq_tol(R[6 * i + 0], want, 1e-6 * fabs(want));
    ck_assert_double_eq_tol(R[6 * i + 1], want, 1e-6 * fabs(want));
    ck_assert_double_eq_tol(R[6 * i + 3], want, 1e-6 * fabs(want));
    ck_assert_double_eq_tol(R[6 * i + 2], 0.0, 1e-12 * fabs(want));
  }
  mfix_close(&f);
}
END_TEST

/* visc_switch: balsara (sph README "Viscosity switch"): on a 3D lattice moving in pure shear
 * v_x = g y the factor f = |div v| / (|div v| + |curl v| + 1e-4 c/h) vanishes and so does the
 * artificial viscosity's work rate (without the switch it is positive: shear has approaching
 * pairs); in uniform compression v = -e x f is e / (e + 1e-4 c/h), close to 1, and the work rate is
 * that of the run without the switch times f. Momentum and energy rates still vanish. */
static double switch_run(int sw, int mode, double *f_lo, double *f_hi)
{
  const ej_real dx = 1e-3, g = 1e5;
  g_visc_switch = sw;
  sfix f;
  const ej_idx n = lattice(&f, 3, 16, dx, 0.0, 3u, "elastic", false, false);
  g_visc_switch = 0;
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v"), *m = ej_set_field(f.set, "m");
  for (ej_idx i = 0; i < n; ++i) {
    v[3 * i] = mode ? -g * x[3 * i] : g * x[3 * i + 1];
    v[3 * i + 1] = mode ? -g * x[3 * i + 1] : 0.0;
    v[3 * i + 2] = mode ? -g * x[3 * i + 2] : 0.0;
  }
  mfix_start(&f);
  f.dt = 1e-12;
  mfix_compute(&f, 2);
  const ej_real *a = ej_set_field(f.set, "a"), *edot = ej_set_field(f.set, "e_dot");
  const ej_real *wdot = ej_set_field(f.set, "w_visc_dot");
  const ej_real *fs = sw ? ej_set_field(f.set, "visc_switch") : NULL;
  ck_assert(!sw || fs);
  ck_assert(sw || ej_set_find_field(f.set, "visc_switch") < 0);
  double W = 0;
  *f_lo = 1e300, *f_hi = -1e300;
  for (ej_idx i = 0; i < n; ++i) {
    /* the kernel sums are one-sided within 2h = 2.6 dx of the faces (at 7.5 dx): rows within 2.2 dx of
     * the centre see only neighbours whose own sums are whole */
    if (!interior(x, i, 3, 2.2 * dx)) continue;
    W += m[i] * wdot[i];
    if (fs) *f_lo = fmin(*f_lo, fs[i]), *f_hi = fmax(*f_hi, fs[i]);
  }
  const rate_sums rs = rate_sums_of(n, m, v, a, edot);
  for (int d = 0; d < 3; ++d)
    ck_assert_msg(fabs(rs.P[d]) < 1e-13 * rs.Pabs, "switch %d mode %d: momentum rate %g (scale %g)", sw, mode, rs.P[d],
                  rs.Pabs);
  ck_assert_msg(fabs(rs.E) < 1e-12 * rs.Eabs, "switch %d mode %d: energy rate %g (scale %g)", sw, mode, rs.E, rs.Eabs);
  mfix_close(&f);
  return W;
}

START_TEST(test_balsara_switch)
{
  double lo, hi;
  const double w_shear = switch_run(0, 0, &lo, &hi), w_shear_b = switch_run(1, 0, &lo, &hi);
  fprintf(stderr, "sph balsara, pure shear: interior viscous work rate %.3e without, %.3e with the switch, f in [%.2e, %.2e]\n",
          w_shear, w_shear_b, lo, hi);
  ck_assert_msg(w_shear > 0.0, "no viscous work in shear without the switch: %g", w_shear);
  ck_assert_msg(hi < 1e-6, "shear: switch factor up to %g", hi);
  ck_assert_msg(fabs(w_shear_b) < 1e-6 * w_shear, "shear: viscous work %g with the switch (%g without)", w_shear_b,
                w_shear);
  const double w_comp = switch_run(0, 1, &lo, &hi), w_comp_b = switch_run(1, 1, &lo, &hi);
  fprintf(stderr, "sph balsara, compression: interior viscous work rate %.3e without, %.3e with the switch, f in [%.5f, %.5f]\n",
          w_comp, w_comp_b, lo, hi);
  ck_assert_msg(w_comp > 0.0, "no viscous work in compression: %g", w_comp);
  ck_assert_msg(lo > 0.98 && hi <= 1.0, "compression: switch factor in [%g, %g]", lo, hi);
  ck_assert_msg(w_comp_b > 0.98 * w_comp && w_comp_b <= w_comp * (1 + 1e-12), "compression: work %g with, %g without",
                w_comp_b, w_comp);
}
END_TEST

/* The artificial viscosity across a velocity jump (sph README "Viscosity in a shear band"): a
 * stress-free 3D block, periodic in x and y, whose upper half moves at +dv/2 and lower half at
 * -dv/2 along x. After one tiny step the x force the lower half exerts on the upper half through
 * the Monaghan viscosity (run with alpha minus run with alpha 0; beta 0) is a traction
 * k * alpha * rho c dv on the plane z = 0 with k independent of the spacing: in a shear band the
 * velocity gradient grows as 1/h while the term's length scale shrinks as h, so the drag does not
 * fade under refinement (pure shear has approaching pairs). The same test as rkpm's
 * `stabilization` (test_rkpm.c test_stabilization_traction). With `visc_switch: balsara` the
 * traction vanishes (div v = 0 at a pure shear jump). Returns k; *k_balsara the switched one. */
static double visc_traction_k(double spacing, double *k_balsara)
{
  double fx[3] = {0, 0, 0}, c0 = 0;
  const double dv = 1e-3, dt = 1e-6, alpha = 1.0;
  for (int run = 0; run < 3; ++run) {
    const ej_plugin_info *pl[] = {ej_plugin_sph_info(), ej_plugin_elastic_info()};
    fx[run] = shear_jump_run(
        "sphvisc", pl, 2, dv, dt, &c0,
        "ejecta: 1\ndimension: 3\ntime: {end: 1, dt: %g, max_steps: 1}\n"
        "output: {file: st.h5, every: 1, fields: [v]}\n"
        "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n"
        "sets:\n  block:\n    method: sph\n    strength: true\n    material: m\n"
        "    alpha: %g\n    beta: 0\n%s"
        "    shape: {box: {min: [0, 0, -0.5], max: [1, 1, 0.5]}}\n    spacing: %.17g\n"
        "    velocity: [%g, 0, 0]\n    initial:\n"
        "      - {region: {half_space: {point: [0, 0, 0], normal: [0, 0, -1]}}, velocity: [%g, 0, 0]}\n"
        "boundaries:\n  - periodic: {axis: x, min: 0, max: 1}\n  - periodic: {axis: y, min: 0, max: 1}\n",
        dt, run ? alpha : 0.0, run == 2 ? "    visc_switch: balsara\n" : "", spacing, -0.5 * dv,
        0.5 * dv);
  }
  /* face 1 x 1: the traction is the force; rho = 1 */
  const double k = -(fx[1] - fx[0]) / (alpha * c0 * dv);
  *k_balsara = -(fx[2] - fx[0]) / (alpha * c0 * dv);
  fprintf(stderr, "sph viscosity across a velocity jump, spacing %g: force without %.3e, with %.3e (balsara %.3e), "
          "k = %.4f, with the switch %.2e\n", spacing, fx[0], fx[1], fx[2], k, *k_balsara);
  ck_assert_msg(fabs(fx[0]) < 1e-3 * fabs(fx[1]), "without viscosity the jump is not stress-free: %g vs %g", fx[0],
                fx[1]);
  return k;
}

START_TEST(test_visc_shear_traction)
{
  double kb8, kb16;
  const double k8 = visc_traction_k(0.125, &kb8), k16 = visc_traction_k(0.0625, &kb16);
  ck_assert_msg(k8 > 0.0 && k16 > 0.0, "no viscous drag across the jump: k = %g, %g", k8, k16);
  ck_assert_msg(fabs(k16 / k8 - 1) < 0.03, "k depends on the spacing: %g vs %g", k8, k16);
  ck_assert_msg(fabs(kb8) < 1e-6 * k8 && fabs(kb16) < 1e-6 * k16, "balsara: k = %g, %g", kb8, kb16);
}
END_TEST

/* strength: true needs a strength model, and a strength model needs strength: true. */
START_TEST(test_config)
{
  sfix f;
  lattice(&f, 2, 4, 1e-3, 0.0, 1u, "elastic", false, true);
  *(bool *)param_ptr(f.mops->params, f.mcfg, "strength") = false;
  void *st = NULL;
  ck_assert_int_ne(f.mops->create(f.mcfg, f.set, &f.model, &st), EJ_OK);
  ej_error_clear();
  *(bool *)param_ptr(f.mops->params, f.mcfg, "strength") = true;
  struct ej_model nomat = f.model;
  nomat.mat = NULL;
  ck_assert_int_ne(f.mops->create(f.mcfg, f.set, &nomat, &st), EJ_OK);
  ej_error_clear();
  mfix_close(&f);
}
END_TEST

/* A plugin's create that refuses the scene's combination (here sph strength: true on a gas) is bad
 * input: one message at the set's line:col and exit 2 (EJ_ERR_INPUT), not an internal error
 * (EJ_ERR_UNSUPPORTED with code frames and exit 1, before 2026-12-02). */
START_TEST(test_refusal_is_located)
{
  vrun_refuses_text("sph_refuse",
                    "ejecta: 1\ndimension: 1\ntime: {end: 1e-3}\n"
                    "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                    "sets:\n  tube: {method: sph, material: gas, strength: true,\n"
                    "         shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n",
                    "sph has strength: true, but material 'gas' has no strength model", 7, 3);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("sph_solid");
  TCase *tm = tcase_create("solid");
  tcase_set_timeout(tm, 60);
  tcase_add_test(tm, test_stress_path);
  tcase_add_test(tm, test_objectivity);
  tcase_add_test(tm, test_conservation);
  tcase_add_test(tm, test_art_stress_tension_only);
  tcase_add_test(tm, test_config);
  tcase_add_test(tm, test_balsara_switch);
  tcase_add_test(tm, test_visc_shear_traction);
  tcase_add_test(tm, test_refusal_is_located);
  suite_add_tcase(s, tm);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
