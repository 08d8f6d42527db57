/* Interaction pd_sph (PD solid - SPH fluid coupling):
 * - pairwise form: total momentum of a free coupled system conserved to round-off, energy
 *   balanced;
 * - decohesion: solid particles next to high-pressure fluid are marked failed and lose bonds;
 * - set checks: exactly one of the two sets must publish F. */
#include <check.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_pd_sph_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);

typedef vscene prun;

/* Loads the printf-formatted scene with the coupling's plugins and creates its sim. */
static ej_err prun_try(prun *c, const char *fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(),    ej_plugin_ideal_gas_info(), ej_plugin_pd_sph_info(),
                               ej_plugin_tlpd_info(),   ej_plugin_elastic_info(),   ej_plugin_polynomial_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "pdsph", p, 6, fmt, ap);
  va_end(ap);
  return rc;
}

static void prun_free(prun *c) { vscene_free(c); }

/* A 2D elastic PD block hit by a moving fluid block; no boundaries. */
static const char scene_free[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 2e-4, cfl: 0.3}\noutput: {file: out.h5}\n"
    "materials:\n  rock: {model: elastic, rho0: 2000, E: 1e9, nu: 0.25}\n"
    "  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
    "sets:\n"
    "  rock: {method: tlpd, material: rock, shape: {box: {min: [0, 0], max: [0.05, 0.05]}}, spacing: 0.0025}\n"
    "  water: {method: sph, material: water, shape: {box: {min: [-0.03, 0.01], max: [0, 0.04]}}, spacing: 0.0025,\n"
    "          velocity: [20, 3]}\n"
    "interactions:\n  - {model: pd_sph, sets: [water, rock], form: %s%s}\n";

START_TEST(test_pairwise_momentum)
{
  prun c;
  ck_assert_int_eq(prun_try(&c, scene_free, "pairwise", ""), EJ_OK);
  const ej_energy *E0 = &c.r.sim->energy;
  const double px0 = E0->momentum[0], py0 = E0->momentum[1];
  vrun_run(&c.r);
  const ej_energy *E = &c.r.sim->energy;
  /* the water really pushed the rock */
  ej_set *rock = c.r.sim->sets[0];
  const ej_real *v = ej_set_field(rock, "v"), *m = ej_set_field(rock, "m");
  double prock = 0;
  for (ej_idx i = 0; i < rock->n; ++i) prock += m[i] * v[3 * i];
  fprintf(stderr, "pairwise: rock momentum %.4e, total drift (%.3e, %.3e) of %.3e, balance %.3e of %.3e\n", prock,
          E->momentum[0] - px0, E->momentum[1] - py0, px0, E->balance, E->total0);
  ck_assert_double_gt(prock, 1e-3 * px0);
  ck_assert_double_lt(fabs(E->momentum[0] - px0), 1e-12 * px0);
  ck_assert_double_lt(fabs(E->momentum[1] - py0), 1e-12 * px0);
  ck_assert_double_lt(fabs(E->balance), 1e-2 * E->total0);
  prun_free(&c);
}
END_TEST

START_TEST(test_decohesion)
{
  prun c;
  /* a 20 m/s water jet gives ~ rho c v = 30 MPa: a 1 MPa threshold decoheres the rock face */
  ck_assert_int_eq(prun_try(&c, scene_free, "pairwise", ", decohesion_pressure: 1 MPa"), EJ_OK);
  vrun_run(&c.r);
  ej_set *rock = c.r.sim->sets[0];
  const int32_t *failed = ej_set_field_int(rock, "failed");
  const ej_real *x = ej_set_field(rock, "x");
  int nf = 0, deep = 0;
  for (ej_idx i = 0; i < rock->n; ++i)
    if (failed[i]) {
      ++nf;
      deep += x[3 * i] > 0.02; /* only the face next to the water decoheres */
    }
  fprintf(stderr, "decohesion: %d failed rock particles, %d deeper than 20 mm\n", nf, deep);
  ck_assert_int_gt(nf, 0);
  ck_assert_int_eq(deep, 0);
  prun_free(&c);
}
END_TEST

START_TEST(test_needs_one_solid)
{
  prun c;
  ej_err rc = prun_try(&c,
                       "ejecta: 1\ndimension: 1\ntime: {end: 1e-4}\n"
                       "materials:\n  w: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.2e9}}\n"
                       "sets:\n  a: {method: sph, material: w, shape: {box: {min: [0], max: [1]}}, spacing: 0.1}\n"
                       "  b: {method: sph, material: w, shape: {box: {min: [1], max: [2]}}, spacing: 0.1}\n"
                       "interactions:\n  - {model: pd_sph, sets: [a, b]}\n");
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(strstr(f->msg, "one peridynamic set"));
  ck_assert_int_eq(f->where.line, 10); /* located at the interaction's node */
  ej_error_clear();
  prun_free(&c);
}
END_TEST

static Suite *pd_sph_suite(void)
{
  Suite *s = suite_create("pd_sph");
  TCase *tc = tcase_create("coupling");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_pairwise_momentum);
  tcase_add_test(tc, test_decohesion);
  tcase_add_test(tc, test_needs_one_solid);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(pd_sph_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
