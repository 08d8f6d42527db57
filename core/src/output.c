/* HDF5 output: one file per run (DESIGN.md "Output").
 *
 * The file is written as PATH.partial and renamed to PATH only when the run succeeds, so a
 * file under the final name is always whole; the XDMF sidecar (PATH with .xdmf) is renamed
 * into place just before it, because it names the final file. Layout:
 *
 *   /meta/{scene, scene_file, ejecta_version, build_signature, plugins}  string datasets
 *   /meta/dimension                                                       int32 dataset
 *   /frames/NNNNNN              attrs time, step
 *   /frames/NNNNNN/<set>        attr count; datasets x, id, output fields ([n] or [n][ncomp])
 *   /xdmf/vertices_N            int32 0 .. N-1: the XDMF vertex cells of a set of N points
 *   /series/energy/<column>     extendible 1-D double datasets, one row per step
 *   /checkpoint                 attrs t, dt, step, ... format_version; per set attr n and
 *                               every non-scratch field
 *
 * Every dataset of fields carries string attributes unit and kind.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <hdf5.h>

#include "core_impl.h"

#define EJ_SERIES_ROWS 1024
#define EJ_CHECKPOINT_FORMAT 2

enum { EJ_SERIES_COLS = 13 };
static const char *const ej_series_names[EJ_SERIES_COLS] = {
    "t",        "step",      "dt",       "kinetic",  "internal",   "viscous",    "plastic",
    "hourglass", "external", "balance", "momentum_x", "momentum_y", "momentum_z"};

struct ej_output {
  hid_t file;
  char *path;    /* final name */
  char *partial; /* path + ".partial": the name while the run is going */
  char *xdmf;    /* sidecar */
  const char *h5_name; /* basename of path, inside path: what the XDMF references */
  hid_t series[EJ_SERIES_COLS + EJ_MAX_REPORTS]; /* energy columns, then plugins' reports */
  int n_cols;
  /* Column-major [EJ_SERIES_COLS][EJ_SERIES_ROWS] so each column flushes as one block. */
  double *rows;
  int n_rows;
  hsize_t n_series; /* rows already in the file */
  /* XDMF grids of the frames written so far: the frame list the sidecar is made of. */
  ej_buf grids;
};

/* ================================================================== HDF5 helpers */

typedef struct ej_h5_reason {
  char text[256];
} ej_h5_reason;

static herr_t ej_h5_walk(unsigned n, const H5E_error2_t *e, void *data)
{
  ej_h5_reason *r = data;
  /* Upward walk: frame 0 is the most specific one, the likeliest to say why. */
  if (n == 0 && e->desc) snprintf(r->text, sizeof r->text, "%s", e->desc);
  return 0;
}

/* Why the last HDF5 call failed, from the library's error stack (which it then clears). */
static void ej_h5_why(ej_h5_reason *r)
{
  r->text[0] = '\0';
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, ej_h5_walk, r);
  H5Eclear2(H5E_DEFAULT);
  if (!r->text[0]) snprintf(r->text, sizeof r->text, "unknown HDF5 error");
}

/* EJ_ERR_IO naming the object (loc/name) and the file it failed in. */
static ej_err ej_h5_fail(hid_t loc, const char *name, const char *func, int line)
{
  ej_h5_reason why;
  ej_h5_why(&why);
  char obj[256] = "", file[512] = "";
  if (loc >= 0) {
    if (H5Iget_name(loc, obj, sizeof obj) < 0) obj[0] = '\0';
    if (H5Fget_name(loc, file, sizeof file) < 0) file[0] = '\0';
    H5Eclear2(H5E_DEFAULT);
  }
  bool sep = name && name[0] && obj[0] && strcmp(obj, "/") != 0;
  return ej_error_push(EJ_ERR_IO, __FILE__, line, func, "cannot write '%s%s%s' in '%s': %s", obj, sep ? "/" : "",
                       name ? name : "", file, why.text);
}
#define EJ_H5_FAIL(loc, name) ej_h5_fail((loc), (name), __func__, __LINE__)

static hid_t ej_h5_string_type(size_t len)
{
  hid_t t = H5Tcopy(H5T_C_S1);
  if (t < 0) return t;
  /* Exactly len bytes on disk (NULLPAD, no terminator) so the scene reads back verbatim;
   * HDF5 has no zero-length fixed strings, so "" is one NUL. */
  if (H5Tset_size(t, len ? len : 1) < 0 || H5Tset_strpad(t, H5T_STR_NULLPAD) < 0) {
    H5Tclose(t);
    return -1;
  }
  return t;
}

/* A scalar string dataset (the scene can exceed the 64 KiB attribute limit). */
static ej_err ej_h5_put_text(hid_t loc, const char *name, const char *s, size_t len)
{
  ej_err rc = EJ_OK;
  if (!s) s = "", len = 0;
  hid_t type = ej_h5_string_type(len), space = -1, dset = -1;
  if (type < 0) goto fail;
  space = H5Screate(H5S_SCALAR);
  if (space < 0) goto fail;
  dset = H5Dcreate2(loc, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (dset < 0 || H5Dwrite(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, len ? s : "") < 0) goto fail;
  goto close_all;
fail:
  rc = EJ_H5_FAIL(loc, name);
close_all:
  if (dset >= 0) H5Dclose(dset);
  if (space >= 0) H5Sclose(space);
  if (type >= 0) H5Tclose(type);
  return rc;
}

static ej_err ej_h5_attr(hid_t loc, const char *name, hid_t file_type, hid_t mem_type, const void *value)
{
  ej_err rc = EJ_OK;
  hid_t space = H5Screate(H5S_SCALAR), attr = -1;
  if (space < 0) goto fail;
  attr = H5Acreate2(loc, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT);
  if (attr < 0 || H5Awrite(attr, mem_type, value) < 0) goto fail;
  goto close_all;
fail:
  rc = EJ_H5_FAIL(loc, name);
close_all:
  if (attr >= 0) H5Aclose(attr);
  if (space >= 0) H5Sclose(space);
  return rc;
}

static ej_err ej_h5_attr_double(hid_t loc, const char *name, double v)
{
  return ej_h5_attr(loc, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v);
}

static ej_err ej_h5_attr_int64(hid_t loc, const char *name, int64_t v)
{
  return ej_h5_attr(loc, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &v);
}

static ej_err ej_h5_attr_string(hid_t loc, const char *name, const char *s)
{
  size_t len = strlen(s);
  hid_t type = ej_h5_string_type(len);
  if (type < 0) return EJ_H5_FAIL(loc, name);
  ej_err rc = ej_h5_attr(loc, name, type, type, len ? s : "");
  H5Tclose(type);
  return rc;
}

/* A 1-D dataset of n values (file type file_type, memory type mem_type); the write is skipped for
 * n = 0, which leaves an empty dataset. */
static ej_err ej_h5_put_array(hid_t loc, const char *name, hid_t file_type, hid_t mem_type, hsize_t n,
                              const void *data)
{
  ej_err rc = EJ_OK;
  hid_t space = H5Screate_simple(1, &n, NULL), dset = -1;
  if (space < 0) goto fail;
  dset = H5Dcreate2(loc, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (dset < 0 || (n > 0 && H5Dwrite(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)) goto fail;
  goto close_all;
fail:
  rc = EJ_H5_FAIL(loc, name);
close_all:
  if (dset >= 0) H5Dclose(dset);
  if (space >= 0) H5Sclose(space);
  return rc;
}

static int ej_kind_ncomp(ej_field_kind k) { return k == EJ_INT ? 1 : (int)k; }

/* The first n particles of field f as dataset f->name in loc: [n] or [n][ncomp]. */
static ej_err ej_h5_put_field(hid_t loc, const ej_field *f, ej_idx n)
{
  ej_err rc = EJ_OK;
  int ncomp = ej_kind_ncomp(f->kind);
  hsize_t dims[2] = {(hsize_t)n, (hsize_t)ncomp};
  bool is_int = f->kind == EJ_INT;
  hid_t space = H5Screate_simple(ncomp == 1 ? 1 : 2, dims, NULL), dset = -1;
  if (space < 0) goto fail;
  dset = H5Dcreate2(loc, f->name, is_int ? H5T_STD_I32LE : H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT,
                    H5P_DEFAULT);
  if (dset < 0) goto fail;
  /* Owned particles come first in every field, so the prefix is the whole write. */
  if (n > 0 && H5Dwrite(dset, is_int ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                        f->data) < 0)
    goto fail;
  /* Rate fields are declared without a unit: "" says unknown, where "1" would say none. */
  EJ_TRY_GOTO(rc, ej_h5_attr_string(dset, "unit", f->unit ? f->unit : ""), close_all);
  EJ_TRY_GOTO(rc, ej_h5_attr_string(dset, "kind", ej_field_kind_name(f->kind)), close_all);
  if (f->kind == EJ_SYM6) EJ_TRY_GOTO(rc, ej_h5_attr_string(dset, "components", "xx yy zz xy yz zx"), close_all);
  goto close_all;
fail:
  rc = EJ_H5_FAIL(loc, f->name);
close_all:
  if (dset >= 0) H5Dclose(dset);
  if (space >= 0) H5Sclose(space);
  return rc;
}

static ej_err ej_h5_group(hid_t loc, const char *name, hid_t *g)
{
  *g = H5Gcreate2(loc, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (*g < 0) return EJ_H5_FAIL(loc, name);
  return EJ_OK;
}

/* ================================================================== XML text */

static ej_err ej_xml_text(ej_buf *b, const char *s)
{
  for (const char *p = s; *p; ++p) {
    switch (*p) {
    case '&': EJ_TRY(ej_buf_printf(b, "&amp;")); break;
    case '<': EJ_TRY(ej_buf_printf(b, "&lt;")); break;
    case '>': EJ_TRY(ej_buf_printf(b, "&gt;")); break;
    case '"': EJ_TRY(ej_buf_printf(b, "&quot;")); break;
    default: EJ_TRY(ej_buf_printf(b, "%c", *p));
    }
  }
  return EJ_OK;
}

/* <DataItem ...>file.h5:/frames/NNNNNN/set/field</DataItem> */
static ej_err ej_xdmf_item(ej_buf *b, const ej_output *out, const char *frame, const char *set, const ej_field *f,
                           ej_idx n)
{
  int ncomp = ej_kind_ncomp(f->kind);
  bool is_int = f->kind == EJ_INT;
  if (ncomp == 1)
    EJ_TRY(ej_buf_printf(b, "<DataItem Dimensions=\"%ld\"", (long)n));
  else
    EJ_TRY(ej_buf_printf(b, "<DataItem Dimensions=\"%ld %d\"", (long)n, ncomp));
  EJ_TRY(ej_buf_printf(b, " NumberType=\"%s\" Precision=\"%d\" Format=\"HDF\">", is_int ? "Int" : "Float",
                       is_int ? 4 : 8));
  EJ_TRY(ej_xml_text(b, out->h5_name));
  EJ_TRY(ej_buf_printf(b, ":%s/", frame));
  EJ_TRY(ej_xml_text(b, set));
  EJ_TRY(ej_buf_printf(b, "/"));
  EJ_TRY(ej_xml_text(b, f->name));
  EJ_TRY(ej_buf_printf(b, "</DataItem>"));
  return EJ_OK;
}

static const char *ej_xdmf_attribute_type(ej_field_kind k)
{
  switch (k) {
  case EJ_VEC3: return "Vector";
  case EJ_SYM6: return "Tensor6";
  case EJ_TENSOR9: return "Tensor";
  default: return "Scalar";
  }
}

/* ================================================================== open */

/* mkdir -p of the directory part of path; on failure names the directory in dir. */
static int ej_make_parents(const char *path, char *dir, size_t dir_size)
{
  snprintf(dir, dir_size, "%s", path);
  char *slash = strrchr(dir, '/');
  if (!slash || slash == dir) return 0;
  *slash = '\0';
  for (char *p = dir + 1;; ++p) {
    if (*p != '/' && *p != '\0') continue;
    char c = *p;
    *p = '\0';
    if (mkdir(dir, 0777) != 0) {
      int err = errno;
      struct stat st;
      if (err != EEXIST) return err;
      if (stat(dir, &st) != 0) return errno;
      if (!S_ISDIR(st.st_mode)) return ENOTDIR;
    }
    *p = c;
    if (!c) return 0;
  }
}

static char *ej_concat(const char *a, const char *b)
{
  size_t la = strlen(a), lb = strlen(b);
  char *s = ej_malloc(la + lb + 1);
  if (!s) return NULL;
  memcpy(s, a, la);
  memcpy(s + la, b, lb + 1);
  return s;
}

/* path with its extension replaced by .xdmf (appended when it has none, or is .xdmf). */
static char *ej_xdmf_name(const char *path)
{
  const char *base = strrchr(path, '/');
  base = base ? base + 1 : path;
  const char *dot = strrchr(base, '.');
  if (!dot || dot == base || strcmp(dot, ".xdmf") == 0) return ej_concat(path, ".xdmf");
  size_t stem = (size_t)(dot - path);
  char *s = ej_malloc(stem + sizeof ".xdmf");
  if (!s) return NULL;
  memcpy(s, path, stem);
  memcpy(s + stem, ".xdmf", sizeof ".xdmf");
  return s;
}

static ej_err ej_output_write_meta(ej_output *out, const ej_sim *sim)
{
  ej_err rc = EJ_OK;
  const ej_doc *doc = sim->scene ? sim->scene->doc : NULL;
  ej_buf plugins = {0};
  hid_t meta = -1, space = -1, dset = -1;
  EJ_TRY(ej_h5_group(out->file, "/meta", &meta));
  EJ_TRY_GOTO(rc, ej_h5_put_text(meta, "scene", doc ? doc->text : NULL, doc && doc->text ? doc->text_len : 0),
              close_meta);
  const char *scene_file = doc && doc->path ? doc->path : "";
  EJ_TRY_GOTO(rc, ej_h5_put_text(meta, "scene_file", scene_file, strlen(scene_file)), close_meta);
  EJ_TRY_GOTO(rc, ej_h5_put_text(meta, "ejecta_version", EJ_VERSION, strlen(EJ_VERSION)), close_meta);
  EJ_TRY_GOTO(rc, ej_h5_put_text(meta, "build_signature", EJ_BUILD_SIGNATURE, strlen(EJ_BUILD_SIGNATURE)),
              close_meta);
  int n_plugins = sim->reg ? ej_registry_plugin_count(sim->reg) : 0;
  for (int i = 0; i < n_plugins; ++i) {
    const char *ppath = NULL;
    const ej_plugin_info *info = ej_registry_plugin(sim->reg, i, &ppath);
    if (!info) continue;
    /* Statically linked plugins (tests) have no file. */
    EJ_TRY_GOTO(rc, ej_buf_printf(&plugins, "%s %s %s\n", info->name, info->version, ppath ? ppath : "(builtin)"),
                free_plugins);
  }
  EJ_TRY_GOTO(rc, ej_h5_put_text(meta, "plugins", plugins.data, plugins.len), free_plugins);

  int32_t dim = sim->dim;
  space = H5Screate(H5S_SCALAR);
  if (space >= 0) dset = H5Dcreate2(meta, "dimension", H5T_STD_I32LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (space < 0 || dset < 0 || H5Dwrite(dset, H5T_NATIVE_INT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, &dim) < 0)
    rc = EJ_H5_FAIL(meta, "dimension");
  if (dset >= 0) H5Dclose(dset);
  if (space >= 0) H5Sclose(space);
free_plugins:
  ej_buf_free(&plugins);
close_meta:
  H5Gclose(meta);
  return rc;
}

static ej_err ej_output_create_series(ej_output *out)
{
  ej_err rc = EJ_OK;
  hid_t series = -1, energy = -1, space = -1, dcpl = -1;
  hsize_t dims = 0, maxdims = H5S_UNLIMITED, chunk = EJ_SERIES_ROWS;
  EJ_TRY(ej_h5_group(out->file, "/series", &series));
  EJ_TRY_GOTO(rc, ej_h5_group(series, "energy", &energy), close_series);
  space = H5Screate_simple(1, &dims, &maxdims);
  dcpl = H5Pcreate(H5P_DATASET_CREATE);
  if (space < 0 || dcpl < 0 || H5Pset_chunk(dcpl, 1, &chunk) < 0) {
    rc = EJ_H5_FAIL(energy, NULL);
    goto close_props;
  }
  for (int c = 0; c < EJ_SERIES_COLS; ++c) {
    out->series[c] = H5Dcreate2(energy, ej_series_names[c], H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (out->series[c] < 0) {
      rc = EJ_H5_FAIL(energy, ej_series_names[c]);
      goto close_props;
    }
  }
close_props:
  if (dcpl >= 0) H5Pclose(dcpl);
  if (space >= 0) H5Sclose(space);
  H5Gclose(energy);
close_series:
  H5Gclose(series);
  return rc;
}

ej_err ej_output_open(ej_output **outp, const ej_sim *sim, const char *path)
{
  EJ_ENSURE(outp && sim && path && path[0], EJ_ERR_ARG, "ej_output_open: null argument");
  *outp = NULL;
  const ej_loc *where = sim->scene ? &sim->scene->output_loc : NULL;
  ej_err rc = EJ_OK;
  /* Failures are reported through ej_err; HDF5's own stderr dump would duplicate them. */
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);

  ej_output *out = ej_calloc(1, sizeof *out);
  EJ_ENSURE(out, EJ_ERR_MEM, "out of memory");
  out->file = -1;
  for (int c = 0; c < EJ_SERIES_COLS + EJ_MAX_REPORTS; ++c) out->series[c] = -1;
  out->n_cols = EJ_SERIES_COLS;
  out->path = ej_strdup(path);
  out->partial = ej_concat(path, ".partial");
  out->xdmf = ej_xdmf_name(path);
  out->rows = ej_malloc(sizeof(double) * EJ_SERIES_COLS * EJ_SERIES_ROWS);
  if (!out->path || !out->partial || !out->xdmf || !out->rows) {
    rc = EJ_ERR_MEM;
    ej_error_push(rc, __FILE__, __LINE__, __func__, "out of memory");
    goto free_out;
  }
  const char *slash = strrchr(out->path, '/');
  out->h5_name = slash ? slash + 1 : out->path;

  char dir[1024];
  int err = ej_make_parents(path, dir, sizeof dir);
  if (err) {
    rc = ej_error_input(where, "cannot write output file '%s': cannot create directory '%s': %s", path, dir,
                        strerror(err));
    goto free_out;
  }
  /* The final name is taken by a rename at the end: a directory there (or at the sidecar's name)
   * would fail only then, after the whole run. */
  struct stat st;
  const char *names[2] = {path, out->xdmf};
  for (int k = 0; k < 2; ++k)
    if (stat(names[k], &st) == 0 && S_ISDIR(st.st_mode)) {
      rc = ej_error_input(where, "cannot write output file '%s': '%s' is a directory (expected a file name)", path,
                          names[k]);
      goto free_out;
    }
  /* Strong close: H5Fclose really closes even if an object id leaked, so the rename that
   * follows never races an open handle. */
  hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  if (fapl >= 0) H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG);
  errno = 0;
  out->file = H5Fcreate(out->partial, H5F_ACC_TRUNC, H5P_DEFAULT, fapl >= 0 ? fapl : H5P_DEFAULT);
  err = errno;
  if (fapl >= 0) H5Pclose(fapl);
  if (out->file < 0) {
    ej_h5_reason why;
    ej_h5_why(&why);
    rc = ej_error_input(where, "cannot write output file '%s': %s", path, err ? strerror(err) : why.text);
    goto free_out;
  }
  EJ_TRY_GOTO(rc, ej_output_write_meta(out, sim), close_file);
  hid_t frames;
  EJ_TRY_GOTO(rc, ej_h5_group(out->file, "/frames", &frames), close_file);
  H5Gclose(frames);
  EJ_TRY_GOTO(rc, ej_output_create_series(out), close_file);
  *outp = out;
  return EJ_OK;

close_file:
  for (int c = 0; c < EJ_SERIES_COLS + EJ_MAX_REPORTS; ++c)
    if (out->series[c] >= 0) H5Dclose(out->series[c]);
  H5Fclose(out->file);
  remove(out->partial);
free_out:
  ej_free(out->rows);
  ej_free(out->xdmf);
  ej_free(out->partial);
  ej_free(out->path);
  ej_free(out);
  return rc;
}

/* ================================================================== frames */

/* Field indices to write for set s: x and id first (x is the XDMF geometry), then the scene's
 * list, or every EJ_FIELD_OUTPUT field. */
static int ej_frame_fields(const ej_set *s, const ej_scene *sc, int *idx)
{
  bool taken[EJ_MAX_FIELDS] = {false};
  int n = 0;
  const char *always[2] = {"x", "id"};
  for (int k = 0; k < 2; ++k) {
    int f = ej_set_find_field(s, always[k]);
    if (f >= 0 && !taken[f]) taken[f] = true, idx[n++] = f;
  }
  if (sc && sc->n_output_fields > 0) {
    /* A listed field that this set lacks belongs to another set's method. */
    for (int k = 0; k < sc->n_output_fields; ++k) {
      int f = ej_set_find_field(s, sc->output_fields[k]);
      if (f >= 0 && !taken[f]) taken[f] = true, idx[n++] = f;
    }
  } else {
    for (int f = 0; f < s->n_fields; ++f)
      if ((s->fields[f].flags & EJ_FIELD_OUTPUT) && !taken[f]) taken[f] = true, idx[n++] = f;
  }
  return n;
}

/* /xdmf/vertices_N: the cell list 0 .. N-1 of a Polyvertex grid of N points, written once per
 * distinct set size. XDMF 3 readers (ParaView's Xdmf3ReaderS/T, the default choices for .xdmf)
 * build no cells from a Polyvertex topology without connectivity, and render nothing. */
static ej_err ej_xdmf_vertices(ej_output *out, ej_idx n, char *name, size_t name_size)
{
  snprintf(name, name_size, "/xdmf/vertices_%ld", (long)n);
  if (H5Lexists(out->file, "/xdmf", H5P_DEFAULT) <= 0) {
    hid_t g;
    EJ_TRY(ej_h5_group(out->file, "/xdmf", &g));
    H5Gclose(g);
  }
  if (H5Lexists(out->file, name, H5P_DEFAULT) > 0) return EJ_OK;
  int32_t *iota = ej_malloc((size_t)n * sizeof *iota);
  EJ_ENSURE(iota, EJ_ERR_MEM, "cannot allocate the XDMF cell list of %ld points", (long)n);
  for (ej_idx i = 0; i < n; ++i) iota[i] = (int32_t)i;
  ej_err rc = ej_h5_put_array(out->file, name, H5T_STD_I32LE, H5T_NATIVE_INT32, (hsize_t)n, iota);
  ej_free(iota);
  return rc;
}

static ej_err ej_frame_set(ej_output *out, hid_t frame, const char *frame_name, const ej_set *s,
                           const ej_scene *sc)
{
  ej_err rc = EJ_OK;
  int idx[EJ_MAX_FIELDS];
  int n_idx = ej_frame_fields(s, sc, idx);
  hid_t g;
  EJ_TRY(ej_h5_group(frame, s->name, &g));
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(g, "count", s->n), close_group);
  for (int k = 0; k < n_idx; ++k) EJ_TRY_GOTO(rc, ej_h5_put_field(g, &s->fields[idx[k]], s->n), close_group);

  /* Empty sets and sets without positions have nothing ParaView could draw. */
  if (s->n == 0 || n_idx == 0 || strcmp(s->fields[idx[0]].name, "x") != 0) goto close_group;
  char cells[64];
  EJ_TRY_GOTO(rc, ej_xdmf_vertices(out, s->n, cells, sizeof cells), close_group);
  ej_buf *b = &out->grids;
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "        <Grid Name=\""), close_group);
  EJ_TRY_GOTO(rc, ej_xml_text(b, s->name), close_group);
  EJ_TRY_GOTO(rc,
              ej_buf_printf(b,
                            "\" GridType=\"Uniform\">\n"
                            "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"%ld\" "
                            "NodesPerElement=\"1\">\n"
                            "            <DataItem Dimensions=\"%ld\" NumberType=\"Int\" Precision=\"4\" "
                            "Format=\"HDF\">",
                            (long)s->n, (long)s->n),
              close_group);
  EJ_TRY_GOTO(rc, ej_xml_text(b, out->h5_name), close_group);
  EJ_TRY_GOTO(rc,
              ej_buf_printf(b,
                            ":%s</DataItem>\n"
                            "          </Topology>\n"
                            "          <Geometry GeometryType=\"XYZ\">\n            ",
                            cells),
              close_group);
  EJ_TRY_GOTO(rc, ej_xdmf_item(b, out, frame_name, s->name, &s->fields[idx[0]], s->n), close_group);
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "\n          </Geometry>\n"), close_group);
  for (int k = 1; k < n_idx; ++k) {
    const ej_field *f = &s->fields[idx[k]];
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "          <Attribute Name=\""), close_group);
    EJ_TRY_GOTO(rc, ej_xml_text(b, f->name), close_group);
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "\" AttributeType=\"%s\" Center=\"Node\">\n            ",
                                  ej_xdmf_attribute_type(f->kind)),
                close_group);
    EJ_TRY_GOTO(rc, ej_xdmf_item(b, out, frame_name, s->name, f, s->n), close_group);
    EJ_TRY_GOTO(rc, ej_buf_printf(b, "\n          </Attribute>\n"), close_group);
  }
  EJ_TRY_GOTO(rc, ej_buf_printf(b, "        </Grid>\n"), close_group);
close_group:
  H5Gclose(g);
  return rc;
}

ej_err ej_output_frame(ej_output *out, const ej_sim *sim)
{
  EJ_ENSURE(out && sim, EJ_ERR_ARG, "ej_output_frame: null argument");
  ej_err rc = EJ_OK;
  char name[40];
  snprintf(name, sizeof name, "/frames/%06lld", (long long)sim->frame);
  /* A failed frame must not leave half a grid in the sidecar. */
  size_t grids_len = out->grids.len;
  hid_t frame;
  EJ_TRY(ej_h5_group(out->file, name, &frame));
  EJ_TRY_GOTO(rc, ej_h5_attr_double(frame, "time", sim->t), close_frame);
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(frame, "step", sim->step), close_frame);
  EJ_TRY_GOTO(rc,
              ej_buf_printf(&out->grids,
                            "      <Grid Name=\"frame_%06lld\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
                            "        <Time Value=\"%.17g\"/>\n",
                            (long long)sim->frame, sim->t),
              close_frame);
  for (int k = 0; k < sim->n_sets; ++k)
    EJ_TRY_GOTO(rc, ej_frame_set(out, frame, name, sim->sets[k], sim->scene), close_frame);
  EJ_TRY_GOTO(rc, ej_buf_printf(&out->grids, "      </Grid>\n"), close_frame);
close_frame:
  H5Gclose(frame);
  if (rc != EJ_OK) {
    out->grids.len = grids_len;
    if (out->grids.data) out->grids.data[grids_len] = '\0';
  }
  return rc;
}

/* ================================================================== series */

static ej_err ej_output_flush_series(ej_output *out)
{
  if (out->n_rows == 0) return EJ_OK;
  ej_err rc = EJ_OK;
  hsize_t start = out->n_series, count = (hsize_t)out->n_rows, total = start + count;
  hid_t mem = H5Screate_simple(1, &count, NULL);
  if (mem < 0) return EJ_H5_FAIL(out->file, "series");
  for (int c = 0; c < out->n_cols; ++c) {
    hid_t ds = out->series[c], space = -1;
    if (H5Dset_extent(ds, &total) < 0 || (space = H5Dget_space(ds)) < 0 ||
        H5Sselect_hyperslab(space, H5S_SELECT_SET, &start, NULL, &count, NULL) < 0 ||
        H5Dwrite(ds, H5T_NATIVE_DOUBLE, mem, space, H5P_DEFAULT, out->rows + (size_t)c * EJ_SERIES_ROWS) < 0) {
      rc = EJ_H5_FAIL(ds, NULL);
    }
    if (space >= 0) H5Sclose(space);
    if (rc != EJ_OK) break;
  }
  H5Sclose(mem);
  if (rc == EJ_OK) {
    out->n_series = total;
    out->n_rows = 0;
  }
  return rc;
}

/* /series/<owner>/<name> for the plugins' reports, made on the first row (the names are
 * known once the plugins have reported). */
static ej_err ej_output_create_reports(ej_output *out, const ej_reports *R)
{
  double *rows = ej_realloc(out->rows, sizeof(double) * (size_t)(EJ_SERIES_COLS + R->n) * EJ_SERIES_ROWS);
  EJ_ENSURE(rows, EJ_ERR_MEM, "out of memory");
  out->rows = rows;
  ej_err rc = EJ_OK;
  hsize_t dims = 0, maxdims = H5S_UNLIMITED, chunk = EJ_SERIES_ROWS;
  hid_t space = H5Screate_simple(1, &dims, &maxdims), dcpl = H5Pcreate(H5P_DATASET_CREATE),
        lcpl = H5Pcreate(H5P_LINK_CREATE);
  if (space < 0 || dcpl < 0 || lcpl < 0 || H5Pset_chunk(dcpl, 1, &chunk) < 0 ||
      H5Pset_create_intermediate_group(lcpl, 1) < 0) {
    rc = EJ_H5_FAIL(out->file, "series");
    goto close;
  }
  for (int k = 0; k < R->n; ++k) {
    char path[sizeof R->names[0] + 16];
    snprintf(path, sizeof path, "/series/%s", R->names[k]);
    hid_t ds = H5Dcreate2(out->file, path, H5T_IEEE_F64LE, space, lcpl, dcpl, H5P_DEFAULT);
    if (ds < 0) {
      rc = EJ_H5_FAIL(out->file, path);
      goto close;
    }
    out->series[EJ_SERIES_COLS + k] = ds;
    out->n_cols = EJ_SERIES_COLS + k + 1;
  }
close:
  if (lcpl >= 0) H5Pclose(lcpl);
  if (dcpl >= 0) H5Pclose(dcpl);
  if (space >= 0) H5Sclose(space);
  return rc;
}

ej_err ej_output_series(ej_output *out, const ej_sim *sim)
{
  EJ_ENSURE(out && sim, EJ_ERR_ARG, "ej_output_series: null argument");
  if (sim->reports.n > 0 && out->n_cols == EJ_SERIES_COLS) {
    EJ_ENSURE(out->n_rows == 0 && out->n_series == 0, EJ_ERR_INTERNAL, "reports appeared after the first series row");
    EJ_TRY(ej_output_create_reports(out, &sim->reports));
  }
  /* A previous flush failed: it already reported, and retrying keeps the rows. */
  if (out->n_rows == EJ_SERIES_ROWS) EJ_TRY(ej_output_flush_series(out));
  const ej_energy *e = &sim->energy;
  const double row[EJ_SERIES_COLS] = {sim->t,      (double)sim->step, sim->dt,       e->kinetic,    e->internal,
                                      e->viscous,  e->plastic,        e->hourglass,  e->external,   e->balance,
                                      e->momentum[0], e->momentum[1], e->momentum[2]};
  for (int c = 0; c < EJ_SERIES_COLS; ++c) out->rows[(size_t)c * EJ_SERIES_ROWS + out->n_rows] = row[c];
  for (int c = EJ_SERIES_COLS; c < out->n_cols; ++c)
    out->rows[(size_t)c * EJ_SERIES_ROWS + out->n_rows] = sim->reports.values[c - EJ_SERIES_COLS];
  if (++out->n_rows == EJ_SERIES_ROWS) EJ_TRY(ej_output_flush_series(out));
  return EJ_OK;
}

/* ================================================================== checkpoint */

/* Boundary-condition masks are decided at t = 0 from the initial positions and follow the
 * particles through reorderings; a restarted run cannot recompute them, so they travel with
 * the checkpoint. */
#define EJ_CP_BC_MASK "_bc_mask"

#define EJ_CP_BONDS "_bond_flags"

/* Plugin instance state (ABI 1.8 save_state / load_state, EJ_MAX_STATE): a 1-D dataset of the
 * values save_state gives, none when it gives none. Sets keep theirs in their group, the
 * interactions in EJ_CP_INTER under "<k>_<model>" (k = the scene's order). */
#define EJ_CP_STATE "_plugin_state"
#define EJ_CP_INTER "_interactions"

typedef ej_err (*ej_save_fn)(const void *state, ej_real *buf, int max, int *n);
typedef ej_err (*ej_load_fn)(void *state, const ej_real *buf, int n);

static ej_err ej_checkpoint_state(hid_t g, const char *name, ej_save_fn save, const void *state, const char *who)
{
  ej_real buf[EJ_MAX_STATE];
  int n = 0;
  EJ_TRY(save(state, buf, EJ_MAX_STATE, &n));
  EJ_ENSURE(n >= 0 && n <= EJ_MAX_STATE, EJ_ERR_INTERNAL, "%s: save_state gave %d values (0 .. %d)", who, n,
            EJ_MAX_STATE);
  if (n == 0) return EJ_OK;
  return ej_h5_put_array(g, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, (hsize_t)n, buf);
}

static ej_err ej_checkpoint_interactions(hid_t cp, const ej_sim *sim)
{
  bool any = false;
  for (int k = 0; k < sim->n_inter; ++k) any |= EJ_HAS_OP(sim->inter[k].ops, ej_interaction_ops, save_state);
  if (!any) return EJ_OK;
  hid_t g;
  EJ_TRY(ej_h5_group(cp, EJ_CP_INTER, &g));
  ej_err rc = EJ_OK;
  for (int k = 0; k < sim->n_inter && rc == EJ_OK; ++k) {
    const ej_inter *in = &sim->inter[k];
    if (!EJ_HAS_OP(in->ops, ej_interaction_ops, save_state)) continue;
    char name[160];
    snprintf(name, sizeof name, "%d_%s", k, in->ops->name);
    rc = ej_checkpoint_state(g, name, in->ops->save_state, in->state, in->ops->name);
  }
  H5Gclose(g);
  return rc;
}

static ej_err ej_checkpoint_set(hid_t cp, const ej_set *s)
{
  ej_err rc = EJ_OK;
  hid_t g;
  EJ_TRY(ej_h5_group(cp, s->name, &g));
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(g, "n", s->n), close_group);
  for (int f = 0; f < s->n_fields; ++f) {
    if (s->fields[f].flags & EJ_FIELD_SCRATCH) continue;
    EJ_TRY_GOTO(rc, ej_h5_put_field(g, &s->fields[f], s->n), close_group);
  }
  if (s->bc_mask)
    EJ_TRY_GOTO(rc, ej_h5_put_array(g, EJ_CP_BC_MASK, H5T_STD_U32LE, H5T_NATIVE_UINT32, (hsize_t)s->n, s->bc_mask),
                close_group);
  if (s->bond_flags)
    EJ_TRY_GOTO(rc,
                ej_h5_put_array(g, EJ_CP_BONDS, H5T_STD_U8LE, H5T_NATIVE_UINT8, (hsize_t)s->n_bonds, s->bond_flags),
                close_group);
  if (s->mops && EJ_HAS_OP(s->mops, ej_method_ops, save_state))
    EJ_TRY_GOTO(rc, ej_checkpoint_state(g, EJ_CP_STATE, s->mops->save_state, s->mstate, s->mops->name), close_group);
close_group:
  H5Gclose(g);
  return rc;
}

#define EJ_CP_NEW "/checkpoint_partial"

ej_err ej_output_checkpoint(ej_output *out, const ej_sim *sim)
{
  EJ_ENSURE(out && sim, EJ_ERR_ARG, "ej_output_checkpoint: null argument");
  ej_err rc = EJ_OK;
  /* Written beside the previous checkpoint and swapped in afterwards, so a crash while
   * writing still leaves the previous one whole. */
  if (H5Lexists(out->file, EJ_CP_NEW, H5P_DEFAULT) > 0 && H5Ldelete(out->file, EJ_CP_NEW, H5P_DEFAULT) < 0)
    return EJ_H5_FAIL(out->file, EJ_CP_NEW);
  hid_t cp;
  EJ_TRY(ej_h5_group(out->file, EJ_CP_NEW, &cp));
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(cp, "format_version", EJ_CHECKPOINT_FORMAT), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(cp, "dimension", sim->dim), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "t", sim->t), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "dt", sim->dt), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(cp, "step", sim->step), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(cp, "n_rebuilds", sim->n_rebuilds), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_int64(cp, "frame", sim->frame), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "next_output", sim->next_output), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "next_checkpoint", sim->next_checkpoint), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "energy_work_gravity", sim->energy.work_gravity), close_cp);
  EJ_TRY_GOTO(rc, ej_h5_attr_double(cp, "energy_total0", sim->energy.total0), close_cp);
  for (int k = 0; k < sim->n_sets; ++k) EJ_TRY_GOTO(rc, ej_checkpoint_set(cp, sim->sets[k]), close_cp);
  EJ_TRY_GOTO(rc, ej_checkpoint_interactions(cp, sim), close_cp);
close_cp:
  H5Gclose(cp);
  if (rc != EJ_OK) return rc;
  if (H5Lexists(out->file, "/checkpoint", H5P_DEFAULT) > 0 && H5Ldelete(out->file, "/checkpoint", H5P_DEFAULT) < 0)
    return EJ_H5_FAIL(out->file, "checkpoint");
  if (H5Lmove(out->file, EJ_CP_NEW, out->file, "/checkpoint", H5P_DEFAULT, H5P_DEFAULT) < 0)
    return EJ_H5_FAIL(out->file, "checkpoint");
  /* The series rows up to here go to disk too, so the .partial file of a crashed run is
   * consistent with its checkpoint. */
  EJ_TRY(ej_output_flush_series(out));
  if (H5Fflush(out->file, H5F_SCOPE_GLOBAL) < 0) return EJ_H5_FAIL(out->file, NULL);
  return EJ_OK;
}

/* ================================================================== close */

static ej_err ej_output_write_xdmf(const ej_output *out)
{
  ej_err rc = EJ_OK;
  char *tmp = ej_concat(out->xdmf, ".partial");
  EJ_ENSURE(tmp, EJ_ERR_MEM, "out of memory");
  FILE *f = fopen(tmp, "w");
  if (!f) {
    rc = ej_error_push(EJ_ERR_IO, __FILE__, __LINE__, __func__, "cannot write '%s': %s", tmp, strerror(errno));
    goto free_tmp;
  }
  fprintf(f,
          "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
          "<Xdmf Version=\"3.0\">\n"
          "  <Domain>\n"
          "    <Grid Name=\"frames\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
  if (out->grids.len) fwrite(out->grids.data, 1, out->grids.len, f);
  fprintf(f,
          "    </Grid>\n"
          "  </Domain>\n"
          "</Xdmf>\n");
  bool bad = ferror(f) != 0;
  if (fclose(f) != 0 || bad) {
    rc = ej_error_push(EJ_ERR_IO, __FILE__, __LINE__, __func__, "cannot write '%s': %s", tmp, strerror(errno));
    remove(tmp);
    goto free_tmp;
  }
  if (rename(tmp, out->xdmf) != 0) {
    rc = ej_error_push(EJ_ERR_IO, __FILE__, __LINE__, __func__, "cannot rename '%s' to '%s': %s", tmp, out->xdmf,
                       strerror(errno));
    remove(tmp);
  }
free_tmp:
  ej_free(tmp);
  return rc;
}

ej_err ej_output_close(ej_output *out, bool success)
{
  if (!out) return EJ_OK;
  ej_err rc = EJ_OK;
  if (success) rc = ej_output_flush_series(out);
  for (int c = 0; c < EJ_SERIES_COLS + EJ_MAX_REPORTS; ++c)
    if (out->series[c] >= 0) H5Dclose(out->series[c]);
  if (H5Fclose(out->file) < 0 && rc == EJ_OK && success) {
    ej_h5_reason why;
    ej_h5_why(&why);
    rc = ej_error_push(EJ_ERR_IO, __FILE__, __LINE__, __func__, "cannot finish '%s': %s", out->partial, why.text);
  }
  if (success && rc == EJ_OK) {
    rc = ej_output_write_xdmf(out);
    if (rc == EJ_OK && rename(out->partial, out->path) != 0)
      rc = ej_error_push(EJ_ERR_IO, __FILE__, __LINE__, __func__, "cannot rename '%s' to '%s': %s", out->partial,
                         out->path, strerror(errno));
  } else if (!success) {
    remove(out->partial);
  }
  ej_buf_free(&out->grids);
  ej_free(out->rows);
  ej_free(out->xdmf);
  ej_free(out->partial);
  ej_free(out->path);
  ej_free(out);
  return rc;
}

/* ================================================================== restart */

typedef struct ej_cp_reader {
  const char *path;
  ej_loc loc;
} ej_cp_reader;

static ej_err ej_cp_attr(const ej_cp_reader *r, hid_t loc, const char *name, hid_t mem_type, void *value)
{
  hid_t attr = H5Aopen(loc, name, H5P_DEFAULT);
  herr_t st = attr >= 0 ? H5Aread(attr, mem_type, value) : -1;
  if (attr >= 0) H5Aclose(attr);
  if (st < 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': checkpoint attribute '%s' is missing or unreadable",
                          r->path, name);
  }
  return EJ_OK;
}

/* Kind recorded with a field dataset ("" if none). */
static void ej_cp_kind(hid_t dset, char *kind, size_t size)
{
  kind[0] = '\0';
  hid_t attr = H5Aopen(dset, "kind", H5P_DEFAULT), type = -1;
  if (attr >= 0) type = H5Aget_type(attr);
  if (type >= 0 && H5Tget_class(type) == H5T_STRING && !H5Tis_variable_str(type) && H5Tget_size(type) < size) {
    memset(kind, 0, size);
    if (H5Aread(attr, type, kind) < 0) kind[0] = '\0';
  }
  if (type >= 0) H5Tclose(type);
  if (attr >= 0) H5Aclose(attr);
  H5Eclear2(H5E_DEFAULT);
}

static ej_err ej_cp_field(const ej_cp_reader *r, hid_t g, ej_set *s, ej_field *f)
{
  ej_err rc = EJ_OK;
  if (H5Lexists(g, f->name, H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': set '%s' has no field '%s' in the checkpoint", r->path,
                          s->name, f->name);
  }
  int ncomp = ej_kind_ncomp(f->kind), rank = 0;
  hsize_t dims[2] = {0, 1};
  char kind[16] = "";
  hid_t dset = H5Dopen2(g, f->name, H5P_DEFAULT), space = -1, type = -1;
  if (dset < 0) goto unreadable;
  space = H5Dget_space(dset);
  type = H5Dget_type(dset);
  if (space < 0 || type < 0) goto unreadable;
  rank = H5Sget_simple_extent_ndims(space);
  if (rank < 1 || rank > 2) goto mismatch;
  H5Sget_simple_extent_dims(space, dims, NULL);
  ej_cp_kind(dset, kind, sizeof kind);
  bool is_int = f->kind == EJ_INT;
  if (dims[0] != (hsize_t)s->n || dims[1] != (hsize_t)ncomp || rank != (ncomp == 1 ? 1 : 2) ||
      H5Tget_class(type) != (is_int ? H5T_INTEGER : H5T_FLOAT) || strcmp(kind, ej_field_kind_name(f->kind)) != 0)
    goto mismatch;
  if (s->n > 0 &&
      H5Dread(dset, is_int ? H5T_NATIVE_INT32 : H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, f->data) < 0)
    goto unreadable;
  goto close_all;
mismatch:
  rc = ej_error_input(&r->loc,
                      "cannot restart from '%s': field '%s' of set '%s' is %s[%llu x %llu] in the checkpoint, "
                      "expected %s[%ld x %d]",
                      r->path, f->name, s->name, kind[0] ? kind : "?", (unsigned long long)dims[0],
                      (unsigned long long)dims[1], ej_field_kind_name(f->kind), (long)s->n, ncomp);
  goto close_all;
unreadable:
  H5Eclear2(H5E_DEFAULT);
  rc = ej_error_input(&r->loc, "cannot restart from '%s': field '%s' of set '%s' is unreadable", r->path, f->name,
                      s->name);
close_all:
  if (type >= 0) H5Tclose(type);
  if (space >= 0) H5Sclose(space);
  if (dset >= 0) H5Dclose(dset);
  return rc;
}

/* The state values NAME of g, if the checkpoint has them, handed to load (ABI 1.8). */
static ej_err ej_cp_state(const ej_cp_reader *r, hid_t g, const char *name, ej_load_fn load, void *state,
                          const char *who)
{
  if (H5Lexists(g, name, H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    return EJ_OK; /* an older checkpoint: the state stays as setup left it */
  }
  ej_real buf[EJ_MAX_STATE];
  hid_t dset = H5Dopen2(g, name, H5P_DEFAULT), space = dset >= 0 ? H5Dget_space(dset) : -1;
  const hssize_t len = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
  herr_t st = len > 0 && len <= EJ_MAX_STATE ? 0 : -1;
  if (st == 0) st = H5Dread(dset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  if (space >= 0) H5Sclose(space);
  if (dset >= 0) H5Dclose(dset);
  if (st < 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': the state of %s is unreadable", r->path, who);
  }
  const ej_err rc = load(state, buf, (int)len);
  if (rc == EJ_ERR_INPUT || rc == EJ_ERR_ARG) {
    ej_error_clear();
    return ej_error_input(&r->loc, "cannot restart from '%s': %s does not take the checkpoint's state (%d values)",
                          r->path, who, (int)len);
  }
  return rc;
}

static ej_err ej_cp_interactions(const ej_cp_reader *r, hid_t cp, ej_sim *sim)
{
  if (H5Lexists(cp, EJ_CP_INTER, H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    return EJ_OK;
  }
  hid_t g = H5Gopen2(cp, EJ_CP_INTER, H5P_DEFAULT);
  if (g < 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': interaction states are unreadable", r->path);
  }
  ej_err rc = EJ_OK;
  for (int k = 0; k < sim->n_inter && rc == EJ_OK; ++k) {
    ej_inter *in = &sim->inter[k];
    if (!EJ_HAS_OP(in->ops, ej_interaction_ops, load_state)) continue;
    char name[160];
    snprintf(name, sizeof name, "%d_%s", k, in->ops->name);
    rc = ej_cp_state(r, g, name, in->ops->load_state, in->state, in->ops->name);
  }
  H5Gclose(g);
  return rc;
}

static ej_err ej_cp_set(const ej_cp_reader *r, hid_t cp, ej_set *s)
{
  ej_err rc = EJ_OK;
  if (H5Lexists(cp, s->name, H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': the checkpoint has no set '%s'", r->path, s->name);
  }
  hid_t g = H5Gopen2(cp, s->name, H5P_DEFAULT);
  if (g < 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r->loc, "cannot restart from '%s': set '%s' is unreadable", r->path, s->name);
  }
  int64_t n = 0;
  EJ_TRY_GOTO(rc, ej_cp_attr(r, g, "n", H5T_NATIVE_INT64, &n), close_group);
  if (n < 0 || n > INT32_MAX) {
    rc = ej_error_input(&r->loc, "cannot restart from '%s': set '%s' has a bad particle count %lld", r->path, s->name,
                        (long long)n);
    goto close_group;
  }
  if ((ej_idx)n > s->cap) EJ_TRY_GOTO(rc, ej_set_reserve(s, (ej_idx)n), close_group);
  s->n = (ej_idx)n;
  s->n_ghost = 0;
  for (int f = 0; f < s->n_fields; ++f) {
    if (s->fields[f].flags & EJ_FIELD_SCRATCH) continue;
    EJ_TRY_GOTO(rc, ej_cp_field(r, g, s, &s->fields[f]), close_group);
  }
  if (s->bc_mask && H5Lexists(g, EJ_CP_BC_MASK, H5P_DEFAULT) > 0) {
    hid_t dset = H5Dopen2(g, EJ_CP_BC_MASK, H5P_DEFAULT), space = dset >= 0 ? H5Dget_space(dset) : -1;
    hssize_t len = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
    herr_t st = len == (hssize_t)s->n ? 0 : -1;
    if (st == 0 && s->n > 0) st = H5Dread(dset, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, s->bc_mask);
    if (space >= 0) H5Sclose(space);
    if (dset >= 0) H5Dclose(dset);
    if (st < 0) {
      H5Eclear2(H5E_DEFAULT);
      rc = ej_error_input(&r->loc, "cannot restart from '%s': boundary masks of set '%s' are unreadable", r->path,
                          s->name);
    }
  }
  if (rc == EJ_OK && H5Lexists(g, EJ_CP_BONDS, H5P_DEFAULT) > 0) {
    /* Kept until the family is rebuilt from x0, which checks the count (sim.c). */
    hid_t dset = H5Dopen2(g, EJ_CP_BONDS, H5P_DEFAULT), space = dset >= 0 ? H5Dget_space(dset) : -1;
    hssize_t len = space >= 0 ? H5Sget_simple_extent_npoints(space) : -1;
    herr_t st = len >= 0 ? 0 : -1;
    ej_free(s->bond_flags);
    s->bond_flags = st == 0 ? ej_calloc((size_t)len + 1, 1) : NULL;
    if (st == 0 && !s->bond_flags) st = -1;
    if (st == 0 && len > 0) st = H5Dread(dset, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, s->bond_flags);
    s->n_bonds = st == 0 ? (ej_off)len : 0;
    if (space >= 0) H5Sclose(space);
    if (dset >= 0) H5Dclose(dset);
    if (st < 0) {
      H5Eclear2(H5E_DEFAULT);
      rc = ej_error_input(&r->loc, "cannot restart from '%s': bond states of set '%s' are unreadable", r->path,
                          s->name);
    }
  }
  H5Eclear2(H5E_DEFAULT);
  if (rc == EJ_OK && s->mops && EJ_HAS_OP(s->mops, ej_method_ops, load_state))
    rc = ej_cp_state(r, g, EJ_CP_STATE, s->mops->load_state, s->mstate, s->mops->name);
close_group:
  H5Gclose(g);
  return rc;
}

ej_err ej_checkpoint_read(const char *path, ej_sim *sim)
{
  EJ_ENSURE(path && sim, EJ_ERR_ARG, "ej_checkpoint_read: null argument");
  ej_cp_reader r = {.path = path, .loc = {path, 0, 0}};
  ej_err rc = EJ_OK;
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);

  FILE *probe = fopen(path, "rb");
  if (!probe) {
    int err = errno;
    char *partial = ej_concat(path, ".partial");
    struct stat st;
    /* An interrupted run keeps its checkpoint in the .partial file. */
    bool hint = partial && stat(partial, &st) == 0;
    rc = ej_error_input(&r.loc, "cannot restart from '%s': %s%s%s%s", path, strerror(err),
                        hint ? " (an interrupted run left '" : "", hint ? partial : "", hint ? "')" : "");
    ej_free(partial);
    return rc;
  }
  fclose(probe);
  hid_t file = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) {
    H5Eclear2(H5E_DEFAULT);
    return ej_error_input(&r.loc, "cannot restart from '%s': not an HDF5 file", path);
  }
  if (H5Lexists(file, "/checkpoint", H5P_DEFAULT) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    rc = ej_error_input(&r.loc, "cannot restart from '%s': no checkpoint in file", path);
    goto close_file;
  }
  hid_t cp = H5Gopen2(file, "/checkpoint", H5P_DEFAULT);
  if (cp < 0) {
    H5Eclear2(H5E_DEFAULT);
    rc = ej_error_input(&r.loc, "cannot restart from '%s': no checkpoint in file", path);
    goto close_file;
  }
  int64_t version = 0, dim = 0, step = 0, n_rebuilds = 0, frame = 0;
  double t = 0, dt = 0, next_output = 0, next_checkpoint = 0, external = 0, total0 = 0;
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "format_version", H5T_NATIVE_INT64, &version), close_cp);
  if (version != EJ_CHECKPOINT_FORMAT) {
    rc = ej_error_input(&r.loc, "cannot restart from '%s': checkpoint format %lld, this build reads format %d", path,
                        (long long)version, EJ_CHECKPOINT_FORMAT);
    goto close_cp;
  }
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "dimension", H5T_NATIVE_INT64, &dim), close_cp);
  if (dim != sim->dim) {
    rc = ej_error_input(&r.loc, "cannot restart from '%s': the checkpoint is %lldD, the scene is %dD", path,
                        (long long)dim, sim->dim);
    goto close_cp;
  }
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "t", H5T_NATIVE_DOUBLE, &t), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "dt", H5T_NATIVE_DOUBLE, &dt), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "step", H5T_NATIVE_INT64, &step), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "n_rebuilds", H5T_NATIVE_INT64, &n_rebuilds), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "frame", H5T_NATIVE_INT64, &frame), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "next_output", H5T_NATIVE_DOUBLE, &next_output), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "next_checkpoint", H5T_NATIVE_DOUBLE, &next_checkpoint), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "energy_work_gravity", H5T_NATIVE_DOUBLE, &external), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_attr(&r, cp, "energy_total0", H5T_NATIVE_DOUBLE, &total0), close_cp);
  for (int k = 0; k < sim->n_sets; ++k) EJ_TRY_GOTO(rc, ej_cp_set(&r, cp, sim->sets[k]), close_cp);
  EJ_TRY_GOTO(rc, ej_cp_interactions(&r, cp, sim), close_cp);
  sim->t = t;
  sim->dt = dt;
  sim->step = step;
  sim->n_rebuilds = n_rebuilds;
  sim->frame = frame;
  sim->next_output = next_output;
  sim->next_checkpoint = next_checkpoint;
  sim->energy.work_gravity = external;
  sim->energy.total0 = total0;
close_cp:
  H5Gclose(cp);
close_file:
  H5Fclose(file);
  return rc;
}
