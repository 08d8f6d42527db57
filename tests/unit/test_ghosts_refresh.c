/* Ghost refresh by need (core/src/particles.c ej_set_refresh_ghosts, plugin.h pass_writes, ABI
 * 1.3): before each pass the core copies to the ghosts only the fields written since the last
 * refresh. The ghosts it leaves must equal a full refresh, bitwise. EJECTA_GHOST_CHECK=1 makes
 * the core compare every partial refresh with a full one (ej_set_ghosts_stale) and stop with an
 * internal error at the first stale value; these runs must finish.
 *  - the SPH gas scene of bench/sph_throughput.py (periodic cube, jittered lattice, pressure bump)
 *    at 12^3 particles, 30 steps with several rebuilds, 1 and 2 threads; sph declares its passes'
 *    writes there, so the refresh is partial (checked);
 *  - the 3D Sod tube of test_determinism (symmetry and periodic ghosts), 20 steps;
 *  - the check itself: a source value changed behind the core's back is found stale, a refresh
 *    without the field marked leaves it stale, one with it marked repairs it; a run whose pass
 *    writes a field it does not name (p dropped from sph's particle-pass mask) stops with an
 *    internal error;
 *  - ej_set_permute in parallel (10007 particles, 1-3 threads) equals the serial gather. */
#include "validation_common.h"

#ifdef _OPENMP
#include <omp.h>
#endif

static const char *gas_scene =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1.0e6, cfl: 0.3, max_steps: 30}\n"
    "output: {file: gas.h5, every: 1.0e6, fields: [v, rho, p, h]}\n"
    "materials:\n"
    "  gas: {rho0: 1, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "sets:\n"
    "  gas:\n"
    "    method: sph\n"
    "    material: gas\n"
    "    h_factor: 1.205\n"
    "    shape: {box: {min: [0, 0, 0], max: [1, 1, 1]}}\n"
    "    spacing: 0.083333333333333329\n"
    "    jitter: 0.1\n"
    "    seed: 1\n"
    "    rho: 1\n"
    "    p: 1\n"
    "    initial: [{region: {sphere: {center: [0.5, 0.5, 0.5], radius: 0.3}}, p: 3}]\n"
    "boundaries:\n"
    "  - periodic: {axis: x, min: 0, max: 1}\n"
    "  - periodic: {axis: y, min: 0, max: 1}\n"
    "  - periodic: {axis: z, min: 0, max: 1}\n";

/* TL-PD with mirror ghosts (two symmetry planes), a strength model with history fields (added to
 * every pass mask by the core) and a critical stretch that breaks bonds within the run, so that
 * post_step rewrites rows (status, coefficient, H, damage) that the next passes read at the images. */
static const char *tlpd_scene =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1.0e6, cfl: 0.5, max_steps: 60}\n"
    "output: {file: pd.h5, every: 1.0e6, fields: [v, damage]}\n"
    "materials:\n"
    "  sand: {model: drucker_prager, rho0: 1700, E: 98.5 MPa, nu: 0.25, friction_angle: 0.5 rad,\n"
    "         dilation_angle: 0.2 rad, cohesion: 10 kPa}\n"
    "sets:\n"
    "  soil:\n"
    "    method: tlpd\n"
    "    material: sand\n"
    "    failure: {critical_stretch: 0.002}\n"
    "    shape: {box: {min: [0, 0, 0], max: [0.08, 0.08, 0.08]}}\n"
    "    spacing: 0.01\n"
    "    jitter: 0.05\n"
    "    seed: 3\n"
    "    initial: [{region: {box: {min: [-1, -1, 0.04], max: [1, 1, 1]}}, velocity: [5, -3, 40]}]\n"
    "boundaries:\n"
    "  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n"
    "  - symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}\n";

/* A gas charge against a TL-PD soil across two symmetry planes, coupled by pd_sph with decohesion
 * (pd_sph names its writes, ABI 1.11: the soil's images are no longer refreshed in full after every
 * coupling pass), and a second gas set coupled to the charge by continuum with the shape tensor, so
 * that continuum's pre-pass (M_cpl) runs too. */
static const char *coupled_scene =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1.0e6, cfl: 0.3, max_steps: 40}\n"
    "output: {file: cpl.h5, every: 1.0e6, fields: [v, damage]}\n"
    "materials:\n"
    "  gas: {rho0: 100, eos: {model: ideal_gas, gamma: 1.4}}\n"
    "  sand: {model: drucker_prager, rho0: 1700, E: 98.5 MPa, nu: 0.25, friction_angle: 0.5 rad,\n"
    "         dilation_angle: 0.2 rad, cohesion: 10 kPa}\n"
    "sets:\n"
    "  charge:\n"
    "    method: sph\n"
    "    material: gas\n"
    "    gradient: shape_tensor\n"
    "    shape: {box: {min: [0, 0, 0], max: [0.03, 0.03, 0.03]}}\n"
    "    spacing: 0.01\n"
    "    rho: 100\n"
    "    p: 50 MPa\n"
    "  air:\n"
    "    method: sph\n"
    "    material: gas\n"
    "    gradient: shape_tensor\n"
    "    shape: {box: {min: [0.03, 0, 0], max: [0.06, 0.03, 0.03]}}\n"
    "    spacing: 0.01\n"
    "    rho: 100\n"
    "    p: 1 MPa\n"
    "  soil:\n"
    "    method: tlpd\n"
    "    material: sand\n"
    "    failure: {critical_stretch: 0.002}\n"
    "    shape: {box: {min: [0, 0, 0.03], max: [0.06, 0.06, 0.07]}}\n"
    "    spacing: 0.01\n"
    "interactions:\n"
    "  - {model: pd_sph, sets: [charge, soil], pair_stress: both, decohesion_pressure: 20 MPa}\n"
    "  - {model: pd_sph, sets: [air, soil], pair_stress: both}\n"
    "  - {model: continuum, sets: [charge, air]}\n"
    "boundaries:\n"
    "  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n"
    "  - symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}\n";

/* SPH solid (strength: true) with the kernel correction, XSPH and the Balsara switch, against two
 * symmetry planes: every solid pass names its writes (2026-12-03). */
static const char *solid_scene =
    "ejecta: 1\n"
    "dimension: 3\n"
    "time: {end: 1.0e6, cfl: 0.3, max_steps: 30}\n"
    "output: {file: sol.h5, every: 1.0e6, fields: [v, stress]}\n"
    "materials:\n"
    "  al: {model: von_mises, rho0: 2700, E: 70 GPa, nu: 0.3, yield_stress: 50 MPa}\n"
    "sets:\n"
    "  block:\n"
    "    method: sph\n"
    "    strength: true\n"
    "    correction: true\n"
    "    xsph: 0.5\n"
    "    visc_switch: balsara\n"
    "    art_stress: true\n"
    "    material: al\n"
    "    shape: {box: {min: [0, 0, 0], max: [0.008, 0.008, 0.008]}}\n"
    "    spacing: 0.001\n"
    "    jitter: 0.05\n"
    "    seed: 5\n"
    "    initial: [{region: {box: {min: [-1, -1, 0.004], max: [1, 1, 1]}}, velocity: [20, 0, -150]}]\n"
    "boundaries:\n"
    "  - symmetry: {point: [0, 0, 0], normal: [1, 0, 0]}\n"
    "  - symmetry: {point: [0, 0, 0], normal: [0, 1, 0]}\n";

/* Runs dir/name with EJECTA_GHOST_CHECK=1; returns the number of rebuilds. */
/* A fresh test directory dir holding the scene text as dir/name. */
static void gr_scene(char *dir, size_t n, const char *name, const char *text)
{
  char path[160];
  vrun_dir(dir, n, "ghr");
  snprintf(path, sizeof path, "%s/%s", dir, name);
  vrun_write(path, text);
}

/* Removes what a run of dir/<stem>.yaml with output <stem>.h5 leaves, and dir. */
static void gr_cleanup(const char *dir, const char *stem)
{
  char f[5][64];
  const char *ext[5] = {".yaml", ".yaml.h5", ".yaml.xdmf", ".h5", ".xdmf"};
  const char *names[5];
  for (int k = 0; k < 5; ++k) snprintf(f[k], sizeof f[k], "%s%s", stem, ext[k]), names[k] = f[k];
  vrun_cleanup(dir, names, 5);
}

/* Whether a write mask of set s has the field name (which s must have). */
static bool gr_marks(uint64_t mask, const ej_set *s, const char *name)
{
  const int f = ej_set_find_field(s, name);
  ck_assert_msg(f >= 0, "set '%s' has no field '%s'", ej_set_name(s), name);
  return (mask >> f) & 1u;
}

/* Opens dir/name (output dir/name.h5) with EJECTA_GHOST_CHECK=1 for steps steps. */
static void gr_open(vrun *r, const char *dir, const char *name, int threads, int64_t steps)
{
  char scene[128], out[128];
  snprintf(scene, sizeof scene, "%s/%s", dir, name);
  snprintf(out, sizeof out, "%s/%s.h5", dir, name);
  ck_assert_int_eq(setenv("EJECTA_GHOST_CHECK", "1", 1), 0);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = threads};
  vrun_open(r, scene, &opts, steps);
  ck_assert(r->sim->ghost_check);
}

/* Runs what gr_open opened to its steps (fails on the first stale ghost); frees it unless keep. */
static void gr_finish(vrun *r, int64_t steps, bool keep)
{
  vrun_run(r); /* fails (ck_abort in vrun_run) on the first stale ghost */
  ck_assert_int_eq(r->sim->step, steps);
  if (!keep) vrun_free(r);
  ck_assert_int_eq(unsetenv("EJECTA_GHOST_CHECK"), 0);
}

static int64_t gr_run(const char *dir, const char *name, int threads, int64_t steps, bool partial)
{
  vrun r;
  gr_open(&r, dir, name, threads, steps);
  ej_set *s = r.sim->sets[0];
  ck_assert_int_gt(s->n_ghost, 0);
  if (partial) {
    /* sph names its writes for this configuration: pass 0 and 1 are not "every field" */
    ck_assert(s->pass_mask[1] != EJ_ALL_FIELDS);
    ck_assert(s->pass_mask[2] != EJ_ALL_FIELDS);
    ck_assert(s->pass_mask[0] != EJ_ALL_FIELDS);
    ck_assert(s->step_mask != EJ_ALL_FIELDS);
  }
  gr_finish(&r, steps, true); /* the check inside the run covered every pass */
  const int64_t nreb = r.sim->n_rebuilds;
  vrun_free(&r);
  return nreb;
}

START_TEST(test_gas_partial_refresh)
{
  char dir[64], path[160];
  vrun_dir(dir, sizeof dir, "ghr");
  snprintf(path, sizeof path, "%s/gas.yaml", dir);
  vrun_write(path, gas_scene);
  const int64_t nreb1 = gr_run(dir, "gas.yaml", 1, 30, true);
  const int64_t nreb2 = gr_run(dir, "gas.yaml", 2, 30, true);
  ck_assert_int_ge(nreb1, 3); /* the initial build and at least two rebuilds in the step loop */
  ck_assert_int_eq(nreb1, nreb2);
  const char *names[] = {"gas.yaml", "gas.yaml.h5", "gas.yaml.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

/* tlpd names its passes' writes (2026-12-03): the refresh is partial, and every partial refresh
 * equals a full one while bonds break (the in-run check); 1 and 2 threads. */
START_TEST(test_tlpd_partial_refresh)
{
  char dir[64];
  gr_scene(dir, sizeof dir, "pd.yaml", tlpd_scene);
  for (int threads = 1; threads <= 2; ++threads) {
    vrun r;
    gr_open(&r, dir, "pd.yaml", threads, 60);
    ej_set *s = r.sim->sets[0];
    ck_assert_int_gt(s->n_ghost, 0);
    for (int q = 0; q < 3; ++q) ck_assert(s->pass_mask[q] != EJ_ALL_FIELDS); /* post_step, pass 0, pass 1 */
    ck_assert(gr_marks(s->pass_mask[1], s, "F"));   /* pass 0 writes F */
    ck_assert(!gr_marks(s->pass_mask[2], s, "F"));  /* pass 1 does not */
    ck_assert(!gr_marks(s->pass_mask[1], s, "x0")); /* nobody writes x0 */
    gr_finish(&r, 60, true);
    const ej_real *damage = ej_set_field(s, "damage");
    ej_real dmax = 0;
    for (ej_idx i = 0; i < s->n; ++i) dmax = damage[i] > dmax ? damage[i] : dmax;
    ck_assert_msg(dmax > 0.05, "no bond broke (max damage %g): the case does not test post_step's writes", dmax);
    vrun_free(&r);
  }
  gr_cleanup(dir, "pd");
}
END_TEST

/* Interactions that name their writes (ABI 1.11): pd_sph's and continuum's passes mark only the
 * fields they write (no EJ_ALL_FIELDS), a set's images stay a full refresh's at every pass (in-run
 * check), 1 and 2 threads. */
START_TEST(test_coupling_partial_refresh)
{
  char dir[64];
  gr_scene(dir, sizeof dir, "cpl.yaml", coupled_scene);
  for (int threads = 1; threads <= 2; ++threads) {
    vrun r;
    gr_open(&r, dir, "cpl.yaml", threads, 40);
    ck_assert_int_eq(r.sim->n_inter, 3);
    for (int k = 0; k < 3; ++k) {
      const ej_inter *in = &r.sim->inter[k];
      const int npre = in->ops->n_pre_passes, np = in->ops->n_passes > 1 ? in->ops->n_passes : 1;
      for (int side = 0; side < 2; ++side)
        for (int q = 1; q <= npre + np; ++q)
          ck_assert_msg(in->wmask[side][q] != EJ_ALL_FIELDS, "interaction %d side %d mask %d", k, side, q);
      /* pass 0 writes a on either side, not x */
      ck_assert(gr_marks(in->wmask[0][1 + npre], in->a, "a"));
      ck_assert(!gr_marks(in->wmask[0][1 + npre], in->a, "x"));
    }
    for (int i = 0; i < r.sim->n_sets; ++i) ck_assert_int_gt(r.sim->sets[i]->n_ghost, 0);
    gr_finish(&r, 40, false);
  }
  gr_cleanup(dir, "cpl");
}
END_TEST

/* The SPH solid passes name their writes: partial masks, and the in-run check stays clean, 1 and 2
 * threads (gr_run asserts the partial masks of post_step and passes 0 and 1). */
START_TEST(test_solid_partial_refresh)
{
  char dir[64];
  gr_scene(dir, sizeof dir, "sol.yaml", solid_scene);
  gr_run(dir, "sol.yaml", 1, 30, true);
  gr_run(dir, "sol.yaml", 2, 30, true);
  gr_cleanup(dir, "sol");
}
END_TEST

START_TEST(test_tube_symmetry_ghosts)
{
  char dir[64], path[160];
  vrun_dir(dir, sizeof dir, "ghr");
  snprintf(path, sizeof path, "%s/tube.yaml", dir);
  char *text = sod_scene_text(3, 0.01, 0.2, 0.04, "tube.h5", NULL);
  vrun_write(path, text);
  free(text);
  gr_run(dir, "tube.yaml", 2, 20, false);
  const char *names[] = {"tube.yaml", "tube.yaml.h5", "tube.yaml.xdmf", "tube.h5", "tube.xdmf"};
  vrun_cleanup(dir, names, 5);
}
END_TEST

START_TEST(test_stale_detected)
{
  char dir[64], path[160], out[160];
  vrun_dir(dir, sizeof dir, "ghr");
  snprintf(path, sizeof path, "%s/gas.yaml", dir);
  snprintf(out, sizeof out, "%s/gas.h5", dir);
  vrun_write(path, gas_scene);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 2};
  vrun r;
  vrun_open(&r, path, &opts, 2);
  vrun_run(&r);
  ej_set *s = r.sim->sets[0];
  ej_set_update_ghosts(s, r.sim->xforms);
  ej_idx g = -1;
  ck_assert_int_eq(ej_set_ghosts_stale(s, r.sim->xforms, &g), -1);
  /* change the source of ghost 0 in field p (scalar) and x (a moved point) */
  const int fp = ej_set_find_field(s, "p");
  ck_assert_int_ge(fp, 0);
  ej_real *p = ej_set_field(s, "p");
  const ej_idx src = s->ghost_src[0];
  p[src] += 1.0;
  ck_assert_int_eq(ej_set_ghosts_stale(s, r.sim->xforms, &g), fp);
  ck_assert_int_eq(g, 0);
  s->ghost_dirty = 0; /* not marked: the refresh leaves it stale */
  ej_set_refresh_ghosts(s, r.sim->xforms);
  ck_assert_int_eq(ej_set_ghosts_stale(s, r.sim->xforms, &g), fp);
  s->ghost_dirty = UINT64_C(1) << fp; /* marked: repaired, and only p was copied */
  ej_set_refresh_ghosts(s, r.sim->xforms);
  ck_assert_int_eq(ej_set_ghosts_stale(s, r.sim->xforms, &g), -1);
  ck_assert(s->ghost_dirty == 0);
  ej_real *x = ej_set_field(s, "x");
  x[3 * src + 1] += 1e-3;
  s->ghost_dirty = UINT64_C(1) << s->f_x;
  ej_set_refresh_ghosts(s, r.sim->xforms);
  ck_assert_int_eq(ej_set_ghosts_stale(s, r.sim->xforms, &g), -1);
  /* a periodic image: the ghost is the source moved by a whole period, not the same point */
  const ej_real *xg = x + 3 * (size_t)(s->n + 0);
  ck_assert(memcmp(xg, x + 3 * (size_t)src, 3 * sizeof(ej_real)) != 0);
  vrun_free(&r);
  const char *names[] = {"gas.yaml", "gas.h5", "gas.xdmf"};
  vrun_cleanup(dir, names, 3);
}
END_TEST

/* A pass that writes a field it does not name: the in-run check stops at the first stale ghost. */
START_TEST(test_undeclared_write_caught)
{
  char dir[64], path[160], out[160];
  vrun_dir(dir, sizeof dir, "ghr");
  snprintf(path, sizeof path, "%s/gas.yaml", dir);
  snprintf(out, sizeof out, "%s/gas.h5", dir);
  vrun_write(path, gas_scene);
  ck_assert_int_eq(setenv("EJECTA_GHOST_CHECK", "1", 1), 0);
  ej_run_opts opts = {.struct_size = sizeof opts, .output = out, .threads = 2};
  vrun r;
  vrun_open(&r, path, &opts, 3);
  ej_set *s = r.sim->sets[0];
  const int fp = ej_set_find_field(s, "p");
  ck_assert_int_ge(fp, 0);
  s->pass_mask[1] &= ~(UINT64_C(1) << fp); /* pass 0 (particle pass) writes p without saying so */
  const ej_err rc = ej_sim_run(r.sim);
  ck_assert_int_eq(rc, EJ_ERR_INTERNAL);
  ej_error_clear();
  vrun_free(&r);
  ck_assert_int_eq(unsetenv("EJECTA_GHOST_CHECK"), 0);
  const char *names[] = {"gas.yaml", "gas.h5", "gas.xdmf", "gas.h5.partial"};
  vrun_cleanup(dir, names, 4);
}
END_TEST

/* ej_set_permute, parallel above 4096 particles (each thread gathers its own range into its
 * own part of the scratch): every field width (int, scalar, vec3, sym6, tensor9) and the
 * boundary-condition masks land where a serial gather puts them, with 1, 2 and 3 threads. */
START_TEST(test_permute_parallel)
{
  const ej_idx n = 10007;
  static const ej_field_decl extra[] = {
      {.name = "s6", .kind = EJ_SYM6, .unit = "1", .doc = "test"},
      {.name = "t9", .kind = EJ_TENSOR9, .unit = "1", .doc = "test"},
      {.name = "k", .kind = EJ_INT, .unit = "1", .doc = "test"}};
  ej_idx *perm = malloc((size_t)n * sizeof *perm);
  ck_assert_ptr_nonnull(perm);
  for (ej_idx i = 0; i < n; ++i) perm[i] = i;
  uint64_t r = 12345;
  for (ej_idx i = n - 1; i > 0; --i) { /* Fisher-Yates with a fixed LCG */
    r = r * 6364136223846793005ull + 1442695040888963407ull;
    const ej_idx j = (ej_idx)((r >> 33) % (uint64_t)(i + 1)), t = perm[i];
    perm[i] = perm[j], perm[j] = t;
  }
  for (int threads = 1; threads <= 3; ++threads) {
    ej_set *s = NULL;
    ck_assert_int_eq(ej_set_create("perm", 0, 3, &s), EJ_OK);
    for (int k = 0; k < 3; ++k) ck_assert_int_eq(ej_set_add_field(s, &extra[k], NULL), EJ_OK);
    ck_assert_int_eq(ej_set_reserve(s, n + 100), EJ_OK);
    s->n = n;
    /* value of component q of particle i in field f: unique, so any misplacement shows */
    for (int f = 0; f < s->n_fields; ++f) {
      const ej_field *F = &s->fields[f];
      for (ej_idx i = 0; i < n; ++i)
        for (int q = 0; q < F->ncomp; ++q) {
          if (F->kind == EJ_INT) ((int32_t *)F->data)[i] = 1000 * f + i;
          else ((ej_real *)F->data)[(size_t)i * F->ncomp + q] = 1e6 * f + 10.0 * i + q;
        }
    }
    for (ej_idx i = 0; i < n; ++i) s->bc_mask[i] = (uint32_t)(7 * i);
#ifdef _OPENMP
    omp_set_num_threads(threads);
#endif
    ck_assert_int_eq(ej_set_permute(s, perm), EJ_OK);
    for (int f = 0; f < s->n_fields; ++f) {
      const ej_field *F = &s->fields[f];
      for (ej_idx i = 0; i < n; ++i)
        for (int q = 0; q < F->ncomp; ++q) {
          if (F->kind == EJ_INT) ck_assert_int_eq(((int32_t *)F->data)[i], 1000 * f + perm[i]);
          else
            ck_assert_msg(((ej_real *)F->data)[(size_t)i * F->ncomp + q] == 1e6 * f + 10.0 * perm[i] + q,
                          "field %s, particle %d, %d threads", F->name, (int)i, threads);
        }
    }
    for (ej_idx i = 0; i < n; ++i) ck_assert_uint_eq(s->bc_mask[i], (uint32_t)(7 * perm[i]));
    ck_assert(s->ghost_dirty == EJ_ALL_FIELDS);
    ej_set_destroy(s);
  }
#ifdef _OPENMP
  omp_set_num_threads(1);
#endif
  free(perm);
}
END_TEST

int main(void)
{
  Suite *s = suite_create("ghosts_refresh");
  TCase *tc = tcase_create("refresh");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_gas_partial_refresh);
  tcase_add_test(tc, test_tlpd_partial_refresh);
  tcase_add_test(tc, test_coupling_partial_refresh);
  tcase_add_test(tc, test_solid_partial_refresh);
  tcase_add_test(tc, test_tube_symmetry_ghosts);
  tcase_add_test(tc, test_stale_detected);
  tcase_add_test(tc, test_undeclared_write_caught);
  tcase_add_test(tc, test_permute_parallel);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
