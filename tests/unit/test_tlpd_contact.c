/* tlpd short-range contact (`contact`) and point failure at inversion (`inversion:
 * point_failure`), issue 8: two detached particles approaching head-on bounce back with momentum
 * conserved to round-off and the energy budget closed; a particle driven to det F <= 0 is
 * point-failed (all bonds broken, counted) instead of stopping the run, and `inversion: abort`
 * (the default) still stops it. */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

#define MAT "materials: {m: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}}\n"

typedef struct crun {
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
  char dir[64], path[128], h5[128];
} crun;

static int crun_threads = 1;

static ej_err crun_open(crun *r, const char *yaml)
{
  memset(r, 0, sizeof *r);
  ej_test_tmpdir(r->dir, sizeof r->dir, "tlpdc");
  snprintf(r->path, sizeof r->path, "%s/s.yaml", r->dir);
  snprintf(r->h5, sizeof r->h5, "%s/o.h5", r->dir);
  FILE *f = fopen(r->path, "w");
  ck_assert_ptr_nonnull(f);
  fprintf(f, "%s\noutput: {file: %s}\n", yaml, r->h5);
  fclose(f);
  ck_assert_int_eq(ej_registry_create(&r->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_tlpd_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(r->reg, ej_plugin_elastic_info()), EJ_OK);
  ej_err rc = ej_scene_load(r->path, r->reg, &r->sc);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_run_opts o = {.struct_size = sizeof o, .threads = crun_threads};
  rc = ej_sim_create(r->sc, r->reg, &o, &r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  return EJ_OK;
}

static void crun_close(crun *r)
{
  ej_sim_destroy(r->sim);
  ej_scene_destroy(r->sc);
  ej_registry_destroy(r->reg);
  char p[256];
  const char *names[] = {"s.yaml", "o.h5", "o.h5.partial", "o.xdmf"};
  for (int k = 0; k < 4; ++k) {
    snprintf(p, sizeof p, "%s/%s", r->dir, names[k]);
    unlink(p);
  }
  rmdir(r->dir);
}

static void momentum(const ej_set *s, double p[3], double *ke)
{
  const ej_real *v = ej_set_field(s, "v"), *m = ej_set_field(s, "m");
  p[0] = p[1] = p[2] = 0;
  *ke = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) {
    for (int a = 0; a < 3; ++a) p[a] += m[i] * v[3 * i + a];
    *ke += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  }
}

/* Two single-particle cubes of spacing 10 mm, 50 mm apart along x (detached from the start),
 * driven head-on at v_left and v_right with the set options opts; runs to `end` and returns the
 * momentum and kinetic energy before (p0, k0) and after (p1, k1), the relative speed before and
 * after and the final gap. The caller asserts and closes r. */
typedef struct pair_out {
  double p0[3], k0, p1[3], k1, vrel0, vrel1, gap;
} pair_out;

static int pair_dim = 3; /* 2: the same two particles as squares in a plane-strain scene */

static void pair_run(crun *r, const char *opts, double end, double cfl, double v_left, double v_right, pair_out *o)
{
  char y[2048];
  /* the third coordinate of every point and vector, or none in 2D */
  const bool d3 = pair_dim == 3;
  const char *z0 = d3 ? ", 0" : "", *z1 = d3 ? ", 0.01" : "", *zm = d3 ? ", -1" : "", *zp = d3 ? ", 1" : "";
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: %d\ntime: {end: %g, cfl: %g}\n" MAT
           "sets: {b: {method: tlpd, material: m, %s, spacing: 0.01,\n"
           "  shape: {union: [{box: {min: [0, 0%s], max: [0.01, 0.01%s]}}, {box: {min: [0.05, 0%s], max: [0.06, 0.01%s]}}]},\n"
           "  initial: [{region: {box: {min: [-1, -1%s], max: [0.03, 1%s]}}, velocity: [%g, 0%s]},\n"
           "            {region: {box: {min: [0.03, -1%s], max: [1, 1%s]}}, velocity: [%g, 0%s]}]}}\n",
           pair_dim, end, cfl, opts, z0, z1, z0, z1, zm, zp, v_left, z0, zm, zp, v_right, z0);
  crun_open(r, y);
  ej_set *s = r->sim->sets[0];
  ck_assert_int_eq(ej_set_count(s), 2);
  momentum(s, o->p0, &o->k0);
  const ej_real *v = ej_set_field(s, "v"), *x = ej_set_field(s, "x");
  o->vrel0 = v[3] - v[0];
  ej_err rc = ej_sim_run(r->sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  momentum(s, o->p1, &o->k1);
  o->vrel1 = v[3] - v[0], o->gap = x[3] - x[0];
  ck_assert(fabs(v[1]) + fabs(v[2]) + fabs(v[4]) + fabs(v[5]) == 0); /* head-on stays head-on */
}

/* Two particles 50 mm apart (spacing 10 mm, horizon 3: R = 35 mm, so no bond: both detached from
 * the start), approaching head-on at 50 + 30 m/s (unequal, so the momentum is not zero). The
 * contact distance is min(0.9 x 50, 1.35 x 10) = 13.5 mm; the LAMMPS spring (k = 15 c_s V_j /
 * delta, c_s = 18 K / (pi delta^4)) stops them at ~2 mm penetration and, being elastic, sends them
 * back with the relative speed reversed (to the integrator's error). */
static double bounce(const char *mode, double cfl, bool expect_contact)
{
  char opts[64];
  snprintf(opts, sizeof opts, "contact: %s", mode);
  crun r;
  pair_out o;
  pair_run(&r, opts, 1.2e-3, cfl, 50, -30, &o);
  const int32_t *st = ej_set_field_int(r.sim->sets[0], "pd_status");
  ck_assert_int_eq(st[0], 2);
  ck_assert_int_eq(st[1], 2);
  const double *p0 = o.p0, *p1 = o.p1, k0 = o.k0, k1 = o.k1, vrel0 = o.vrel0, vrel1 = o.vrel1, gap = o.gap;
  const double pscale = fabs(p0[0]) + 2e-3 * 80;
  double dp = 0;
  for (int a = 0; a < 3; ++a) dp = fmax(dp, fabs(p1[a] - p0[a]));
  const double bal = fabs(r.sim->energy.balance) / k0, dke = fabs(k1 - k0) / k0;
  fprintf(stderr, "tlpd contact %s, cfl %g: relative speed %.6g -> %.6g m/s, gap %.4g m, |dp| / p %.3e, KE %.6g -> %.6g J (%.2e), balance / KE0 %.3e\n",
          mode, cfl, vrel0, vrel1, gap, dp / pscale, k0, k1, dke, bal);
  ck_assert_msg(dp < 1e-13 * pscale, "momentum changed by %g", dp);
  if (expect_contact) {
    /* bounced: the relative speed reversed and the budget closed (the contact's energy is in e
     * while they touch, back to kinetic after) */
    ck_assert_msg(vrel1 > 0 && fabs(vrel1 + vrel0) < 1e-3 * fabs(vrel0), "relative speed %g -> %g", vrel0, vrel1);
    ck_assert_msg(bal < 1e-12, "energy balance / KE0 = %g", bal);
    ck_assert_msg(gap > 0.0135, "still in contact: gap %g", gap);
  } else {
    /* no contact: they pass through each other at constant speed */
    ck_assert(vrel1 == vrel0 && gap < 0);
  }
  crun_close(&r);
  return dke;
}

/* The law is elastic: the kinetic energy comes back up to the integrator's error, which is second
 * order in dt (the contact spring's omega dt = 0.28 at cfl 0.5): asserted < 1e-3 at cfl 0.5 and
 * falling by more than 2.5x when dt halves. */
static void bounce_energy(const char *mode)
{
  const double e1 = bounce(mode, 0.5, true), e2 = bounce(mode, 0.25, true);
  fprintf(stderr, "tlpd contact %s: |KE1 - KE0| / KE0 %.3e (cfl 0.5), %.3e (cfl 0.25), ratio %.2f\n", mode, e1, e2, e1 / e2);
  ck_assert_msg(e1 < 1e-3, "kinetic energy error %g", e1);
  ck_assert_msg(e2 < e1 / 2.5, "not second order: %g -> %g", e1, e2);
}

START_TEST(test_contact_bounce_unbonded) { bounce_energy("unbonded"); }
END_TEST
START_TEST(test_contact_bounce_all) { bounce_energy("all"); }
END_TEST
START_TEST(test_contact_off_passes_through) { bounce("off", 0.5, false); }
END_TEST

/* The same bounce in 2D (plane strain, squares of 10 mm, V an area): the spring uses the 2-D
 * micromodulus 12 K/(pi delta^3), about twice the 3-D spring of these particles (12/18 x delta/dx).
 * Measured: balance / KE0 3e-16 and 2e-16, KE error 8.6e-4 and 1.6e-3 at cfl 0.25 and 0.125 (it
 * does not fall with the step here, unlike 3D: not understood; asserted < 2e-3), rebound speed
 * within 1e-3. With the 3-D formula (every dimension until 2026-11-30) the 2-D spring was 1/delta
 * (33 per metre) times stiffer and the bounce created energy: balance / KE0 0.52 at cfl 0.25 (2.06
 * at 0.5), KE +4.2 %. */
START_TEST(test_contact_bounce_2d)
{
  pair_dim = 2;
  const double e1 = bounce("unbonded", 0.25, true), e2 = bounce("unbonded", 0.125, true);
  ck_assert_msg(e1 < 2e-3 && e2 < 2e-3, "kinetic energy error %g, %g", e1, e2);
}
END_TEST

static void pair_dim_reset(void) { pair_dim = 3; }

/* contact_law impact (fifth pass of validation/buried_charge): the same two detached particles
 * at 1 km/s relative (+600 and -400 m/s). The LAMMPS spring stores at most 15 c_s V^2 d^2/(2 delta)
 * (here K = 667 MPa, d = 13.5 mm: ~0.65 km/s of relative speed) and lets them pass through; the
 * impact law's viscous pressure rho (alpha c |w| + beta w^2) on the face dx^2 stops them within
 * dx/(2 beta) ln(1 + beta |w0|/(alpha c)) = 3.2 mm of first contact (c = 775 m/s), the spring
 * then pushes them apart slowly. Asserted: no pass-through (gap > 0 at the end, head-on), momentum
 * to round-off, the core's energy balance closed (heat in e), the series contact_dissipated equal
 * to the kinetic energy lost (the integrator's error, asserted < 1e-3 of KE0) and to sum m e. */
static double impact_run(const char *law, double cfl, double *gap_out, double *vrel_out)
{
  char opts[64];
  snprintf(opts, sizeof opts, "contact: unbonded, contact_law: %s", law);
  crun r;
  pair_out o;
  pair_run(&r, opts, 3e-4, cfl, 600, -400, &o);
  ej_set *s = r.sim->sets[0];
  const double *p0 = o.p0, *p1 = o.p1, k0 = o.k0, k1 = o.k1, vrel0 = o.vrel0, vrel1 = o.vrel1, gap = o.gap;
  double dp = 0;
  for (int a = 0; a < 3; ++a) dp = fmax(dp, fabs(p1[a] - p0[a]));
  const double pscale = fabs(p0[0]) + 2e-3 * 1000; /* |p0| + m |vrel| */
  const double bal = fabs(r.sim->energy.balance) / k0;
  const ej_real *e = ej_set_field(s, "e"), *m = ej_set_field(s, "m");
  const double eint = m[0] * e[0] + m[1] * e[1];
  double wdis = -1;
  for (int k = 0; k < r.sim->reports.n; ++k)
    if (!strcmp(r.sim->reports.names[k], "b/contact_dissipated")) wdis = r.sim->reports.values[k];
  fprintf(stderr,
          "tlpd contact_law %s, cfl %g: relative speed %.6g -> %.6g m/s, gap %.4g m, |dp| / p %.3e, KE %.6g -> %.6g J, "
          "sum m e %.6g J, contact_dissipated %.6g J, balance / KE0 %.3e\n",
          law, cfl, vrel0, vrel1, gap, dp / pscale, k0, k1, eint, wdis, bal);
  ck_assert_msg(dp < 1e-13 * pscale, "momentum changed by %g", dp);
  ck_assert_msg(bal < 1e-12, "energy balance / KE0 = %g", bal);
  if (!strcmp(law, "impact")) {
    ck_assert_msg(gap > 0, "passed through: gap %g", gap);
    ck_assert_msg(vrel1 >= 0 && vrel1 < 0.5 * fabs(vrel0), "relative speed %g -> %g", vrel0, vrel1);
    /* sum m e = heat + what the spring's integrator error left in e after the pair separated
     * (the spring alone: 6e-4 of KE0 at cfl 0.5 in bounce()); the heat is the larger part */
    ck_assert_msg(wdis > 0.9 * (k0 - k1) && wdis <= eint + 1e-9 * k0, "dissipated %g, kinetic energy lost %g, sum m e %g",
                  wdis, k0 - k1, eint);
  } else {
    ck_assert_msg(wdis == -1, "spring law reports contact_dissipated");
  }
  *gap_out = gap;
  *vrel_out = vrel1;
  crun_close(&r);
  return (eint - wdis) / k0;
}

START_TEST(test_contact_impact_stops_1kms)
{
  double gap, vrel;
  /* the LAMMPS spring alone: 1 km/s passes through */
  impact_run("spring", 0.5, &gap, &vrel);
  ck_assert_msg(gap < 0 && vrel < 0, "spring law stopped 1 km/s (gap %g, vrel %g)", gap, vrel);
  const double e1 = impact_run("impact", 0.5, &gap, &vrel);
  const double e2 = impact_run("impact", 0.25, &gap, &vrel);
  /* the non-dissipated rest in e is the spring's integrator error: it falls with dt */
  fprintf(stderr, "tlpd contact_law impact: (sum m e - dissipated) / KE0 %.3e (cfl 0.5), %.3e (cfl 0.25)\n", e1, e2);
  ck_assert_msg(e2 < e1, "rest in e does not fall with dt: %g -> %g", e1, e2);
}
END_TEST

/* The impact law in 2D: the same pair at 1 km/s relative is stopped (no pass-through, rebound
 * below half the approach speed, the heat booked). Its dashpot acts on the face lc^(dim-1), a
 * length in 2D; with lc^2 (every dimension until 2026-11-30) the 2-D dashpot was 100 times too weak
 * here and the pair passed through. */
START_TEST(test_contact_impact_2d)
{
  pair_dim = 2;
  double gap, vrel;
  impact_run("impact", 0.5, &gap, &vrel);
}
END_TEST

/* Two halves of an elastic block driven into each other at 2 x 3000 m/s (c = 866 m/s, dx = 10 mm; impact strain ~ v/c > 1):
 * the particles at the collision plane invert within a few steps. `inversion: abort` stops the
 * run with det F <= 0; `point_failure` fails them (all bonds broken, counted), the run reaches its
 * end, momentum stays exact and every point-failed particle is detached. */
static ej_err invert_run(const char *opts, int64_t *npf, double *dprel, int64_t *ndet)
{
  char y[2048];
  snprintf(y, sizeof y,
           "ejecta: 1\ndimension: 3\ntime: {end: 1, cfl: 0.5, max_steps: 40}\n" MAT
           "sets: {b: {method: tlpd, material: m, %s, spacing: 0.01,\n"
           "  shape: {box: {min: [0, 0, 0], max: [0.05, 0.05, 0.08]}},\n"
           "  initial: [{region: {box: {min: [-1, -1, -1], max: [1, 1, 0.04]}}, velocity: [0, 0, 3000]},\n"
           "            {region: {box: {min: [-1, -1, 0.04], max: [1, 1, 1]}}, velocity: [0, 0, -3000]}]}}\n",
           opts);
  crun r;
  crun_open(&r, y);
  ej_set *s = r.sim->sets[0];
  double p0[3], k0, p1[3], k1;
  momentum(s, p0, &k0);
  ej_err rc = ej_sim_run(r.sim);
  momentum(s, p1, &k1);
  double msum = 0;
  const ej_real *m = ej_set_field(s, "m");
  for (ej_idx i = 0; i < ej_set_count(s); ++i) msum += m[i];
  *dprel = fmax(fabs(p1[0] - p0[0]), fmax(fabs(p1[1] - p0[1]), fabs(p1[2] - p0[2]))) / (msum * 3000);
  ej_counter c[8];
  int nc = 0;
  *npf = -1;
  *ndet = 0;
  if (rc == EJ_OK) {
    ck_assert_int_eq(s->mops->counters(s->mstate, c, 8, &nc), EJ_OK);
    for (int k = 0; k < nc; ++k)
      if (strstr(c[k].name, "det F")) *npf = c[k].value;
    const int32_t *st = ej_set_field_int(s, "pd_status"), *fl = ej_set_field_int(s, "failed");
    for (ej_idx i = 0; i < ej_set_count(s); ++i) {
      *ndet += st[i] == 2;
      if (fl[i]) ck_assert_int_eq(st[i], 2);
    }
  }
  crun_close(&r);
  return rc;
}

START_TEST(test_inversion_point_failure)
{
  int64_t npf, ndet;
  double dp;
  ej_err rc = invert_run("inversion: abort", &npf, &dp, &ndet);
  fprintf(stderr, "tlpd inversion: abort -> rc %d\n", (int)rc);
  ck_assert_int_eq(rc, EJ_ERR_NUMERIC);
  ej_error_clear();
  rc = invert_run("inversion: point_failure", &npf, &dp, &ndet);
  if (rc != EJ_OK) ej_error_report("test");
  fprintf(stderr, "tlpd inversion: point_failure -> rc %d, %lld point-failed, %lld detached, |dp| / (M v) %.3e\n", (int)rc,
          (long long)npf, (long long)ndet, dp);
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_msg(npf > 0, "no particle point-failed");
  ck_assert(ndet >= npf);
  ck_assert_msg(dp < 1e-12, "momentum %g", dp);
  /* with contact the failed particles still resist interpenetration; the run also completes */
  rc = invert_run("inversion: point_failure, contact: unbonded", &npf, &dp, &ndet);
  if (rc != EJ_OK) ej_error_report("test");
  fprintf(stderr, "tlpd inversion + contact: rc %d, %lld point-failed, |dp| / (M v) %.3e\n", (int)rc, (long long)npf, dp);
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert(npf > 0);
  ck_assert_msg(dp < 1e-12, "momentum %g", dp);
}
END_TEST

/* gather form: 1 and 2 threads give the same bits (contact grid built serially, rows scanned in a
 * fixed cell order), with contact, point failures and bond breaking in the run */
static void thread_run(int threads, ej_real **xv, ej_idx *n, const char *law)
{
  crun_threads = threads;
  crun r;
  char y[2048];
  snprintf(y, sizeof y, "ejecta: 1\ndimension: 3\ntime: {end: 1, cfl: 0.5, max_steps: 30}\n" MAT
                "sets: {b: {method: tlpd, material: m, inversion: point_failure, contact: all, contact_law: %s, spacing: 0.01, jitter: 0.2,\n"
                "  failure: {critical_stretch: 0.02}, shape: {box: {min: [0, 0, 0], max: [0.05, 0.05, 0.08]}},\n"
                "  initial: [{region: {box: {min: [-1, -1, -1], max: [1, 1, 0.04]}}, velocity: [0, 0, 3000]},\n"
                "            {region: {box: {min: [-1, -1, 0.04], max: [1, 1, 1]}}, velocity: [0, 0, -3000]}]}}\n", law);
  crun_open(&r, y);
  crun_threads = 1;
  ej_err rc = ej_sim_run(r.sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_set *s = r.sim->sets[0];
  *n = ej_set_count(s);
  *xv = malloc(6 * (size_t)*n * sizeof **xv);
  memcpy(*xv, ej_set_field(s, "x"), 3 * (size_t)*n * sizeof **xv);
  memcpy(*xv + 3 * *n, ej_set_field(s, "v"), 3 * (size_t)*n * sizeof **xv);
  crun_close(&r);
}

START_TEST(test_contact_threads_bitwise)
{
  const char *laws[] = {"spring", "impact"};
  for (int l = 0; l < 2; ++l) {
    ej_real *a, *b;
    ej_idx na, nb;
    thread_run(1, &a, &na, laws[l]);
    thread_run(2, &b, &nb, laws[l]);
    ck_assert_int_eq(na, nb);
    ck_assert_msg(memcmp(a, b, 6 * (size_t)na * sizeof *a) == 0, "1 and 2 threads differ (%s)", laws[l]);
    free(a), free(b);
  }
}
END_TEST

static Suite *suite(void)
{
  Suite *s = suite_create("tlpd_contact");
  TCase *tc = tcase_create("core");
  tcase_set_timeout(tc, 60);
  tcase_add_checked_fixture(tc, pair_dim_reset, pair_dim_reset);
  tcase_add_test(tc, test_contact_bounce_unbonded);
  tcase_add_test(tc, test_contact_bounce_all);
  tcase_add_test(tc, test_contact_off_passes_through);
  tcase_add_test(tc, test_contact_bounce_2d);
  tcase_add_test(tc, test_contact_impact_2d);
  tcase_add_test(tc, test_contact_impact_stops_1kms);
  tcase_add_test(tc, test_inversion_point_failure);
  tcase_add_test(tc, test_contact_threads_bitwise);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(suite());
  srunner_run_all(sr, CK_NORMAL);
  const int nf = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nf == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
