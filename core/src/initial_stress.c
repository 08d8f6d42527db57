/* Initial stress for the methods that integrate a rate-form Cauchy stress (plugin.h, ABI 1.13):
 * the `initial_stress` parameter block and its application at setup, shared by tlpd and rkpm.
 * Like LS-DYNA's *INITIAL_STRESS_SOLID (uniform or per point) and *INITIAL_STRESS_DEPTH
 * (geostatic: vertical stress from the overburden, horizontal = K0 times it). */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

const ej_param ej_initial_stress_params[] = {
    EJ_PARAM_ARRAY(ej_initial_stress, uniform, 6, "Pa", 0,
                   "Cauchy stress given to every particle at t = 0, Voigt order xx yy zz xy yz zx (tension "
                   "positive); default zero."),
    EJ_PARAM_STRING(ej_initial_stress, file, NULL, EJ_PF_PATH,
                    "CSV file (path absolute or relative to the scene file's directory) with a header line naming "
                    "the columns x, y, z (as many as the dimension) and any of sxx, syy, szz, sxy, syz, szx (Pa; "
                    "absent ones 0): each particle takes the stress of the row at its initial position (within "
                    "a quarter of its spacing; a particle without a row is an error). Not with uniform or geostatic."),
    EJ_PARAM_BOOL(ej_initial_stress, geostatic, false,
                  "Geostatic stress from the overburden (like LS-DYNA *INITIAL_STRESS_DEPTH): with up = -g/|g| "
                  "(the scene's gravity, required) and depth d = surface - x.up, the vertical stress is "
                  "sigma_v = -(surcharge + rho g d) (rho: the particle's density at t = 0) and the horizontal "
                  "stresses are k0 sigma_v. A particle above the surface is an error. Not with uniform or file."),
    EJ_PARAM_REAL(ej_initial_stress, surface, "m", 0.0, 0.0, 0.0, 0,
                  "geostatic: position of the free surface along up (the coordinate of the top for gravity along "
                  "-z)."),
    EJ_PARAM_REAL(ej_initial_stress, k0, "1", 0.5, 0.0, 10.0, EJ_PF_HAS_MIN | EJ_PF_HAS_MAX,
                  "geostatic: ratio of horizontal to vertical stress (at rest, e.g. Jaky's 1 - sin(phi) for a "
                  "normally consolidated granular soil)."),
    EJ_PARAM_REAL(ej_initial_stress, surcharge, "Pa", 0.0, 0.0, 0.0, EJ_PF_HAS_MIN,
                  "geostatic: vertical pressure on the surface (the weight of whatever lies on the set), added to "
                  "the overburden."),
    {0}};

ej_err ej_initial_stress_check(const ej_initial_stress *c, ej_diag *diag)
{
  bool uniform = false;
  for (int k = 0; k < 6; ++k) uniform |= c->uniform[k] != 0;
  const bool file = c->file && c->file[0];
  if ((int)uniform + (int)file + (int)c->geostatic > 1)
    return ej_diag_error(diag, "initial_stress", "initial_stress: give one of 'uniform', 'file' or 'geostatic: true'");
  return EJ_OK;
}

/* One row of the CSV: its cell (key), position and values. */
typedef struct is_row {
  int64_t key[3];
  ej_real x[3];
  ej_real s[6];
} is_row;

static int is_cmp_key(const int64_t *a, const int64_t *b)
{
  for (int k = 0; k < 3; ++k)
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  return 0;
}

static int is_cmp(const void *a, const void *b) { return is_cmp_key(((const is_row *)a)->key, ((const is_row *)b)->key); }

/* Reads the CSV (header: x, y, z, sxx, syy, szz, sxy, syz, szx in any order) into rows. */
static ej_err is_read(const char *set, int dim, const char *path, is_row **rows_out, size_t *n_out)
{
  static const char *const names[9] = {"x", "y", "z", "sxx", "syy", "szz", "sxy", "syz", "szx"};
  FILE *fp = fopen(path, "r");
  EJ_ENSURE(fp, EJ_ERR_INPUT, "set '%s': cannot read initial_stress file '%s'", set, path);
  char line[4096];
  int col[16], ncol = 0; /* kind of each column: 0..8 */
  bool have[9] = {false};
  ej_err rc = EJ_OK;
  is_row *rows = NULL;
  size_t n = 0, cap = 0;
  long lineno = 1;
  if (!fgets(line, sizeof line, fp)) {
    fclose(fp);
    EJ_FAIL(EJ_ERR_INPUT, "set '%s': initial_stress file '%s' is empty (expected a header line)", set, path);
  }
  char *save = NULL;
  for (char *tok = strtok_r(line, ",\r\n", &save); tok; tok = strtok_r(NULL, ",\r\n", &save)) {
    while (*tok == ' ' || *tok == '\t') ++tok;
    size_t L = strlen(tok);
    while (L > 0 && (tok[L - 1] == ' ' || tok[L - 1] == '\t')) tok[--L] = 0;
    int kind = -1;
    for (int k = 0; k < 9; ++k)
      if (strcmp(tok, names[k]) == 0) kind = k;
    if (kind < 0 || have[kind] || ncol == 16) {
      fclose(fp);
      EJ_FAIL(EJ_ERR_INPUT,
              "set '%s': initial_stress file '%s' line 1: %s column '%s' (expected x, y, z, sxx, syy, szz, sxy, "
              "syz, szx)",
              set, path, kind < 0 ? "unknown" : "repeated", tok);
    }
    have[kind] = true;
    col[ncol++] = kind;
  }
  for (int k = 0; k < dim; ++k)
    if (!have[k]) {
      fclose(fp);
      EJ_FAIL(EJ_ERR_INPUT, "set '%s': initial_stress file '%s' lacks column '%s'", set, path, names[k]);
    }
  while (fgets(line, sizeof line, fp)) {
    ++lineno;
    char *p = line;
    while (*p == ' ' || *p == '\t') ++p;
    if (*p == '\n' || *p == '\r' || *p == 0 || *p == '#') continue;
    if (n == cap) {
      cap = cap ? 2 * cap : 1024;
      is_row *nr = ej_realloc(rows, cap * sizeof *rows);
      if (!nr) {
        rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
        goto out;
      }
      rows = nr;
    }
    is_row *r = &rows[n];
    memset(r, 0, sizeof *r);
    for (int c = 0; c < ncol; ++c) {
      char *end;
      const double v = strtod(p, &end);
      while (*end == ' ' || *end == '\t') ++end;
      if (end == p || !isfinite(v) || (c + 1 < ncol ? *end != ',' : (*end != 0 && *end != '\n' && *end != '\r'))) {
        rc = ej_error_push(EJ_ERR_INPUT, __FILE__, __LINE__, __func__,
                           "set '%s': initial_stress file '%s' line %ld: column %d ('%s') is not a number", set, path,
                           lineno, c + 1, names[col[c]]);
        goto out;
      }
      if (col[c] < 3) r->x[col[c]] = v;
      else r->s[col[c] - 3] = v;
      p = end + 1;
    }
    ++n;
  }
out:
  fclose(fp);
  if (rc != EJ_OK) {
    ej_free(rows);
    return rc;
  }
  *rows_out = rows;
  *n_out = n;
  return EJ_OK;
}

static inline ej_real is_dx(int dim, ej_real vol0) { return dim == 3 ? cbrt(vol0) : dim == 2 ? sqrt(vol0) : vol0; }

/* Each particle takes the nearest row within a quarter of its spacing dx_i = vol0^(1/dim); rows
 * sorted by cells of size h = max_i dx_i / 4, so a particle searches its 3^dim cells. */
static ej_err is_file(const ej_set *set, const char *path, ej_real *stress)
{
  const ej_idx n = ej_set_count(set);
  const int dim = ej_set_dim(set);
  const char *name = ej_set_name(set);
  const ej_real *x = ej_set_field(set, "x"), *vol0 = ej_set_field(set, "vol0");
  EJ_ENSURE(x && vol0, EJ_ERR_INTERNAL, "set '%s': fields x, vol0 missing", name);
  is_row *rows = NULL;
  size_t nr = 0;
  EJ_TRY(is_read(name, dim, path, &rows, &nr));
  ej_real h = 0;
  for (ej_idx i = 0; i < n; ++i) h = fmax(h, 0.25 * is_dx(dim, vol0[i]));
  if (!(h > 0)) h = 1;
  for (size_t k = 0; k < nr; ++k)
    for (int a = 0; a < 3; ++a) rows[k].key[a] = a < dim ? (int64_t)floor(rows[k].x[a] / h) : 0;
  if (nr > 0) qsort(rows, nr, sizeof *rows, is_cmp);
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real *xi = x + 3 * i, tol = 0.25 * is_dx(dim, vol0[i]);
    int64_t ki[3];
    for (int a = 0; a < 3; ++a) ki[a] = a < dim ? (int64_t)floor(xi[a] / h) : 0;
    ej_real best = INFINITY;
    const is_row *pick = NULL;
    for (int d0 = -1; d0 <= 1; ++d0)
      for (int d1 = (dim > 1 ? -1 : 0); d1 <= (dim > 1 ? 1 : 0); ++d1)
        for (int d2 = (dim > 2 ? -1 : 0); d2 <= (dim > 2 ? 1 : 0); ++d2) {
          const int64_t key[3] = {ki[0] + d0, ki[1] + d1, ki[2] + d2};
          size_t a = 0, b = nr; /* first row with key >= cell */
          while (a < b) {
            const size_t mid = a + (b - a) / 2;
            if (is_cmp_key(rows[mid].key, key) < 0) a = mid + 1;
            else b = mid;
          }
          for (; a < nr && is_cmp_key(rows[a].key, key) == 0; ++a) {
            ej_real d2s = 0;
            for (int q = 0; q < dim; ++q) d2s += (rows[a].x[q] - xi[q]) * (rows[a].x[q] - xi[q]);
            if (d2s < best) best = d2s, pick = &rows[a];
          }
        }
    if (!pick || sqrt(best) > tol) {
      ej_free(rows);
      EJ_FAIL(EJ_ERR_INPUT, "set '%s': initial_stress file '%s' has no row within %g m of particle %d at (%g, %g, %g)",
              name, path, tol, (int)i, xi[0], xi[1], xi[2]);
    }
    memcpy(stress + 6 * i, pick->s, 6 * sizeof *stress);
  }
  ej_free(rows);
  return EJ_OK;
}

/* sigma = k0 sigma_v I + (1 - k0) sigma_v up (x) up, sigma_v = -(surcharge + rho |g| d). */
static ej_err is_geostatic(const ej_initial_stress *c, const ej_set *set, ej_real *stress)
{
  const ej_idx n = ej_set_count(set);
  const char *name = ej_set_name(set);
  const ej_real *x = ej_set_field(set, "x"), *rho = ej_set_field(set, "rho");
  EJ_ENSURE(x && rho, EJ_ERR_INTERNAL, "set '%s': fields x, rho missing", name);
  const ej_real *g = set->sim ? set->sim->scene->gravity : NULL;
  const ej_real gn = g ? sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) : 0.0;
  EJ_ENSURE(gn > 0, EJ_ERR_INPUT, "set '%s': initial_stress: geostatic needs the scene's gravity (none is given)", name);
  const ej_real up[3] = {-g[0] / gn, -g[1] / gn, -g[2] / gn};
  const int pa[6] = {0, 1, 2, 0, 1, 2}, pb[6] = {0, 1, 2, 1, 2, 0}; /* Voigt xx yy zz xy yz zx */
  for (ej_idx i = 0; i < n; ++i) {
    const ej_real *xi = x + 3 * i;
    const ej_real d = c->surface - (xi[0] * up[0] + xi[1] * up[1] + xi[2] * up[2]);
    /* a particle that sits on the surface to round-off (the top layer of a lattice) has depth 0 */
    EJ_ENSURE(d >= -1e-9 * (fabs(c->surface) + 1e-3), EJ_ERR_INPUT,
              "set '%s': initial_stress: particle %d at (%g, %g, %g) is %g m above the geostatic surface", name,
              (int)i, xi[0], xi[1], xi[2], -d);
    const ej_real sv = -(c->surcharge + rho[i] * gn * fmax(d, 0.0));
    for (int k = 0; k < 6; ++k)
      stress[6 * i + k] = (k < 3 ? c->k0 * sv : 0.0) + (1.0 - c->k0) * sv * up[pa[k]] * up[pb[k]];
  }
  return EJ_OK;
}

ej_err ej_initial_stress_apply(const ej_initial_stress *c, const ej_set *set, ej_real *stress)
{
  EJ_ENSURE(c && set && stress, EJ_ERR_ARG, "ej_initial_stress_apply: NULL argument");
  if (c->file && c->file[0]) return is_file(set, c->file, stress);
  if (c->geostatic) return is_geostatic(c, set, stress);
  bool any = false;
  for (int k = 0; k < 6; ++k) any |= c->uniform[k] != 0;
  if (any)
    for (ej_idx i = 0, n = ej_set_count(set); i < n; ++i) memcpy(stress + 6 * i, c->uniform, 6 * sizeof *stress);
  return EJ_OK;
}
