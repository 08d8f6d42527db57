/* jh2: Johnson-Holmquist 2 with the granite of Zhu & Zhao (seed 002 Table 1 and text; digest 002
 * §2, §3, §7): strengths against the digest's derived values, damage as the sum of ratios,
 * bulking's first increment, the polynomial EOS of Eq 25 and its non-monotonic band, the two
 * hydrostatic tension rules, the rate-dependent tension model (Eqs 37-38) and the failed state. */
#include <unistd.h>

#include "material_point_driver.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_jh2_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_pd_sph_info(void);
const ej_plugin_info *ej_plugin_jwl_info(void);

/* 002: K1 21.9 GPa, G 25.7 GPa, rho0 2660, HEL 4.5 GPa, p_HEL 3.7 GPa, A 1.9, N 0.62, B 0.25,
 * M 0.62, C 0.005, T 54 MPa, beta 0.5, D1 0.005, D2 0.7, K2 -4500 GPa, K3 300 000 GPa */
static const double K1_ = 21.9e9, G_ = 25.7e9, RHO0_ = 2660, PHEL_ = 3.7e9, T_ = 54e6;
static const double SHEL_ = 1.5 * (4.5e9 - 3.7e9); /* 1.2 GPa */

static void jh2_open(mpd *m)
{
  mpd_open(m, ej_plugin_jh2_info(), "jh2");
  mpd_set(m, "K", K1_);
  mpd_set(m, "G", G_);
  mpd_set(m, "rho0", RHO0_);
  mpd_set(m, "K2", -4500e9);
  mpd_set(m, "K3", 300000e9);
  mpd_set(m, "HEL", 4.5e9);
  mpd_set(m, "p_HEL", PHEL_);
  mpd_set(m, "A", 1.9);
  mpd_set(m, "N", 0.62);
  mpd_set(m, "B", 0.25);
  mpd_set(m, "M", 0.62);
  mpd_set(m, "C", 0.005);
  mpd_set(m, "T", T_);
  mpd_set(m, "beta", 0.5);
  mpd_set(m, "D1", 0.005);
  mpd_set(m, "D2", 0.7);
  m->rho = RHO0_;
}

static double intact(double p, double rate)
{
  return SHEL_ * 1.9 * pow(p / PHEL_ + T_ / PHEL_, 0.62) * (1 + 0.005 * log(fmax(rate, 1.0)));
}

/* Pure shear at pressure p (passed as an attached EOS's) and equivalent rate `rate`: the
 * equivalent stress of the first plastic step is sigma_HEL sigma_i*(p, rate) (D = 0 then). */
static double first_yield(double p, double rate, double *dep)
{
  mpd m;
  jh2_open(&m);
  mpd_set(&m, "beta", 0);
  mpd_create(&m);
  m.pext = &p;
  const double dt = 2e-5 / rate; /* about 1 MPa of shear stress per step */
  const ej_real d[6] = {0, 0, 0, rate * sqrt(3.0) / 2, 0, 0}; /* sqrt(2/3 d':d') = rate */
  double seq = -1;
  for (int n = 0; n < 100000 && seq < 0; ++n) {
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    if (mpd_hist(&m, "eps_p") > 0) {
      seq = sqrt(3.0) * fabs(m.stress[3]);
      *dep = mpd_hist(&m, "eps_p");
      if (p >= 0) ck_assert_double_eq_tol(mpd_mean(m.stress), -p, 1e-6 * fmax(p, 1));
    }
  }
  mpd_close(&m);
  return seq;
}

/* digest 002 §2.2: sigma_i = 165.9 MPa at p = 0 (the UCS "calibration"), 305 MPa at 80 MPa and
 * 1e4 /s, 209 MPa at 20 MPa and 2000 /s, 453 MPa at 200 MPa and 1e4 /s */
START_TEST(test_intact_strength)
{
  const double p[4] = {0, 80e6, 20e6, 200e6}, r[4] = {0.5, 1e4, 2000, 1e4}, hand[4] = {165.9e6, 305e6, 209e6, 453e6};
  FILE *csv = mpd_csv_open("jh2_intact", "p,seq,seq_exact");
  for (int k = 0; k < 4; ++k) {
    double dep;
    const double s = first_yield(p[k], r[k], &dep);
    ck_assert_msg(mpd_relerr(s, intact(p[k], r[k])) < 1e-12, "p %g: %.12g vs %.12g", p[k], s, intact(p[k], r[k]));
    ck_assert_msg(mpd_relerr(s, hand[k]) < 3e-3, "p %g: %.6g vs the digest's %.6g", p[k], s, hand[k]);
    ck_assert(dep > 0);
  }
  /* the strength surface from tension (-T) to 1 GPa, quasi-static (rate clamped to 1) */
  for (int k = 0; k <= 40; ++k) {
    const double pk = -0.95 * T_ + k * (1e9 + 0.95 * T_) / 40;
    double dep;
    const double s = first_yield(pk, 0.5, &dep);
    ck_assert_msg(mpd_relerr(s, intact(pk, 1)) < 1e-12, "p %g", pk);
    if (csv) fprintf(csv, "%.17g,%.17g,%.17g\n", pk, s, intact(pk, 1));
  }
  if (csv) fclose(csv);
}
END_TEST

/* Damage = eps_p / eps_f at a fixed pressure (sum of ratios, constant eps_f), then the fractured
 * strength B p*^M once D = 1; eps_f = 2.6e-4 at p = 0 and 4.9e-4 at 80 MPa (digest §2.2). */
START_TEST(test_damage_and_fractured_strength)
{
  ck_assert_double_eq_tol(0.005 * pow(T_ / PHEL_, 0.7), 2.6e-4, 0.05e-4);
  ck_assert_double_eq_tol(0.005 * pow((80e6 + T_) / PHEL_, 0.7), 4.9e-4, 0.05e-4);
  mpd m;
  jh2_open(&m);
  mpd_set(&m, "beta", 0);
  mpd_create(&m);
  double p = 80e6;
  m.pext = &p;
  const double ef = 0.005 * pow((p + T_) / PHEL_, 0.7), sf = SHEL_ * 0.25 * pow(p / PHEL_, 0.62);
  const double dt = 1e-5, rate = 0.9; /* rate term clamped to 1 */
  const ej_real d[6] = {0, 0, 0, rate * sqrt(3.0) / 2, 0, 0};
  FILE *csv = mpd_csv_open("jh2_softening", "eps_p,seq,seq_exact");
  int plastic = 0;
  for (int n = 0; n < 2000; ++n) {
    const double D0 = mpd_hist(&m, "damage"), ep0 = mpd_hist(&m, "eps_p");
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double ep = mpd_hist(&m, "eps_p");
    if (ep > 0) {
      ++plastic;
      ck_assert_double_eq_tol(mpd_hist(&m, "damage"), fmin(ep / ef, 1.0), 1e-12);
      /* the return uses D of t_n */
      const double si = intact(p, 1), sy = si - fmin(ep0 / ef, 1.0) * (si - sf); /* D of t_n from eps_p */
      ck_assert_double_eq_tol(D0, fmin(ep0 / ef, 1.0), 1e-12);
      const double seq = sqrt(3.0) * fabs(m.stress[3]);
      if (ep > ep0) ck_assert_msg(mpd_relerr(seq, sy) < 1e-10, "step %d: %.12g vs %.12g", n, seq, sy);
      if (csv) fprintf(csv, "%.17g,%.17g,%.17g\n", ep, seq, sy);
    }
  }
  if (csv) fclose(csv);
  ck_assert_int_gt(plastic, 100);
  ck_assert(mpd_hist(&m, "damage") == 1);
  ck_assert_msg(mpd_relerr(sqrt(3.0) * fabs(m.stress[3]), sf) < 1e-10, "fractured %g vs %g", sqrt(3.0) * fabs(m.stress[3]), sf);
  ck_assert_int_eq(m.failed, 0); /* damage_failure off: the fractured strength carries on */
  mpd_close(&m);
}
END_TEST

/* Eq 25 through the material: p(mu) = 33.3 MPa, 69 MPa and 1.038 GPa at mu = 0.003, 0.01, 0.02
 * (digest §2.2), K1 mu in tension; the sound speed uses max(K1, dp/dmu) */
START_TEST(test_polynomial_eos)
{
  const double mu[5] = {0.003, 0.01, 0.02, 0.005, -0.001}, hand[5] = {33.3e6, 69e6, 1.038e9, 0, -21.9e6};
  for (int k = 0; k < 5; ++k) {
    mpd m;
    jh2_open(&m);
    mpd_create(&m);
    m.rho = RHO0_ * (1 + mu[k]);
    const ej_real d[6] = {0};
    ck_assert_int_eq(mpd_step(&m, d, 1e-8), EJ_OK);
    const double me = m.rho / RHO0_ - 1; /* the mu the material sees */
    const double pe = me >= 0 ? me * (K1_ + me * (-4500e9 + me * 300000e9)) : K1_ * me;
    ck_assert_double_eq_tol(-mpd_mean(m.stress), pe, 1e-6);
    if (hand[k] != 0) ck_assert_double_eq_tol(pe, hand[k], 0.1e6 + 1e-3 * fabs(hand[k]));
    const double dpdmu = me >= 0 ? K1_ + 2 * -4500e9 * me + 3 * 300000e9 * me * me : K1_;
    if (k == 3) ck_assert(dpdmu < 0); /* inside the band 0.004184 < mu < 0.005817 */
    const double c = sqrt((fmax(K1_, dpdmu) + 4 * G_ / 3) / m.rho);
    ck_assert_double_eq_tol(m.c, c, 1e-9 * c);
    mpd_close(&m);
  }
  /* the band's edges, roots of K1 + 2 K2 mu + 3 K3 mu^2 */
  const double a = 3 * 300000e9, bq = 2 * -4500e9, cq = K1_, disc = sqrt(bq * bq - 4 * a * cq);
  ck_assert_double_eq_tol((-bq - disc) / (2 * a), 0.004184, 1e-6);
  ck_assert_double_eq_tol((-bq + disc) / (2 * a), 0.005817, 1e-6);
}
END_TEST

/* Bulking: the first damaging step at mu = 0 from dp = 0 gives dp = sqrt(2 beta K1 dU),
 * dU = (sigma_y(D_n)^2 - sigma_y(D_n+1)^2)/(6G); dp never decreases */
START_TEST(test_bulking)
{
  mpd m;
  jh2_open(&m);
  mpd_create(&m);
  const double dt = 1e-5;
  const ej_real d[6] = {0, 0, 0, 0.9 * sqrt(3.0) / 2, 0, 0};
  double dp_prev = 0;
  bool first = true;
  for (int n = 0; n < 3000; ++n) {
    const double D0 = mpd_hist(&m, "damage"), dpb0 = mpd_hist(&m, "dp_bulk");
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    const double D1 = mpd_hist(&m, "damage"), dpb = mpd_hist(&m, "dp_bulk");
    ck_assert(dpb >= dp_prev);
    dp_prev = dpb;
    if (first && D1 > D0) {
      first = false;
      ck_assert(dpb0 == 0);
      const double si = intact(0, 1), sf = 0; /* p* = 0 at mu = 0, dp = 0 */
      const double s0 = si - D0 * (si - sf), s1 = si - D1 * (si - sf);
      const double ex = sqrt(2 * 0.5 * K1_ * (s0 * s0 - s1 * s1) / (6 * G_));
      ck_assert_msg(mpd_relerr(dpb, ex) < 1e-12, "%.12g vs %.12g", dpb, ex);
      /* the stress carries it: p = p_EOS(0) + dp */
      ck_assert_double_eq_tol(-mpd_mean(m.stress), dpb, 1e-9 * dpb);
    }
  }
  ck_assert(!first);
  ck_assert(dp_prev > 1e6);
  mpd_close(&m);
}
END_TEST

/* Hydrostatic tension: cutoff holds p at -T (1 - D); fail marks the point failed once p < -T,
 * and the failed point carries compression only. */
START_TEST(test_hydrostatic_tension)
{
  for (int mode = 0; mode < 2; ++mode) {
    mpd m;
    jh2_open(&m);
    mpd_set_enum(&m, "tension", mode ? "fail" : "cutoff");
    mpd_create(&m);
    const double dt = 1e-6, r = 10; /* isotropic expansion: tr(d) = 3r */
    const ej_real d[6] = {r, r, r, 0, 0, 0};
    int failed_at = -1;
    for (int n = 0; n < 400; ++n) {
      m.rho *= exp(-3 * r * dt);
      ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
      const double mu = m.rho / RHO0_ - 1, pe = K1_ * mu;
      if (mode == 0) {
        ck_assert_double_eq_tol(-mpd_mean(m.stress), fmax(pe, -T_), 0.1);
        ck_assert_int_eq(m.failed, 0);
      } else if (pe < -T_ && failed_at < 0) {
        /* the check uses the pressure of this step */
        ck_assert_int_eq(m.failed, 1);
        failed_at = n;
      } else if (failed_at < 0) {
        ck_assert_int_eq(m.failed, 0);
        ck_assert_double_eq_tol(-mpd_mean(m.stress), pe, 0.1);
      } else {
        for (int k = 0; k < 6; ++k) ck_assert(m.stress[k] == 0);
      }
    }
    if (mode == 1) {
      ck_assert_int_gt(failed_at, 0);
      ck_assert(mpd_hist(&m, "damage") == 1 && mpd_hist(&m, "jh2_failed") == 1);
      /* recompressed: pressure only */
      m.rho = RHO0_ * 1.001;
      const ej_real d2[6] = {-1, -1, 0, 5, 0, 0};
      ck_assert_int_eq(mpd_step(&m, d2, dt), EJ_OK);
      ck_assert_double_eq_tol(m.stress[0], -K1_ * 0.001 + 4500e9 * 1e-6 - 300000e9 * 1e-9, 1e-3);
      ck_assert(m.stress[3] == 0 && m.stress[1] == m.stress[0]);
      ck_assert_int_eq(m.failed, 1);
    }
    mpd_close(&m);
  }
  /* cutoff after damage: sheared to D > 0 at mu = 0, then expanded: p = max(p_EOS, -T (1 - D)) */
  mpd m;
  jh2_open(&m);
  mpd_set(&m, "beta", 0);
  mpd_create(&m);
  const ej_real ds[6] = {0, 0, 0, 0.9 * sqrt(3.0) / 2, 0, 0}, dv[6] = {10, 10, 10, 0, 0, 0};
  while (mpd_hist(&m, "damage") < 0.3) ck_assert_int_eq(mpd_step(&m, ds, 1e-5), EJ_OK);
  /* unloaded (no deviator: isotropic expansion then stays elastic, D stays) */
  memset(m.stress, 0, sizeof m.stress);
  const double Dfix = mpd_hist(&m, "damage");
  ck_assert(Dfix < 0.9);
  bool bound = false;
  for (int n = 0; n < 200; ++n) {
    m.rho *= exp(-30 * 1e-6);
    ck_assert_int_eq(mpd_step(&m, dv, 1e-6), EJ_OK);
    const double D = mpd_hist(&m, "damage"), pe = K1_ * (m.rho / RHO0_ - 1);
    ck_assert_double_eq_tol(-mpd_mean(m.stress), fmax(pe, -T_ * (1 - D)), 0.1);
    bound = bound || (pe < -T_ * (1 - D) && D < 1);
    ck_assert(D == Dfix);
  }
  ck_assert(bound);
  mpd_close(&m);
}
END_TEST

/* 002 Eqs 37-38: uniaxial strain in tension at an equivalent rate of 1000 /s fails when the
 * largest principal stress exceeds 6.9 MPa (1000/0.4)^0.33 = 91.2 MPa (digest §3 table); the
 * strength constant A is raised so that the path stays elastic. */
START_TEST(test_tension_model)
{
  mpd m;
  jh2_open(&m);
  mpd_set(&m, "A", 10);
  mpd_set(&m, "tension_strength", 6.9e6);
  mpd_set(&m, "tension_rate0", 0.4);
  mpd_set(&m, "tension_C1", 0.33);
  mpd_create(&m);
  const double lim = 6.9e6 * pow(1000 / 0.4, 0.33);
  ck_assert_double_eq_tol(lim, 91.2e6, 0.1e6);
  const double r = 1500, dt = 1e-9; /* sqrt(2/3 d':d') = 2/3 r = 1000 /s */
  const ej_real d[6] = {r, 0, 0, 0, 0, 0};
  double s_prev = 0;
  int failed_at = -1;
  for (int n = 0; n < 4000 && failed_at < 0; ++n) {
    m.rho *= exp(-r * dt);
    ck_assert_int_eq(mpd_step(&m, d, dt), EJ_OK);
    if (m.failed) {
      failed_at = n;
      ck_assert(s_prev <= lim);
      ck_assert(mpd_hist(&m, "jh2_failed") == 1);
    } else {
      s_prev = m.stress[0];
      ck_assert(mpd_hist(&m, "eps_p") == 0);
    }
  }
  ck_assert_int_gt(failed_at, 0);
  /* the step before failing was within 0.1 % of the limit */
  ck_assert_msg(s_prev > 0.999 * lim, "%g vs %g", s_prev, lim);
  mpd_close(&m);
}
END_TEST

START_TEST(test_config)
{
  mpd m;
  jh2_open(&m);
  mpd_set(&m, "p_HEL", 4.5e9);
  mpd_expect_reject(&m);
  mpd_close(&m);
  /* damage_failure: D reaching 1 fails the point */
  jh2_open(&m);
  mpd_set(&m, "beta", 0);
  mpd_set_bool(&m, "damage_failure", true);
  mpd_create(&m);
  double p = 80e6;
  m.pext = &p;
  const ej_real d[6] = {0, 0, 0, 0.9 * sqrt(3.0) / 2, 0, 0};
  int n = 0;
  while (!m.failed && n < 40000) {
    ck_assert_int_eq(mpd_step(&m, d, 1e-5), EJ_OK);
    ++n;
  }
  ck_assert_int_eq(m.failed, 1);
  ck_assert(m.stress[3] == 0 && m.stress[0] == -p);
  mpd_close(&m);
}
END_TEST

/* A scene run to its end with the plugins of this suite linked in (tlpd, jh2, sph, pd_sph, jwl),
 * in a fresh temporary folder (dir; the scene is dir/s.yaml, written by the caller). */
typedef struct srun {
  char dir[32], path[64];
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
} srun;

static void srun_dir(srun *r)
{
  memset(r, 0, sizeof *r);
  ej_test_tmpdir(r->dir, sizeof r->dir, "jh2");
  snprintf(r->path, sizeof r->path, "%s/s.yaml", r->dir);
}

static void srun_go(srun *r, const char *who)
{
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  const ej_plugin_info *infos[] = {ej_plugin_tlpd_info(), ej_plugin_jh2_info(), ej_plugin_sph_info(),
                                   ej_plugin_pd_sph_info(), ej_plugin_jwl_info()};
  for (int k = 0; k < 5; ++k) ck_assert_int_eq(ej_registry_add_static(r->reg, infos[k]), EJ_OK);
  ej_err rc = ej_scene_load(r->path, r->reg, &r->sc);
  if (rc == EJ_OK) {
    ej_run_opts o = {.struct_size = sizeof o, .threads = 1};
    rc = ej_sim_create(r->sc, r->reg, &o, &r->sim);
  }
  if (rc == EJ_OK) rc = ej_sim_run(r->sim);
  if (rc != EJ_OK) ej_error_report(who);
  ck_assert_int_eq(rc, EJ_OK);
}

static void srun_close(srun *r)
{
  ej_sim_destroy(r->sim);
  ej_scene_destroy(r->sc);
  ej_registry_destroy(r->reg);
  ej_test_rmtree(r->dir);
}

/* Under tlpd: a granite bar (examples/materials/granite_002.yaml's constants) pulled apart at its
 * ends. The material's history variable "damage" would share tlpd's field of the same name (the
 * broken-bond fraction): the core names it mat_damage. Every particle that jh2 fails (the
 * tension model) has lost all its bonds (tlpd point failure: damage 1) and has mat_damage 1. */
START_TEST(test_under_tlpd)
{
  srun r;
  srun_dir(&r);
  FILE *f = fopen(r.path, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "ejecta: 1\ndimension: 3\ntime: {end: 20 us, cfl: 0.3}\noutput: {file: %s/o.h5}\n"
             "materials: {g: {model: jh2, rho0: 2660, K: 21.9 GPa, G: 25.7 GPa, K2: -4500 GPa, K3: 300000 GPa, "
             "HEL: 4.5 GPa, p_HEL: 3.7 GPa, A: 1.9, N: 0.62, B: 0.25, M: 0.62, C: 0.005, T: 54 MPa, beta: 0.5, "
             "D1: 0.005, D2: 0.7, tension: fail, damage_failure: true, tension_strength: 6.9 MPa, "
             "tension_rate0: 0.4, tension_C1: 0.33}}\n"
             "sets: {bar: {method: tlpd, material: g, shape: {box: {min: [0, 0, 0], max: [0.05, 0.012, 0.012]}}, "
             "spacing: 0.002, initial: [{region: {box: {min: [-1, -1, -1], max: [0.006, 1, 1]}}, velocity: [-3, 0, 0]}, "
             "{region: {box: {min: [0.044, -1, -1], max: [1, 1, 1]}}, velocity: [3, 0, 0]}]}}\n",
          r.dir);
  fclose(f);
  srun_go(&r, "test_under_tlpd");
  ej_set *s = r.sim->sets[0];
  const ej_real *pd = ej_set_field(s, "damage"), *md = ej_set_field(s, "mat_damage");
  const int32_t *failed = ej_set_field_int(s, "failed");
  const ej_real *x = ej_set_field(s, "x");
  ck_assert_ptr_nonnull(pd);
  ck_assert_ptr_nonnull(md);
  ck_assert_ptr_ne(pd, md);
  int nf = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int k = 0; k < 3; ++k) ck_assert(isfinite(x[3 * i + k]));
    if (failed[i]) {
      ++nf;
      ck_assert_msg(pd[i] == 1 && md[i] == 1, "failed particle %d: bond damage %g, jh2 damage %g", (int)i, pd[i], md[i]);
    }
  }
  ck_assert_msg(nf > 0, "the pull should fail particles");
  ck_assert_msg(nf < (int)ej_set_count(s) / 2, "%d of %d failed", nf, (int)ej_set_count(s));
  srun_close(&r);
}
END_TEST

/* examples/granite_blast_hole.yaml for its first 100 steps (about 2 us): it loads, stays finite,
 * and the crushed zone starts: particles next to the hole fail, none beyond 8 mm of the axis. */
START_TEST(test_blast_hole_example)
{
  srun r;
  char line[1024];
  srun_dir(&r);
  FILE *in = fopen(EJ_TEST_SOURCE_DIR "/examples/granite_blast_hole.yaml", "r"), *out = fopen(r.path, "w");
  ck_assert_ptr_nonnull(in);
  ck_assert_ptr_nonnull(out);
  int edits = 0;
  while (fgets(line, sizeof line, in)) {
    if (!strncmp(line, "time:", 5)) {
      fprintf(out, "time: {end: 60 us, cfl: 0.3, max_steps: 100}\n");
      ++edits;
    } else if (!strncmp(line, "output:", 7)) {
      fprintf(out, "output: {file: %s/o.h5}\n", r.dir);
      ++edits;
    } else {
      fputs(line, out);
    }
  }
  fclose(in);
  fclose(out);
  ck_assert_int_eq(edits, 2);
  srun_go(&r, "test_blast_hole_example");
  ej_set *s = r.sim->sets[1];
  ck_assert_str_eq(ej_set_name(s), "rock");
  const ej_real *x = ej_set_field(s, "x"), *x0 = ej_set_field(s, "x0");
  const int32_t *failed = ej_set_field_int(s, "failed");
  int nf = 0;
  double rmax = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int k = 0; k < 3; ++k) ck_assert(isfinite(x[3 * i + k]));
    if (failed[i]) {
      ++nf;
      rmax = fmax(rmax, hypot(x0[3 * i], x0[3 * i + 1]));
    }
  }
  ck_assert_msg(nf > 10 && rmax < 8e-3, "%d failed, out to %g m", nf, rmax);
  srun_close(&r);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("jh2");
  TCase *tc = tcase_create("paths");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_intact_strength);
  tcase_add_test(tc, test_damage_and_fractured_strength);
  tcase_add_test(tc, test_polynomial_eos);
  tcase_add_test(tc, test_bulking);
  tcase_add_test(tc, test_hydrostatic_tension);
  tcase_add_test(tc, test_tension_model);
  tcase_add_test(tc, test_config);
  tcase_add_test(tc, test_under_tlpd);
  tcase_add_test(tc, test_blast_hole_example);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
