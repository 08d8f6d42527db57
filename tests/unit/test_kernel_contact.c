/* kernel_contact interaction: two elastic RKPM blocks (2D plane strain) collide obliquely.
 * Total momentum is conserved to round-off (pair forces antisymmetric bitwise, applied both
 * ways in gather form), the blocks do exchange momentum, friction dissipates energy (and only
 * friction: mu = 0 dissipates exactly nothing), and the energy budget with the reported
 * penalty work and dissipation closes (cfl 0.25: the balance error of this coarse impact is
 * second order in dt, 7.4 % of E0 at cfl 0.5, 1.1 % at 0.25, 0.17 % at 0.125). */
#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_rkpm_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_kernel_contact_info(void);

typedef struct kc_result {
  double p0[3], p1[3], pscale;    /* total momentum before / after, sum m |v| */
  double pa0[3], pa1[3];          /* momentum of block a */
  double dissipated, balance, e0;
} kc_result;

static double report_value(const ej_sim *sim, const char *name)
{
  for (int k = 0; k < sim->reports.n; ++k)
    if (!strcmp(sim->reports.names[k], name)) return sim->reports.values[k];
  ck_abort_msg("no series '%s'", name);
  return NAN;
}

static void set_momentum(const ej_set *s, double p[3], double *scale)
{
  const ej_real *v = ej_set_field(s, "v"), *m = ej_set_field(s, "m");
  for (ej_idx i = 0; i < ej_set_count(s); ++i)
    for (int d = 0; d < 3; ++d) {
      p[d] += m[i] * v[3 * i + d];
      if (scale) *scale += m[i] * fabs(v[3 * i + d]);
    }
}

static void collide(double mu, int threads, kc_result *res)
{
  char dir[256], scene[512], out[512];
  ej_test_tmpdir(dir, sizeof dir, "kc");
  snprintf(scene, sizeof scene, "%s/kc.yaml", dir);
  snprintf(out, sizeof out, "%s/kc.h5", dir);
  FILE *fp = fopen(scene, "w");
  ck_assert_ptr_nonnull(fp);
  fprintf(fp,
          "ejecta: 1\ndimension: 2\ntime: {end: 3.0, cfl: 0.25}\noutput: {file: kc.h5, fields: [v]}\n"
          "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n  n: {model: elastic, rho0: 2, E: 3, nu: 0.3}\n"
          "sets:\n"
          "  a: {method: rkpm, material: m, shape: {box: {min: [0, 0], max: [0.6, 0.6]}}, spacing: 0.1,"
          " velocity: [0.03, 0.02]}\n"
          "  b: {method: rkpm, material: n, shape: {box: {min: [0.65, 0.2], max: [1.15, 0.8]}}, spacing: 0.1,"
          " velocity: [-0.02, -0.01]}\n"
          "interactions:\n  - {model: kernel_contact, sets: [a, b], mu: %.17g}\n",
          mu);
  fclose(fp);
  ej_registry *reg;
  ej_scene *sc;
  ej_sim *sim;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_rkpm_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_kernel_contact_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene, reg, &sc);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = threads};
  rc = ej_sim_create(sc, reg, &opts, &sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  memset(res, 0, sizeof *res);
  for (int k = 0; k < 2; ++k) set_momentum(sim->sets[k], res->p0, &res->pscale);
  set_momentum(sim->sets[0], res->pa0, NULL);
  res->e0 = sim->energy.kinetic + sim->energy.internal;
  rc = ej_sim_run(sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  for (int k = 0; k < 2; ++k) set_momentum(sim->sets[k], res->p1, NULL);
  set_momentum(sim->sets[0], res->pa1, NULL);
  res->dissipated = report_value(sim, "kernel_contact_0/dissipated");
  res->balance = sim->energy.balance;
  ej_sim_destroy(sim);
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
  ej_test_rmtree(dir);
}

START_TEST(test_momentum_and_friction)
{
  kc_result r0, r1;
  collide(0.0, 1, &r0);
  collide(0.5, 1, &r1);
  const kc_result *rs[2] = {&r0, &r1};
  for (int k = 0; k < 2; ++k) {
    const kc_result *r = rs[k];
    double dp = 0, dpa = 0;
    for (int d = 0; d < 3; ++d) dp = fmax(dp, fabs(r->p1[d] - r->p0[d])), dpa = fmax(dpa, fabs(r->pa1[d] - r->pa0[d]));
    fprintf(stderr,
            "kernel_contact mu %.1f: |dP_total| %.3g (scale %.3g), |dP_a| %.3g, dissipated %.4g J, balance %.3g J "
            "(%.2e of E0)\n",
            k ? 0.5 : 0.0, dp, r->pscale, dpa, r->dissipated, r->balance, fabs(r->balance) / r->e0);
    ck_assert_msg(dp < 1e-13 * r->pscale, "total momentum changed by %g (scale %g)", dp, r->pscale);
    ck_assert_msg(dpa > 0.2 * r->pscale, "blocks exchanged too little momentum (%g of %g): no collision?", dpa,
                  r->pscale);
    ck_assert_msg(fabs(r->balance) < 0.02 * r->e0, "energy balance %g of E0 %g", r->balance, r->e0);
  }
  ck_assert_msg(r0.dissipated == 0.0, "frictionless contact dissipated %g", r0.dissipated);
  ck_assert_msg(r1.dissipated > 1e-3 * r1.e0, "friction dissipated only %g (E0 %g)", r1.dissipated, r1.e0);
  /* Friction changes the tangential (y) momentum exchange. */
  ck_assert_msg(fabs((r1.pa1[1] - r1.pa0[1]) - (r0.pa1[1] - r0.pa0[1])) > 1e-3 * r0.pscale,
                "friction left the tangential exchange unchanged");
}
END_TEST

/* Same run with 1 and 2 threads: bitwise identical momenta (gather form, no atomics). */
START_TEST(test_threads_bitwise)
{
  kc_result r1, r2;
  collide(0.5, 1, &r1);
  collide(0.5, 2, &r2);
  for (int d = 0; d < 3; ++d) ck_assert(r1.pa1[d] == r2.pa1[d]);
  ck_assert(r1.dissipated == r2.dissipated);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("kernel_contact");
  TCase *tc = tcase_create("kernel_contact");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_momentum_and_friction);
  tcase_add_test(tc, test_threads_bitwise);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
