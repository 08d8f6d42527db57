/* Artificial conductivity (Price, J. Comput. Phys. 227 (2008) 10040, section 4) of sph
 * (`conductivity`) and of the `continuum` interface (`conductivity`):
 * plugins/methods/sph/README.md "Artificial conductivity".
 * The rates of the first evaluation (ej_sim_create computes them at t = 0) of a scene with
 * alpha_u = 1 minus those of the same scene with alpha_u = 0 are the conductivity's share
 * D_i of de_i/dt. Checks:
 * - energy: sum_i m_i D_i = 0 to round-off (pairwise antisymmetric exchange), planar and
 *   geometry: spherical (shell masses), inside one set and across two coupled sets;
 * - direction: the hot particles lose energy, the cold ones gain;
 * - equal pressure (a contact at rest with a density and energy jump): D = 0 exactly. */
#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_continuum_info(void);

/* sets: one sph set "gas" (two = 0) on [0.3, 0.7] or two sets "a" [0.3, 0.5], "b" [0.5, 0.7]
 * coupled by continuum; rho 1, e 2.5 (p = 1), a hot (e_hot, rho_hot) slab [0.45, 0.55]. */
static const char scene_fmt[] =
    "ejecta: 1\ndimension: 1\ntime: {end: 1}\noutput: {file: o.h5}\n"
    "materials:\n  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n%s"
    "%s"
    "boundaries:\n  - symmetry: {point: [0.3], normal: [1]}\n  - symmetry: {point: [0.7], normal: [-1]}\n";

typedef struct cond_case {
  int two;          /* two coupled sets instead of one */
  int spherical;    /* geometry: spherical, spherical_energy: pair */
  double rho_hot, e_hot;
  int interface_only; /* two sets: conductivity on the continuum interface only, not in the sets */
} cond_case;

/* Opens the scene with sph and continuum alpha_u = au; fills e_dot (per particle, sets in
 * order), m (shell masses), e; returns the particle count. */
static int cond_rates(const cond_case *k, double au, double *edot, double *m, double *e, double *x)
{
  char set_text[2048], inter[256], geom[96], cond[64];
  snprintf(geom, sizeof geom, "%s", k->spherical ? "geometry: spherical, spherical_energy: pair, " : "");
  snprintf(cond, sizeof cond, "conductivity: %g, ", k->interface_only ? 0.0 : au);
  if (!k->two) {
    snprintf(set_text, sizeof set_text,
             "  gas: {method: sph, material: gas, %s%srenormalize: false, shape: {box: {min: [0.3], max: [0.7]}},\n"
             "        spacing: 0.01, rho: 1, e: 2.5,\n"
             "        initial: [{region: {box: {min: [0.45], max: [0.55]}}, rho: %.17g, e: %.17g}]}\n",
             geom, cond, k->rho_hot, k->e_hot);
    inter[0] = 0;
  } else {
    snprintf(set_text, sizeof set_text,
             "  a: {method: sph, material: gas, %s%srenormalize: false, shape: {box: {min: [0.3], max: [0.5]}},\n"
             "      spacing: 0.01, rho: 1, e: 2.5,\n"
             "      initial: [{region: {box: {min: [0.45], max: [0.5]}}, rho: %.17g, e: %.17g}]}\n"
             "  b: {method: sph, material: gas, %s%srenormalize: false, shape: {box: {min: [0.5], max: [0.7]}},\n"
             "      spacing: 0.01, rho: 1, e: 2.5}\n",
             geom, cond, k->rho_hot, k->e_hot, geom, cond);
    snprintf(inter, sizeof inter, "interactions:\n  - {model: continuum, sets: [a, b], conductivity: %g}\n", au);
  }
  vscene c;
  const ej_plugin_info *pl[3] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info(), ej_plugin_continuum_info()};
  char text[4096];
  snprintf(text, sizeof text, scene_fmt, set_text, inter);
  memset(&c, 0, sizeof c);
  vrun_dir(c.dir, sizeof c.dir, "sphcond");
  snprintf(c.scene, sizeof c.scene, "%s/s.yaml", c.dir);
  snprintf(c.out, sizeof c.out, "%s/out.h5", c.dir);
  vrun_write(c.scene, text);
  ck_assert_int_eq(ej_registry_create(&c.r.reg), EJ_OK);
  for (int q = 0; q < 3; ++q) ck_assert_int_eq(ej_registry_add_static(c.r.reg, pl[q]), EJ_OK);
  ej_err rc = ej_scene_load(c.scene, c.r.reg, &c.r.scene);
  if (rc == EJ_OK) {
    ej_run_opts o = {.threads = 1, .output = c.out};
    rc = ej_sim_create(c.r.scene, c.r.reg, &o, &c.r.sim);
  }
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  int n = 0;
  for (int s = 0; s < c.r.sim->n_sets; ++s) {
    const ej_set *set = c.r.sim->sets[s];
    const ej_real *ed = ej_set_field(set, "e_dot"), *ms = ej_set_field(set, "m"), *es = ej_set_field(set, "e");
    const ej_real *xs = ej_set_field(set, "x");
    for (ej_idx i = 0; i < ej_set_count(set); ++i, ++n) {
      edot[n] = ed[i], m[n] = ms[i], e[n] = es[i], x[n] = xs[3 * i];
    }
  }
  vscene_free(&c);
  return n;
}

/* sum m D / sum m |D| and sum m |D| (the conductivity's share D of e_dot). */
static void cond_check(const cond_case *k, double *rel, double *mabs, double *dmax_hot, double *dmax_cold)
{
  enum { N = 256 };
  double e1[N], e0[N], m[N], e[N], x[N], m0[N], ee0[N], x0[N];
  const int n1 = cond_rates(k, 1.0, e1, m, e, x), n0 = cond_rates(k, 0.0, e0, m0, ee0, x0);
  ck_assert_int_eq(n1, n0);
  double s = 0, sa = 0, dh = 0, dc = 0;
  for (int i = 0; i < n1; ++i) {
    ck_assert(x[i] == x0[i] && m[i] == m0[i] && e[i] == ee0[i]);
    const double d = e1[i] - e0[i];
    s += m[i] * d, sa += fabs(m[i] * d);
    if (e[i] > 2.5) dh = fmin(dh, d); /* most negative on the hot side */
    else dc = fmax(dc, d);
  }
  *rel = sa > 0 ? fabs(s) / sa : 0;
  *mabs = sa;
  *dmax_hot = dh, *dmax_cold = dc;
}

static void run_case(const char *name, const cond_case *k)
{
  double rel, sa, dh, dc;
  cond_check(k, &rel, &sa, &dh, &dc);
  fprintf(stderr, "%s: |sum m D| / sum m|D| = %.2e, sum m|D| = %.4e, hot min D %.3e, cold max D %.3e\n", name, rel, sa,
          dh, dc);
  ck_assert_msg(sa > 0, "%s: the conductivity did nothing at a pressure jump", name);
  ck_assert_msg(rel < 1e-12, "%s: energy not conserved: %g", name, rel);
  ck_assert_msg(dh < 0 && dc > 0, "%s: heat must flow from hot to cold (%g, %g)", name, dh, dc);
}

START_TEST(test_one_set_planar) { run_case("one set, planar", &(cond_case){0, 0, 1.0, 25.0, 0}); }
END_TEST

START_TEST(test_one_set_spherical) { run_case("one set, spherical", &(cond_case){0, 1, 1.0, 25.0, 0}); }
END_TEST

START_TEST(test_two_sets_planar) { run_case("two sets (continuum), planar", &(cond_case){1, 0, 1.0, 25.0, 0}); }
END_TEST

START_TEST(test_two_sets_spherical) { run_case("two sets (continuum), spherical", &(cond_case){1, 1, 1.0, 25.0, 0}); }
END_TEST

START_TEST(test_interface_only)
{
  /* only continuum's share: the exchange across the set-to-set contact at x = 0.5 */
  run_case("continuum only, planar", &(cond_case){1, 0, 1.0, 25.0, 1});
  run_case("continuum only, spherical", &(cond_case){1, 1, 1.0, 25.0, 1});
}
END_TEST

START_TEST(test_equal_pressure)
{
  /* a contact at rest: rho 0.125, e 20 next to rho 1, e 2.5 (p = 1 on both sides, exactly in
   * floating point): v_sig = 0, the conductivity must add nothing, one set and two sets */
  for (int two = 0; two < 2; ++two)
    for (int sph = 0; sph < 2; ++sph) {
      double rel, sa, dh, dc;
      cond_check(&(cond_case){two, sph, 0.125, 20.0, 0}, &rel, &sa, &dh, &dc);
      fprintf(stderr, "equal pressure (two sets %d, spherical %d): sum m|D| = %.3e\n", two, sph, sa);
      ck_assert_msg(sa == 0.0, "conductivity at equal pressure: sum m|D| = %g", sa);
    }
}
END_TEST

static Suite *suite(void)
{
  Suite *s = suite_create("sph_conductivity");
  TCase *tc = tcase_create("core");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_one_set_planar);
  tcase_add_test(tc, test_one_set_spherical);
  tcase_add_test(tc, test_two_sets_planar);
  tcase_add_test(tc, test_two_sets_spherical);
  tcase_add_test(tc, test_interface_only);
  tcase_add_test(tc, test_equal_pressure);
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
