/* rkpm: the linear algebra of the mixed transformation method for essential boundaries
 * (rk_essential.h; README "Essential boundary conditions"). Serial (ej_method_ops.serial), in a
 * fixed order: the results do not depend on the thread count. */
#include "rk_essential.h"

#include <math.h>
#include <string.h>

enum { RK_ESS_NW = 10 };    /* solver vectors: x r rh p v s t z dinv b */
#define RK_ESS_MAXIT 400    /* BiCGSTAB iterations of one solve */
#define RK_ESS_RTOL 1e-13   /* max |residual| / max |values| */
#define RK_ESS_DEGEN 1e-10  /* |own weight| / sum |row| below which a held component is dropped */

ej_err rk_ess_create(rk_ess **out, ej_idx n)
{
  rk_ess *e = ej_calloc(1, sizeof *e);
  EJ_ENSURE(e, EJ_ERR_MEM, "rkpm transformation: out of memory");
  const size_t nn = (size_t)(n > 0 ? n : 1);
  e->n = n;
  e->held = ej_calloc(nn, sizeof *e->held);
  e->bpos = ej_calloc(nn, sizeof *e->bpos);
  e->blist = ej_calloc(nn, sizeof *e->blist);
  e->roff = ej_calloc(nn + 1, sizeof *e->roff);
  bool ok = e->held && e->bpos && e->blist && e->roff;
  for (int c = 0; c < 3 && ok; ++c) {
    e->aoff[c] = ej_calloc(nn + 1, sizeof *e->aoff[c]);
    e->adiag[c] = ej_calloc(nn, sizeof *e->adiag[c]);
    ok = e->aoff[c] && e->adiag[c];
  }
  if (!ok) {
    rk_ess_destroy(e);
    EJ_FAIL(EJ_ERR_MEM, "rkpm transformation: out of memory (%lld nodes)", (long long)n);
  }
  *out = e;
  return EJ_OK;
}

void rk_ess_destroy(rk_ess *e)
{
  if (!e) return;
  ej_free(e->held);
  ej_free(e->bpos);
  ej_free(e->blist);
  ej_free(e->roff);
  ej_free(e->rsrc);
  ej_free(e->rval);
  ej_free(e->rsgn);
  ej_free(e->w);
  for (int c = 0; c < 3; ++c) {
    ej_free(e->aoff[c]);
    ej_free(e->acol[c]);
    ej_free(e->aval[c]);
    ej_free(e->adiag[c]);
  }
  ej_free(e);
}

ej_err rk_ess_held(rk_ess *e, const ej_set *set)
{
  const ej_idx n = ej_set_count(set);
  EJ_ENSURE(n == e->n, EJ_ERR_INTERNAL, "set '%s': rkpm transformation sized for %lld nodes, set has %lld",
            ej_set_name(set), (long long)e->n, (long long)n);
  e->nb = 0;
  for (ej_idx i = 0; i < n; ++i) {
    e->held[i] = (uint8_t)ej_set_held(set, i);
    e->bpos[i] = e->held[i] ? (int32_t)e->nb : -1;
    if (e->held[i]) e->blist[e->nb++] = i;
  }
  e->roff[0] = 0;
  if (e->nb > e->wcap) {
    ej_real *w = ej_realloc(e->w, (size_t)RK_ESS_NW * (size_t)e->nb * sizeof *w);
    EJ_ENSURE(w, EJ_ERR_MEM, "set '%s': rkpm transformation: out of memory", ej_set_name(set));
    e->w = w;
    e->wcap = e->nb;
  }
  return EJ_OK;
}

ej_err rk_ess_reserve(rk_ess *e, size_t nnz)
{
  if (nnz <= e->cap) return EJ_OK;
  const size_t cap = nnz + nnz / 8 + 64;
  ej_idx *rsrc = ej_realloc(e->rsrc, cap * sizeof *rsrc);
  if (rsrc) e->rsrc = rsrc;
  ej_real *rval = ej_realloc(e->rval, cap * sizeof *rval);
  if (rval) e->rval = rval;
  int8_t *rsgn = ej_realloc(e->rsgn, 3 * cap * sizeof *rsgn);
  if (rsgn) e->rsgn = rsgn;
  EJ_ENSURE(rsrc && rval && rsgn, EJ_ERR_MEM, "rkpm transformation: out of memory (%zu row entries)", cap);
  e->cap = cap;
  return EJ_OK;
}

/* Whether owned node M is an unknown of component c. */
static inline bool rk_ess_act(const rk_ess *e, ej_idx M, int c) { return (e->held[M] >> c) & 1u; }

ej_err rk_ess_rows_done(rk_ess *e)
{
  for (ej_idx k = 0; k < e->nb; ++k) {
    const ej_idx K = e->blist[k];
    for (int c = 0; c < 3; ++c) {
      if (!rk_ess_act(e, K, c)) continue;
      ej_real own = 0, sum = 0;
      for (ej_off q = e->roff[k]; q < e->roff[k + 1]; ++q) {
        sum += fabs(e->rval[q]);
        if (e->rsrc[q] == K) own += e->rval[q] * e->rsgn[3 * q + c];
      }
      if (!(fabs(own) > RK_ESS_DEGEN * sum)) {
        e->held[K] &= (uint8_t)~(1u << c);
        e->degenerate++;
      }
    }
  }
  /* the compact systems: one entry per (row, unknown) in the order of first appearance */
  const size_t need = (size_t)e->roff[e->nb] + (size_t)e->nb;
  if (need > e->acap) {
    const size_t cap = need + need / 8 + 64;
    for (int c = 0; c < 3; ++c) {
      ej_idx *col = ej_realloc(e->acol[c], cap * sizeof *col);
      if (col) e->acol[c] = col;
      ej_real *val = ej_realloc(e->aval[c], cap * sizeof *val);
      if (val) e->aval[c] = val;
      EJ_ENSURE(col && val, EJ_ERR_MEM, "rkpm transformation: out of memory (%zu entries)", cap);
    }
    e->acap = cap;
  }
  for (int c = 0; c < 3; ++c) {
    ej_off *off = e->aoff[c];
    ej_idx *col = e->acol[c];
    ej_real *val = e->aval[c];
    ej_off o = 0;
    off[0] = 0;
    for (ej_idx k = 0; k < e->nb; ++k) {
      const ej_idx K = e->blist[k];
      e->adiag[c][k] = 1.0;
      if (!rk_ess_act(e, K, c)) {
        col[o] = k, val[o] = 1.0, ++o;
        off[k + 1] = o;
        continue;
      }
      const ej_off row0 = o;
      for (ej_off q = e->roff[k]; q < e->roff[k + 1]; ++q) {
        const ej_idx M = e->rsrc[q];
        if (!rk_ess_act(e, M, c)) continue;
        const ej_idx m = e->bpos[M];
        const ej_real a = e->rval[q] * e->rsgn[3 * q + c];
        ej_off t = row0;
        while (t < o && col[t] != m) ++t; /* images of a node already in the row: merged */
        if (t < o) {
          val[t] += a;
        } else {
          col[o] = m, val[o] = a, ++o;
        }
      }
      for (ej_off t = row0; t < o; ++t)
        if (col[t] == k) e->adiag[c][k] = val[t];
      off[k + 1] = o;
    }
  }
  return EJ_OK;
}

/* y = A x (trans: A^T x) over the held nodes for component c (the compact system). */
static void rk_ess_apply(const rk_ess *e, int c, bool trans, const ej_real *x, ej_real *y)
{
  const ej_idx nb = e->nb;
  const ej_off *restrict off = e->aoff[c];
  const ej_idx *restrict col = e->acol[c];
  const ej_real *restrict val = e->aval[c];
  if (trans) {
    for (ej_idx k = 0; k < nb; ++k) y[k] = 0.0;
    for (ej_idx k = 0; k < nb; ++k)
      for (ej_off t = off[k]; t < off[k + 1]; ++t) y[col[t]] += val[t] * x[k];
    return;
  }
  for (ej_idx k = 0; k < nb; ++k) {
    ej_real acc = 0;
    for (ej_off t = off[k]; t < off[k + 1]; ++t) acc += val[t] * x[col[t]];
    y[k] = acc;
  }
}

static ej_real rk_ess_dot(ej_idx n, const ej_real *a, const ej_real *b)
{
  ej_real s = 0;
  for (ej_idx k = 0; k < n; ++k) s += a[k] * b[k];
  return s;
}

static ej_real rk_ess_amax(ej_idx n, const ej_real *a)
{
  ej_real m = 0;
  for (ej_idx k = 0; k < n; ++k) m = fmax(m, fabs(a[k]));
  return m;
}

/* Solves A x = b (trans: A^T x = b) for component c by BiCGSTAB with Jacobi preconditioning, from
 * the x given, to max |b - A x| <= RK_ESS_RTOL scale (checked on the true residual). */
static ej_err rk_ess_solve(rk_ess *e, const char *set_name, int c, bool trans, const ej_real *b, ej_real *x,
                           ej_real scale)
{
  const ej_idx nb = e->nb;
  ej_real *r = e->w + nb, *rh = e->w + 2 * nb, *p = e->w + 3 * nb, *v = e->w + 4 * nb, *s = e->w + 5 * nb,
          *t = e->w + 6 * nb, *z = e->w + 7 * nb, *dinv = e->w + 8 * nb;
  /* Jacobi: the weight of each unknown on its own row (the same for A and A^T) */
  for (ej_idx k = 0; k < nb; ++k) dinv[k] = 1.0 / e->adiag[c][k];
  const ej_real tol = RK_ESS_RTOL * (scale > 0 ? scale : 1.0);
  e->solves++;
  int it = 0;
  ej_real res = 0;
  for (int restart = 0; restart < 4; ++restart) {
    rk_ess_apply(e, c, trans, x, r);
    for (ej_idx k = 0; k < nb; ++k) r[k] = b[k] - r[k];
    res = rk_ess_amax(nb, r);
    if (res <= tol || it >= RK_ESS_MAXIT) break;
    memcpy(rh, r, (size_t)nb * sizeof *rh);
    memset(p, 0, (size_t)nb * sizeof *p);
    memset(v, 0, (size_t)nb * sizeof *v);
    ej_real rho = 1, alpha = 1, omega = 1;
    for (; it < RK_ESS_MAXIT; ++it) {
      const ej_real rho1 = rk_ess_dot(nb, rh, r);
      if (rho1 == 0.0) break; /* breakdown: restart from the true residual */
      const ej_real beta = (rho1 / rho) * (alpha / omega);
      for (ej_idx k = 0; k < nb; ++k) p[k] = r[k] + beta * (p[k] - omega * v[k]);
      for (ej_idx k = 0; k < nb; ++k) z[k] = dinv[k] * p[k];
      rk_ess_apply(e, c, trans, z, v);
      const ej_real rv = rk_ess_dot(nb, rh, v);
      if (rv == 0.0) break;
      alpha = rho1 / rv;
      for (ej_idx k = 0; k < nb; ++k) x[k] += alpha * z[k], s[k] = r[k] - alpha * v[k];
      if (rk_ess_amax(nb, s) <= tol) {
        ++it;
        break;
      }
      for (ej_idx k = 0; k < nb; ++k) z[k] = dinv[k] * s[k];
      rk_ess_apply(e, c, trans, z, t);
      const ej_real tt = rk_ess_dot(nb, t, t);
      omega = tt > 0.0 ? rk_ess_dot(nb, t, s) / tt : 0.0;
      for (ej_idx k = 0; k < nb; ++k) x[k] += omega * z[k], r[k] = s[k] - omega * t[k];
      rho = rho1;
      if (rk_ess_amax(nb, r) <= tol || omega == 0.0) {
        ++it;
        break;
      }
    }
  }
  e->iters += it;
  if (it > e->maxit) e->maxit = it;
  EJ_ENSURE(res <= tol, EJ_ERR_NUMERIC,
            "set '%s': rkpm transformation method (essential boundaries, component %c%s): BiCGSTAB left a "
            "residual %.3g after %d iterations (tolerance %.3g)",
            set_name, "xyz"[c], trans ? ", forces" : "", res, it, tol);
  return EJ_OK;
}

ej_err rk_ess_coefficients(rk_ess *e, const char *set_name, const ej_real *val, ej_real *out)
{
  const ej_idx nb = e->nb;
  ej_real *x = e->w, *b = e->w + 9 * nb;
  if (out != val) memcpy(out, val, 3 * (size_t)e->n * sizeof *out);
  for (int c = 0; c < 3; ++c) {
    bool any = false;
    ej_real scale = 0;
    for (ej_idx k = 0; k < nb; ++k) {
      const ej_idx K = e->blist[k];
      if (!rk_ess_act(e, K, c)) {
        b[k] = x[k] = 0;
        continue;
      }
      any = true;
      /* the nodal value less the known coefficients' share; unknowns start at the nodal value */
      ej_real known = 0;
      scale = fmax(scale, fabs(val[3 * K + c]));
      for (ej_off q = e->roff[k]; q < e->roff[k + 1]; ++q) {
        const ej_idx M = e->rsrc[q];
        scale = fmax(scale, fabs(val[3 * M + c]));
        if (!rk_ess_act(e, M, c)) known += e->rval[q] * e->rsgn[3 * q + c] * val[3 * M + c];
      }
      b[k] = val[3 * K + c] - known;
      x[k] = val[3 * K + c];
    }
    if (!any) continue;
    EJ_TRY(rk_ess_solve(e, set_name, c, false, b, x, scale));
    for (ej_idx k = 0; k < nb; ++k)
      if (rk_ess_act(e, e->blist[k], c)) out[3 * e->blist[k] + c] = x[k];
  }
  return EJ_OK;
}

ej_err rk_ess_forces(rk_ess *e, const char *set_name, const ej_real *m, ej_real *a)
{
  const ej_idx nb = e->nb;
  ej_real *y = e->w, *f = e->w + 9 * nb;
  for (int c = 0; c < 3; ++c) {
    bool any = false;
    ej_real scale = 0;
    for (ej_idx k = 0; k < nb; ++k) {
      const ej_idx K = e->blist[k];
      const bool act = rk_ess_act(e, K, c);
      f[k] = act ? m[K] * a[3 * K + c] : 0.0;
      y[k] = f[k];
      any |= act;
      scale = fmax(scale, fabs(f[k]));
    }
    if (!any || scale == 0.0) continue;
    EJ_TRY(rk_ess_solve(e, set_name, c, true, f, y, scale));
    /* the held node takes y (its reaction, which the core's constraint then takes away), every
     * other node I of its row loses Lambda_KI y_K (T^T of the dependent coefficients) */
    for (ej_idx k = 0; k < nb; ++k) {
      const ej_idx K = e->blist[k];
      if (!rk_ess_act(e, K, c)) continue;
      for (ej_off q = e->roff[k]; q < e->roff[k + 1]; ++q) {
        const ej_idx M = e->rsrc[q];
        if (rk_ess_act(e, M, c)) continue;
        a[3 * M + c] -= e->rval[q] * e->rsgn[3 * q + c] * y[k] / m[M];
      }
    }
    for (ej_idx k = 0; k < nb; ++k)
      if (rk_ess_act(e, e->blist[k], c)) a[3 * e->blist[k] + c] = y[k] / m[e->blist[k]];
  }
  return EJ_OK;
}
