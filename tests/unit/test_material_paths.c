/* The shipped parameter sets examples/materials/{sand_000,sand_001,armco_iron,al6061_t6,copper,granite_002}.yaml
 * load through the scene parser with the material and EOS plugins of this family (units,
 * bounds, check_config; jh2 receives the material's rho0), and every strength model then survives a common strain path
 * (compression, shear, release) with finite stress and a non-negative plastic work. */
#include <stdio.h>
#include <unistd.h>

#include "material_point_driver.h"

const ej_plugin_info *ej_plugin_drucker_prager_info(void);
const ej_plugin_info *ej_plugin_dp_cap_info(void);
const ej_plugin_info *ej_plugin_von_mises_info(void);
const ej_plugin_info *ej_plugin_johnson_cook_info(void);
const ej_plugin_info *ej_plugin_soil_evp_info(void);
const ej_plugin_info *ej_plugin_mie_gruneisen_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);
const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_jh2_info(void);

static const char *const files[] = {"sand_000", "sand_001", "armco_iron", "al6061_t6", "copper", "granite_002"};
static const char *const first[] = {"sand_dp", "sand_dp", "armco_iron", "al6061_t6", "copper", "granite"};

START_TEST(test_shipped_sets)
{
  for (int f = 0; f < 6; ++f) {
    char src[1024], tmp[] = "/tmp/ej_matset_XXXXXX";
    snprintf(src, sizeof src, "%s/examples/materials/%s.yaml", EJ_TEST_SOURCE_DIR, files[f]);
    FILE *in = fopen(src, "r");
    ck_assert_ptr_nonnull(in);
    const int fd = mkstemp(tmp);
    ck_assert_int_ge(fd, 0);
    FILE *out = fdopen(fd, "w");
    fprintf(out, "ejecta: 1\ntime: {end: 1e-3}\nsets:\n  s: {method: sph, material: %s, shape: {box: {min: [0, 0, 0], "
                 "max: [1, 1, 1]}}, spacing: 0.5}\n",
            first[f]);
    char line[1024];
    while (fgets(line, sizeof line, in)) fputs(line, out);
    fclose(in);
    fclose(out);
    ej_registry *reg;
    ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
    const ej_plugin_info *infos[] = {ej_plugin_drucker_prager_info(), ej_plugin_dp_cap_info(),
                                     ej_plugin_von_mises_info(),      ej_plugin_johnson_cook_info(),
                                     ej_plugin_soil_evp_info(),       ej_plugin_mie_gruneisen_info(),
                                     ej_plugin_polynomial_info(),    ej_plugin_sph_info(),
                                     ej_plugin_jh2_info()};
    for (int k = 0; k < 9; ++k) ck_assert_int_eq(ej_registry_add_static(reg, infos[k]), EJ_OK);
    ej_scene *sc = NULL;
    ej_err rc = ej_scene_load(tmp, reg, &sc);
    if (rc != EJ_OK) ej_error_report(files[f]);
    ck_assert_msg(rc == EJ_OK, "%s does not load", files[f]);
    ck_assert_int_ge(sc->n_materials, 1);
    for (int i = 0; i < sc->n_materials; ++i) {
      const ej_scene_material *m = &sc->materials[i];
      ck_assert_ptr_nonnull(m->mat_ops);
      void *st = NULL;
      ck_assert_int_eq(m->mat_ops->create(m->mat_config, &st), EJ_OK);
      ej_real hb[MPD_MAX_HIST] = {0}, *h[MPD_MAX_HIST];
      for (int k = 0; k < MPD_MAX_HIST; ++k) h[k] = &hb[k];
      if (m->mat_ops->init_hist) ck_assert_int_eq(m->mat_ops->init_hist(st, 1, h), EJ_OK);
      ej_real K, G;
      ck_assert_int_eq(m->mat_ops->moduli(st, &K, &G), EJ_OK);
      ck_assert(K > 0 && G > 0);
      void *eos = NULL;
      if (m->eos_ops) ck_assert_int_eq(m->eos_ops->create(m->eos_config, &eos), EJ_OK);
      ej_real sig[6] = {0}, rho = m->rho0, e = 0, c = 0, wp = 0, p = 0;
      int32_t failed = 0;
      const ej_real legs[3][6] = {{-1, -0.2, -0.2, 0, 0, 0}, {0, 0, 0, 2, 0, 1}, {0.8, 0.3, 0.3, 0, 0, 0}};
      double wsum = 0;
      int failed_at = -1;
      for (int n = 0; n < 300; ++n) {
        const ej_real *d = legs[n / 100];
        const double dt = 1e-4;
        rho *= exp(-(d[0] + d[1] + d[2]) * dt);
        if (eos) ck_assert_int_eq(m->eos_ops->evaluate(eos, 1, &rho, &e, &p, NULL), EJ_OK);
        ej_mat_batch b = {.n = 1, .dt = dt, .rho = &rho, .e = &e, .d = d, .p = eos ? &p : NULL, .stress = sig,
                          .hist = h, .c = &c, .w_plastic = &wp, .failed = &failed};
        ck_assert_int_eq(m->mat_ops->update(st, &b), EJ_OK);
        for (int k = 0; k < 6; ++k) ck_assert(isfinite(sig[k]));
        ck_assert(wp >= -1e-12 * (1 + fabs(wsum)));
        wsum += wp;
        e += wp; /* crude: heat the EOS with the plastic work */
        if (failed && failed_at < 0) failed_at = n;
      }
      if (f == 5) {
        /* granite_002: 002's polynomial EOS softens (dp/dmu < 0 for 0.004184 < mu < 0.005817)
         * while the deviator of this compression leg keeps growing, so the lateral principal
         * stress turns tensile and 002's tension model fails the point, elastically, near mu =
         * 0.0043 (step 30), before the intact strength is reached */
        ck_assert_msg(failed_at > 20 && failed_at < 40, "granite failed at step %d", failed_at);
      } else {
        ck_assert_msg(wsum > 0, "%s/%s: the path should be plastic", files[f], m->name);
        ck_assert_int_eq(failed_at, -1);
      }
      ck_assert(c > 0);
      if (eos) m->eos_ops->destroy(eos);
      m->mat_ops->destroy(st);
    }
    ej_scene_free(sc);
    ej_registry_destroy(reg);
    unlink(tmp);
  }
}
END_TEST

int main(void)
{
  Suite *s = suite_create("material_paths");
  TCase *tc = tcase_create("sets");
  tcase_add_test(tc, test_shipped_sets);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
