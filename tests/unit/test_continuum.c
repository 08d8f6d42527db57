/* Interaction `continuum`: the generic pairwise coupling of two particle sets.
 * - equilibrium: two gases of different density at the same pressure, coupled across their
 *   interface, stay at rest;
 * - Sod split in two sets (left and right states in different sets coupled by `continuum`)
 *   reproduces the single-set SPH solution and converges to the exact one;
 * - momentum: a free, colliding two-set system conserves total momentum to round-off;
 * - shape tensor: a shape-tensor gas cut into two coupled sets is the one-set run to round-off
 *   (the other set's neighbours in M_i, sph's G_ij on the interface pairs). */
#include <check.h>
#include <stdarg.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_continuum_info(void);

typedef vscene crun;

/* Loads, creates and runs the printf-formatted scene with sph, ideal_gas and continuum. */
static void crun_go(crun *c, const char *text_fmt, ...)
{
  const ej_plugin_info *p[] = {ej_plugin_sph_info(), ej_plugin_ideal_gas_info(), ej_plugin_continuum_info()};
  va_list ap;
  va_start(ap, text_fmt);
  ej_err rc = vscene_open(c, "cont", p, 3, text_fmt, ap);
  va_end(ap);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  vrun_run(&c->r);
}

static void crun_free(crun *c) { vscene_free(c); }

/* Two ideal gases (gamma 1.4) at p = 1, densities 1 and rho_r, in contact at x = 0, in two
 * coupled sets ("two") or one set with a region-wise initial density ("one"). */
static const char scene_two[] =
    "ejecta: 1\ndimension: 1\ntime: {end: %g, cfl: 0.3%s}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "  l: {rho0: %g, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  heavy: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0]}}, spacing: 0.005, p: 1}\n"
    "  light: {method: sph, material: l, shape: {box: {min: [0], max: [0.5]}}, spacing: 0.005, p: 1}\n"
    "interactions:\n  - {model: continuum, sets: [heavy, light]}\n"
    "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n";
static const char scene_one[] =
    "ejecta: 1\ndimension: 1\ntime: {end: %g, cfl: 0.3}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  tube: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0.5]}}, spacing: 0.005, p: 1,\n"
    "         initial: [{region: {box: {min: [0], max: [0.5]}}, rho: %g, p: 1}]}\n"
    "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n";

static double crun_vmax(const crun *c)
{
  double vmax = 0;
  for (int s = 0; s < c->r.sim->n_sets; ++s) {
    ej_set *set = c->r.sim->sets[s];
    const ej_real *v = ej_set_field(set, "v");
    for (ej_idx i = 0; i < set->n; ++i) vmax = fmax(vmax, fabs(v[3 * i]));
  }
  return vmax;
}

START_TEST(test_uniform_split_at_rest)
{
  /* one uniform gas cut into two coupled sets: the interface must be invisible. 1000 steps. */
  crun c;
  crun_go(&c, scene_two, 100.0, ", max_steps: 1000", "/tmp/ej_cont_uniform.h5", 1.0);
  ck_assert_int_eq(c.r.sim->step, 1000);
  const double vmax = crun_vmax(&c), cs = sqrt(1.4);
  fprintf(stderr, "uniform split: max |v| / c = %.3e after 1000 steps\n", vmax / cs);
  ck_assert_double_lt(vmax / cs, 1e-8);
  crun_free(&c);
  unlink("/tmp/ej_cont_uniform.h5");
}
END_TEST

START_TEST(test_contact_no_worse_than_one_set)
{
  /* a density jump of 8 at equal pressure: standard SPH's contact wiggle. The two-set
   * coupling must not be worse than the same contact inside one SPH set. */
  crun two, one;
  crun_go(&two, scene_two, 0.05, "", "/tmp/ej_cont_two.h5", 0.125);
  const double v2 = crun_vmax(&two);
  crun_free(&two);
  crun_go(&one, scene_one, 0.05, "/tmp/ej_cont_one.h5", 0.125);
  const double v1 = crun_vmax(&one);
  crun_free(&one);
  unlink("/tmp/ej_cont_two.h5");
  unlink("/tmp/ej_cont_one.h5");
  fprintf(stderr, "contact: max |v| two sets %.3e, one set %.3e\n", v2, v1);
  ck_assert_double_le(v2, v1);
}
END_TEST

START_TEST(test_density_ratio_1334)
{
  /* explosive products next to air: equal pressure 1e5 Pa, densities 1601 and 1.2 (the hard
   * case of the explosives issue). The standard form blows up here (pair force ~ ratio); the
   * volume form must stay finite and nearly at rest. */
  crun c;
  crun_go(&c,
          "ejecta: 1\ndimension: 1\ntime: {end: 2e-3, cfl: 0.3}\noutput: {file: %s}\n"
          "materials:\n  g: {rho0: 1601, eos: {model: ideal_gas, gamma: 1.4}}\n"
          "  l: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
          "sets:\n"
          "  heavy: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0]}}, spacing: 0.005, p: 1e5}\n"
          "  light: {method: sph, material: l, shape: {box: {min: [0], max: [0.5]}}, spacing: 0.005, p: 1e5}\n"
          "interactions:\n  - {model: continuum, sets: [heavy, light]}\n"
          "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n",
          "/tmp/ej_cont_ratio.h5");
  const double vmax = crun_vmax(&c), c_air = sqrt(1.4 * 1e5 / 1.2);
  fprintf(stderr, "density ratio 1334: max |v| = %.3e (air sound speed %.0f m/s), steps %lld\n", vmax, c_air,
          (long long)c.r.sim->step);
  ck_assert(isfinite(vmax));
  ck_assert_double_lt(vmax, 0.05 * c_air);
  crun_free(&c);
  unlink("/tmp/ej_cont_ratio.h5");
}
END_TEST

START_TEST(test_momentum_conserved)
{
  crun c;
  /* the heavy gas pushed into the light one: the pair forces are antisymmetric */
  static const char scene[] =
      "ejecta: 1\ndimension: 1\ntime: {end: 0.05, cfl: 0.3}\noutput: {file: %s}\n"
      "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
      "  l: {rho0: 0.125, eos: {model: ideal_gas, gamma: 1.4}}\n"
      "sets:\n"
      "  heavy: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0]}}, spacing: 0.01, p: 3, "
      "velocity: [1]}\n"
      "  light: {method: sph, material: l, shape: {box: {min: [0], max: [0.5]}}, spacing: 0.01, p: 1}\n"
      "interactions:\n  - {model: continuum, sets: [heavy, light]}\n";
  crun_go(&c, scene, "/tmp/ej_cont_mom.h5");
  const ej_energy *E = &c.r.sim->energy;
  const double p0 = 1.0 * 0.5 * 1.0; /* heavy mass x 1 m/s */
  fprintf(stderr, "momentum drift %.3e, energy balance %.3e of %.3e\n", E->momentum[0] - p0, E->balance,
          E->total0);
  ck_assert_double_lt(fabs(E->momentum[0] - p0), 1e-12);
  ck_assert_double_lt(fabs(E->balance), 1e-3 * E->total0);
  crun_free(&c);
}
END_TEST

static double split_sod_l1(const char *continuity)
{
  /* Sod with the left and right states in two coupled sets vs the exact solution at t = 0.2 */
  const double dx = 0.0025;
  crun c;
  crun_go(&c,
          "ejecta: 1\ndimension: 1\ntime: {end: 0.2, cfl: 0.3}\noutput: {file: %s}\n"
          "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
          "  l: {rho0: 0.125, eos: {model: ideal_gas, gamma: 1.4}}\n"
          "sets:\n"
          "  left: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0]}}, spacing: %g, p: 1}\n"
          "  right: {method: sph, material: l, shape: {box: {min: [0], max: [0.5]}}, spacing: %g, p: 0.1}\n"
          "interactions:\n  - {model: continuum, sets: [left, right], continuity: %s}\n"
          "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n",
          "/tmp/ej_cont_sod.h5", dx, dx, continuity);
  const sod_state L = {1, 0, 1}, R = {0.125, 0, 0.1};
  double ps, us;
  toro_star(&L, &R, 1.4, &ps, &us);
  double l1 = 0, len = 0;
  for (int s = 0; s < 2; ++s) {
    ej_set *set = c.r.sim->sets[s];
    const ej_real *x = ej_set_field(set, "x"), *rho = ej_set_field(set, "rho"), *vol = ej_set_field(set, "vol0");
    for (ej_idx i = 0; i < set->n; ++i) {
      if (fabs(x[3 * i]) > 0.4) continue;
      const double ex = toro_rho(&L, &R, 1.4, ps, us, x[3 * i], 0.2);
      /* weight by the particle's current length m / rho */
      const double w = vol[i] * (s == 0 ? 1.0 : 0.125) / rho[i];
      l1 += fabs(rho[i] - ex) * w;
      len += w;
    }
  }
  l1 /= len;
  /* the single-set SPH Sod at the same spacing has L1 = 0.0053 with a smoothed jump
   * (validation/sod); with the sharp two-set interface the target is within 2x of that */
  fprintf(stderr, "split Sod (continuity %s) L1(rho) = %.4f at dx = %g\n", continuity, l1, dx);
  crun_free(&c);
  return l1;
}

START_TEST(test_split_sod) { ck_assert_double_lt(split_sod_l1("volume"), 0.0106); }
END_TEST

/* 001 Eq 4 continuity blend on the interface pairs (continuity: blend): a uniform gas cut in two
 * sets (k = 1: psi infinite, the mass form) stays at rest; a contact of density ratio 8 at equal
 * pressure (psi = 0.48) stays at rest. (At ratio 1334, products next to air, the blend's weight
 * on the air side is 164 times the volume form's and the run blows up: README.) */
START_TEST(test_continuity_blend)
{
  static const char scene[] =
      "ejecta: 1\ndimension: 1\ntime: {end: %g, cfl: 0.3, max_steps: 1000}\noutput: {file: %s}\n"
      "materials:\n  g: {rho0: %g, eos: {model: ideal_gas, gamma: 1.4}}\n"
      "  l: {rho0: %g, eos: {model: ideal_gas, gamma: 1.4}}\n"
      "sets:\n"
      "  heavy: {method: sph, material: g, shape: {box: {min: [-0.5], max: [0]}}, spacing: 0.005, p: %g}\n"
      "  light: {method: sph, material: l, shape: {box: {min: [0], max: [0.5]}}, spacing: 0.005, p: %g}\n"
      "interactions:\n  - {model: continuum, sets: [heavy, light], continuity: blend}\n"
      "boundaries:\n  - symmetry: {point: [-0.5], normal: [1]}\n  - symmetry: {point: [0.5], normal: [-1]}\n";
  crun c;
  crun_go(&c, scene, 100.0, "/tmp/ej_cont_blend1.h5", 1.0, 1.0, 1.0, 1.0);
  const double v1 = crun_vmax(&c) / sqrt(1.4);
  fprintf(stderr, "blend, uniform split: max |v| / c = %.3e after %lld steps\n", v1, (long long)c.r.sim->step);
  ck_assert_double_lt(v1, 1e-8);
  crun_free(&c);
  unlink("/tmp/ej_cont_blend1.h5");
  crun_go(&c, scene, 100.0, "/tmp/ej_cont_blend2.h5", 1.0, 0.125, 1.0, 1.0);
  const double v2 = crun_vmax(&c) / sqrt(1.4 / 0.125);
  fprintf(stderr, "blend, density ratio 8: max |v| / c_light = %.3e after %lld steps\n", v2, (long long)c.r.sim->step);
  ck_assert_double_lt(v2, 1e-8);
  crun_free(&c);
  unlink("/tmp/ej_cont_blend2.h5");
  /* Sod split at the contact (ratio 8 across the interface once the waves have passed) */
  ck_assert_double_lt(split_sod_l1("blend"), 0.0106);
}
END_TEST

/* Shape tensor across the interface (README "Shape tensor across an interface"): a 2D Sod-like
 * gas (1 | 0.125 in density, 1 | 0.1 in pressure, jump at x = 0, free edges all round) with
 * `gradient: shape_tensor`, run as one set with a region-wise initial state and as two sets cut at
 * the jump and coupled by continuum, 60 fixed steps. With continuum's default gradient (auto: the
 * other set's neighbours in M_i, sph's G_ij on the interface pairs) the two runs are the same
 * particle by particle to round-off; with `gradient: kernel` (the coupling before 2026-11-30) the
 * interface is counted twice and they differ at O(1). */
static const char scene_shape_one[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1, dt: 1e-3, max_steps: 60}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  tube: {method: sph, material: g, gradient: shape_tensor, spacing: 0.01, p: 1,\n"
    "         shape: {box: {min: [-0.2, 0], max: [0.2, 0.1]}},\n"
    "         initial: [{region: {box: {min: [0, -1], max: [1, 1]}}, rho: 0.125, p: 0.1}]}\n";
static const char scene_shape_two[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 1, dt: 1e-3, max_steps: 60}\noutput: {file: %s}\n"
    "materials:\n  g: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "  l: {rho0: 0.125, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  left: {method: sph, material: g, gradient: shape_tensor, spacing: 0.01, p: 1,\n"
    "         shape: {box: {min: [-0.2, 0], max: [0, 0.1]}}}\n"
    "  right: {method: sph, material: l, gradient: shape_tensor, spacing: 0.01, p: 0.1,\n"
    "          shape: {box: {min: [0, 0], max: [0.2, 0.1]}}}\n"
    "interactions:\n  - {model: continuum, sets: [left, right]%s}\n";

/* max over the particles of the two-set run of |rho/rho_one - 1| and |v - v_one| / max|v_one|, each
 * particle matched to the nearest one-set particle; *dx the largest distance of a match (0 to
 * round-off when the runs agree: the same lattice, the same motion) */
static void shape_split_diff(const crun *one, const crun *two, double *drho, double *dv, double *dx)
{
  ej_set *o = one->r.sim->sets[0];
  const ej_real *xo = ej_set_field(o, "x"), *ro = ej_set_field(o, "rho"), *vo = ej_set_field(o, "v");
  double vmax = 0;
  for (ej_idx i = 0; i < o->n; ++i) vmax = fmax(vmax, hypot(vo[3 * i], vo[3 * i + 1]));
  *drho = *dv = *dx = 0;
  int matched = 0;
  for (int s = 0; s < 2; ++s) {
    ej_set *t = two->r.sim->sets[s];
    const ej_real *xt = ej_set_field(t, "x"), *rt = ej_set_field(t, "rho"), *vt = ej_set_field(t, "v");
    for (ej_idx i = 0; i < t->n; ++i) {
      ej_idx best = -1;
      double d2 = INFINITY;
      for (ej_idx k = 0; k < o->n; ++k) {
        const double dx = xt[3 * i] - xo[3 * k], dy = xt[3 * i + 1] - xo[3 * k + 1];
        if (dx * dx + dy * dy < d2) d2 = dx * dx + dy * dy, best = k;
      }
      ck_assert(best >= 0);
      *dx = fmax(*dx, sqrt(d2));
      ++matched;
      *drho = fmax(*drho, fabs(rt[i] / ro[best] - 1));
      *dv = fmax(*dv, hypot(vt[3 * i] - vo[3 * best], vt[3 * i + 1] - vo[3 * best + 1]) / vmax);
    }
  }
  ck_assert_int_eq(matched, o->n);
}

START_TEST(test_split_shape_tensor)
{
  crun one, two, twok;
  crun_go(&one, scene_shape_one, "/tmp/ej_cont_shape1.h5");
  crun_go(&two, scene_shape_two, "/tmp/ej_cont_shape2.h5", "");
  crun_go(&twok, scene_shape_two, "/tmp/ej_cont_shape3.h5", ", gradient: kernel");
  ck_assert_int_eq(two.r.sim->step, 60);
  double dr, dv, dx, drk, dvk, dxk;
  shape_split_diff(&one, &two, &dr, &dv, &dx);
  shape_split_diff(&one, &twok, &drk, &dvk, &dxk);
  fprintf(stderr,
          "shape tensor split in two sets (2D, 60 steps): max |rho/rho_one - 1| %.3e, max |dv|/|v|max %.3e, "
          "positions %.3e m; with continuum gradient: kernel %.3e, %.3e, %.3e m\n",
          dr, dv, dx, drk, dvk, dxk);
  ck_assert_double_lt(dx, 1e-12);
  ck_assert_double_lt(dr, 1e-10);
  ck_assert_double_lt(dv, 1e-10);
  ck_assert_double_gt(drk, 1e-2);
  const ej_energy *E = &two.r.sim->energy;
  ck_assert_double_lt(fabs(E->momentum[0]) + fabs(E->momentum[1]), 1e-12);
  crun_free(&one), crun_free(&two), crun_free(&twok);
}
END_TEST

static Suite *continuum_suite(void)
{
  Suite *s = suite_create("continuum");
  TCase *tc = tcase_create("coupling");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_uniform_split_at_rest);
  tcase_add_test(tc, test_contact_no_worse_than_one_set);
  tcase_add_test(tc, test_density_ratio_1334);
  tcase_add_test(tc, test_momentum_conserved);
  tcase_add_test(tc, test_split_sod);
  tcase_add_test(tc, test_continuity_blend);
  tcase_add_test(tc, test_split_shape_tensor);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(continuum_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
