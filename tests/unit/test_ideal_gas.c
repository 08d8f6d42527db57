/* ideal_gas EOS: closed-form p and c, no NaN for e < 0, and thermodynamic consistency
 * c^2 = dp/drho at constant entropy, by finite differences along an isentrope integrated
 * from de = p / rho^2 drho (first law with ds = 0). */
#include <check.h>
#include <math.h>
#include <stdlib.h>

#include "core_impl.h"

const ej_plugin_info *ej_plugin_ideal_gas_info(void);

typedef struct eos_fix {
  ej_registry *reg;
  const ej_eos_ops *ops;
  void *config;
  void *state;
} eos_fix;

static void eos_fix_open(eos_fix *f, double gamma)
{
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_ideal_gas_info()), EJ_OK);
  const void *ops = NULL;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_EOS, "ideal_gas", NULL, &ops), EJ_OK);
  f->ops = ops;
  f->config = ej_calloc(1, f->ops->config_size);
  ck_assert_ptr_nonnull(f->config);
  ck_assert_int_eq(ej_params_defaults(f->ops->params, f->config), EJ_OK);
  if (gamma > 0) *(ej_real *)((char *)f->config + f->ops->params[0].offset) = gamma;
  ck_assert_int_eq(f->ops->create(f->config, &f->state), EJ_OK);
}

static void eos_fix_close(eos_fix *f)
{
  f->ops->destroy(f->state);
  ej_free(f->config);
  ej_registry_destroy(f->reg);
}

START_TEST(test_params)
{
  eos_fix f;
  eos_fix_open(&f, 0);
  const ej_param *g = &f.ops->params[0];
  ck_assert_str_eq(g->name, "gamma");
  ck_assert_str_eq(g->unit, "1");
  ck_assert(g->def == 1.4);
  ck_assert(g->min == 1.0 && (g->flags & EJ_PF_HAS_MIN) && (g->flags & EJ_PF_MIN_OPEN));
  ck_assert(*(ej_real *)((char *)f.config + g->offset) == 1.4);
  ck_assert_ptr_null(f.ops->params[1].name);
  eos_fix_close(&f);
}
END_TEST

START_TEST(test_values)
{
  eos_fix f;
  eos_fix_open(&f, 0);
  const ej_real rho[] = {1.0, 1.225, 2.5, 1e-6, 1000.0};
  const ej_real e[] = {2.5e5, 2.0e5, 1.0e6, 3.0e4, 0.0};
  enum { N = 5 };
  ej_real p[N], c[N];
  ck_assert_int_eq(f.ops->evaluate(f.state, N, rho, e, p, c), EJ_OK);
  for (int i = 0; i < N; ++i) {
    const double pe = 0.4 * rho[i] * e[i];
    const double ce = sqrt(1.4 * pe / rho[i]);
    ck_assert_double_eq_tol(p[i], pe, 1e-14 * fabs(pe) + 1e-300);
    ck_assert_double_eq_tol(c[i], ce, 1e-14 * ce + 1e-300);
  }
  /* air at 1.225 kg/m^3, 101325 Pa: c = 340.3 m/s */
  const ej_real rho_air = 1.225, e_air = 101325.0 / (0.4 * 1.225);
  ej_real p_air, c_air;
  ck_assert_int_eq(f.ops->evaluate(f.state, 1, &rho_air, &e_air, &p_air, &c_air), EJ_OK);
  ck_assert_double_eq_tol(p_air, 101325.0, 1e-9);
  ck_assert_double_eq_tol(c_air, 340.2940, 1e-3);
  /* c may be NULL */
  ej_real p2[N];
  ck_assert_int_eq(f.ops->evaluate(f.state, N, rho, e, p2, NULL), EJ_OK);
  for (int i = 0; i < N; ++i) ck_assert(p2[i] == p[i]);
  eos_fix_close(&f);
}
END_TEST

START_TEST(test_negative_energy)
{
  eos_fix f;
  eos_fix_open(&f, 5.0 / 3.0);
  const ej_real rho[] = {1.0, 0.0}, e[] = {-1.0e3, 5.0};
  ej_real p[2], c[2];
  ck_assert_int_eq(f.ops->evaluate(f.state, 2, rho, e, p, c), EJ_OK);
  ck_assert(p[0] < 0.0);
  ck_assert(c[0] == 0.0); /* sound speed from max(e, 0): never NaN */
  ck_assert(p[1] == 0.0);
  ck_assert(isfinite(c[1]) && c[1] > 0.0); /* rho = 0 cannot divide by zero */
  eos_fix_close(&f);
}
END_TEST

/* e along the isentrope through (rho0, e0) at rho1: RK4 on de/drho = p(rho, e) / rho^2. */
static ej_real isentrope(const eos_fix *f, ej_real rho0, ej_real e0, ej_real rho1)
{
  const int n = 64;
  const ej_real d = (rho1 - rho0) / n;
  ej_real r = rho0, e = e0;
  for (int k = 0; k < n; ++k) {
    ej_real rr[4] = {r, r + d / 2, r + d / 2, r + d}, ee[4], p[4], kk[4];
    ee[0] = e;
    for (int s = 0; s < 4; ++s) {
      if (s) ee[s] = e + (s == 3 ? d : d / 2) * kk[s - 1];
      ck_assert_int_eq(f->ops->evaluate(f->state, 1, &rr[s], &ee[s], &p[s], NULL), EJ_OK);
      kk[s] = p[s] / (rr[s] * rr[s]);
    }
    e += d / 6 * (kk[0] + 2 * kk[1] + 2 * kk[2] + kk[3]);
    r += d;
  }
  return e;
}

START_TEST(test_isentropic_sound_speed)
{
  const double gammas[] = {1.4, 5.0 / 3.0, 1.1, 3.0};
  const double states[][2] = {{1.0, 2.5e5}, {1.225, 2.07e5}, {1630.0, 4.0e6}, {0.01, 1.0e3}};
  for (int g = 0; g < 4; ++g) {
    eos_fix f;
    eos_fix_open(&f, gammas[g]);
    for (int s = 0; s < 4; ++s) {
      const ej_real rho = states[s][0], e = states[s][1], drho = 1e-4 * rho;
      const ej_real rp = rho + drho, rm = rho - drho;
      const ej_real ep = isentrope(&f, rho, e, rp), em = isentrope(&f, rho, e, rm);
      ej_real pp, pm, p0, c0;
      ck_assert_int_eq(f.ops->evaluate(f.state, 1, &rp, &ep, &pp, NULL), EJ_OK);
      ck_assert_int_eq(f.ops->evaluate(f.state, 1, &rm, &em, &pm, NULL), EJ_OK);
      ck_assert_int_eq(f.ops->evaluate(f.state, 1, &rho, &e, &p0, &c0), EJ_OK);
      const double dpdrho = (pp - pm) / (2 * drho);
      ck_assert_msg(fabs(dpdrho - c0 * c0) <= 1e-6 * c0 * c0, "gamma %g state %d: dp/drho|s = %.12g, c^2 = %.12g",
                    gammas[g], s, dpdrho, c0 * c0);
    }
    eos_fix_close(&f);
  }
}
END_TEST

START_TEST(test_bad_gamma)
{
  eos_fix f;
  eos_fix_open(&f, 0);
  *(ej_real *)((char *)f.config + f.ops->params[0].offset) = 1.0;
  void *st = NULL;
  ck_assert_int_eq(f.ops->create(f.config, &st), EJ_ERR_ARG);
  ck_assert_ptr_null(st);
  ej_error_clear();
  eos_fix_close(&f);
}
END_TEST

START_TEST(test_descriptor)
{
  const ej_plugin_info *info = ej_plugin_ideal_gas_info();
  ck_assert_str_eq(info->name, "ideal_gas");
  ck_assert_uint_eq(info->abi_major, EJ_ABI_MAJOR);
  ck_assert_str_eq(info->build_signature, EJ_BUILD_SIGNATURE);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("ideal_gas");
  TCase *tc = tcase_create("eos");
  tcase_add_test(tc, test_params);
  tcase_add_test(tc, test_values);
  tcase_add_test(tc, test_negative_energy);
  tcase_add_test(tc, test_isentropic_sound_speed);
  tcase_add_test(tc, test_bad_gamma);
  tcase_add_test(tc, test_descriptor);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
