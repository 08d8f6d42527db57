/* HDF5 output: file layout, series buffering, XDMF sidecar, checkpoint round trip, failure
 * paths. The sim is assembled by hand (no scene file, no plugins) so only output.c and the
 * particle sets are exercised. */
#define _POSIX_C_SOURCE 200809L

#include <check.h>
#include <hdf5.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core_impl.h"
#include "test_tmpdir.h"

#define N_CHARGE 7
#define N_SOIL 5
#define N_GHOST 2
#define N_ROWS 3000 /* crosses the 1024-row series buffer twice */

static const char scene_text[] = "ejecta: 1\n"
                                 "dimension: 3\n"
                                 "# unicode and markup survive verbatim: \xc2\xb5s <a> & \"q\"\n"
                                 "output: {file: out/run.h5, every: 20 us}\n";

typedef struct fixture {
  char dir[64];
  char path[128];
  ej_doc doc;
  ej_scene scene;
  ej_sim sim;
  ej_set *sets[2];
} fixture;

static bool exists(const char *p)
{
  struct stat st;
  return stat(p, &st) == 0;
}

/* Distinct, non-round values so a byte-level mismatch anywhere shows. */
static double pattern(int set, int field, int i, int c, int salt)
{
  return sin(1.0 + set * 0.37 + field * 1.13 + i * 0.071 + c * 0.0023 + salt * 0.5) * 1e3 / 3.0;
}

static void fill_set(ej_set *s, int set, int salt)
{
  ej_idx all = s->n + s->n_ghost;
  for (int f = 0; f < s->n_fields; ++f) {
    ej_field *fd = &s->fields[f];
    for (ej_idx i = 0; i < all; ++i)
      for (int c = 0; c < fd->ncomp; ++c) {
        if (fd->kind == EJ_INT)
          ((int32_t *)fd->data)[i] = 1000 * set + 37 * f + 3 * (int)i + salt;
        else
          ((double *)fd->data)[(size_t)i * fd->ncomp + c] = pattern(set, f, (int)i, c, salt);
      }
  }
  for (ej_idx i = 0; i < all; ++i) s->bc_mask[i] = (uint32_t)(i * 3 + set + salt);
}

static ej_set *make_set(const char *name, int index, ej_idx n, const ej_field_decl *extra, int n_extra)
{
  ej_set *s = NULL;
  ck_assert_int_eq(ej_set_create(name, index, 3, &s), EJ_OK);
  for (int k = 0; k < n_extra; ++k) ck_assert_int_eq(ej_set_add_field(s, &extra[k], NULL), EJ_OK);
  ck_assert_int_eq(ej_set_reserve(s, n + N_GHOST), EJ_OK);
  s->n = n;
  s->n_ghost = N_GHOST; /* ghosts must never reach the file */
  return s;
}

static const ej_field_decl charge_fields[] = {
    {.name = "rho", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "kg/m^3", .rate = "rho_rate"},
    {.name = "stress", .kind = EJ_SYM6, .flags = EJ_FIELD_OUTPUT, .unit = "Pa"},
    {.name = "burnt", .kind = EJ_INT, .flags = EJ_FIELD_OUTPUT, .unit = "1"},
    {.name = "tmp", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH | EJ_FIELD_OUTPUT, .unit = "1"},
};
static const ej_field_decl soil_fields[] = {
    {.name = "F", .kind = EJ_TENSOR9, .unit = "1"},
    {.name = "damage", .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "1"},
    {.name = "bonds", .kind = EJ_INT, .unit = "1"},
    {.name = "work", .kind = EJ_SCALAR, .flags = EJ_FIELD_SCRATCH, .unit = "J"},
};

static void fixture_init(fixture *fx)
{
  memset(fx, 0, sizeof *fx);
  ej_test_tmpdir(fx->dir, sizeof fx->dir, "output");
  /* Two missing levels: open must create them. */
  snprintf(fx->path, sizeof fx->path, "%s/a/b/run.h5", fx->dir);
  fx->doc.path = "scenes/run.yaml";
  fx->doc.text = (char *)scene_text;
  fx->doc.text_len = sizeof scene_text - 1;
  fx->scene.doc = &fx->doc;
  fx->scene.dimension = 3;
  fx->scene.output_loc = (ej_loc){"scenes/run.yaml", 4, 15};
  fx->sets[0] = make_set("charge", 0, N_CHARGE, charge_fields, 4);
  fx->sets[1] = make_set("soil", 1, N_SOIL, soil_fields, 4);
  fill_set(fx->sets[0], 0, 0);
  fill_set(fx->sets[1], 1, 0);
  fx->sim.scene = &fx->scene;
  fx->sim.reg = NULL;
  fx->sim.dim = 3;
  fx->sim.n_sets = 2;
  fx->sim.sets = fx->sets;
  ej_error_clear();
}

static void remove_tree(const char *dir)
{
  ej_test_rmtree(dir);
}

static void fixture_fini(fixture *fx)
{
  ej_set_destroy(fx->sets[0]);
  ej_set_destroy(fx->sets[1]);
  remove_tree(fx->dir);
}

static void series_row(ej_sim *sim, int k)
{
  sim->t = k * 1e-7;
  sim->step = k;
  sim->dt = 1e-7 + k * 1e-12;
  sim->energy.kinetic = 1.5 * k;
  sim->energy.internal = 2.5 * k + 1;
  sim->energy.viscous = k * 0.25;
  sim->energy.plastic = k * 0.125;
  sim->energy.hourglass = -k * 1e-3;
  sim->energy.work_gravity = sim->energy.external = k * 3.0;
  sim->energy.balance = 1e-9 * k;
  sim->energy.momentum[0] = k;
  sim->energy.momentum[1] = -k;
  sim->energy.momentum[2] = k * 0.5;
}

/* Writes two frames, N_ROWS series rows and two checkpoints (the second replaces the first). */
static void write_run(fixture *fx)
{
  ej_output *out = NULL;
  ck_assert_int_eq(ej_output_open(&out, &fx->sim, fx->path), EJ_OK);
  char partial[160];
  snprintf(partial, sizeof partial, "%s.partial", fx->path);
  ck_assert(exists(partial));
  ck_assert(!exists(fx->path));

  fx->sim.t = 0;
  fx->sim.step = 0;
  fx->sim.frame = 0;
  ck_assert_int_eq(ej_output_frame(out, &fx->sim), EJ_OK);
  fx->sim.frame++;
  for (int k = 0; k < N_ROWS; ++k) {
    series_row(&fx->sim, k);
    ck_assert_int_eq(ej_output_series(out, &fx->sim), EJ_OK);
    if (k == 1500) ck_assert_int_eq(ej_output_checkpoint(out, &fx->sim), EJ_OK);
  }
  fill_set(fx->sets[0], 0, 1);
  fill_set(fx->sets[1], 1, 1);
  ck_assert_int_eq(ej_output_frame(out, &fx->sim), EJ_OK);
  fx->sim.frame++;
  fx->sim.n_rebuilds = 42;
  fx->sim.next_output = 0.125;
  fx->sim.next_checkpoint = 0.375;
  fx->sim.energy.total0 = 12345.678;
  ck_assert_int_eq(ej_output_checkpoint(out, &fx->sim), EJ_OK);
  ck_assert_int_eq(ej_output_close(out, true), EJ_OK);
  ck_assert(!exists(partial));
  ck_assert(exists(fx->path));
}

static char *read_text(hid_t f, const char *name, size_t *len)
{
  hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  ck_assert_int_ge(d, 0);
  hid_t t = H5Dget_type(d);
  size_t n = H5Tget_size(t);
  char *s = calloc(n + 1, 1);
  ck_assert_int_ge(H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, s), 0);
  H5Tclose(t);
  H5Dclose(d);
  *len = strnlen(s, n);
  return s;
}

static char *attr_text(hid_t loc, const char *name)
{
  hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
  ck_assert_int_ge(a, 0);
  hid_t t = H5Aget_type(a);
  size_t n = H5Tget_size(t);
  char *s = calloc(n + 1, 1);
  ck_assert_int_ge(H5Aread(a, t, s), 0);
  H5Tclose(t);
  H5Aclose(a);
  return s;
}

static double attr_double(hid_t loc, const char *name)
{
  double v = NAN;
  hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
  ck_assert_int_ge(a, 0);
  ck_assert_int_ge(H5Aread(a, H5T_NATIVE_DOUBLE, &v), 0);
  H5Aclose(a);
  return v;
}

static int64_t attr_int(hid_t loc, const char *name)
{
  int64_t v = -1;
  hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
  ck_assert_int_ge(a, 0);
  ck_assert_int_ge(H5Aread(a, H5T_NATIVE_INT64, &v), 0);
  H5Aclose(a);
  return v;
}

static bool has(hid_t f, const char *path) { return H5Lexists(f, path, H5P_DEFAULT) > 0; }

/* Dataset path must hold the owned prefix of field name of s, bit for bit. */
static void check_dataset(hid_t f, const char *path, const ej_set *s, const char *name, const char *kind)
{
  int k = ej_set_find_field(s, name);
  ck_assert_int_ge(k, 0);
  const ej_field *fd = &s->fields[k];
  hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
  ck_assert_msg(d >= 0, "missing %s", path);
  hid_t sp = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  int rank = H5Sget_simple_extent_dims(sp, dims, NULL);
  ck_assert_int_eq(rank, fd->ncomp == 1 ? 1 : 2);
  ck_assert_int_eq(dims[0], s->n);
  if (rank == 2) ck_assert_int_eq(dims[1], fd->ncomp);
  size_t bytes = (size_t)s->n * fd->ncomp * (fd->kind == EJ_INT ? 4 : 8);
  void *buf = malloc(bytes + 8);
  ck_assert_int_ge(H5Dread(d, fd->kind == EJ_INT ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL,
                           H5P_DEFAULT, buf),
                   0);
  ck_assert_msg(memcmp(buf, fd->data, bytes) == 0, "%s differs", path);
  char *kd = attr_text(d, "kind");
  ck_assert_str_eq(kd, kind);
  free(kd);
  char *unit = attr_text(d, "unit");
  ck_assert_str_eq(unit, fd->unit ? fd->unit : "");
  free(unit);
  free(buf);
  H5Sclose(sp);
  H5Dclose(d);
}

static char *slurp(const char *path)
{
  FILE *f = fopen(path, "rb");
  ck_assert_ptr_nonnull(f);
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *s = calloc((size_t)n + 1, 1);
  ck_assert_int_eq(fread(s, 1, (size_t)n, f), (size_t)n);
  fclose(f);
  return s;
}

START_TEST(test_file_layout)
{
  fixture fx;
  fixture_init(&fx);
  write_run(&fx);
  hid_t f = H5Fopen(fx.path, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);

  size_t len;
  char *s = read_text(f, "/meta/scene", &len);
  ck_assert_int_eq(len, sizeof scene_text - 1);
  ck_assert(memcmp(s, scene_text, len) == 0);
  free(s);
  s = read_text(f, "/meta/scene_file", &len);
  ck_assert_str_eq(s, "scenes/run.yaml");
  free(s);
  s = read_text(f, "/meta/ejecta_version", &len);
  ck_assert_str_eq(s, EJ_VERSION);
  free(s);
  s = read_text(f, "/meta/build_signature", &len);
  ck_assert_str_eq(s, EJ_BUILD_SIGNATURE);
  free(s);
  s = read_text(f, "/meta/plugins", &len);
  ck_assert_int_eq(len, 0); /* no registry: empty list */
  free(s);
  int32_t dim = 0;
  hid_t d = H5Dopen2(f, "/meta/dimension", H5P_DEFAULT);
  ck_assert_int_ge(H5Dread(d, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, &dim), 0);
  H5Dclose(d);
  ck_assert_int_eq(dim, 3);

  /* Frame 1 holds the second fill (salt 1), the state still in the sets. */
  hid_t fr = H5Gopen2(f, "/frames/000001", H5P_DEFAULT);
  ck_assert_int_ge(fr, 0);
  ck_assert(attr_double(fr, "time") == (N_ROWS - 1) * 1e-7);
  ck_assert_int_eq(attr_int(fr, "step"), N_ROWS - 1);
  hid_t g = H5Gopen2(fr, "charge", H5P_DEFAULT);
  ck_assert_int_eq(attr_int(g, "count"), N_CHARGE);
  H5Gclose(g);
  H5Gclose(fr);
  check_dataset(f, "/frames/000001/charge/x", fx.sets[0], "x", "vec3");
  check_dataset(f, "/frames/000001/charge/id", fx.sets[0], "id", "int");
  check_dataset(f, "/frames/000001/charge/v", fx.sets[0], "v", "vec3");
  check_dataset(f, "/frames/000001/charge/rho", fx.sets[0], "rho", "scalar");
  check_dataset(f, "/frames/000001/charge/stress", fx.sets[0], "stress", "sym6");
  check_dataset(f, "/frames/000001/charge/burnt", fx.sets[0], "burnt", "int");
  check_dataset(f, "/frames/000001/charge/tmp", fx.sets[0], "tmp", "scalar");
  check_dataset(f, "/frames/000001/soil/x", fx.sets[1], "x", "vec3");
  check_dataset(f, "/frames/000001/soil/damage", fx.sets[1], "damage", "scalar");
  /* Not flagged for output. */
  ck_assert(!has(f, "/frames/000001/charge/a"));
  ck_assert(!has(f, "/frames/000001/charge/rho_rate"));
  ck_assert(!has(f, "/frames/000001/soil/F"));
  ck_assert(!has(f, "/frames/000001/soil/bonds"));
  ck_assert(has(f, "/frames/000000/soil/x"));
  ck_assert(!has(f, "/frames/000002"));

  /* Series: every row, in order, across the buffer flushes. */
  const char *cols[] = {"t", "step", "kinetic", "momentum_y", "balance"};
  for (int c = 0; c < 5; ++c) {
    char name[64];
    snprintf(name, sizeof name, "/series/energy/%s", cols[c]);
    d = H5Dopen2(f, name, H5P_DEFAULT);
    ck_assert_int_ge(d, 0);
    hid_t sp = H5Dget_space(d);
    ck_assert_int_eq(H5Sget_simple_extent_npoints(sp), N_ROWS);
    H5Sclose(sp);
    double *v = malloc(sizeof(double) * N_ROWS);
    ck_assert_int_ge(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v), 0);
    H5Dclose(d);
    for (int k = 0; k < N_ROWS; ++k) {
      ej_sim row = {0};
      series_row(&row, k);
      double want[] = {row.t, (double)row.step, row.energy.kinetic, row.energy.momentum[1], row.energy.balance};
      ck_assert_msg(v[k] == want[c], "series %s row %d", cols[c], k);
    }
    free(v);
  }
  ck_assert(has(f, "/series/energy/momentum_z"));
  ck_assert(has(f, "/series/energy/hourglass"));

  /* One checkpoint left, the second. */
  ck_assert(has(f, "/checkpoint"));
  ck_assert(!has(f, "/checkpoint_partial"));
  hid_t cp = H5Gopen2(f, "/checkpoint", H5P_DEFAULT);
  ck_assert_int_eq(attr_int(cp, "format_version"), 2);
  ck_assert_int_eq(attr_int(cp, "frame"), 2);
  ck_assert_int_eq(attr_int(cp, "n_rebuilds"), 42);
  H5Gclose(cp);
  ck_assert(has(f, "/checkpoint/charge/rho_rate"));
  ck_assert(has(f, "/checkpoint/charge/burnt"));
  ck_assert(!has(f, "/checkpoint/charge/tmp"));
  ck_assert(!has(f, "/checkpoint/charge/v_half"));
  ck_assert(!has(f, "/checkpoint/soil/work"));
  {
    int cells[7];
    hid_t d = H5Dopen2(f, "/xdmf/vertices_7", H5P_DEFAULT);
    ck_assert(d >= 0 && H5Dread(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, cells) >= 0);
    for (int k = 0; k < 7; ++k) ck_assert_int_eq(cells[k], k);
    H5Dclose(d);
  }
  check_dataset(f, "/checkpoint/soil/F", fx.sets[1], "F", "tensor9");
  H5Fclose(f);

  /* XDMF: next to the file, names the final file and every written field. */
  char xdmf[160];
  snprintf(xdmf, sizeof xdmf, "%s/a/b/run.xdmf", fx.dir);
  ck_assert(exists(xdmf));
  char xpartial[170];
  snprintf(xpartial, sizeof xpartial, "%s.partial", xdmf);
  ck_assert(!exists(xpartial));
  char *x = slurp(xdmf);
  ck_assert_ptr_nonnull(strstr(x, "run.h5:/frames/000000/charge/x"));
  ck_assert_ptr_nonnull(strstr(x, "run.h5:/frames/000001/soil/damage"));
  ck_assert_ptr_null(strstr(x, ".partial"));
  const char *names[] = {"\"id\"", "\"v\"", "\"rho\"", "\"stress\"", "\"burnt\"", "\"damage\""};
  for (int k = 0; k < 6; ++k) ck_assert_msg(strstr(x, names[k]) != NULL, "xdmf lacks %s", names[k]);
  ck_assert_ptr_nonnull(strstr(x, "AttributeType=\"Tensor6\""));
  ck_assert_ptr_nonnull(strstr(x, "CollectionType=\"Temporal\""));
  ck_assert_ptr_nonnull(strstr(x, "NumberOfElements=\"7\""));
  /* Vertex cells listed (XDMF 3 readers build none without them): the set of 7 points. */
  ck_assert_ptr_nonnull(strstr(x, "run.h5:/xdmf/vertices_7</DataItem>"));
  free(x);
  if (system("command -v xmllint >/dev/null 2>&1") == 0) {
    char cmd[256];
    snprintf(cmd, sizeof cmd, "xmllint --noout '%s'", xdmf);
    ck_assert_int_eq(system(cmd), 0);
  } else {
    fprintf(stderr, "note: xmllint not found, XDMF well-formedness not checked\n");
  }
  fixture_fini(&fx);
}
END_TEST

static ej_err register_nothing(ej_registry *reg)
{
  (void)reg;
  return EJ_OK;
}
EJ_PLUGIN_DEFINE(output_probe, "9.8.7", "MIT", "registers nothing", register_nothing)

START_TEST(test_output_field_list)
{
  fixture fx;
  fixture_init(&fx);
  char *list[] = {"damage", "x"};
  fx.scene.n_output_fields = 2;
  fx.scene.output_fields = list;
  ej_registry *reg = NULL;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_output_probe_info()), EJ_OK);
  fx.sim.reg = reg;
  ej_output *out = NULL;
  ck_assert_int_eq(ej_output_open(&out, &fx.sim, fx.path), EJ_OK);
  ej_registry_destroy(reg);
  ck_assert_int_eq(ej_output_frame(out, &fx.sim), EJ_OK);
  ck_assert_int_eq(ej_output_close(out, true), EJ_OK);
  hid_t f = H5Fopen(fx.path, H5F_ACC_RDONLY, H5P_DEFAULT);
  ck_assert_int_ge(f, 0);
  ck_assert(has(f, "/frames/000000/soil/damage"));
  ck_assert(has(f, "/frames/000000/soil/x"));
  ck_assert(has(f, "/frames/000000/soil/id"));
  ck_assert(has(f, "/frames/000000/charge/x"));
  ck_assert(!has(f, "/frames/000000/charge/rho"));
  ck_assert(!has(f, "/frames/000000/soil/v"));
  size_t len;
  char *plugins = read_text(f, "/meta/plugins", &len);
  ck_assert_ptr_nonnull(strstr(plugins, "output_probe 9.8.7 (linked)\n"));
  free(plugins);
  hid_t g = H5Gopen2(f, "/frames/000000/soil", H5P_DEFAULT);
  H5G_info_t info;
  H5Gget_info(g, &info);
  ck_assert_int_eq(info.nlinks, 3);
  H5Gclose(g);
  /* No rows: the series exist, empty. */
  hid_t d = H5Dopen2(f, "/series/energy/t", H5P_DEFAULT);
  hid_t sp = H5Dget_space(d);
  ck_assert_int_eq(H5Sget_simple_extent_npoints(sp), 0);
  H5Sclose(sp);
  H5Dclose(d);
  H5Fclose(f);
  fixture_fini(&fx);
}
END_TEST

/* Every non-scratch field and bc mask of every set, bitwise. */
static void assert_sets_equal(ej_set *const *a, ej_set *const *b)
{
  for (int k = 0; k < 2; ++k) {
    ck_assert_int_eq(a[k]->n, b[k]->n);
    for (int f = 0; f < a[k]->n_fields; ++f) {
      const ej_field *fa = &a[k]->fields[f], *fb = &b[k]->fields[f];
      if (fa->flags & EJ_FIELD_SCRATCH) continue;
      size_t bytes = (size_t)a[k]->n * fa->ncomp * (fa->kind == EJ_INT ? 4 : 8);
      ck_assert_msg(memcmp(fa->data, fb->data, bytes) == 0, "set %s field %s differs", a[k]->name, fa->name);
    }
    ck_assert(memcmp(a[k]->bc_mask, b[k]->bc_mask, (size_t)a[k]->n * 4) == 0);
  }
}

START_TEST(test_checkpoint_roundtrip)
{
  fixture fx;
  fixture_init(&fx);
  write_run(&fx);
  ej_sim saved = fx.sim;

  /* Reference copy of the state that was checkpointed last (salt 1). */
  fixture ref;
  fixture_init(&ref);
  fill_set(ref.sets[0], 0, 1);
  fill_set(ref.sets[1], 1, 1);

  /* Disturb everything, then restore. */
  fill_set(fx.sets[0], 0, 7);
  fill_set(fx.sets[1], 1, 7);
  fx.sim.t = fx.sim.dt = -1;
  fx.sim.step = fx.sim.n_rebuilds = fx.sim.frame = -1;
  fx.sim.next_output = fx.sim.next_checkpoint = -1;
  fx.sim.energy.work_gravity = fx.sim.energy.total0 = -1;
  ck_assert_int_eq(ej_checkpoint_read(fx.path, &fx.sim), EJ_OK);
  ck_assert_int_eq(fx.sets[0]->n_ghost, 0);
  assert_sets_equal(fx.sets, ref.sets);
  ck_assert(fx.sim.t == saved.t && fx.sim.dt == saved.dt);
  ck_assert_int_eq(fx.sim.step, saved.step);
  ck_assert_int_eq(fx.sim.n_rebuilds, 42);
  ck_assert_int_eq(fx.sim.frame, 2);
  ck_assert(fx.sim.next_output == 0.125 && fx.sim.next_checkpoint == 0.375);
  ck_assert(fx.sim.energy.work_gravity == saved.energy.work_gravity && fx.sim.energy.total0 == 12345.678);

  /* A fresh sim with no particles yet grows to the checkpoint's counts. */
  ej_set *fresh[2];
  fresh[0] = make_set("charge", 0, 0, charge_fields, 4);
  fresh[1] = make_set("soil", 1, 0, soil_fields, 4);
  fresh[0]->n_ghost = fresh[1]->n_ghost = 0;
  ej_sim sim2 = {.scene = &fx.scene, .dim = 3, .n_sets = 2, .sets = fresh};
  ck_assert_int_eq(ej_checkpoint_read(fx.path, &sim2), EJ_OK);
  assert_sets_equal(fresh, ref.sets);
  ej_set_destroy(fresh[0]);
  ej_set_destroy(fresh[1]);
  fixture_fini(&ref);
  fixture_fini(&fx);
}
END_TEST

static void assert_input_error(const char *needle)
{
  ck_assert_int_eq(ej_error_last_code(), EJ_ERR_INPUT);
  const ej_error_frame *cause = ej_error_cause();
  ck_assert_ptr_nonnull(cause);
  ck_assert_msg(strstr(cause->msg, needle) != NULL, "message '%s' lacks '%s'", cause->msg, needle);
  ej_error_clear();
}

START_TEST(test_restart_errors)
{
  fixture fx;
  fixture_init(&fx);
  char missing[160];
  snprintf(missing, sizeof missing, "%s/nope.h5", fx.dir);
  ck_assert_int_eq(ej_checkpoint_read(missing, &fx.sim), EJ_ERR_INPUT);
  assert_input_error("cannot restart from");

  /* A finished file without a checkpoint. */
  char empty[160];
  snprintf(empty, sizeof empty, "%s/empty.h5", fx.dir);
  ej_output *out = NULL;
  ck_assert_int_eq(ej_output_open(&out, &fx.sim, empty), EJ_OK);
  ck_assert_int_eq(ej_output_close(out, true), EJ_OK);
  ck_assert_int_eq(ej_checkpoint_read(empty, &fx.sim), EJ_ERR_INPUT);
  assert_input_error("no checkpoint in file");
  const ej_error_frame *cause;

  /* Not HDF5 at all. */
  char xdmf[160];
  snprintf(xdmf, sizeof xdmf, "%s/empty.xdmf", fx.dir);
  ck_assert_int_eq(ej_checkpoint_read(xdmf, &fx.sim), EJ_ERR_INPUT);
  assert_input_error("not an HDF5 file");

  write_run(&fx);
  /* A scene with a set the checkpoint lacks. */
  free(fx.sets[1]->name);
  fx.sets[1]->name = ej_strdup("rock");
  ck_assert_int_eq(ej_checkpoint_read(fx.path, &fx.sim), EJ_ERR_INPUT);
  cause = ej_error_cause();
  ck_assert_str_eq(cause->where.file, fx.path);
  assert_input_error("no set 'rock'");
  free(fx.sets[1]->name);
  fx.sets[1]->name = ej_strdup("soil");

  /* A field the checkpoint lacks, and one of another kind. */
  ej_field_decl extra = {.name = "porosity", .kind = EJ_SCALAR, .unit = "1"};
  ck_assert_int_eq(ej_set_add_field(fx.sets[1], &extra, NULL), EJ_OK);
  ck_assert_int_eq(ej_checkpoint_read(fx.path, &fx.sim), EJ_ERR_INPUT);
  assert_input_error("set 'soil' has no field 'porosity'");
  fx.sets[1]->n_fields--;
  ej_free(fx.sets[1]->fields[fx.sets[1]->n_fields].data);
  int k = ej_set_find_field(fx.sets[1], "damage");
  fx.sets[1]->fields[k].kind = EJ_INT; /* same bytes per particle would not hide it */
  ck_assert_int_eq(ej_checkpoint_read(fx.path, &fx.sim), EJ_ERR_INPUT);
  assert_input_error("field 'damage' of set 'soil'");
  fx.sets[1]->fields[k].kind = EJ_SCALAR;
  fixture_fini(&fx);
}
END_TEST

START_TEST(test_failure_leaves_nothing)
{
  fixture fx;
  fixture_init(&fx);
  ej_output *out = NULL;
  ck_assert_int_eq(ej_output_open(&out, &fx.sim, fx.path), EJ_OK);
  ck_assert_int_eq(ej_output_frame(out, &fx.sim), EJ_OK);
  ck_assert_int_eq(ej_output_series(out, &fx.sim), EJ_OK);
  ck_assert_int_eq(ej_output_checkpoint(out, &fx.sim), EJ_OK);
  ck_assert_int_eq(ej_output_close(out, false), EJ_OK);
  char p[160];
  snprintf(p, sizeof p, "%s.partial", fx.path);
  ck_assert(!exists(p));
  ck_assert(!exists(fx.path));
  snprintf(p, sizeof p, "%s/a/b/run.xdmf", fx.dir);
  ck_assert(!exists(p));
  ck_assert_int_eq(ej_output_close(NULL, true), EJ_OK);
  ck_assert_int_eq(ej_output_close(NULL, false), EJ_OK);
  fixture_fini(&fx);
}
END_TEST

START_TEST(test_unwritable_path)
{
  fixture fx;
  fixture_init(&fx);
  ej_output *out = (ej_output *)&fx; /* must be reset to NULL */
  ck_assert_int_eq(ej_output_open(&out, &fx.sim, "/proc/forbidden/x.h5"), EJ_ERR_INPUT);
  ck_assert_ptr_null(out);
  const ej_error_frame *cause = ej_error_cause();
  ck_assert_ptr_nonnull(cause);
  ck_assert_str_eq(cause->where.file, "scenes/run.yaml");
  ck_assert_int_eq(cause->where.line, 4);
  assert_input_error("cannot write output file '/proc/forbidden/x.h5': ");

  /* The directory exists but the file cannot be created in it (a directory is in the way). */
  char dir[160];
  snprintf(dir, sizeof dir, "%s/x.h5.partial", fx.dir);
  ck_assert_int_eq(mkdir(dir, 0777), 0);
  char path[160];
  snprintf(path, sizeof path, "%s/x.h5", fx.dir);
  ck_assert_int_eq(ej_output_open(&out, &fx.sim, path), EJ_ERR_INPUT);
  assert_input_error("cannot write output file");
  fixture_fini(&fx);
}
END_TEST

static Suite *output_suite(void)
{
  Suite *s = suite_create("output");
  TCase *tc = tcase_create("hdf5");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_file_layout);
  tcase_add_test(tc, test_output_field_list);
  tcase_add_test(tc, test_checkpoint_roundtrip);
  tcase_add_test(tc, test_restart_errors);
  tcase_add_test(tc, test_failure_leaves_nothing);
  tcase_add_test(tc, test_unwritable_path);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(output_suite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
