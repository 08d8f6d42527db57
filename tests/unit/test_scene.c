/* Scene loading: a full valid scene parses into the expected values, and each class of bad
 * input gives one precise message at the right line:col. */
#ifndef _DEFAULT_SOURCE
#define _DEFAULT_SOURCE /* mkdtemp */
#endif
#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scene_impl.h"
#include "test_tmpdir.h"

const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_ideal_gas_info(void);

static char tmpdir[256];
static ej_registry *reg;

static void setup(void)
{
  ej_test_tmpdir(tmpdir, sizeof tmpdir, "scene");
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_ideal_gas_info()), EJ_OK);
  ej_error_clear();
}

static void teardown(void)
{
  ej_registry_destroy(reg);
  ej_error_clear();
  static const char *const files[] = {"scene.yaml", "particles.csv"};
  char path[600];
  for (int i = 0; i < 2; ++i) {
    snprintf(path, sizeof path, "%s/%s", tmpdir, files[i]);
    unlink(path);
  }
  rmdir(tmpdir);
}

static const char *write_file(const char *name, const char *text)
{
  static char path[512];
  snprintf(path, sizeof path, "%s/%s", tmpdir, name);
  FILE *fp = fopen(path, "wb");
  ck_assert_ptr_nonnull(fp);
  fputs(text, fp);
  fclose(fp);
  return path;
}

static ej_err load(const char *text, ej_scene **sc)
{
  ej_error_clear();
  *sc = NULL;
  return ej_scene_load(write_file("scene.yaml", text), reg, sc);
}

static ej_scene *load_ok(const char *text)
{
  ej_scene *sc;
  ej_err rc = load(text, &sc);
  if (rc != EJ_OK) ej_error_print(stderr, "test_scene", true);
  ck_assert_int_eq(rc, EJ_OK);
  return sc;
}

/* Loading fails with an input error whose cause contains text at line:col. */
static void load_bad(const char *scene, const char *text, int line, int col)
{
  ej_scene *sc;
  ck_assert_int_eq(load(scene, &sc), EJ_ERR_INPUT);
  ck_assert_ptr_null(sc);
  const ej_error_frame *c = ej_error_cause();
  ck_assert_ptr_nonnull(c);
  if (!strstr(c->msg, text)) ck_abort_msg("message '%s' lacks '%s'", c->msg, text);
  ck_assert_int_eq(c->code, EJ_ERR_INPUT);
  ck_assert_ptr_nonnull(c->where.file);
  ck_assert(strstr(c->where.file, "scene.yaml") != NULL);
  if (c->where.line != line || c->where.col != col)
    ck_abort_msg("'%s' at %d:%d, expected %d:%d", c->msg, c->where.line, c->where.col, line, col);
  ej_error_clear();
}

#define HEAD "ejecta: 1\ntime: {end: 1 ms}\nmaterials:\n  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"

/* ------------------------------------------------------------------ valid scenes */

START_TEST(test_valid_full)
{
  ej_scene *sc = load_ok("ejecta: 1\n"
                         "dimension: 3\n"
                         "time: {end: 0.2 ms, cfl: 0.25, dt_max: 1 us, max_steps: 100}\n"
                         "output: {every: 10 us, fields: [rho, p, v]}\n"
                         "neighbours: {skin: 0.2}\n"
                         "gravity: [0, 0, -9.81]\n"
                         "materials:\n"
                         "  air: {rho0: 1.2 kg/m^3, eos: {model: ideal_gas, gamma: 1.4}}\n"
                         "  hot: {rho0: 1, eos: {model: ideal_gas}}\n"
                         "sets:\n"
                         "  gas:\n"
                         "    method: sph\n"
                         "    material: air\n"
                         "    shape: {box: {min: [0, 0, 0], max: [1, 0.5, 0.5]}, minus: [core]}\n"
                         "    spacing: 50 mm\n"
                         "    lattice: hcp\n"
                         "    jitter: 0.1\n"
                         "    seed: 42\n"
                         "    velocity: [1 m/s, 0, 0]\n"
                         "    p: 1e5\n"
                         "    h_factor: 1.5\n"
                         "    refine: [{region: {sphere: {center: [0.5, 0.25, 0.25], radius: 0.1}}, spacing: 25 mm}]\n"
                         "    initial:\n"
                         "      - {region: {box: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}}, p: 1e6, velocity: [0, 0, 0]}\n"
                         "      - {energy_total: 1 J}\n"
                         "  core:\n"
                         "    method: sph\n"
                         "    material: hot\n"
                         "    shape: {sphere: {center: [2, 0.25, 0.25], radius: 0.1}}\n"
                         "    spacing: 0.02\n"
                         "boundaries:\n"
                         "  - {set: gas, region: {box: {min: [0, 0, 0], max: [0.1, 0.5, 0.5]}}, fix: [x]}\n"
                         "  - {velocity: [0, 0, 1], components: [z]}\n"
                         "  - {symmetry: {point: [0, 0, 0], normal: [0, 2, 0]}}\n"
                         "  - {periodic: {axis: z, min: 0, max: 0.5}}\n"
                         "  - {set: gas, region: {box: {min: [0.9, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [2, 0, "
                         "0]}}\n"
                         "  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {center: [0, 0, 0], cp: "
                         "1.5 km/s, cs: 0, rho: 1800}}\n");
  ck_assert_int_eq(sc->dimension, 3);
  ck_assert(fabs(sc->t_end - 2e-4) < 1e-18 && sc->cfl == 0.25 && fabs(sc->dt_max - 1e-6) < 1e-20);
  ck_assert(sc->dt_fixed == 0 && sc->max_steps == 100 && sc->skin == 0.2);
  ck_assert(sc->gravity[2] == -9.81 && sc->gravity[0] == 0);
  ck_assert_str_eq(sc->output_file, "out/scene.h5");
  ck_assert(fabs(sc->output_every - 1e-5) < 1e-18);
  ck_assert_int_eq(sc->n_output_fields, 3);
  ck_assert_str_eq(sc->output_fields[2], "v");
  ck_assert_int_eq(sc->output_field_locs[2].line, 4);
  ck_assert_int_eq(sc->n_materials, 2);
  ck_assert_str_eq(sc->materials[0].name, "air");
  ck_assert(sc->materials[0].rho0 == 1.2);
  ck_assert_ptr_nonnull(sc->materials[0].eos_ops);
  ck_assert_str_eq(sc->materials[0].eos_ops->name, "ideal_gas");
  ck_assert_ptr_null(sc->materials[0].mat_ops);
  ck_assert_int_eq(sc->n_sets, 2);
  const ej_scene_set *g = &sc->sets[0];
  ck_assert_str_eq(g->name, "gas");
  ck_assert_int_eq(g->loc.line, 11);
  ck_assert_int_eq(g->material, 0);
  ck_assert_int_eq(sc->sets[1].material, 1);
  ck_assert_str_eq(g->method_ops->name, "sph");
  ck_assert(fabs(g->spacing - 0.05) < 1e-15);
  ck_assert_int_eq(g->lattice, EJ_LATTICE_HCP);
  ck_assert(g->jitter == 0.1 && g->seed == 42);
  ck_assert_int_eq(g->n_refine, 1);
  ck_assert(fabs(g->refine[0].spacing - 0.025) < 1e-15);
  ck_assert_int_eq(g->n_init, 3);
  ck_assert(g->init[0].has_v && g->init[0].v[0] == 1 && g->init[0].has_p && g->init[0].p == 1e5);
  ck_assert(!g->init[0].has_e && !g->init[0].has_rho && g->init[0].region == NULL);
  ck_assert(g->init[1].has_p && g->init[1].p == 1e6 && g->init[1].has_v && g->init[1].region);
  ck_assert(g->init[2].has_energy_total && g->init[2].energy_total == 1 && !g->init[2].region);
  /* the shape subtracts set 'core', defined further down */
  const ej_real in_core[3] = {2, 0.25, 0.25}, in_box[3] = {0.5, 0.25, 0.25};
  ck_assert(ej_shape_contains(g->shape, in_box));
  ck_assert(!ej_shape_contains(g->shape, in_core) && ej_shape_contains(sc->sets[1].shape, in_core));
  ck_assert_int_eq(sc->n_bcs, 6);
  ck_assert_int_eq(sc->bcs[0].kind, EJ_BC_FIX);
  ck_assert(sc->bcs[0].set == 0 && sc->bcs[0].comp[0] && !sc->bcs[0].comp[1] && sc->bcs[0].region);
  ck_assert_int_eq(sc->bcs[1].kind, EJ_BC_VELOCITY);
  ck_assert(sc->bcs[1].set == -1 && sc->bcs[1].comp[2] && !sc->bcs[1].comp[0] && sc->bcs[1].velocity[2] == 1);
  ck_assert_int_eq(sc->bcs[2].kind, EJ_BC_SYMMETRY);
  ck_assert(sc->bcs[2].normal[1] == 1 && sc->bcs[2].normal[0] == 0);
  ck_assert_int_eq(sc->bcs[3].kind, EJ_BC_PERIODIC);
  ck_assert(sc->bcs[3].axis == 2 && sc->bcs[3].lo == 0 && sc->bcs[3].hi == 0.5);
  ck_assert_int_eq(sc->bcs[3].loc.line, 35);
  ck_assert_int_eq(sc->bcs[4].kind, EJ_BC_NONREFLECT);
  ck_assert(sc->bcs[4].set == 0 && !sc->bcs[4].radial && sc->bcs[4].normal[0] == 1 && sc->bcs[4].region);
  ck_assert(isnan(sc->bcs[4].rho) && isnan(sc->bcs[4].cp) && isnan(sc->bcs[4].cs));
  ck_assert(!sc->bcs[4].comp[0] && !sc->bcs[4].comp[1] && !sc->bcs[4].comp[2]);
  ck_assert_int_eq(sc->bcs[5].kind, EJ_BC_NONREFLECT);
  ck_assert(sc->bcs[5].set == -1 && sc->bcs[5].radial && sc->bcs[5].point[0] == 0);
  ck_assert(sc->bcs[5].cp == 1500 && isnan(sc->bcs[5].cs) && sc->bcs[5].rho == 1800);

  ej_points pts;
  ck_assert_int_eq(ej_scene_set_points(sc, 0, &pts), EJ_OK);
  ck_assert(pts.n > 100);
  bool fine = false;
  for (ej_idx i = 0; i < pts.n; ++i) fine = fine || pts.spacing[i] == 0.025;
  ck_assert(fine);
  ej_points_free(&pts);
  ck_assert_int_eq(ej_scene_set_points(sc, 1, &pts), EJ_OK);
  ck_assert(pts.n > 100);
  ej_points_free(&pts);
  ej_scene_destroy(sc);
  ej_scene_destroy(NULL);
}
END_TEST

START_TEST(test_valid_minimal_2d_csv)
{
  write_file("particles.csv", "x,y\n0,0\n0.1,0\n");
  ej_scene *sc = load_ok(HEAD "dimension: 2\n"
                              "output: {file: results/run.h5}\n"
                              "sets:\n"
                              "  gas: {method: sph, material: air, file: particles.csv, spacing: 0.1,\n"
                              "        velocity: [1, 2]}\n");
  ck_assert_int_eq(sc->dimension, 2);
  ck_assert(sc->cfl == 0.3 && sc->skin == 0.15);
  ck_assert_str_eq(sc->output_file, "results/run.h5");
  const ej_scene_set *g = &sc->sets[0];
  ck_assert_ptr_null(g->shape);
  ck_assert_ptr_nonnull(g->file);
  ck_assert(strstr(g->file, tmpdir) == g->file); /* relative to the scene's directory */
  ck_assert(g->init[0].v[0] == 1 && g->init[0].v[1] == 2 && g->init[0].v[2] == 0);
  ej_points pts;
  ck_assert_int_eq(ej_scene_set_points(sc, 0, &pts), EJ_OK);
  ck_assert_int_eq(pts.n, 2);
  ck_assert(fabs(pts.vol[0] - 0.01) < 1e-15);
  ej_points_free(&pts);
  ej_scene_destroy(sc);
}
END_TEST

/* ------------------------------------------------------------------ one test per bad-input class */

#define SET_OK "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 0.1}\n"

START_TEST(test_bad_yaml)
{
  ej_scene *sc;
  ck_assert_int_eq(load("ejecta: 1\ntime: {end: 1\nsets: [\n", &sc), EJ_ERR_INPUT);
  const ej_error_frame *c = ej_error_cause();
  ck_assert(strstr(c->msg, "malformed YAML") != NULL);
  ck_assert(c->where.line >= 2);
  /* a tab indent: libyaml's "cannot start any token", with what the character is */
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n\tair: {rho0: 1}\n",
           "cannot start any token (while scanning for the next token at line 4); the character there is a tab: "
           "YAML indents with spaces, not tabs", 4, 1);
}
END_TEST

START_TEST(test_bad_unknown_key)
{
  load_bad(HEAD "tme: {end: 1}\n" SET_OK, "unknown key 'tme' in scene; did you mean 'time'?", 5, 1);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}},"
                " spacing: 0.1, jiter: 0.1}\n",
           "did you mean 'jitter'?", 6, 99);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {bx: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 0.1}\n",
           "unknown shape 'bx'; did you mean 'box'?", 6, 45);
}
END_TEST

START_TEST(test_bad_type)
{
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: [1, 2]}\n",
           "'spacing' in set 'gas' must be a number (m), got a list", 6, 94);
  load_bad("ejecta: 1\ntime: 5\n" SET_OK, "time", 2, 7);
  load_bad(HEAD "sets: [gas]\n", "sets must be a map", 5, 7);
}
END_TEST

START_TEST(test_bad_range)
{
  load_bad("ejecta: 1\ntime: {end: 1 ms, cfl: 1.5}\n" SET_OK, "'cfl' = 1.5 is out of range", 2, 24);
  load_bad("ejecta: 2\ntime: {end: 1 ms}\n" SET_OK, "'ejecta' = 2 is out of range", 1, 9);
  load_bad(HEAD "dimension: 2\nsets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0], max: [1, 1]}},"
                " spacing: 0.1}\nboundaries:\n  - {periodic: {axis: z, min: 0, max: 1}}\n",
           "periodic axis 'z' is not used in a 2D scene", 9, 23);
}
END_TEST

START_TEST(test_bad_missing)
{
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {eos: {model: ideal_gas}}\n" SET_OK,
           "material 'air' is missing required key 'rho0'", 4, 8);
  load_bad("ejecta: 1\n" SET_OK, "scene is missing required key 'time'", 1, 1);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}}\n",
           "set 'gas' needs 'spacing'", 6, 3);
  load_bad(HEAD "sets:\n  gas: {material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 1}\n",
           "set 'gas' needs 'method'", 6, 3);
}
END_TEST

START_TEST(test_bad_plugin)
{
  load_bad(HEAD "sets:\n  gas: {method: sfh, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 0.1}\n",
           "unknown method 'sfh'; did you mean 'sph'?", 6, 17);
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {rho0: 1, eos: {model: ideal_gaz}}\n" SET_OK,
           "did you mean 'ideal_gas'?", 4, 31);
}
END_TEST

START_TEST(test_bad_unit)
{
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 4 GPa}\n",
           "'spacing' in set 'gas' expects a length (m), got '4 GPa'", 6, 94);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1 s]}}, spacing: 1}\n",
           "expects a length (m), got '1 s'", 6, 79);
}
END_TEST

START_TEST(test_bad_no_particles)
{
  ej_scene *sc = load_ok(HEAD "sets:\n  gas:\n    method: sph\n    material: air\n"
                              "    shape: {box: {min: [0, 0, 0], max: [1, 1, 0.001]}}\n    spacing: 4 mm\n");
  ej_points pts;
  ej_error_clear();
  ck_assert_int_eq(ej_scene_set_points(sc, 0, &pts), EJ_ERR_INPUT);
  const ej_error_frame *c = ej_error_cause();
  ck_assert_str_eq(c->msg, "set 'gas' has no particles: its shape holds no lattice point at spacing 0.004 m");
  ck_assert_int_eq(c->where.line, 6);
  ck_assert_int_eq(c->where.col, 3);
  ej_scene_destroy(sc);
  /* an unbounded shape is caught at load */
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {half_space: {point: [0, 0, 0], normal: [0, 0, 1]}},"
                " spacing: 1}\n",
           "shape is unbounded", 6, 44);
}
END_TEST

START_TEST(test_bad_material_ref)
{
  load_bad(HEAD "sets:\n  gas: {method: sph, material: ari, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 0.1}\n",
           "set 'gas' uses undefined material 'ari'; did you mean 'air'?", 6, 32);
}
END_TEST

START_TEST(test_bad_missing_file)
{
  ej_scene *sc = NULL;
  char path[600];
  snprintf(path, sizeof path, "%s/nonexistent.yaml", tmpdir);
  ej_error_clear();
  ck_assert_int_eq(ej_scene_load(path, reg, &sc), EJ_ERR_INPUT);
  ck_assert_ptr_null(sc);
  const ej_error_frame *c = ej_error_cause();
  ck_assert(strstr(c->msg, "cannot open scene file") != NULL);
  ck_assert(strstr(c->where.file, "nonexistent.yaml") != NULL);
}
END_TEST

START_TEST(test_bad_misc)
{
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 1,"
                " p: 1, e: 2}\n",
           "give either 'e' or 'p', not both", 6, 97);
  load_bad(HEAD SET_OK "boundaries:\n  - {set: gsa, fix: [x]}\n", "undefined set 'gsa'; did you mean 'gas'?", 8, 11);
  load_bad(HEAD SET_OK "boundaries:\n  - {set: gas, fix: [x], velocity: [1, 0, 0]}\n", "found both 'fix' and 'velocity'",
           8, 26);
  load_bad(HEAD "sets:\n  a: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}, minus: [b]},"
                " spacing: 1}\n  b: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]},"
                " minus: [a]}, spacing: 1}\n",
           "set 'a' subtracts itself", 7, 90);
  load_bad(HEAD "sets:\n  a: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}, minus: [charge]},"
                " spacing: 1}\n",
           "'minus' names undefined set 'charge'", 6, 90);
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {rho0: 1}\n" SET_OK,
           "material 'air' needs an equation of state", 4, 3);
  /* a configuration that asks for the EOS (ABI 1.9 eos_required_by): located at that parameter */
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "  steel: {rho0: 7850, model: von_mises, E: 200 GPa, nu: 0.3, yield_stress: 250 MPa,\n"
           "          volumetric: eos}\n" SET_OK,
           "material 'steel': von_mises with volumetric: eos needs an equation of state; expected 'eos: {model: ...}'", 6, 23);
  load_bad("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "  iron: {rho0: 7890, model: johnson_cook, E: 200 GPa, nu: 0.29, A: 175 MPa, B: 380 MPa, n: 0.32, T_melt: 1811,\n"
           "         volumetric: eos}\n" SET_OK,
           "material 'iron': johnson_cook with volumetric: eos needs an equation of state; expected 'eos: {model: ...}'", 6, 22);
  /* auto and elastic take no EOS; eos with one attached loads */
  ej_scene_destroy(load_ok("ejecta: 1\ntime: {end: 1}\nmaterials:\n  air: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
                           "  steel: {rho0: 7850, model: von_mises, E: 200 GPa, nu: 0.3, yield_stress: 250 MPa}\n"
                           "  iron: {rho0: 7890, model: johnson_cook, E: 200 GPa, nu: 0.29, A: 175 MPa, B: 380 MPa,"
                           " n: 0.32, T_melt: 1811, volumetric: eos,\n"
                           "         eos: {model: mie_gruneisen, rho0: 7890, C0: 3630, S1: 1.8, gamma0: 1.81}}\n" SET_OK));
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 1,"
                " file: p.csv}\n",
           "takes either 'shape' or 'file'", 6, 97);
  load_bad(HEAD "sets: {}\n", "'sets' is empty", 5, 7);
  load_bad(HEAD "gravity: [0, -9.81]\n" SET_OK, "expected a list of 3 numbers", 5, 10);
  /* a 2D scene may write 3 numbers, but a velocity, gravity or normal out of its plane is refused */
  load_bad("ejecta: 1\ndimension: 2\ntime: {end: 1 ms}\ngravity: [0, 0, -9.81]\nmaterials:\n"
           "  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0], max: [1, 1]}}, spacing: 0.1}\n",
           "component 3 is -9.81, but the scene has dimension 2", 4, 17);
  load_bad("ejecta: 1\ndimension: 2\ntime: {end: 1 ms}\nmaterials:\n"
           "  air: {rho0: 1.2, eos: {model: ideal_gas, gamma: 1.4}}\n"
           "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0], max: [1, 1]}}, spacing: 0.1,\n"
           "        velocity: [1, 0, 5]}\n",
           "component 3 is 5, but the scene has dimension 2", 8, 26);
  write_file("particles.csv", "x,y,z\n0,0,0\n0.1,0,0\n");
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, file: particles.csv, spacing: 0.1,"
                " lattice_origin: [0, 0, 0]}\n",
           "'lattice_origin' applies to sets filled from a shape", 6, 72);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, file: particles.csv, spacing: 0.1,"
                " jitter_volume: kernel}\n",
           "'jitter_volume' applies to sets filled from a shape", 6, 72);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 1,"
                " jitter: 0.1, jitter_volume: voronoi}\n",
           "'jitter_volume' in set 'gas' must be one of cell, kernel, got 'voronoi'", 6, 125);
  load_bad(HEAD "sets:\n  gas: {method: sph, material: air, shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, spacing: 1,"
                " lattice_origin: [0, 0]}\n",
           "must be a list of 3 numbers, got 2", 6, 113);
}
END_TEST

/* probes: (docs/core.md "Probes"); the fields are checked against the sets later (test_probes) */
START_TEST(test_probes_parse)
{
  ej_scene *sc = load_ok(HEAD SET_OK "probes:\n  - {name: g1, set: gas, point: [0.5, 0.5, 20 cm], fields: [p, v]}\n"
                                     "  - {set: gas, point: [0.1, 0.1, 0.1], follow: true, fields: [rho]}\n"
                                     "  - {set: gas, point: [0.3, 0, 0], radius: 5 cm, fields: [e]}\n");
  ck_assert_int_eq(sc->n_probes, 3);
  ck_assert_str_eq(sc->probes[0].name, "g1");
  ck_assert_int_eq(sc->probes[0].set, 0);
  ck_assert_double_eq(sc->probes[0].point[2], 0.2);
  ck_assert(!sc->probes[0].follow);
  ck_assert_int_eq(sc->probes[0].n_fields, 2);
  ck_assert_str_eq(sc->probes[0].fields[1], "v");
  ck_assert_str_eq(sc->probes[1].name, "probe1");
  ck_assert(sc->probes[1].follow);
  ck_assert_double_eq(sc->probes[2].radius, 0.05);
  ej_scene_destroy(sc);
}
END_TEST

START_TEST(test_bad_non_reflecting)
{
  load_bad(HEAD SET_OK "boundaries:\n  - {set: gas, non_reflecting: {normal: [1, 0, 0]}}\n", "non_reflecting needs 'region'",
           8, 16);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {cp: 1}}\n",
           "needs one of 'normal' (a plane face, outward) and 'center'", 8, 71);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [1, 0, "
                       "0], center: [0, 0, 0]}}\n",
           "not both", 8, 99);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [0, 0, "
                       "0]}}\n",
           "normal must be a non-zero vector", 8, 80);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [1, 0, "
                       "0], cs: -1}}\n",
           "'cs' = -1 is out of range [0, inf) m/s", 8, 95);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [1, 0, "
                       "0], cq: 1}}\n",
           "unknown key 'cq'", 8, 91);
  load_bad(HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, non_reflecting: {normal: [1, 0, "
                       "0]}, components: [x]}\n",
           "unknown key 'components'", 8, 92);
}
END_TEST

START_TEST(test_pressure_parse)
{
  ej_scene *sc = load_ok(HEAD SET_OK "boundaries:\n"
                                     "  - {region: {box: {min: [0.9, 0, 0], max: [1, 1, 1]}}, pressure: {normal: [2, 0, 0], "
                                     "value: 3 MPa}}\n"
                                     "  - {set: gas, region: {sphere: {center: [0, 0, 0], radius: 0.3}}, pressure: {center: "
                                     "[0, 0, 0], cavity: true, curve: [[0, 0], [1 ms, 2 MPa], [2 ms, 0]]}}\n"
                                     "  - {region: {box: {min: [0, 0, 0.9], max: [1, 1, 1]}}, pressure: {normal: [0, 0, 1], "
                                     "blast: {charge: [0.5, 0.5, 2 m], tnt: 500 g, burst: surface, time: 10 us}}}\n");
  ck_assert_int_eq(sc->n_bcs, 3);
  const ej_scene_bc *b = sc->bcs;
  ck_assert(b[0].kind == EJ_BC_PRESSURE && b[0].source == EJ_PRESSURE_VALUE && b[0].p_value == 3e6);
  ck_assert(b[0].normal[0] == 1 && !b[0].radial && b[0].set == -1);
  ck_assert(b[1].source == EJ_PRESSURE_CURVE && b[1].radial && b[1].cavity && b[1].n_curve == 3);
  ck_assert(b[1].curve_t[1] == 1e-3 && b[1].curve_p[1] == 2e6 && b[1].curve_t[2] == 2e-3);
  ck_assert(b[2].source == EJ_PRESSURE_BLAST && b[2].burst == EJ_BURST_SURFACE && b[2].tnt == 0.5);
  ck_assert(b[2].charge[2] == 2 && fabs(b[2].t_det - 1e-5) < 1e-20);
  ej_scene_destroy(sc);
}
END_TEST

START_TEST(test_bad_pressure)
{
#define PB HEAD SET_OK "boundaries:\n  - {region: {box: {min: [0, 0, 0], max: [1, 1, 1]}}, pressure: "
  load_bad(HEAD SET_OK "boundaries:\n  - {set: gas, pressure: {normal: [1, 0, 0], value: 1}}\n", "pressure needs 'region'",
           8, 16);
  load_bad(PB "{normal: [1, 0, 0]}}\n", "pressure needs one of 'value'", 8, 65);
  load_bad(PB "{value: 1 MPa}}\n", "pressure needs one of 'normal' (a plane face, outward) and 'center'", 8, 65);
  load_bad(PB "{normal: [1, 0, 0], value: 1, curve: [[0, 1]]}}\n", "found both 'value' and 'curve'", 8, 95);
  load_bad(PB "{normal: [1, 0, 0], curve: [[0, 1], [0, 2]]}}\n", "curve point 2: time 0 s must be after", 8, 102);
  load_bad(PB "{normal: [1, 0, 0], curve: [[0, 1], [1 ms]]}}\n", "curve point 2: expected [time, pressure]", 8, 101);
  load_bad(PB "{normal: [1, 0, 0], curve: []}}\n", "curve: expected a list of [time, pressure] points", 8, 92);
  load_bad(PB "{normal: [1, 0, 0], curve: [[0, 1 m]]}}\n", "expects a pressure (Pa), got '1 m'", 8, 97);
  load_bad(PB "{normal: [1, 0, 0], blast: {tnt: 1}}}\n", "blast needs 'charge'", 8, 92);
  load_bad(PB "{normal: [1, 0, 0], blast: {charge: [0, 0, 2], tnt: 0}}}\n", "'tnt' = 0 is out of range", 8, 117);
  load_bad(PB "{normal: [1, 0, 0], blast: {charge: [0, 0, 2], tnt: 1, burst: ground}}}\n", "'burst' in blast must be one of air, surface", 8, 127);
  load_bad(PB "{normal: [1, 0, 0], cavity: true, value: 1}}\n", "cavity is for a face around 'center'", 8, 93);
  load_bad(PB "{normal: [1, 0, 0], valeu: 1}}\n", "unknown key 'valeu'", 8, 85);
#undef PB
}
END_TEST

START_TEST(test_bad_probes)
{
  load_bad(HEAD SET_OK "probes:\n  - {set: gsa, point: [0, 0, 0], fields: [p]}\n", "undefined set 'gsa'; did you mean 'gas'?",
           8, 11);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, fields: [p]}\n", "a probe needs 'point'", 8, 5);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0]}\n", "a probe needs 'fields'", 8, 5);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0], fields: []}\n", "non-empty list", 8, 42);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0], fields: [p, p]}\n", "'p' is listed twice", 8, 46);
  load_bad(HEAD SET_OK "probes:\n  - {name: a/b, set: gas, point: [0, 0, 0], fields: [p]}\n",
           "expected 1 to 32 letters, digits", 8, 12);
  load_bad(HEAD SET_OK "probes:\n  - {name: g, set: gas, point: [0, 0, 0], fields: [p]}\n"
                       "  - {name: g, set: gas, point: [1, 0, 0], fields: [p]}\n",
           "probe name 'g' is used twice (first at line 8)", 9, 12);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0], follow: true, radius: 1 cm, fields: [p]}\n",
           "radius applies to a gauge", 8, 56);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0], fields: [p], every: 1}\n", "unknown key 'every'", 8, 47);
  load_bad(HEAD SET_OK "probes: {set: gas}\n", "probes must be a list", 7, 9);
  load_bad(HEAD SET_OK "probes:\n  - {set: gas, point: [0, 0, 0], radius: -1, fields: [p]}\n", "radius", 8, 42);
}
END_TEST

/* ------------------------------------------------------------------ schema */

START_TEST(test_schema)
{
  ej_buf a = {0}, b = {0};
  ck_assert_int_eq(ej_scene_schema(reg, &a), EJ_OK);
  ck_assert_int_eq(ej_scene_schema(reg, &b), EJ_OK);
  ck_assert_uint_eq(a.len, b.len);
  ck_assert(memcmp(a.data, b.data, a.len) == 0);
  ck_assert(strstr(a.data, "\"$schema\": \"https://json-schema.org/draft/2020-12/schema\""));
  ck_assert(strstr(a.data, "\"const\": \"sph\""));
  ck_assert(strstr(a.data, "\"const\": \"ideal_gas\""));
  ck_assert(strstr(a.data, "\"h_factor\""));
  ck_assert(strstr(a.data, "\"gamma\""));
  /* balanced braces outside strings */
  int depth = 0;
  bool str = false;
  for (size_t i = 0; i < a.len; ++i) {
    char c = a.data[i];
    if (str) {
      if (c == '\\') ++i;
      else if (c == '"') str = false;
    } else if (c == '"') {
      str = true;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      --depth;
      ck_assert(depth >= 0);
    }
  }
  ck_assert_int_eq(depth, 0);
  ej_buf_free(&a);
  ej_buf_free(&b);
}
END_TEST

/* The committed schema matches the one generated from every in-tree plugin, when the build
 * has them all (the CLI test of 'ejecta schema' covers the full comparison). */

int main(void)
{
  Suite *s = suite_create("scene");
  TCase *tc = tcase_create("valid");
  tcase_add_checked_fixture(tc, setup, teardown);
  tcase_add_test(tc, test_valid_full);
  tcase_add_test(tc, test_valid_minimal_2d_csv);
  tcase_add_test(tc, test_probes_parse);
  tcase_add_test(tc, test_schema);
  suite_add_tcase(s, tc);
  tc = tcase_create("bad_input");
  tcase_add_checked_fixture(tc, setup, teardown);
  tcase_add_test(tc, test_bad_yaml);
  tcase_add_test(tc, test_bad_unknown_key);
  tcase_add_test(tc, test_bad_type);
  tcase_add_test(tc, test_bad_range);
  tcase_add_test(tc, test_bad_missing);
  tcase_add_test(tc, test_bad_plugin);
  tcase_add_test(tc, test_bad_unit);
  tcase_add_test(tc, test_bad_no_particles);
  tcase_add_test(tc, test_bad_material_ref);
  tcase_add_test(tc, test_bad_missing_file);
  tcase_add_test(tc, test_bad_misc);
  tcase_add_test(tc, test_bad_probes);
  tcase_add_test(tc, test_bad_non_reflecting);
  tcase_add_test(tc, test_pressure_parse);
  tcase_add_test(tc, test_bad_pressure);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
