/* Unit test of my_von_mises in plain C with assert: it includes the plugin's source, so it can
 * call the ops table the .so exports through EJ_PLUGIN_DEFINE, and checks the parameter table,
 * the elastic predictor and the radial return against closed forms. Run by `ctest`. */
#undef NDEBUG
#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "my_von_mises.c"

static int close_to(double a, double b, double rel) { return fabs(a - b) <= rel * fmax(fabs(a), fabs(b)) + 1e-300; }

/* Defaults from the table, then E (required). */
static void *make_state(double E, double nu, double sy, double H)
{
  mvm_config cfg = {.E = E, .nu = nu, .yield_stress = sy, .hardening = H};
  void *state = NULL;
  assert(mvm_ops.create(&cfg, &state) == EJ_OK && state);
  return state;
}

static void test_table(void)
{
  const ej_plugin_info *info = ej_plugin_my_von_mises_info();
  assert(info->abi_major == EJ_ABI_MAJOR && !strcmp(info->name, "my_von_mises"));
  assert(!strcmp(info->build_signature, EJ_BUILD_SIGNATURE));
  int n = 0;
  for (const ej_param *p = mvm_ops.params; p->name; ++p, ++n) {
    assert(p->unit && p->doc && strlen(p->doc) > 10); /* every row documented, with a unit */
    assert((p->flags & EJ_PF_REQUIRED) || p->type != EJ_PT_REAL || p->def >= p->min);
  }
  assert(n == 4);
  assert(mvm_ops.n_hist == 1 && !strcmp(mvm_ops.hist_names[0], "eps_p") && mvm_ops.moduli);
  /* Out-of-range parameters are refused by create as well. */
  mvm_config bad = {.E = 200e9, .nu = 0.5, .yield_stress = 1e8};
  void *state = NULL;
  assert(mvm_ops.create(&bad, &state) == EJ_ERR_ARG && !state);
}

static void test_moduli_and_elastic(void)
{
  const double E = 200e9, nu = 0.3;
  void *st = make_state(E, nu, 250e6, 1e9);
  double K, G;
  assert(mvm_ops.moduli(st, &K, &G) == EJ_OK);
  assert(close_to(K, E / (3 * (1 - 2 * nu)), 1e-15) && close_to(G, E / (2 * (1 + nu)), 1e-15));
  /* One small step of general d stays elastic: sigma = K dt tr(d) I + 2 G dt dev(d). */
  double d[6] = {1e-3, -2e-3, 0.5e-3, 0.7e-3, -0.2e-3, 0.1e-3}, stress[6] = {0}, eps_p = 0, c, w;
  double rho = 7800, e = 0;
  ej_real *hist[1] = {&eps_p};
  ej_mat_batch b = {.n = 1, .dt = 1e-3, .rho = &rho, .e = &e, .d = d, .stress = stress, .hist = hist, .c = &c,
                    .w_plastic = &w};
  assert(mvm_ops.update(st, &b) == EJ_OK);
  const double tr = d[0] + d[1] + d[2];
  for (int k = 0; k < 3; ++k) assert(close_to(stress[k], 1e-3 * (K * tr + 2 * G * (d[k] - tr / 3)), 1e-12));
  for (int k = 3; k < 6; ++k) assert(close_to(stress[k], 1e-3 * 2 * G * d[k], 1e-12));
  assert(eps_p == 0 && w == 0 && close_to(c, sqrt((K + 4 * G / 3) / rho), 1e-15));
  mvm_ops.destroy(st);
}

/* Monotonic pure shear d_xy = r: the deviator keeps its direction, so the radial return with
 * linear hardening is exact. With strain norm E_t = sqrt(2) r t, consistency
 * 2G (E_t - gamma) = sqrt(2/3) (sigma_y + H sqrt(2/3) gamma) gives the plastic multiplier gamma. */
static void test_shear_return(double H)
{
  const double sy = 250e6, r = 10.0, dt = 1e-6;
  void *st = make_state(200e9, 0.3, sy, H);
  double K, G;
  mvm_ops.moduli(st, &K, &G);
  double d[6] = {0, 0, 0, r, 0, 0}, stress[6] = {0}, eps_p = 0, c, w, wsum = 0, rho = 7800, e = 0;
  ej_real *hist[1] = {&eps_p};
  ej_mat_batch b = {.n = 1, .dt = dt, .rho = &rho, .e = &e, .d = d, .stress = stress, .hist = hist, .c = &c,
                    .w_plastic = &w};
  const int steps = 400;
  for (int k = 0; k < steps; ++k) {
    assert(mvm_ops.update(st, &b) == EJ_OK);
    assert(w >= 0);
    wsum += w;
  }
  const double Et = sqrt(2.0) * r * dt * steps;
  const double gamma = (2 * G * Et - sqrt(2.0 / 3.0) * sy) / (2 * G + 2 * H / 3);
  assert(gamma > 0); /* the loading does yield */
  assert(close_to(eps_p, sqrt(2.0 / 3.0) * gamma, 1e-9));
  const double norm = sqrt(2.0) * fabs(stress[3]);
  assert(close_to(norm, sqrt(2.0 / 3.0) * (sy + H * eps_p), 1e-12)); /* on the yield surface */
  assert(stress[0] == 0 && stress[1] == 0 && stress[2] == 0 && stress[4] == 0 && stress[5] == 0);
  /* Plastic work per mass: integral of |s| dgamma; with H = 0, |s| is constant once yielded. */
  if (H == 0) assert(close_to(wsum, norm * gamma / rho, 1e-6));
  mvm_ops.destroy(st);
  printf("  shear H = %g Pa: eps_p = %.6e (closed form %.6e)\n", H, eps_p, sqrt(2.0 / 3.0) * gamma);
}

int main(void)
{
  test_table();
  test_moduli_and_elastic();
  test_shear_return(0);
  test_shear_return(2e9);
  printf("test_my_von_mises: all passed\n");
  return 0;
}
