/* rigid_indenter interaction: LAMMPS fix indent force law (sphere and plane, plain and per-volume),
 * the moving centre, the reaction force, and the work series balancing the kinetic energy of a
 * particle that bounces off a fixed sphere. */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

const ej_plugin_info *ej_plugin_rigid_indenter_info(void);

typedef struct ri_fix {
  ej_registry *reg;
  const ej_interaction_ops *ops;
  void *cfg, *state;
  ej_set *set;
  ej_real t, dt;
} ri_fix;

static const ej_param *find_param(const ej_param *t, const char *name)
{
  for (; t && t->name; ++t)
    if (!strcmp(t->name, name)) return t;
  ck_abort_msg("no parameter '%s'", name);
  return NULL;
}
static void *field(ri_fix *f, const char *name) { return (char *)f->cfg + find_param(f->ops->params, name)->offset; }

static void fix_open(ri_fix *f, ej_idx n)
{
  memset(f, 0, sizeof *f);
  ck_assert_int_eq(ej_registry_create(&f->reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(f->reg, ej_plugin_rigid_indenter_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(f->reg, EJ_KIND_INTERACTION, "rigid_indenter", NULL, &ops), EJ_OK);
  f->ops = ops;
  f->cfg = ej_calloc(1, f->ops->config_size);
  ck_assert_int_eq(ej_params_defaults(f->ops->params, f->cfg), EJ_OK);
  ck_assert_int_eq(ej_set_create("target", 0, 3, &f->set), EJ_OK);
  static const ej_field_decl vh = {.name = "v_half", .kind = EJ_VEC3, .unit = "m/s"};
  ck_assert_int_eq(ej_set_add_field(f->set, &vh, NULL), EJ_OK);
  ck_assert_int_eq(ej_set_reserve(f->set, n), EJ_OK);
  f->set->n = n;
  f->set->t = &f->t;
  f->set->dt = &f->dt;
  ej_real *m = ej_set_field(f->set, "m"), *v0 = ej_set_field(f->set, "vol0");
  for (ej_idx i = 0; i < n; ++i) m[i] = 2.0, v0[i] = 1e-3;
}

static void fix_close(ri_fix *f)
{
  if (f->state) f->ops->destroy(f->state);
  ej_set_destroy(f->set);
  ej_free(f->cfg);
  ej_registry_destroy(f->reg);
}

static void accel(ri_fix *f)
{
  memset(ej_set_field(f->set, "a"), 0, (size_t)f->set->n * 3 * sizeof(ej_real));
  ck_assert_int_eq(f->ops->compute(f->state, f->set, NULL, NULL, 0, (ej_range){0, f->set->n}), EJ_OK);
}

START_TEST(test_sphere_law)
{
  for (int pv = 0; pv < 2; ++pv) {
    ri_fix f;
    fix_open(&f, 2);
    ej_real *c = field(&f, "center"), *vel = field(&f, "velocity");
    c[0] = 0, c[1] = 1.0, c[2] = 0;
    vel[1] = -2.0;
    *(ej_real *)field(&f, "radius") = 0.5;
    *(ej_real *)field(&f, "K") = 1e3;
    *(bool *)field(&f, "per_volume") = pv;
    ck_assert_int_eq(f.ops->create(f.cfg, f.set, NULL, &f.state), EJ_OK);
    ej_real *x = ej_set_field(f.set, "x");
    /* at t = 0.1 the centre is at y = 0.8: particle 0 at (0.3, 0.8, 0) is 0.2 inside, particle 1 outside */
    x[0] = 0.3, x[1] = 0.8, x[2] = 0;
    x[3] = 0, x[4] = 0, x[5] = 0;
    f.t = 0.1;
    accel(&f);
    const ej_real *a = ej_set_field(f.set, "a");
    const ej_real F = 1e3 * 0.2 * 0.2 * (pv ? 1e-3 : 1.0);
    ck_assert_msg(fabs(a[0] - F / 2.0) < 1e-12 * F, "a_x %g want %g", a[0], F / 2.0);
    ck_assert(fabs(a[1]) < 1e-15 && a[2] == 0.0);
    ck_assert(a[3] == 0.0 && a[4] == 0.0 && a[5] == 0.0);
    /* reaction on the indenter in the report */
    f.dt = 0.0;
    ck_assert_int_eq(f.ops->post_step(f.state, f.set, NULL), EJ_OK);
    ej_series_value out[EJ_MAX_SERIES];
    int n = 0;
    ck_assert_int_eq(f.ops->report(f.state, out, EJ_MAX_SERIES, &n), EJ_OK);
    ck_assert_int_eq(n, 8);
    ck_assert_str_eq(out[0].name, "force_x");
    ck_assert(fabs(out[0].value + F) < 1e-12 * F);
    ck_assert_int_eq(out[4].role, EJ_SERIES_WORK);
    ck_assert(fabs(out[6].value - 0.8) < 1e-15);
    fix_close(&f);
  }
}
END_TEST

START_TEST(test_plane_law)
{
  ri_fix f;
  fix_open(&f, 1);
  *(int *)field(&f, "shape") = 1;
  ej_real *c = field(&f, "center"), *nn = field(&f, "normal");
  c[2] = 1.0, nn[2] = 2.0; /* normalised by the plugin */
  *(ej_real *)field(&f, "K") = 50.0;
  ck_assert_int_eq(f.ops->create(f.cfg, f.set, NULL, &f.state), EJ_OK);
  ej_real *x = ej_set_field(f.set, "x");
  x[2] = 0.9;
  accel(&f);
  const ej_real *a = ej_set_field(f.set, "a");
  ck_assert(fabs(a[2] - 50.0 * 0.01 / 2.0) < 1e-12);
  x[2] = 1.1;
  accel(&f);
  ck_assert(a[2] == 0.0);
  fix_close(&f);
}
END_TEST

/* A particle thrown at a fixed sphere bounces back; velocity Verlet by hand with the plugin's
 * post_step: the work series equals the kinetic energy change at every step (conservative, so
 * both return near zero after the bounce), to the Verlet error. */
START_TEST(test_work_balance)
{
  ri_fix f;
  fix_open(&f, 1);
  ej_real *c = field(&f, "center");
  c[0] = 1.0;
  *(ej_real *)field(&f, "radius") = 0.5;
  *(ej_real *)field(&f, "K") = 1e4;
  ck_assert_int_eq(f.ops->create(f.cfg, f.set, NULL, &f.state), EJ_OK);
  ej_real *x = ej_set_field(f.set, "x"), *v = ej_set_field(f.set, "v"), *a = ej_set_field(f.set, "a");
  ej_real *vh = ej_set_field(f.set, "v_half");
  v[0] = 1.0;
  const ej_real m = 2.0, KE0 = 0.5 * m;
  f.dt = 1e-4;
  accel(&f);
  ej_series_value out[EJ_MAX_SERIES];
  int n = 0;
  ck_assert_int_eq(f.ops->report(f.state, out, EJ_MAX_SERIES, &n), EJ_OK);
  double worst = 0, wmin = 0;
  for (int step = 0; step < 12000; ++step) {
    for (int k = 0; k < 3; ++k) vh[k] = v[k] + 0.5 * f.dt * a[k], x[k] += f.dt * vh[k];
    f.t += f.dt;
    accel(&f);
    for (int k = 0; k < 3; ++k) v[k] = vh[k] + 0.5 * f.dt * a[k];
    ck_assert_int_eq(f.ops->post_step(f.state, f.set, NULL), EJ_OK);
    ck_assert_int_eq(f.ops->report(f.state, out, EJ_MAX_SERIES, &n), EJ_OK);
    const double KE = 0.5 * m * v[0] * v[0];
    worst = fmax(worst, fabs(KE - KE0 - out[4].value));
    wmin = fmin(wmin, out[4].value);
  }
  ck_assert_msg(v[0] < -0.99, "did not bounce: v = %g", v[0]);
  ck_assert_msg(wmin < -0.9 * KE0, "work never took the kinetic energy: %g", wmin);
  ck_assert_msg(worst < 1e-3 * KE0, "KE - KE0 - W up to %g (KE0 %g)", worst, KE0);
  fix_close(&f);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("rigid_indenter");
  TCase *tc = tcase_create("indenter");
  tcase_add_test(tc, test_sphere_law);
  tcase_add_test(tc, test_plane_law);
  tcase_add_test(tc, test_work_balance);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
