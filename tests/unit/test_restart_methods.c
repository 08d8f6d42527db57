/* Restart of the solid methods (DESIGN.md "Determinism"; test_determinism covers sph gas): a run
 * restarted from the output of a run stopped at step N/2 continues bitwise identically to an
 * uninterrupted run of N steps. Scenes: a free, jittered 3D elastic block with a smooth
 * nonuniform velocity field, as semi-Lagrangian rkpm with MSNNI (its face data live in plugin
 * arrays that the method's setup allocates: a restart used to stop with "rkpm particle id outside
 * the setup range" because the core did not call setup on a restart). */
#include <check.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "validation_common.h"

const ej_plugin_info *ej_plugin_rkpm_info(void);
const ej_plugin_info *ej_plugin_elastic_info(void);
const ej_plugin_info *ej_plugin_tlpd_info(void);
const ej_plugin_info *ej_plugin_rigid_body_info(void);
const ej_plugin_info *ej_plugin_kernel_contact_info(void);
const ej_plugin_info *ej_plugin_rigid_indenter_info(void);
const ej_plugin_info *ej_plugin_repulsive_wall_info(void);
const ej_plugin_info *ej_plugin_polynomial_info(void);
const ej_plugin_info *ej_plugin_sph_wall_info(void);
const ej_plugin_info *ej_plugin_drucker_prager_info(void);

#define RS_STEPS 24

typedef struct rs_snap {
  ej_idx n;
  double *x, *v; /* ordered by particle id */
} rs_snap;

static void rs_scene(const char *path, const char *method_lines)
{
  char init[4096];
  smooth_block_initial(init, sizeof init, 0.01);
  char text[8192];
  snprintf(text, sizeof text,
           "ejecta: 1\ndimension: 3\ntime: {end: 100, cfl: 0.3}\n"
           "output: {file: out.h5, every: 100, fields: [v]}\n"
           "materials:\n  m: {model: elastic, rho0: 1, E: 1, nu: 0.25}\n"
           "sets:\n  block:\n%s"
           "    material: m\n    shape: {box: {min: [0, 0, 0], max: [0.5, 0.5, 0.5]}}\n"
           "    spacing: 0.0625\n    jitter: 0.3\n    initial:\n%s",
           method_lines, init);
  vrun_write(path, text);
}

static void rs_run(const char *dir, const char *out_name, int64_t steps, const char *restart, rs_snap *sn)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/%s", dir, out_name);
  ej_registry *reg = NULL;
  ej_scene *sc = NULL;
  ej_sim *sim = NULL;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_rkpm_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_elastic_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_tlpd_info()), EJ_OK);
  ej_err rc = ej_scene_load(scene, reg, &sc);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  sc->max_steps = steps;
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = restart, .threads = 1};
  rc = ej_sim_create(sc, reg, &opts, &sim);
  if (rc == EJ_OK) rc = ej_sim_run(sim);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
  ck_assert_int_eq(sim->step, steps);
  const ej_set *s = sim->sets[0];
  const ej_idx n = ej_set_count(s);
  const int32_t *id = ej_set_field_int(s, "id");
  const ej_real *x = ej_set_field(s, "x"), *v = ej_set_field(s, "v");
  ck_assert(id && x && v);
  sn->n = n;
  sn->x = calloc((size_t)n * 3, sizeof(double));
  sn->v = calloc((size_t)n * 3, sizeof(double));
  ck_assert(sn->x && sn->v);
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert(id[i] >= 0 && id[i] < n);
    memcpy(sn->x + 3 * id[i], x + 3 * i, 3 * sizeof(double));
    memcpy(sn->v + 3 * id[i], v + 3 * i, 3 * sizeof(double));
  }
  ej_sim_destroy(sim);
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
}

/* rs_case's comparison; text: the whole scene, or NULL for rs_scene's block with method_lines */
static void rs_case_text(const char *tag, const char *method_lines, const char *text)
{
  char dir[64], half[128];
  vrun_dir(dir, sizeof dir, tag);
  char scene[128];
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  if (text) vrun_write(scene, text);
  else rs_scene(scene, method_lines);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  rs_snap full, first, cont;
  rs_run(dir, "full.h5", RS_STEPS, NULL, &full);
  rs_run(dir, "half.h5", RS_STEPS / 2, NULL, &first);
  rs_run(dir, "cont.h5", RS_STEPS, half, &cont);
  ck_assert_int_eq(full.n, cont.n);
  double dv = 0, vmax = 0;
  for (ej_idx k = 0; k < 3 * full.n; ++k) {
    dv = fmax(dv, fabs(full.v[k] - cont.v[k]));
    vmax = fmax(vmax, fabs(full.v[k]));
  }
  printf("%s restart: %ld particles, max |v_full - v_restarted| %.3g (max |v| %.3g)\n", tag, (long)full.n, dv, vmax);
  fflush(stdout);
  ck_assert_msg(memcmp(full.x, cont.x, (size_t)full.n * 3 * sizeof(double)) == 0, "%s: x differs", tag);
  ck_assert_msg(memcmp(full.v, cont.v, (size_t)full.n * 3 * sizeof(double)) == 0, "%s: v differs", tag);
  ck_assert(vmax > 0); /* the block moves: the comparison is not of two resting blocks */
  free(full.x), free(full.v), free(first.x), free(first.v), free(cont.x), free(cont.v);
  const char *names[] = {"s.yaml", "full.h5", "full.xdmf", "half.h5", "half.xdmf", "cont.h5", "cont.xdmf"};
  vrun_cleanup(dir, names, 7);
}

static void rs_case(const char *tag, const char *method_lines) { rs_case_text(tag, method_lines, NULL); }

START_TEST(test_rkpm_msnni_restart)
{
  rs_case("rsrk", "    method: rkpm\n    integration: msnni\n");
}
END_TEST

/* Lagrangian rkpm on a 2D plate one node thick: every node's moment matrix is singular (constant
 * basis, no deformation). With dni the run used to stop at det F = 0 (the fallback node's F was 0
 * in-plane); with msnni a restart used to bring the fallback nodes back (their flag was not in the
 * checkpoint) and stop at det F = 0 where the uninterrupted run went on. Both now run, and the
 * restarted run is bitwise the uninterrupted one. */
static const char rs_line_scene[] =
    "ejecta: 1\ndimension: 2\ntime: {end: 100, cfl: 0.3}\noutput: {file: out.h5, every: 100, fields: [v]}\n"
    "materials:\n  m: {model: elastic, rho0: 1800, E: 200 MPa, nu: 0.3}\n"
    "sets:\n  line: {method: rkpm, formulation: lagrangian, integration: %s, material: m,\n"
    "         shape: {box: {min: [0, 0], max: [0.05, 0.0025]}}, spacing: 2.5 mm, velocity: [10, 5]}\n";

START_TEST(test_rkpm_lagrangian_fallback_restart)
{
  char text[1024];
  snprintf(text, sizeof text, rs_line_scene, "msnni");
  rs_case_text("rsrl", NULL, text);
  snprintf(text, sizeof text, rs_line_scene, "dni");
  rs_case_text("rsrd", NULL, text);
}
END_TEST

/* tlpd: its family stable-step cache (dt per family, valid until a bond breaks), the flag that F
 * of the previous step may be differenced (grad du = F_n+1 - F_n) and F itself must survive a
 * restart; the critical stretch breaks bonds in the second half, so the cache is invalidated
 * after the restart too. */
START_TEST(test_tlpd_restart)
{
  rs_case("rstl", "    method: tlpd\n");
}
END_TEST

START_TEST(test_tlpd_restart_breaking)
{
  rs_case("rstb", "    method: tlpd\n    failure: {critical_stretch: 0.004}\n");
}
END_TEST

/* ---- plugin state beyond fields (ABI 1.8 save_state / load_state) ----
 * A rigid body's orientation and the work and dissipation that interactions and tlpd sum over the
 * run live in the plugins' own state. Before it was checkpointed, a restarted run turned a spinning
 * rigid body back to its initial orientation (the particles jumped by 35 mm in a 2D scene of a box
 * spinning at 300 rad/s against a block) and the energy budget lost every summed work (balance
 * -86 J against 0.02 J). Each scene below is run for N steps, for N/2, and from the N/2
 * checkpoint to N: every set's x and v, the budget and every plugin series of the last step
 * must be bitwise those of the uninterrupted run. */

static void rs_plugins(const ej_plugin_info **p, int *np)
{
  int n = 0;
  p[n++] = ej_plugin_rkpm_info(), p[n++] = ej_plugin_elastic_info(), p[n++] = ej_plugin_tlpd_info();
  p[n++] = ej_plugin_rigid_body_info(), p[n++] = ej_plugin_kernel_contact_info();
  p[n++] = ej_plugin_rigid_indenter_info(), p[n++] = ej_plugin_repulsive_wall_info();
  p[n++] = ej_plugin_sph_info(), p[n++] = ej_plugin_polynomial_info(), p[n++] = ej_plugin_sph_wall_info();
  p[n++] = ej_plugin_drucker_prager_info();
  *np = n;
}

static void rs_open(vrun *r, const char *dir, const char *out_name, int64_t steps, const char *restart)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(out, sizeof out, "%s/%s", dir, out_name);
  const ej_plugin_info *p[16];
  int np;
  rs_plugins(p, &np);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = restart, .threads = 1};
  vrun_open_with(r, scene, &opts, steps, p, np);
  vrun_run(r);
  ck_assert_int_eq(r->sim->step, steps);
}

/* Runs the scene text uninterrupted and restarted; the series named in must_move must have
 * changed over the second half (so that the comparison is not of quantities that stay 0). */
static void rs_state_case(const char *tag, const char *text, int64_t steps, const char *const *must_move, int nm)
{
  char dir[64], scene[128], half[128];
  vrun_dir(dir, sizeof dir, tag);
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  vrun_write(scene, text);
  vrun full, first, cont;
  rs_open(&full, dir, "full.h5", steps, NULL);
  rs_open(&first, dir, "half.h5", steps / 2, NULL);
  rs_open(&cont, dir, "cont.h5", steps, half);
  const ej_sim *a = full.sim, *b = cont.sim;
  ck_assert_int_eq(a->n_sets, b->n_sets);
  for (int k = 0; k < a->n_sets; ++k) {
    const ej_set *sa = a->sets[k], *sb = b->sets[k];
    ck_assert_int_eq(ej_set_count(sa), ej_set_count(sb));
    const size_t nb = (size_t)ej_set_count(sa) * 3 * sizeof(ej_real);
    ck_assert_msg(!memcmp(ej_set_field(sa, "x"), ej_set_field(sb, "x"), nb), "%s: x of set %s differs", tag,
                  ej_set_name(sa));
    ck_assert_msg(!memcmp(ej_set_field(sa, "v"), ej_set_field(sb, "v"), nb), "%s: v of set %s differs", tag,
                  ej_set_name(sa));
  }
  ck_assert_msg(!memcmp(&a->energy.external, &b->energy.external, sizeof(ej_real)), "%s: external %.17g vs %.17g",
                tag, a->energy.external, b->energy.external);
  ck_assert_msg(!memcmp(&a->energy.balance, &b->energy.balance, sizeof(ej_real)), "%s: balance %.17g vs %.17g", tag,
                a->energy.balance, b->energy.balance);
  ck_assert_int_eq(a->reports.n, b->reports.n);
  for (int k = 0; k < a->reports.n; ++k) {
    ck_assert_str_eq(a->reports.names[k], b->reports.names[k]);
    const ej_real va = a->reports.values[k], vb = b->reports.values[k];
    ck_assert_msg(!memcmp(&va, &vb, sizeof va) || (isnan(va) && isnan(vb)), "%s: series %s %.17g vs %.17g", tag,
                  a->reports.names[k], va, vb);
  }
  for (int m = 0; m < nm; ++m) {
    int k = 0;
    while (k < a->reports.n && strcmp(a->reports.names[k], must_move[m]) != 0) ++k;
    ck_assert_msg(k < a->reports.n, "%s: no series %s", tag, must_move[m]);
    int j = 0;
    while (j < first.sim->reports.n && strcmp(first.sim->reports.names[j], must_move[m]) != 0) ++j;
    ck_assert(j < first.sim->reports.n);
    printf("%s: %s %.6g at step %ld, %.6g at step %ld\n", tag, must_move[m], first.sim->reports.values[j],
           (long)(steps / 2), a->reports.values[k], (long)steps);
    ck_assert_msg(a->reports.values[k] != first.sim->reports.values[j], "%s: %s did not change", tag, must_move[m]);
  }
  printf("%s: balance %.6g J, external %.6g J, restarted bitwise\n", tag, a->energy.balance, a->energy.external);
  fflush(stdout);
  vrun_free(&full), vrun_free(&first), vrun_free(&cont);
  const char *names[] = {"s.yaml", "full.h5", "full.xdmf", "half.h5", "half.xdmf", "cont.h5", "cont.xdmf"};
  vrun_cleanup(dir, names, 7);
}

/* A steel box spinning at 300 rad/s (rigid_body) slides over a soft rkpm block with friction and
 * normal damping (kernel_contact): the orientation and the dissipation must carry over. */
static const char rs_rigid_text[] =
      "ejecta: 1\ndimension: 2\ntime: {end: 1, cfl: 0.3}\n"
      "output: {file: out.h5, every: 1, fields: [v]}\n"
      "materials:\n  soft: {model: elastic, rho0: 1800, E: 200 MPa, nu: 0.3}\n"
      "  steel: {model: elastic, rho0: 7800, E: 200 GPa, nu: 0.3}\n"
      "sets:\n  block:\n    method: rkpm\n    material: soft\n"
      "    shape: {box: {min: [0, 0], max: [0.1, 0.05]}}\n    spacing: 5 mm\n"
      "  box:\n    method: rigid_body\n    material: steel\n    modulus: 2 GPa\n    omega: [0, 0, 300]\n"
      "    shape: {box: {min: [0.02, 0.0505], max: [0.06, 0.0705]}}\n    spacing: 5 mm\n"
      "    velocity: [3, -20]\n"
      "interactions:\n  - {model: kernel_contact, sets: [block, box], mu: 0.3, damping: 0.3}\n";

START_TEST(test_rigid_contact_restart)
{
  const char *move[] = {"kernel_contact_0/dissipated", "box/omega_z"};
  rs_state_case("rsrb", rs_rigid_text, 40, move, 2);
}
END_TEST

/* A Drucker-Prager sand column on an sph_wall with the wall's share of the velocity gradient
 * (wall_gradient): that pre-pass reads sph's h of the previous evaluation, which a restart took
 * from the initial state while h was a scratch field (validation/sand_collapse's scene differed
 * after a restart by 7e-8 in the wall force). */
START_TEST(test_sph_wall_gradient_restart)
{
  static const char text[] =
      "ejecta: 1\ndimension: 2\ntime: {end: 10, cfl: 0.3}\n"
      "output: {file: out.h5, every: 10, fields: [v]}\n"
      "materials:\n  sand: {model: drucker_prager, rho0: 1379, E: 21.6 MPa, nu: 0.3, friction_angle: 36 deg,\n"
      "    dilation_angle: 0 deg, cohesion: 0 Pa, beta: 1}\n  floor: {rho0: 1379}\n"
      "sets:\n  sand:\n    method: sph\n    strength: true\n    kernel: wendland_c2\n    h_factor: 1.5\n"
      "    alpha: 0.2\n    beta: 10\n    material: sand\n"
      "    shape: {box: {min: [0, 0], max: [0.2, 0.1]}}\n    spacing: 0.02\n    velocity: [0.3, -0.5]\n"
      "  floor:\n    method: rigid_body\n    material: floor\n    fix_translation: [1, 1, 1]\n"
      "    fix_rotation: [1, 1, 1]\n    shape: {box: {min: [-0.06, -0.06], max: [0.4, 0]}}\n    spacing: 0.02\n"
      "interactions:\n  - {model: sph_wall, sets: [sand, floor], kernel: wendland_c2, slip: no_slip, alpha: 0.2,"
      " beta: 10,\n     gravity: [0, -9.81, 0], wall_gradient: true}\n"
      "gravity: [0, -9.81]\n";
  const char *move[] = {"sph_wall_0/work"};
  rs_state_case("rsgw", text, 40, move, 1);
}
END_TEST

/* A gauge (probe) on a tlpd set: its weights use the particles' search radii, which a restart did
 * not compute for a set with a reference-configuration family (count 0 and NaN after the restart
 * in examples/nonreflecting_2d.yaml). */
START_TEST(test_probe_reference_restart)
{
  static const char text[] =
      "ejecta: 1\ndimension: 2\ntime: {end: 1, cfl: 0.3}\n"
      "output: {file: out.h5, every: 1, fields: [v]}\n"
      "materials:\n  m: {model: elastic, rho0: 2000, E: 1 GPa, nu: 0.25}\n"
      "sets:\n  solid:\n    method: tlpd\n    material: m\n"
      "    shape: {box: {min: [0, 0], max: [0.2, 0.1]}}\n    spacing: 0.01\n"
      "    initial:\n      - {region: {box: {min: [-1, -1], max: [0.05, 1]}}, velocity: [1, 0]}\n"
      "probes:\n  - {name: g, set: solid, point: [0.08, 0.05], fields: [v]}\n";
  const char *move[] = {"probe/g/v_x"};
  rs_state_case("rspr", text, 40, move, 1);
}
END_TEST

/* The same with the box's level-set normals (rigid_body normals: true, kernel_contact normal: body):
 * the normals are computed once, in the first evaluation, and must come from the checkpoint. */
START_TEST(test_body_contact_restart)
{
  char text[2048];
  snprintf(text, sizeof text, "%s", rs_rigid_text);
  char *o = strstr(text, "    omega: [0, 0, 300]\n");
  ck_assert_ptr_nonnull(o);
  memmove(o + 18, o, strlen(o) + 1);
  memcpy(o, "    normals: true\n", 18);
  char *m = strstr(text, "damping: 0.3}");
  ck_assert_ptr_nonnull(m);
  snprintf(m, sizeof text - (size_t)(m - text), "damping: 0.3, normal: body}\n");
  const char *move[] = {"kernel_contact_0/dissipated", "box/omega_z"};
  rs_state_case("rsbn", text, 40, move, 2);
}
END_TEST

/* A checkpoint whose plugin state does not fit the plugin (here kernel_contact's 3 values cut to
 * 2) is refused as bad input naming the file, not read into the wrong members. */
START_TEST(test_state_mismatch_refused)
{
  char dir[64], scene[128], half[128];
  vrun_dir(dir, sizeof dir, "rsmm");
  snprintf(scene, sizeof scene, "%s/s.yaml", dir);
  snprintf(half, sizeof half, "%s/half.h5", dir);
  vrun_write(scene, rs_rigid_text);
  vrun first;
  rs_open(&first, dir, "half.h5", 4, NULL);
  vrun_free(&first);
  hid_t f = H5Fopen(half, H5F_ACC_RDWR, H5P_DEFAULT);
  ck_assert(f >= 0);
  const char *ds = "/checkpoint/_interactions/0_kernel_contact";
  ck_assert(H5Lexists(f, ds, H5P_DEFAULT) > 0);
  ck_assert(H5Ldelete(f, ds, H5P_DEFAULT) >= 0);
  const double two[2] = {1, 2};
  hsize_t n = 2;
  hid_t sp = H5Screate_simple(1, &n, NULL);
  hid_t d = H5Dcreate2(f, ds, H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ck_assert(d >= 0 && H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, two) >= 0);
  H5Dclose(d), H5Sclose(sp), H5Fclose(f);
  const ej_plugin_info *p[16];
  int np;
  rs_plugins(p, &np);
  ej_registry *reg = NULL;
  ej_scene *sc = NULL;
  ej_sim *sim = NULL;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  for (int k = 0; k < np; ++k) ck_assert_int_eq(ej_registry_add_static(reg, p[k]), EJ_OK);
  ck_assert_int_eq(ej_scene_load(scene, reg, &sc), EJ_OK);
  char out[128];
  snprintf(out, sizeof out, "%s/cont.h5", dir);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .restart = half, .threads = 1};
  ej_error_clear();
  ck_assert_int_eq(ej_sim_create(sc, reg, &opts, &sim), EJ_ERR_INPUT);
  const ej_error_frame *e = ej_error_cause();
  ck_assert_ptr_nonnull(e);
  printf("rsmm: %s\n", e->msg);
  ck_assert_msg(strstr(e->msg, "kernel_contact does not take the checkpoint's state (2 values)") != NULL, "%s",
                e->msg);
  ck_assert_msg(strstr(e->msg, half) != NULL, "%s", e->msg);
  ej_error_clear();
  ej_scene_destroy(sc);
  ej_registry_destroy(reg);
  const char *names[] = {"s.yaml", "half.h5", "half.xdmf", "cont.h5", "cont.h5.partial"};
  vrun_cleanup(dir, names, 5);
}
END_TEST

/* tlpd's traction work and damping, a rigid_indenter's work and a repulsive_wall's work. */
START_TEST(test_wall_work_restart)
{
  static const char text[] =
      "ejecta: 1\ndimension: 2\ntime: {end: 1, cfl: 0.3}\n"
      "output: {file: out.h5, every: 1, fields: [v]}\n"
      "materials:\n  m: {model: elastic, rho0: 2000, E: 100 MPa, nu: 0.25}\n  plate: {rho0: 7800}\n"
      "sets:\n  col:\n    method: tlpd\n    material: m\n    damping: 50\n"
      "    traction: {pressure: 1 MPa, normal: [0, 1, 0], lo: [-1, 0.095, -1], hi: [0.05, 1, 1], rise_time: 1e-4}\n"
      "    shape: {box: {min: [0, 0], max: [0.1, 0.1]}}\n    spacing: 10 mm\n    velocity: [0, -2]\n"
      "  plate:\n    method: rigid_body\n    material: plate\n    fix_translation: [1, 1, 1]\n"
      "    fix_rotation: [1, 1, 1]\n    shape: {box: {min: [-0.02, -0.03], max: [0.12, -0.001]}}\n"
      "    spacing: 10 mm\n"
      "interactions:\n"
      "  - {model: rigid_indenter, sets: [col], shape: sphere, center: [0.08, 0.123, 0], velocity: [0, -5, 0],\n"
      "     radius: 0.03, K: 1e10}\n"
      "  - {model: repulsive_wall, sets: [col, plate], normal: [0, 1, 0], spacing: 0.01, coefficient: 0.02,\n"
      "     sound_speed: 224, h: 0.015}\n";
  const char *move[] = {"col/traction_work", "col/damping_dissipated", "rigid_indenter_0/work",
                        "repulsive_wall_1/work"};
  rs_state_case("rsww", text, 40, move, 4);
}
END_TEST

/* An sph water column on an sph_wall (its wall work). */
START_TEST(test_sph_wall_restart)
{
  static const char text[] =
      "ejecta: 1\ndimension: 2\ntime: {end: 10, cfl: 0.3}\n"
      "output: {file: out.h5, every: 10, fields: [v]}\n"
      "materials:\n  water: {rho0: 1000, eos: {model: polynomial, rho0: 1000, C1: 2.0e5}}\n  tank: {rho0: 1000}\n"
      "sets:\n  fluid:\n    method: sph\n    material: water\n    kernel: wendland_c2\n"
      "    shape: {box: {min: [0, 0], max: [0.1, 0.1]}}\n    spacing: 0.01\n    velocity: [0.5, -1]\n"
      "  wall:\n    method: rigid_body\n    material: tank\n    fix_translation: [1, 1, 1]\n"
      "    fix_rotation: [1, 1, 1]\n"
      "    shape: {box: {min: [-0.03, -0.03], max: [0.13, 0.2]}, minus: [{box: {min: [0, 0], max: [0.1, 0.21]}}]}\n"
      "    spacing: 0.01\n"
      "interactions:\n  - {model: sph_wall, sets: [fluid, wall], kernel: wendland_c2, slip: no_slip,"
      " gravity: [0, -9.81, 0]}\n"
      "gravity: [0, -9.81]\n";
  const char *move[] = {"sph_wall_0/work"};
  rs_state_case("rssw", text, 40, move, 1);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("restart_methods");
  TCase *tc = tcase_create("bitwise");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_rkpm_msnni_restart);
  tcase_add_test(tc, test_rkpm_lagrangian_fallback_restart);
  tcase_add_test(tc, test_tlpd_restart);
  tcase_add_test(tc, test_tlpd_restart_breaking);
  tcase_add_test(tc, test_rigid_contact_restart);
  tcase_add_test(tc, test_wall_work_restart);
  tcase_add_test(tc, test_sph_wall_restart);
  tcase_add_test(tc, test_sph_wall_gradient_restart);
  tcase_add_test(tc, test_probe_reference_restart);
  tcase_add_test(tc, test_body_contact_restart);
  tcase_add_test(tc, test_state_mismatch_refused);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
