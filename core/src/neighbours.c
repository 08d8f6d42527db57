/* Cell-list neighbour search on a uniform grid and CSR lists (DESIGN.md "Neighbours").
 *
 * A build splits the candidates into radius classes, bins each class into its own grid of
 * cells (one stable counting sort over all the cells; the candidates' coordinates and radii
 * are copied in that order, so that a cell row is contiguous and tested eight at a time with
 * AVX-512 or four at a time with AVX2), then scans each row once into the buffer of the thread
 * that takes its block of rows; a prefix sum of the row counts places the blocks in the CSR
 * arrays. Each row is sorted ascending and its content does not depend on the thread, so the
 * list is bitwise identical for any OpenMP thread count (DESIGN.md "Determinism"). */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core_impl.h"

#ifdef _OPENMP
#include <omp.h>
#endif
#ifdef __AVX2__
#include <immintrin.h>
#endif
/* The candidate test eight at a time with AVX-512 (F and VL: masked loads, mask compares, register
 * compress), else four at a time with AVX2, else scalar; the same pairs pass in every build. */
#if defined(__AVX512F__) && defined(__AVX512VL__)
#define EJ_SCAN_AVX512 1
#else
#define EJ_SCAN_AVX512 0
#endif

#if defined(__GNUC__)
#define EJ_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define EJ_ALWAYS_INLINE inline
#endif

/* Relative and absolute (cell units) widening of the scanned ball: covers the rounding of
 * cell coordinates (about 1e-16 times the number of cells). */
#define EJ_CELL_MARGIN 1e-6
#ifndef EJ_CELL_SPLIT
#define EJ_CELL_SPLIT 1
#endif

/* A uniform grid over a bounding box; components >= dim have one cell. */
typedef struct ej_grid {
  int dim;
  ej_real lo[3];
  ej_real inv_h;
  int64_t nc[3];
  int64_t n_cells;
} ej_grid;

/* Sizes the grid over points x[0..n) (n > 0) with cells of at least h, enlarged until the
 * grid has at most max_cells cells: a few points in a huge box must not cost memory.
 * With anchor (a lower corner, at or above the points' own), the grid's corner is moved down
 * from anchor by whole cells: the cells are then those of the grid that ej_nbr_sort_order
 * put the first particles in (the rows of a self list, whose lower corner anchor is), so a
 * row's candidates come out nearly ascending and its sort is mostly the run check. The
 * cells do not change which pairs are listed. */
static ej_err ej_grid_setup(ej_grid *g, int dim, const ej_real *x, ej_idx n, ej_real h, int64_t max_cells,
                            const ej_real *anchor)
{
  ej_real lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim; d++) lo[d] = hi[d] = x[d];
  for (ej_idx i = 1; i < n; i++) {
    for (int d = 0; d < dim; d++) {
      const ej_real v = x[3 * (size_t)i + d];
      if (v < lo[d]) lo[d] = v;
      if (v > hi[d]) hi[d] = v;
    }
  }
  ej_real ext_max = 0;
  for (int d = 0; d < dim; d++) {
    const ej_real ext = hi[d] - lo[d];
    /* NaN coordinates are skipped by the comparisons above; infinite ones are not. */
    EJ_ENSURE(isfinite(lo[d]) && isfinite(hi[d]) && isfinite(ext), EJ_ERR_NUMERIC,
              "non-finite particle position (component %d) in neighbour search", d);
    if (ext > ext_max) ext_max = ext;
  }
  /* Keeps ext / h finite even for absurdly small h. */
  if (h < ext_max / (ej_real)max_cells) h = ext_max / (ej_real)max_cells;

  ej_real nc[3] = {1, 1, 1};
  const ej_real lo_pts[3] = {lo[0], lo[1], lo[2]};
  for (;;) {
    ej_real total = 1;
    for (int d = 0; d < dim; d++) {
      if (anchor) {
        const ej_real a = anchor[d] - ceil((anchor[d] - lo_pts[d]) / h) * h;
        lo[d] = isfinite(a) && a <= lo_pts[d] ? a : lo_pts[d];
      }
      nc[d] = floor((hi[d] - lo[d]) / h) + 1;
      total *= nc[d];
    }
    if (total <= (ej_real)max_cells) break;
    ej_real grow = pow(total / (ej_real)max_cells, 1.0 / dim);
    h *= grow > 1.01 ? grow : 1.01;
  }

  g->dim = dim;
  g->inv_h = 1 / h;
  g->n_cells = 1;
  for (int d = 0; d < 3; d++) {
    g->lo[d] = d < dim ? lo[d] : 0;
    g->nc[d] = d < dim ? (int64_t)nc[d] : 1;
    g->n_cells *= g->nc[d];
  }
  return EJ_OK;
}

/* Cell coordinate of a point of the gridded set; clamped since rounding (or a NaN) may
 * step just outside. */
static EJ_ALWAYS_INLINE int64_t ej_grid_coord(const ej_grid *g, int d, ej_real x)
{
  const ej_real t = (x - g->lo[d]) * g->inv_h;
  if (!(t > 0)) return 0;
  if (t >= (ej_real)(g->nc[d] - 1)) return g->nc[d] - 1;
  return (int64_t)t;
}

static EJ_ALWAYS_INLINE int64_t ej_grid_cell(const ej_grid *g, const ej_real *x)
{
  int64_t c = 0;
  for (int d = g->dim - 1; d >= 0; d--) c = c * g->nc[d] + ej_grid_coord(g, d, x[d]);
  return c;
}

/* Quicksort (median of three, recursing on the smaller side) with insertion sort for short
 * ranges. Row entries are distinct. */
static void ej_idx_qsort(ej_idx *a, int64_t n)
{
  while (n > 24) {
    const int64_t m = n / 2;
    ej_idx p0 = a[0], p1 = a[m], p2 = a[n - 1], piv;
    if (p0 < p1) piv = p1 < p2 ? p1 : (p0 < p2 ? p2 : p0);
    else piv = p0 < p2 ? p0 : (p1 < p2 ? p2 : p1);
    int64_t i = 0, j = n - 1;
    for (;;) {
      while (a[i] < piv) i++;
      while (a[j] > piv) j--;
      if (i >= j) break;
      ej_idx t = a[i];
      a[i] = a[j];
      a[j] = t;
      i++;
      j--;
    }
    /* a[0..j] <= piv <= a[j+1..n) */
    const int64_t nl = j + 1;
    if (nl < n - nl) {
      ej_idx_qsort(a, nl);
      a += nl;
      n -= nl;
    } else {
      ej_idx_qsort(a + nl, n - nl);
      n = nl;
    }
  }
  for (int64_t i = 1; i < n; i++) {
    const ej_idx v = a[i];
    int64_t k = i;
    while (k > 0 && a[k - 1] > v) {
      a[k] = a[k - 1];
      k--;
    }
    a[k] = v;
  }
}

#define EJ_SORT_RUNS 64
#define EJ_SORT_BUF 1024

/* A row is a concatenation of ascending runs (one per cell, or one per cell row when the
 * particles are in cell order, then already sorted): natural merge sort, falling back to
 * quicksort for rows with too many runs or too long for the stack buffer. */
static void ej_idx_sort(ej_idx *a, int64_t n)
{
  int64_t b[EJ_SORT_RUNS + 1];
  int nr = 0;
  b[0] = 0;
  for (int64_t k = 1; k < n; k++) {
    if (a[k] < a[k - 1]) {
      if (nr == EJ_SORT_RUNS - 1 || n > EJ_SORT_BUF) {
        ej_idx_qsort(a, n);
        return;
      }
      b[++nr] = k;
    }
  }
  b[++nr] = n;
  if (nr == 1) return;
  ej_idx tmp[EJ_SORT_BUF];
  ej_idx *src = a, *dst = tmp;
  while (nr > 1) {
    int m = 0;
    for (int r = 0; r < nr; r += 2) {
      if (r + 1 == nr) { /* odd run out: copy */
        memcpy(dst + b[r], src + b[r], (size_t)(b[r + 1] - b[r]) * sizeof *src);
      } else {
        int64_t i = b[r], j = b[r + 1], k = b[r];
        const int64_t ie = b[r + 1], je = b[r + 2];
        while (i < ie && j < je) dst[k++] = src[i] < src[j] ? src[i++] : src[j++];
        while (i < ie) dst[k++] = src[i++];
        while (j < je) dst[k++] = src[j++];
      }
      b[m++] = b[r];
    }
    b[m] = n;
    nr = m;
    ej_idx *t = src;
    src = dst;
    dst = t;
  }
  if (src != a) memcpy(a, src, (size_t)n * sizeof *a);
}

/* Discards the contents and grows a scratch array to at least need elements (plus slack
 * for arrays whose size drifts between rebuilds). */
static ej_err ej_scratch_grow(void **p, int64_t *cap, int64_t need, size_t elem, bool slack)
{
  if (need <= *cap && *p) return EJ_OK;
  int64_t want = need + (slack ? need / 8 + 64 : 0);
  if (want < 1) want = 1;
  EJ_ENSURE((uint64_t)want <= SIZE_MAX / elem, EJ_ERR_MEM, "neighbour scratch of %lld items overflows",
            (long long)want);
  ej_free(*p);
  *p = ej_malloc((size_t)want * elem);
  if (!*p) {
    *cap = 0;
    EJ_FAIL(EJ_ERR_MEM, "out of memory for %lld neighbour scratch items", (long long)want);
  }
  *cap = want;
  return EJ_OK;
}

ej_err ej_nbrlist_create(ej_nbrlist **L)
{
  EJ_ENSURE(L, EJ_ERR_ARG, "NULL list pointer");
  *L = ej_calloc(1, sizeof **L);
  EJ_ENSURE(*L, EJ_ERR_MEM, "out of memory");
  return EJ_OK;
}

void ej_nbrlist_destroy(ej_nbrlist *L)
{
  if (!L) return;
  ej_free(L->off);
  ej_free(L->idx);
  ej_free(L->cell_start);
  ej_free(L->cell_items);
  ej_free(L->cell_of);
  ej_free(L->cell_pos);
  for (int t = 0; t < L->n_tbuf; t++) ej_free(L->tbuf[t]);
  ej_free(L->tbuf);
  ej_free(L->tcap);
  ej_free(L);
}

/* Distance in cell units from coordinate t to cell c's interval [c, c + 1). */
static EJ_ALWAYS_INLINE ej_real ej_cell_gap(ej_real t, int64_t c)
{
  const ej_real a = (ej_real)c - t, b = t - (ej_real)(c + 1);
  return a > 0 ? a : (b > 0 ? b : 0);
}

#if defined(__AVX2__) && !EJ_SCAN_AVX512
/* _mm_shuffle_epi8 masks packing the 32-bit lanes selected by a 4-bit mask to the front. */
#define EJ_Z4 128, 128, 128, 128
static const uint8_t ej_pack_lut[16][16] __attribute__((aligned(16))) = {
    {EJ_Z4, EJ_Z4, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, EJ_Z4, EJ_Z4, EJ_Z4},
    {4, 5, 6, 7, EJ_Z4, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 4, 5, 6, 7, EJ_Z4, EJ_Z4},
    {8, 9, 10, 11, EJ_Z4, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 8, 9, 10, 11, EJ_Z4, EJ_Z4},
    {4, 5, 6, 7, 8, 9, 10, 11, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, EJ_Z4},
    {12, 13, 14, 15, EJ_Z4, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 12, 13, 14, 15, EJ_Z4, EJ_Z4},
    {4, 5, 6, 7, 12, 13, 14, 15, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 4, 5, 6, 7, 12, 13, 14, 15, EJ_Z4},
    {8, 9, 10, 11, 12, 13, 14, 15, EJ_Z4, EJ_Z4},
    {0, 1, 2, 3, 8, 9, 10, 11, 12, 13, 14, 15, EJ_Z4},
    {4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, EJ_Z4},
    {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15},
};
#undef EJ_Z4
#endif

/* Writes the candidates of row i into out[0..len); inlined with a constant dim so the
 * distance test is specialised. Only cells that the ball of radius
 * R = max(ri, rb_max) + skin around xi can touch are scanned: per cell row along x (one
 * contiguous run of cell_items, since x is the fastest cell index) the x range is the
 * ball's chord over that row. Works in cell units; the margin on R covers the rounding of
 * the cell coordinates, so a pair that passes the test is never in a skipped cell.
 * The candidates' coordinates and radii are read from P, a copy in cell_items order (SoA,
 * component d at P + d ps), so a cell row is contiguous: with AVX-512 eight candidates are
 * tested at once and the passing indices packed by a register compress, with AVX2 four and a
 * byte shuffle (the same operations in the same order as the scalar test, no FMA: the same
 * pairs pass). Returns len when the row may not fit (then out[0..len) is garbage), else the
 * row's length. */
static EJ_ALWAYS_INLINE ej_idx ej_row_scan(const ej_grid *g, const int dim, const ej_real *xi, ej_real ri,
                                           ej_idx i, const ej_real *P, int64_t ps, ej_real rb_max,
                                           ej_real skin, bool same, const ej_idx *cell_start,
                                           const ej_idx *cell_items, ej_idx *out, ej_idx len)
{
  const ej_real rrow = (ri > rb_max ? ri : rb_max) + skin;
  const ej_real rr = rrow * g->inv_h * (1 + EJ_CELL_MARGIN) + EJ_CELL_MARGIN;
  ej_real t[3] = {0, 0, 0};
  int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim; d++) {
    t[d] = (xi[d] - g->lo[d]) * g->inv_h;
    if (!(t[d] + rr >= 0 && t[d] - rr < (ej_real)g->nc[d])) return 0; /* also NaN */
    lo[d] = t[d] - rr > 0 ? (int64_t)(t[d] - rr) : 0;
    hi[d] = t[d] + rr < (ej_real)(g->nc[d] - 1) ? (int64_t)(t[d] + rr) : g->nc[d] - 1;
  }
  /* Rows at least as wide as every candidate need no candidate radius. */
  const bool row_wide = ri >= rb_max;
  const ej_real r2_row = (ri + skin) * (ri + skin);
  const ej_real x0 = xi[0], x1 = dim > 1 ? xi[1] : 0, x2 = dim > 2 ? xi[2] : 0;
  const ej_idx self = same ? i : -1;
  const ej_real *px = P, *py = P + ps, *pz = P + 2 * ps, *pr = P + 3 * ps;
#if EJ_SCAN_AVX512
  const __m512d wx0 = _mm512_set1_pd(x0), wx1 = _mm512_set1_pd(x1), wx2 = _mm512_set1_pd(x2);
  const __m512d wr2 = _mm512_set1_pd(r2_row), wri = _mm512_set1_pd(ri), wskin = _mm512_set1_pd(skin);
  const __m256i wself = _mm256_set1_epi32(self);
#elif defined(__AVX2__)
  const __m256d vx0 = _mm256_set1_pd(x0), vx1 = _mm256_set1_pd(x1), vx2 = _mm256_set1_pd(x2);
  const __m256d vr2 = _mm256_set1_pd(r2_row), vri = _mm256_set1_pd(ri), vskin = _mm256_set1_pd(skin);
  const __m128i vself = _mm_set1_epi32(self);
#endif
  ej_idx n = 0;
  if (len == 0) return 0;
  for (int64_t cz = lo[2]; cz <= hi[2]; cz++) {
    const ej_real gz = dim > 2 ? ej_cell_gap(t[2], cz) : 0;
    for (int64_t cy = lo[1]; cy <= hi[1]; cy++) {
      int64_t cxl = lo[0], cxh = hi[0];
      if (dim > 1) {
        const ej_real gy = ej_cell_gap(t[1], cy);
        const ej_real w2 = rr * rr - gy * gy - gz * gz;
        if (w2 < 0) continue;
        const ej_real w = sqrt(w2);
        if (t[0] - w > (ej_real)cxl) cxl = (int64_t)(t[0] - w);
        if (t[0] + w < (ej_real)cxh) cxh = (int64_t)(t[0] + w);
        if (cxl > cxh) continue;
      }
      const int64_t base = (cz * g->nc[1] + cy) * g->nc[0];
      const ej_idx e = cell_start[base + cxh + 1];
      ej_idx k = cell_start[base + cxl];
#if EJ_SCAN_AVX512
      /* Eight at a time while eight more entries fit (n <= len after each store), the cell row's last
       * partial group under a load mask (masked-off lanes are not read and fail the test), the passing
       * indices packed in lane order by a register compress: the same test, the same entries in the
       * same order as the loops below. */
      for (; k < e && len - n >= 8; k += 8) {
        const ej_idx rem = e - k;
        const __mmask8 lm = rem >= 8 ? (__mmask8)0xFF : (__mmask8)((1u << rem) - 1u);
        const __m512d dx = _mm512_sub_pd(_mm512_maskz_loadu_pd(lm, px + k), wx0);
        __m512d d2 = _mm512_mul_pd(dx, dx);
        if (dim > 1) {
          const __m512d dy = _mm512_sub_pd(_mm512_maskz_loadu_pd(lm, py + k), wx1);
          d2 = _mm512_add_pd(d2, _mm512_mul_pd(dy, dy));
        }
        if (dim > 2) {
          const __m512d dz = _mm512_sub_pd(_mm512_maskz_loadu_pd(lm, pz + k), wx2);
          d2 = _mm512_add_pd(d2, _mm512_mul_pd(dz, dz));
        }
        __m512d lim = wr2;
        if (!row_wide) {
          const __m512d r = _mm512_add_pd(_mm512_max_pd(wri, _mm512_maskz_loadu_pd(lm, pr + k)), wskin);
          lim = _mm512_mul_pd(r, r);
        }
        const __m256i vj = _mm256_maskz_loadu_epi32(lm, cell_items + k);
        const __mmask8 m = _mm512_mask_cmp_pd_mask(lm, d2, lim, _CMP_LT_OQ) & ~_mm256_cmpeq_epi32_mask(vj, wself);
        _mm256_storeu_si256((__m256i *)(void *)(out + n), _mm256_maskz_compress_epi32(m, vj));
        n += (ej_idx)__builtin_popcount((unsigned)m);
      }
#elif defined(__AVX2__)
      /* Four at a time while four more entries fit: n <= len holds after each store. */
      for (; k + 4 <= e && len - n >= 4; k += 4) {
        const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(px + k), vx0);
        __m256d d2 = _mm256_mul_pd(dx, dx);
        if (dim > 1) {
          const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(py + k), vx1);
          d2 = _mm256_add_pd(d2, _mm256_mul_pd(dy, dy));
        }
        if (dim > 2) {
          const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(pz + k), vx2);
          d2 = _mm256_add_pd(d2, _mm256_mul_pd(dz, dz));
        }
        __m256d lim = vr2;
        if (!row_wide) {
          /* max_pd(a, b) is a > b ? a : b, as max(ri, rj) below. */
          const __m256d r = _mm256_add_pd(_mm256_max_pd(vri, _mm256_loadu_pd(pr + k)), vskin);
          lim = _mm256_mul_pd(r, r);
        }
        const __m128i vj = _mm_loadu_si128((const __m128i *)(const void *)(cell_items + k));
        const int m = _mm256_movemask_pd(_mm256_cmp_pd(d2, lim, _CMP_LT_OQ)) &
                      ~_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(vj, vself)));
        _mm_storeu_si128((__m128i *)(void *)(out + n),
                         _mm_shuffle_epi8(vj, _mm_load_si128((const __m128i *)(const void *)ej_pack_lut[m])));
        n += (ej_idx)__builtin_popcount((unsigned)m);
      }
#endif
#if EJ_SCAN_AVX512 || defined(__AVX2__)
      if (n == len) return n; /* a vector loop filled the row exactly */
#endif
      for (; k < e; k++) {
        const ej_idx j = cell_items[k];
        const ej_real dx = px[k] - x0;
        ej_real d2 = dx * dx;
        if (dim > 1) {
          const ej_real dy = py[k] - x1;
          d2 = d2 + dy * dy;
        }
        if (dim > 2) {
          const ej_real dz = pz[k] - x2;
          d2 = d2 + dz * dz;
        }
        ej_idx in;
        if (row_wide) {
          in = d2 < r2_row;
        } else {
          /* Same operations as max(ri, rj) + skin when ri < rj. */
          const ej_real rj = pr[k];
          const ej_real r = (ri > rj ? ri : rj) + skin;
          in = d2 < r * r;
        }
        /* Branch-free: about a third of the candidates pass, at random. */
        in &= j != self;
        /* The store is in the row while n < len, and the scan stops at len. */
        out[n] = j;
        n += in;
        if (n == len) return n;
      }
    }
  }
  return n;
}

/* Rows per block of the one-pass build: a block's rows are scanned by one thread into its
 * buffer, then copied to their CSR place. */
#define EJ_ROW_BLOCK 256

static EJ_ALWAYS_INLINE ej_idx ej_row_scan_dim(const ej_grid *g, int dim, const ej_real *xi, ej_real ri, ej_idx i,
                                               const ej_real *P, int64_t ps, ej_real rb_max, ej_real skin,
                                               bool same, const ej_idx *cell_start, const ej_idx *cell_items,
                                               ej_idx *out, ej_idx len)
{
  switch (dim) {
  case 1: return ej_row_scan(g, 1, xi, ri, i, P, ps, rb_max, skin, same, cell_start, cell_items, out, len);
  case 2: return ej_row_scan(g, 2, xi, ri, i, P, ps, rb_max, skin, same, cell_start, cell_items, out, len);
  default: return ej_row_scan(g, 3, xi, ri, i, P, ps, rb_max, skin, same, cell_start, cell_items, out, len);
  }
}

/* Grows one thread's row buffer to hold at least need entries, keeping its first keep. */
static bool ej_tbuf_grow(ej_idx **buf, int64_t *cap, int64_t keep, int64_t need)
{
  int64_t want = *cap * 2 > need ? *cap * 2 : need;
  if (want < 4096) want = 4096;
  if ((uint64_t)want > SIZE_MAX / sizeof **buf) return false;
  ej_idx *nb = ej_malloc((size_t)want * sizeof *nb);
  if (!nb) return false;
  if (keep > 0) memcpy(nb, *buf, (size_t)keep * sizeof *nb);
  ej_free(*buf);
  *buf = nb;
  *cap = want;
  return true;
}

/* Candidates are split into radius classes (class c: rb in (rb_max / 2^(c+1), rb_max / 2^c],
 * the last class takes every smaller radius), each binned in its own grid of cells sized by
 * the class's largest radius. A row scans class c with the ball max(ri, rmax_c) + skin, so a
 * small particle of a graded set no longer scans the ball of the largest radius. The pairs
 * found are the same whatever the classes; the row is sorted afterwards. */
#define EJ_NCLASS 8

typedef struct ej_classes {
  int n;                      /* classes with members, in use: cls[0..n) */
  ej_grid g[EJ_NCLASS];
  ej_real rmax[EJ_NCLASS];
  const ej_idx *start[EJ_NCLASS]; /* cell_start of the class's grid (global cell_items positions) */
} ej_classes;

static EJ_ALWAYS_INLINE int ej_radius_class(ej_real r, ej_real rb_max)
{
  int c = 0;
  ej_real t = 0.5 * rb_max;
  while (c < EJ_NCLASS - 1 && r <= t) {
    c++;
    t *= 0.5;
  }
  return c;
}

/* Scans row i over every class into out[0..len); returns len when the row may not fit. */
static EJ_ALWAYS_INLINE ej_idx ej_row_scan_classes(const ej_classes *K, int dim, const ej_real *xi, ej_real ri,
                                                   ej_idx i, const ej_real *P, int64_t ps, ej_real skin,
                                                   bool same, const ej_idx *cell_items, ej_idx *out, ej_idx len)
{
  ej_idx n = 0;
  for (int c = 0; c < K->n; c++) {
    n += ej_row_scan_dim(&K->g[c], dim, xi, ri, i, P, ps, K->rmax[c], skin, same, K->start[c], cell_items, out + n,
                         len - n);
    if (n == len) return len;
  }
  return n;
}

/* Grows the list's column array to at least need entries, keeping its first keep; est is the
 * expected final size (extrapolated from the blocks done), so that the array is mostly
 * allocated once, as large as the list: the peak memory stays about one list. */
static bool ej_idx_grow_keep(ej_nbrlist *L, int64_t keep, int64_t need, int64_t est)
{
  int64_t want = est > need ? est : need;
  want += want / 8 + 64;
  if (want < L->idx_cap + L->idx_cap / 4) want = L->idx_cap + L->idx_cap / 4;
  if ((uint64_t)want > SIZE_MAX / sizeof *L->idx) return false;
  ej_idx *p = ej_malloc((size_t)want * sizeof *p);
  if (!p) return false;
  if (keep > 0) memcpy(p, L->idx, (size_t)keep * sizeof *p);
  ej_free(L->idx);
  L->idx = p;
  L->idx_cap = want;
  return true;
}

/* One scan per row: each block of EJ_ROW_BLOCK rows is scanned (and each row sorted) into the
 * buffer of the thread that takes it, row lengths going to off[i + 1]; then, in block order
 * (an ordered region: only the copy is serialised), the block is appended to the CSR column
 * array. The rows do not depend on the thread, so the arrays are the same for any thread
 * count, and only the list (plus one block per thread) is held in memory. Returns false when
 * memory runs out. */
static bool ej_rows_scan(ej_nbrlist *L, const ej_classes *K, int dim, const ej_real *xa, const ej_real *ra, ej_idx na,
                         const ej_real *P, int64_t ps, ej_real skin, bool same, const ej_idx *cell_items,
                         int64_t n_blk)
{
  ej_off *off = L->off;
  int64_t pos = 0;  /* end of the blocks appended so far (ordered region only) */
  int lost = 0;     /* the column array could not grow (ordered region only) */
  int fail = 0;
#pragma omp parallel reduction(| : fail)
  {
#ifdef _OPENMP
    const int t = omp_get_thread_num();
#else
    const int t = 0;
#endif
    ej_idx *buf = L->tbuf[t];
    int64_t cap = L->tcap[t];
#pragma omp for ordered schedule(dynamic, 1)
    for (int64_t b = 0; b < n_blk; b++) {
      int64_t used = 0;
      const ej_idx i1 = (b + 1) * EJ_ROW_BLOCK < na ? (ej_idx)((b + 1) * EJ_ROW_BLOCK) : na;
      for (ej_idx i = (ej_idx)(b * EJ_ROW_BLOCK); i < i1 && !fail; i++) {
        const ej_real *xi = xa + 3 * (size_t)i;
        ej_idx n = 0;
        for (;;) {
          if (cap - used < 64 && !ej_tbuf_grow(&buf, &cap, used, used + 64)) {
            fail = 1;
            break;
          }
          const int64_t room = cap - used;
          const ej_idx len = room < INT32_MAX ? (ej_idx)room : INT32_MAX;
          n = ej_row_scan_classes(K, dim, xi, ra[i], i, P, ps, skin, same, cell_items, buf + used, len);
          if (n < len) break;
          /* the row may not fit: rescan it into a buffer at least twice as roomy */
          if (!ej_tbuf_grow(&buf, &cap, used, used + 2 * (int64_t)len)) {
            fail = 1;
            break;
          }
        }
        if (fail) break;
        ej_idx_sort(buf + used, n);
        off[i + 1] = n;
        used += n;
      }
#pragma omp ordered
      {
        if (!fail && !lost) {
          if (pos + used > L->idx_cap && !ej_idx_grow_keep(L, pos, pos + used, (pos + used) / (b + 1) * n_blk))
            lost = 1;
          if (!lost && used) memcpy(L->idx + pos, buf, (size_t)used * sizeof *buf);
          pos += used;
        }
      }
    }
    L->tbuf[t] = buf;
    L->tcap[t] = cap;
  }
  return !fail && !lost;
}

/* Per-thread block buffers for n_thr threads. */
static ej_err ej_scan_scratch(ej_nbrlist *L, int n_thr)
{
  if (n_thr > L->n_tbuf) {
    ej_idx **tb = ej_calloc((size_t)n_thr, sizeof *tb);
    int64_t *tc = ej_calloc((size_t)n_thr, sizeof *tc);
    if (!tb || !tc) {
      ej_free(tb);
      ej_free(tc);
      EJ_FAIL(EJ_ERR_MEM, "out of memory for %d neighbour buffers", n_thr);
    }
    for (int t = 0; t < L->n_tbuf; t++) tb[t] = L->tbuf[t], tc[t] = L->tcap[t];
    ej_free(L->tbuf);
    ej_free(L->tcap);
    L->tbuf = tb;
    L->tcap = tc;
    L->n_tbuf = n_thr;
  }
  return EJ_OK;
}

/* At most this many cells per candidate: beyond it memory, not search time, dominates. */
static int64_t ej_cell_limit(ej_idx n)
{
  int64_t lim = 4 * (int64_t)n + 64;
  return lim < INT32_MAX - 1 ? lim : INT32_MAX - 1; /* cell ids are stored as ej_idx */
}

static ej_err ej_radius_max(const ej_real *r, ej_idx n, ej_real *rmax)
{
  ej_real m = 0;
  ej_idx bad = 0;
#pragma omp parallel for reduction(max : m) reduction(+ : bad) schedule(static)
  for (ej_idx i = 0; i < n; i++) {
    if (!(r[i] >= 0) || !isfinite(r[i])) bad++;
    else if (r[i] > m) m = r[i];
  }
  EJ_ENSURE(!bad, EJ_ERR_ARG, "%d search radii are negative or not finite", (int)bad);
  *rmax = m > *rmax ? m : *rmax;
  return EJ_OK;
}

ej_err ej_nbrlist_build(ej_nbrlist *L, int dim, const ej_real *xa, const ej_real *ra, ej_idx na,
                        const ej_real *xb, const ej_real *rb, ej_idx nb, ej_real skin, bool same)
{
  EJ_ENSURE(L, EJ_ERR_ARG, "NULL list");
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "dimension %d not in 1..3", dim);
  EJ_ENSURE(na >= 0 && nb >= 0, EJ_ERR_ARG, "negative particle count (%d, %d)", (int)na, (int)nb);
  EJ_ENSURE(!na || (xa && ra), EJ_ERR_ARG, "NULL row positions or radii");
  EJ_ENSURE(!nb || (xb && rb), EJ_ERR_ARG, "NULL candidate positions or radii");
  EJ_ENSURE(skin >= 0 && isfinite(skin), EJ_ERR_ARG, "skin %g is negative or not finite", skin);

  /* Caps are stored before checking rc: a failed grow leaves an array NULL with cap 0. */
  L->pub.n_rows = 0;
  int64_t cap = (int64_t)L->row_cap + 1;
  ej_err rc = ej_scratch_grow((void **)&L->off, &cap, (int64_t)na + 1, sizeof *L->off, false);
  L->row_cap = (ej_idx)(cap - 1 > INT32_MAX ? INT32_MAX : (cap > 0 ? cap - 1 : 0));
  EJ_TRY(rc);
  cap = L->idx_cap;
  rc = ej_scratch_grow((void **)&L->idx, &cap, 0, sizeof *L->idx, true);
  L->idx_cap = cap;
  EJ_TRY(rc);
  L->pub.off = L->off;
  L->pub.idx = L->idx;
  memset(L->off, 0, ((size_t)na + 1) * sizeof *L->off);

  ej_real ra_max = 0, rb_max = 0;
  EJ_TRY(ej_radius_max(ra, na, &ra_max));
  EJ_TRY(ej_radius_max(rb, nb, &rb_max));
  const ej_real h = ((ra_max > rb_max ? ra_max : rb_max) + skin) / EJ_CELL_SPLIT;
  /* No pair is closer than a zero radius: every row is empty. */
  if (na == 0 || nb == 0 || !(h > 0)) {
    L->pub.n_rows = na;
    return EJ_OK;
  }

  /* Radius classes: members, largest radius, grid and first cell of each. */
  if (nb > L->item_cap) {
    int64_t c1 = L->item_cap, c2 = L->item_cap;
    L->item_cap = 0;
    rc = ej_scratch_grow((void **)&L->cell_items, &c1, nb, sizeof *L->cell_items, false);
    if (rc == EJ_OK) rc = ej_scratch_grow((void **)&L->cell_of, &c2, nb, sizeof *L->cell_of, false);
    EJ_TRY(rc);
    L->item_cap = (ej_idx)(c1 < c2 ? c1 : c2);
  }
  ej_idx *cell_items = L->cell_items, *cell_of = L->cell_of;
#pragma omp parallel for schedule(static)
  for (ej_idx j = 0; j < nb; j++) cell_of[j] = ej_radius_class(rb[j], rb_max);
  ej_idx n_in[EJ_NCLASS] = {0};
  ej_real r_in[EJ_NCLASS] = {0};
  for (ej_idx j = 0; j < nb; j++) {
    const int c = (int)cell_of[j];
    n_in[c]++;
    if (rb[j] > r_in[c]) r_in[c] = rb[j];
  }
  /* Lower corner of the rows (a self list's rows are the first na candidates). */
  ej_real lo_rows[3] = {0, 0, 0};
  if (same) {
    for (int d = 0; d < dim; d++) lo_rows[d] = xa[d];
    for (ej_idx i = 1; i < na; i++)
      for (int d = 0; d < dim; d++)
        if (xa[3 * (size_t)i + d] < lo_rows[d]) lo_rows[d] = xa[3 * (size_t)i + d];
  }
  ej_classes K;
  int cls_of[EJ_NCLASS];
  int64_t base[EJ_NCLASS + 1];
  K.n = 0;
  base[0] = 0;
  int n_used = 0;
  for (int c = 0; c < EJ_NCLASS; c++) n_used += n_in[c] > 0;
  for (int c = 0; c < EJ_NCLASS; c++) {
    cls_of[c] = -1;
    if (!n_in[c]) continue;
    const int k = K.n++;
    cls_of[c] = k;
    K.rmax[k] = r_in[c];
    /* the first class (largest radii) keeps the cell of the former single grid */
    ej_real hc = k == 0 ? h : (r_in[c] + skin) / EJ_CELL_SPLIT;
    if (!(hc > 0)) hc = h; /* zero radii and skin: their pairs are the rows' */
    /* at most 4 nb + 64 cells over all classes, as with one grid */
    EJ_TRY(ej_grid_setup(&K.g[k], dim, xb, nb, hc, 4 * (int64_t)n_in[c] + 64 / n_used, same ? lo_rows : NULL));
    base[k + 1] = base[k] + K.g[k].n_cells;
  }
  const int64_t n_cells = base[K.n];
  EJ_ENSURE(n_cells < INT32_MAX - 1, EJ_ERR_MEM, "neighbour grid of %lld cells is too large", (long long)n_cells);

  /* Bin candidates by a stable counting sort: cell_items lists j ascending within a cell. */
  cap = L->cell_cap + 1;
  /* When it must grow, room for one more cell per dimension in every class: the anchored
   * corner moves by up to a cell between rebuilds, and must not reallocate each time. */
  int64_t cells_room = n_cells;
  if (n_cells + 1 > cap || !L->cell_start) {
    cells_room = 0;
    for (int k = 0; k < K.n; k++) {
      int64_t c = 1;
      for (int d = 0; d < dim; d++) c *= K.g[k].nc[d] + 1;
      cells_room += c;
    }
    /* within the grids' own bound (4 nb + 64 cells in all) */
    if (cells_room > 4 * (int64_t)nb + 64) cells_room = 4 * (int64_t)nb + 64;
    if (cells_room < n_cells || cells_room >= INT32_MAX - 1) cells_room = n_cells;
  }
  rc = ej_scratch_grow((void **)&L->cell_start, &cap, cells_room + 1, sizeof *L->cell_start, false);
  L->cell_cap = cap > 0 ? cap - 1 : 0;
  EJ_TRY(rc);
  ej_idx *cell_start = L->cell_start;
#pragma omp parallel for schedule(static)
  for (ej_idx j = 0; j < nb; j++) {
    const int k = cls_of[cell_of[j]];
    cell_of[j] = (ej_idx)(base[k] + ej_grid_cell(&K.g[k], xb + 3 * (size_t)j));
  }
  for (int k = 0; k < K.n; k++) K.start[k] = cell_start + base[k];
  memset(cell_start, 0, ((size_t)n_cells + 1) * sizeof *cell_start);
  for (ej_idx j = 0; j < nb; j++) cell_start[cell_of[j] + 1]++;
  for (int64_t c = 0; c < n_cells; c++) cell_start[c + 1] += cell_start[c];
  /* Scatter with cell_start[c] as the cursor of cell c, then shift it back by one cell. */
  for (ej_idx j = 0; j < nb; j++) cell_items[cell_start[cell_of[j]]++] = j;
  for (int64_t c = n_cells; c > 0; c--) cell_start[c] = cell_start[c - 1];
  cell_start[0] = 0;

#ifdef _OPENMP
  const int n_thr = omp_get_max_threads();
#else
  const int n_thr = 1;
#endif
  const int64_t n_blk = ((int64_t)na + EJ_ROW_BLOCK - 1) / EJ_ROW_BLOCK;
  EJ_TRY(ej_scan_scratch(L, n_thr));
  /* Candidates' coordinates and radii in cell_items order (SoA): cell rows are contiguous. */
  if (nb > L->pos_cap) {
    const int64_t want = (int64_t)nb + nb / 8 + 64;
    ej_free(L->cell_pos);
    L->pos_cap = 0;
    L->cell_pos = ej_malloc((size_t)want * 4 * sizeof *L->cell_pos);
    EJ_ENSURE(L->cell_pos, EJ_ERR_MEM, "out of memory for %lld neighbour candidates", (long long)want);
    L->pos_cap = want;
  }
  ej_real *P = L->cell_pos;
  const int64_t ps = L->pos_cap;
#pragma omp parallel for schedule(static)
  for (ej_idx k = 0; k < nb; k++) {
    const ej_idx j = cell_items[k];
    for (int d = 0; d < dim; d++) P[d * ps + k] = xb[3 * (size_t)j + d];
    P[3 * ps + k] = rb[j];
  }
  const bool ok = ej_rows_scan(L, &K, dim, xa, ra, na, P, ps, skin, same, cell_items, n_blk);
  L->pub.idx = L->idx;
  EJ_ENSURE(ok, EJ_ERR_MEM, "out of memory for the neighbour rows of %d particles", (int)na);
  for (ej_idx i = 0; i < na; i++) L->off[i + 1] += L->off[i];
  L->pub.n_rows = na;
  return EJ_OK;
}

ej_real ej_nbr_sort_cell(const ej_real *r, ej_idx n, ej_real scale)
{
  ej_real rmax = 0;
  for (ej_idx i = 0; i < n; i++) {
    const ej_real v = r[i] * scale;
    rmax = v > rmax ? v : rmax;
  }
  int64_t cnt[EJ_NCLASS] = {0};
  ej_real top[EJ_NCLASS] = {0};
  for (ej_idx i = 0; i < n; i++) {
    const ej_real v = r[i] * scale; /* the scaled radius of the list build, the same operation */
    const int c = ej_radius_class(v, rmax);
    cnt[c]++;
    top[c] = v > top[c] ? v : top[c];
  }
  int best = 0;
  for (int c = 1; c < EJ_NCLASS; c++)
    if (cnt[c] > cnt[best]) best = c;
  return cnt[best] ? top[best] : rmax;
}

ej_err ej_nbr_sort_order(int dim, const ej_real *x, ej_idx n, ej_real cell, ej_idx *perm)
{
  EJ_ENSURE(dim >= 1 && dim <= 3, EJ_ERR_ARG, "dimension %d not in 1..3", dim);
  EJ_ENSURE(n >= 0, EJ_ERR_ARG, "negative particle count %d", (int)n);
  EJ_ENSURE(cell > 0 && isfinite(cell), EJ_ERR_ARG, "cell size %g is not positive and finite", cell);
  if (n == 0) return EJ_OK;
  EJ_ENSURE(x && perm, EJ_ERR_ARG, "NULL positions or permutation");

  ej_grid g;
  EJ_TRY(ej_grid_setup(&g, dim, x, n, cell, ej_cell_limit(n), NULL));
  ej_err rc = EJ_OK;
  ej_idx *cell_of = ej_malloc((size_t)n * sizeof *cell_of);
  ej_idx *start = ej_calloc((size_t)g.n_cells + 1, sizeof *start);
  if (!cell_of || !start) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory sorting %d particles", (int)n);
    goto free_scratch;
  }
#pragma omp parallel for schedule(static)
  for (ej_idx i = 0; i < n; i++) cell_of[i] = (ej_idx)ej_grid_cell(&g, x + 3 * (size_t)i);
  for (ej_idx i = 0; i < n; i++) start[cell_of[i] + 1]++;
  for (int64_t c = 0; c < g.n_cells; c++) start[c + 1] += start[c];
  for (ej_idx i = 0; i < n; i++) perm[start[cell_of[i]]++] = i;
free_scratch:
  ej_free(start);
  ej_free(cell_of);
  return rc;
}

ej_err ej_nbrlist_permute(ej_nbrlist *L, const ej_idx *perm)
{
  EJ_ENSURE(L, EJ_ERR_ARG, "NULL list");
  const ej_idx n = L->pub.n_rows;
  if (n == 0) return EJ_OK;
  EJ_ENSURE(perm, EJ_ERR_ARG, "NULL permutation");

  ej_err rc = EJ_OK;
  ej_idx *inv = ej_malloc((size_t)n * sizeof *inv);
  ej_off *off = ej_malloc(((size_t)L->row_cap + 1) * sizeof *off);
  ej_idx *idx = ej_malloc((size_t)(L->idx_cap > 0 ? L->idx_cap : 1) * sizeof *idx);
  if (!inv || !off || !idx) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory permuting %d rows", (int)n);
    goto free_new;
  }
  for (ej_idx i = 0; i < n; i++) inv[i] = -1;
  for (ej_idx i = 0; i < n; i++) {
    const ej_idx p = perm[i];
    if (p < 0 || p >= n || inv[p] >= 0) {
      rc = ej_error_push(EJ_ERR_ARG, __FILE__, __LINE__, __func__,
                         "perm is not a permutation of 0..%d (entry %d = %d)", (int)n - 1, (int)i, (int)p);
      goto free_new;
    }
    inv[p] = i;
  }
  off[0] = 0;
  for (ej_idx i = 0; i < n; i++) off[i + 1] = off[i] + (L->off[perm[i] + 1] - L->off[perm[i]]);
#pragma omp parallel for schedule(dynamic, 256)
  for (ej_idx i = 0; i < n; i++) {
    const ej_idx *src = L->idx + L->off[perm[i]];
    ej_idx *dst = idx + off[i];
    const int64_t len = off[i + 1] - off[i];
    /* Ghost columns (>= n) are not reordered with the owned particles. */
    for (int64_t k = 0; k < len; k++) dst[k] = src[k] < n ? inv[src[k]] : src[k];
    ej_idx_sort(dst, len);
  }
  ej_free(L->off);
  ej_free(L->idx);
  L->off = off;
  L->idx = idx;
  if (L->idx_cap < 1) L->idx_cap = 1;
  L->pub.off = off;
  L->pub.idx = idx;
  off = NULL;
  idx = NULL;
free_new:
  ej_free(idx);
  ej_free(off);
  ej_free(inv);
  return rc;
}
