/* Pressure loads (scene `boundaries: [{pressure: ...}]`, core/src/sim.c ej_pressure_load, core/src/blast.c,
 * docs/core.md "Pressure loads"): the Kingery-Bulmash curves against their published values, the
 * Friedlander pulse's impulse, the angle rule of Randers-Pehrson & Bannister, the momentum and
 * energy a load puts into a free block, 1 and 2 threads and a restart, and the inputs refused. */
#include <hdf5.h>

#include "validation_common.h"

const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);

static void prun_open(vrun *r, const char *scene, const char *out, int threads, const char *restart)
{
  const ej_plugin_info *p[] = {ej_plugin_tlpd_info(), ej_plugin_elastic_info()};
  ej_run_opts o = {.struct_size = sizeof o, .output = out, .threads = threads, .restart = restart};
  vrun_open_with(r, scene, &o, -1, p, 2);
}

static void near(double got, double want, double rel, const char *what, double z)
{
  ck_assert_msg(fabs(got / want - 1) <= rel, "%s at Z = %g: %.6g, expected %.6g (tolerance %g)", what, z, got, want,
                rel);
}

/* ------------------------------------------------------------------ the curves */

/* Free-air burst: shared/reference/README.md section 3.4 and kingery_bulmash_computed_table_metric.csv
 * (the metric Kingery-Bulmash polynomials, BRL-TR-02555 = UFC 3-340-02 Fig. 2-7), printed to 4
 * digits: Pso, Pr (kPa), is (kPa ms/kg^(1/3)), ta, td (ms/kg^(1/3)). */
START_TEST(test_kb_free_air)
{
  static const double tab[][6] = {{0.5, 3885, 30360, 141.3, 0.1541, 0.3196}, {1, 934.9, 5006, 174.5, 0.5318, 1.795},
                                  {2, 194.7, 645.8, 92.12, 1.944, 1.846},     {3, 81.59, 215.5, 64.33, 3.987, 2.685},
                                  {5, 31.3, 70.02, 40.62, 8.995, 3.333},      {10, 11.09, 23.31, 21.13, 22.72, 4.2},
                                  {40, 1.72, 3.479, 5.304, 109.5, 6.165}};
  for (size_t k = 0; k < sizeof tab / sizeof tab[0]; ++k) {
    ej_blast_kb kb;
    const double z = tab[k][0];
    ej_blast_curves(EJ_BURST_AIR, z, &kb);
    near(kb.p_i / 1e3, tab[k][1], 1e-3, "Pso", z);
    near(kb.p_r / 1e3, tab[k][2], 1e-3, "Pr", z);
    near(kb.i_i, tab[k][3], 1e-3, "is", z); /* Pa s = kPa ms */
    near(kb.t_a * 1e3, tab[k][4], 1e-3, "ta", z);
    near(kb.t_d * 1e3, tab[k][5], 2e-3, "td", z);
    ck_assert(kb.i_r > kb.i_i && kb.p_r > 2 * kb.p_i); /* a rigid face reflects more than twice the peak */
  }
}
END_TEST

/* Surface burst: 10 kg TNT at 1, 2, 5, 10 m, the hemispherical data of the blastFoam validation
 * (shared/reference/kingery_bulmash_hemispherical_10kgTNT_swisdak1994_blastfoam.csv): Pso (kPa), is
 * (kPa ms), ta (ms). */
START_TEST(test_kb_surface)
{
  static const double tab[][4] = {
      {1, 5472, 360.3, 0.2744}, {2, 1585, 497, 0.8809}, {5, 202.4, 250.6, 4.811}, {10, 49.27, 136.3, 15.82}};
  const double w3 = cbrt(10.0);
  for (size_t k = 0; k < sizeof tab / sizeof tab[0]; ++k) {
    ej_blast_kb kb;
    const double z = tab[k][0] / w3;
    ej_blast_curves(EJ_BURST_SURFACE, z, &kb);
    near(kb.p_i / 1e3, tab[k][1], 2e-3, "surface Pso", z);
    near(kb.i_i * w3, tab[k][2], 2e-3, "surface is", z);
    near(kb.t_a * w3 * 1e3, tab[k][3], 2e-3, "surface ta", z);
    ej_blast_kb air;
    ej_blast_curves(EJ_BURST_AIR, z, &air);
    ck_assert(kb.p_i > air.p_i); /* the ground doubles the charge, nearly */
  }
}
END_TEST

/* The pulse carries the curve's impulse: Simpson's rule over the pulse, for decays from 0 to large
 * and for a duration too short to carry it (the triangle is lengthened). */
START_TEST(test_friedlander_impulse)
{
  static const double cases[][3] = {{1e6, 300, 1e-3}, {1e6, 100, 1e-3}, {1e6, 10, 1e-3}, {5e6, 559, 1.79e-3},
                                    {1e5, 1.0, 1e-3}, {1e6, 600, 1e-3}, {1e6, 499.99, 1e-3}};
  for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
    const double P = cases[k][0], I = cases[k][1];
    double td = cases[k][2];
    const double a = ej_blast_decay(P, I, &td);
    ck_assert(a >= 0 && td >= cases[k][2]);
    if (I / (P * cases[k][2]) >= 0.5) ck_assert(a == 0 && fabs(td - 2 * I / P) < 1e-15 * td);
    else ck_assert(td == cases[k][2]);
    const int n = 200000;
    double s = 0;
    for (int q = 0; q <= n; ++q) {
      const double w = q == 0 || q == n ? 1 : q % 2 ? 4 : 2;
      s += w * ej_blast_friedlander(P, a, td, td * q / n);
    }
    s *= td / n / 3;
    ck_assert_msg(fabs(s / I - 1) < 1e-7, "P %g I %g: integral %.10g, decay %g, td %g", P, I, s, a, td);
    ck_assert(ej_blast_friedlander(P, a, td, 0) == P && ej_blast_friedlander(P, a, td, -1e-9) == 0 &&
              ej_blast_friedlander(P, a, td, 1.0001 * td) == 0);
  }
}
END_TEST

/* Randers-Pehrson & Bannister: p_r at normal incidence, p_i at grazing incidence and on a face turned
 * away, cos^2 p_r + (1 + cos^2 - 2 cos) p_i between; just after the arrival. */
START_TEST(test_angle_rule)
{
  const double W = 8, charge[3] = {0, 0, 0}, x[3] = {4, 0, 0}, z = 4 / cbrt(W);
  ej_blast_kb kb;
  ej_blast_curves(EJ_BURST_AIR, z, &kb);
  const double t = 1e-4 + kb.t_a * cbrt(W) + 1e-9, w3 = cbrt(W);
  struct {
    double n[3], want;
  } c[] = {{{-1, 0, 0}, kb.p_r},
           {{0, 1, 0}, kb.p_i},
           {{1, 0, 0}, kb.p_i},
           {{-0.5, sqrt(0.75), 0}, 0.25 * kb.p_r + 0.25 * kb.p_i},
           {{0.6, 0.8, 0}, kb.p_i}};
  for (size_t k = 0; k < sizeof c / sizeof c[0]; ++k) {
    const double p = ej_blast_pressure(EJ_BURST_AIR, W, charge, 1e-4, x, c[k].n, t);
    ck_assert_msg(fabs(p / c[k].want - 1) < 1e-5, "normal %zu: %g, expected %g", k, p, c[k].want);
  }
  const double n[3] = {-1, 0, 0};
  ck_assert(ej_blast_pressure(EJ_BURST_AIR, W, charge, 1e-4, x, n, t - 2e-9) == 0); /* before the arrival */
  ej_blast_face f;
  ej_blast_peak(EJ_BURST_AIR, W, charge, x, n, &f);
  ck_assert(fabs(f.z - z) < 1e-14 && fabs(f.p / kb.p_r - 1) < 1e-14 && fabs(f.impulse / (kb.i_r * w3) - 1) < 1e-14);
}
END_TEST

/* ------------------------------------------------------------------ loads on a free block */

/* A free steel block, 0.1 x 0.1 x 0.02 m, spacing 0.01 (200 particles), loaded on its top face. */
static const char block_fmt[] = "ejecta: 1\n"
                                "dimension: 3\n"
                                "time: {end: %s, cfl: 0.5%s}\n"
                                "output: {file: %s}\n"
                                "materials:\n"
                                "  steel: {model: elastic, rho0: 7850, E: 200 GPa, nu: 0.3}\n"
                                "sets:\n"
                                "  plate:\n"
                                "    method: tlpd\n"
                                "    material: steel\n"
                                "    shape: {box: {%s}}\n"
                                "    spacing: 0.01\n"
                                "boundaries:\n"
                                "  - {set: plate, region: {box: {min: [-1, -1, -0.009], max: [1, 1, 1]}}, pressure: %s}\n";

static void block_run(vrun *r, const char *dir, const char *end, const char *extra, const char *load, int threads,
                      const char *tag, const char *restart)
{
  char scene[160], out[160], text[2048];
  snprintf(scene, sizeof scene, "%s/%s.yaml", dir, tag);
  snprintf(out, sizeof out, "%s/%s.h5", dir, tag);
  snprintf(text, sizeof text, block_fmt, end, extra, out, "min: [-0.05, -0.05, -0.02], max: [0.05, 0.05, 0]", load);
  vrun_write(scene, text);
  prun_open(r, scene, out, threads, restart);
  vrun_run(r);
}

/* momentum z of the set and the face's summed force now */
static double block_pz(const ej_sim *sim, double *fz)
{
  const ej_set *s = sim->sets[0];
  const ej_real *v = ej_set_field(s, "v"), *m = ej_set_field(s, "m"), *f = ej_set_field(s, "load_force");
  double pz = 0;
  *fz = 0;
  for (ej_idx i = 0; i < ej_set_count(s); ++i) pz += m[i] * v[3 * i + 2], *fz += f[3 * i + 2];
  return pz;
}

/* A constant pressure and a linear ramp: the impulse of velocity Verlet is the exact integral (the
 * trapezoidal rule of a linear force), the load's work is the kinetic and internal energy it made. */
START_TEST(test_value_and_curve)
{
  char dir[64];
  vrun_dir(dir, sizeof dir, "pr_value");
  const double A = 0.01, P = 2e6, T = 2e-4;
  vrun r;
  block_run(&r, dir, "0.1 ms", "", "{normal: [0, 0, 1], value: 2 MPa}", 1, "v", NULL);
  double fz;
  double pz = block_pz(r.sim, &fz);
  ck_assert_msg(fabs(fz / (-P * A) - 1) < 1e-13, "force %g", fz);
  ck_assert_msg(fabs(pz / (-P * A * r.sim->t) - 1) < 1e-12, "momentum %.15g vs %.15g", pz, -P * A * r.sim->t);
  const ej_energy *e = &r.sim->energy;
  ck_assert(e->external > 0);
  /* tlpd's internal energy is its own quadrature of the bond work (5.6e-6 of the load's work here) */
  ck_assert_msg(fabs(e->balance) < 1e-4 * e->external, "balance %g of work %g", e->balance, e->external);
  vrun_free(&r);
  /* one particle (no bonds: the load alone): its work is the kinetic energy to round-off */
  char text[2048], scene[160], out[160];
  snprintf(scene, sizeof scene, "%s/one.yaml", dir);
  snprintf(out, sizeof out, "%s/one.h5", dir);
  snprintf(text, sizeof text, block_fmt, "0.1 ms", "", out, "min: [-0.005, -0.005, -0.01], max: [0.005, 0.005, 0]",
           "{normal: [0, 0, 1], curve: [[0, 0], [50 us, 2 MPa]]}");
  vrun_write(scene, text);
  prun_open(&r, scene, out, 1, NULL);
  vrun_run(&r);
  ck_assert_int_eq((int)ej_set_count(r.sim->sets[0]), 1);
  const ej_energy *e1 = &r.sim->energy;
  ck_assert_msg(fabs(e1->balance) < 1e-12 * e1->external, "one particle: balance %g of work %g", e1->balance,
                e1->external);
  vrun_free(&r);
  /* p = P t / T up to T, then P: at t <= T the impulse is P A t^2 / (2 T) */
  block_run(&r, dir, "0.1 ms", "", "{normal: [0, 0, 1], curve: [[0, 0], [0.2 ms, 2 MPa], [1 s, 2 MPa]]}", 1, "c",
            NULL);
  pz = block_pz(r.sim, &fz);
  const double t = r.sim->t;
  ck_assert_msg(fabs(pz / (-P * A * t * t / (2 * T)) - 1) < 1e-11, "ramp momentum %.15g vs %.15g", pz,
                -P * A * t * t / (2 * T));
  ck_assert_msg(fabs(fz / (-P * A * t / T) - 1) < 1e-12, "ramp force %g", fz);
  vrun_free(&r);
  ej_test_rmtree(dir);
}
END_TEST

/* 1 kg TNT 1 m above the face: the block's momentum after the pulse is the impulse `ejecta check`
 * predicts (sum of A (i_r cos^2 + i_i (1 + cos^2 - 2 cos)) W^(1/3)) to the time step's resolution of
 * the shock's jump; the load's work balances the budget. */
START_TEST(test_blast_impulse)
{
  char dir[64];
  vrun_dir(dir, sizeof dir, "pr_blast");
  const char *load = "{normal: [0, 0, 1], blast: {charge: [0, 0, 1 m], tnt: 1 kg, time: 0.1 ms}}";
  double err[2];
  for (int k = 0; k < 2; ++k) {
    vrun r;
    block_run(&r, dir, "3 ms", k ? ", dt: 0.05 us" : ", dt: 0.5 us", load, 1, k ? "b1" : "b0", NULL);
    const ej_set *s = r.sim->sets[0];
    const ej_scene_bc *bc = &r.scene->bcs[0];
    /* the expected impulse on the face at t = 0, where the load is evaluated */
    double want = 0;
    const ej_real *vol0 = ej_set_field(s, "vol0"), *x = ej_set_field(s, "load_x0");
    int nface = 0;
    for (ej_idx i = 0; i < ej_set_count(s); ++i) {
      if (!(s->bc_mask[i] & 1u)) continue;
      ++nface;
      ej_blast_face f;
      const ej_real n[3] = {0, 0, 1}, xi[3] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
      ej_blast_peak(bc->burst, bc->tnt, bc->charge, xi, n, &f);
      want += ej_face_area(3, vol0[i]) * f.impulse;
    }
    ck_assert_int_eq(nface, 100);
    double fz;
    const double pz = block_pz(r.sim, &fz);
    ck_assert_msg(fz == 0, "the pulse is over at 3 ms: %g", fz);
    err[k] = fabs(-pz / want - 1);
    const ej_energy *e = &r.sim->energy;
    ck_assert_msg(fabs(e->balance) < 1e-5 * e->external, "balance %g of work %g", e->balance, e->external);
    vrun_free(&r);
  }
  /* the step samples the pressure's jump at the arrival: at most P dt / 2 per face particle, 2.2e-3 of
   * the impulse at dt = 0.5 us */
  fprintf(stderr, "blast impulse error %.3g (dt 0.5 us), %.3g (0.05 us)\n", err[0], err[1]);
  ck_assert_msg(err[0] < 1.1e-3 && err[1] < 1.1e-4, "impulse error %g (dt 0.5 us), %g (0.05 us)", err[0], err[1]);
  ej_test_rmtree(dir);
}
END_TEST

static void same_state(const ej_sim *a, const ej_sim *b, const char *what)
{
  static const char *const f[] = {"x", "v", "load_force", "load_power"};
  vrun_same_state(a, b, f, 4, what);
}

START_TEST(test_threads_and_restart)
{
  char dir[64];
  vrun_dir(dir, sizeof dir, "pr_rs");
  const char *load = "{normal: [0, 0, 1], blast: {charge: [0.02, 0, 0.3 m], tnt: 0.1 kg}}";
  vrun a, b, c, d;
  block_run(&a, dir, "1 ms", ", max_steps: 300", load, 1, "a", NULL);
  ck_assert(a.sim->energy.external > 0);
  block_run(&b, dir, "1 ms", ", max_steps: 300", load, 2, "b", NULL);
  same_state(a.sim, b.sim, " between 1 and 2 threads");
  block_run(&c, dir, "1 ms", ", max_steps: 150", load, 1, "c", NULL);
  char rs[160];
  snprintf(rs, sizeof rs, "%s/c.h5", dir);
  block_run(&d, dir, "1 ms", ", max_steps: 300", load, 1, "d", rs);
  ck_assert_int_eq((int)d.sim->step, 300);
  same_state(a.sim, d.sim, " after a restart at step 150");
  vrun_free(&a);
  vrun_free(&b);
  vrun_free(&c);
  vrun_free(&d);
  ej_test_rmtree(dir);
}
END_TEST

/* A face around a centre: a convex one is pushed towards it, a cavity wall away from it. */
START_TEST(test_radial_faces)
{
  ej_scene_bc bc = {.kind = EJ_BC_PRESSURE, .radial = true, .point = {1, 2, 3}, .source = EJ_PRESSURE_VALUE,
                    .p_value = 1e6};
  const ej_real x[3] = {1, 2 + 0.6, 3 + 0.8};
  ej_real F[3];
  ck_assert(ej_pressure_load(&bc, 3, x, 1e-3, 0, NULL, F) == 1e6);
  ck_assert(fabs(F[0]) < 1e-9 && fabs(F[1] + 0.6e4) < 1e-9 && fabs(F[2] + 0.8e4) < 1e-9); /* A = 1e-2 */
  bc.cavity = true;
  ej_pressure_load(&bc, 3, x, 1e-3, 0, NULL, F);
  ck_assert(fabs(F[1] - 0.6e4) < 1e-9 && fabs(F[2] - 0.8e4) < 1e-9);
  ej_pressure_load(&bc, 2, x, 1e-4, 0, NULL, F); /* 2D: A = sqrt(area) per m of thickness */
  ck_assert(fabs(F[1] - 0.6e4) < 1e-9);
  ck_assert(ej_pressure_load(&bc, 3, bc.point, 1e-3, 0, NULL, F) == 0 && F[0] == 0); /* at the centre: no normal */
}
END_TEST

/* ------------------------------------------------------------------ inputs refused at set-up */

START_TEST(test_refused)
{
  char dir[64], scene[128];
  vrun_dir(dir, sizeof dir, "pr_bad");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  static const char head[] = "ejecta: 1\n"
                             "time: {end: 1 ms}\n"
                             "materials:\n"
                             "  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
                             "sets:\n"
                             "  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, "
                             "spacing: 0.1, p: 1e5}\n"
                             "boundaries:\n";
  char text[1024];
  snprintf(text, sizeof text, "%s  - {region: {box: {min: [0.9, 0, 0], max: [1, 1, 1]}}, pressure: {normal: [1, 0, 0], "
                              "blast: {charge: [0.97, 0.55, 0.55], tnt: 1 kg}}}\n", head);
  vrun_write(scene, text);
  vrun_check_refuses(scene, "scaled distance Z = 0.0", 8, 5);
  snprintf(text, sizeof text, "%s  - {region: {box: {min: [5, 0, 0], max: [6, 1, 1]}}, pressure: {normal: [1, 0, 0], "
                              "value: 1 MPa}}\n", head);
  vrun_write(scene, text);
  vrun_check_refuses(scene, "its region holds no particle", 8, 5);
  ej_test_rmtree(dir);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("pressure");
  TCase *tc = tcase_create("pressure");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_kb_free_air);
  tcase_add_test(tc, test_kb_surface);
  tcase_add_test(tc, test_friedlander_impulse);
  tcase_add_test(tc, test_angle_rule);
  tcase_add_test(tc, test_value_and_curve);
  tcase_add_test(tc, test_blast_impulse);
  tcase_add_test(tc, test_threads_and_restart);
  tcase_add_test(tc, test_radial_faces);
  tcase_add_test(tc, test_refused);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
