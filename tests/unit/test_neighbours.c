/* Neighbour search against O(N^2) brute force, thread-count determinism, scratch reuse,
 * cell-order sort and list renumbering (DESIGN.md "Neighbours", "Determinism"). */
#include <check.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "test_rng.h"

/* ------------------------------------------------------------------ helpers */

/* n points uniform in [lo, lo + size)^dim; components >= dim get garbage the search must
 * ignore. */
static ej_real *cloud(uint64_t *s, ej_idx n, int dim, ej_real lo, ej_real size)
{
  ej_real *x = ej_malloc(3 * (size_t)(n ? n : 1) * sizeof *x);
  for (ej_idx i = 0; i < n; i++)
    for (int d = 0; d < 3; d++)
      x[3 * i + d] = d < dim ? lo + size * rng_uniform(s) : 1e3 * (rng_uniform(s) - 0.5);
  return x;
}

/* Radii uniform in [r, r * factor]. */
static ej_real *radii(uint64_t *s, ej_idx n, ej_real r, ej_real factor)
{
  ej_real *a = ej_malloc((size_t)(n ? n : 1) * sizeof *a);
  for (ej_idx i = 0; i < n; i++) a[i] = r * (1 + (factor - 1) * rng_uniform(s));
  return a;
}

/* The pair predicate of the contract, evaluated in the same operation order. */
static bool pair_in(int dim, const ej_real *xi, ej_real ri, const ej_real *xj, ej_real rj, ej_real skin)
{
  const ej_real dx = xj[0] - xi[0];
  ej_real d2 = dx * dx;
  if (dim > 1) {
    const ej_real dy = xj[1] - xi[1];
    d2 = d2 + dy * dy;
  }
  if (dim > 2) {
    const ej_real dz = xj[2] - xi[2];
    d2 = d2 + dz * dz;
  }
  const ej_real r = (ri > rj ? ri : rj) + skin;
  return d2 < r * r;
}

/* Builds the list and checks every row against brute force: as a set (every brute-force
 * member present, nothing else, no duplicate) and as the ascending array. Returns the
 * number of pairs. */
static int64_t check_build(int dim, const ej_real *xa, const ej_real *ra, ej_idx na, const ej_real *xb,
                           const ej_real *rb, ej_idx nb, ej_real skin, bool same)
{
  ej_nbrlist *L = NULL;
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, dim, xa, ra, na, xb, rb, nb, skin, same), EJ_OK);
  ck_assert_int_eq(L->pub.n_rows, na);
  ck_assert_ptr_nonnull(L->pub.off);
  ck_assert_int_eq(L->pub.off[0], 0);
  ej_idx *brute = ej_malloc((size_t)(nb ? nb : 1) * sizeof *brute);
  unsigned char *mark = ej_calloc((size_t)(nb ? nb : 1), 1);
  for (ej_idx i = 0; i < na; i++) {
    ej_idx nbrute = 0;
    for (ej_idx j = 0; j < nb; j++)
      if (!(same && j == i) && pair_in(dim, xa + 3 * i, ra[i], xb + 3 * j, rb[j], skin)) brute[nbrute++] = j;
    const ej_off s = L->pub.off[i], e = L->pub.off[i + 1];
    ck_assert_msg(e >= s, "row %d: negative length", (int)i);
    /* As sets. */
    for (ej_off k = s; k < e; k++) {
      const ej_idx j = L->pub.idx[k];
      ck_assert_msg(j >= 0 && j < nb, "row %d: column %d out of range", (int)i, (int)j);
      ck_assert_msg(!mark[j], "row %d: column %d listed twice", (int)i, (int)j);
      mark[j] = 1;
    }
    for (ej_idx m = 0; m < nbrute; m++)
      ck_assert_msg(mark[brute[m]], "row %d (dim %d): missing neighbour %d", (int)i, dim, (int)brute[m]);
    ck_assert_msg(e - s == nbrute, "row %d (dim %d): %lld listed, brute force %d", (int)i, dim,
                  (long long)(e - s), (int)nbrute);
    for (ej_off k = s; k < e; k++) mark[L->pub.idx[k]] = 0;
    /* As sorted arrays. */
    for (ej_idx m = 0; m < nbrute; m++) ck_assert_int_eq(L->pub.idx[s + m], brute[m]);
  }
  const int64_t pairs = L->pub.off[na];
  ej_free(mark);
  ej_free(brute);
  ej_nbrlist_destroy(L);
  return pairs;
}

/* ------------------------------------------------------------------ brute force */

START_TEST(test_self_constant_radius)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 11 + dim;
    const ej_idx n = 1500;
    const ej_real size = dim == 1 ? 300 : dim == 2 ? 40 : 12;
    ej_real *x = cloud(&s, n, dim, -3, size);
    ej_real *r = ej_malloc(n * sizeof *r);
    for (ej_idx i = 0; i < n; i++) r[i] = 1.3;
    int64_t p0 = check_build(dim, x, r, n, x, r, n, 0, true);
    int64_t p1 = check_build(dim, x, r, n, x, r, n, 0.4, true);
    ck_assert_int_gt(p0, 3 * n);
    ck_assert_int_gt(p1, p0);
    ej_free(r);
    ej_free(x);
  }
}
END_TEST

START_TEST(test_self_variable_radius)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 101 + dim;
    const ej_idx n = 1500;
    const ej_real size = dim == 1 ? 300 : dim == 2 ? 40 : 12;
    ej_real *x = cloud(&s, n, dim, 5, size);
    ej_real *r = radii(&s, n, 0.6, 3);
    ck_assert_int_gt(check_build(dim, x, r, n, x, r, n, 0, true), n);
    ck_assert_int_gt(check_build(dim, x, r, n, x, r, n, 0.25, true), n);
    /* same = false on one cloud lists i itself. */
    ck_assert_int_eq(check_build(dim, x, r, n, x, r, n, 0.25, false),
                     check_build(dim, x, r, n, x, r, n, 0.25, true) + n);
    ej_free(r);
    ej_free(x);
  }
}
END_TEST

START_TEST(test_set_to_set)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 1001 + dim;
    const ej_idx na = 900, nb = 1400;
    const ej_real size = dim == 1 ? 200 : dim == 2 ? 30 : 10;
    /* B is shifted by half its size: the clouds overlap partially. */
    ej_real *xa = cloud(&s, na, dim, 0, size);
    ej_real *xb = cloud(&s, nb, dim, 0.5 * size, 1.2 * size);
    ej_real *ra = radii(&s, na, 0.5, 3);
    ej_real *rb = radii(&s, nb, 0.9, 3);
    ck_assert_int_gt(check_build(dim, xa, ra, na, xb, rb, nb, 0, false), na);
    ck_assert_int_gt(check_build(dim, xa, ra, na, xb, rb, nb, 0.3, false), na);
    ck_assert_int_gt(check_build(dim, xb, rb, nb, xa, ra, na, 0.3, false), na);
    /* Rows that share an index with a candidate drop it when same. */
    check_build(dim, xa, ra, na, xb, rb, nb, 0.3, true);
    ej_free(rb);
    ej_free(ra);
    ej_free(xb);
    ej_free(xa);
  }
}
END_TEST

/* Graded radii (log-uniform over a factor 60, as in a set graded 13 mm .. 800 mm): rows of a
 * few to several thousand entries, so the one-pass build's per-thread buffers overflow and the
 * rows are scanned again into grown buffers; the result must still be the brute-force list,
 * identical for 1, 2 and 3 threads. */
START_TEST(test_graded_radius)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 7001 + dim;
    const ej_idx na = 600, nb = 7000;
    const ej_real size = dim == 1 ? 400 : dim == 2 ? 60 : 16;
    ej_real *xa = cloud(&s, na, dim, 0, size);
    ej_real *xb = cloud(&s, nb, dim, 0, size);
    ej_real *ra = ej_malloc(na * sizeof *ra), *rb = ej_malloc(nb * sizeof *rb);
    for (ej_idx i = 0; i < na; i++) ra[i] = 0.1 * exp(log(60.0) * rng_uniform(&s));
    for (ej_idx j = 0; j < nb; j++) rb[j] = 0.1 * exp(log(60.0) * rng_uniform(&s));
    const int64_t pairs = check_build(dim, xa, ra, na, xb, rb, nb, 0.05, false);
    ck_assert_int_gt(pairs, 10 * (int64_t)na);
    check_build(dim, xa, ra, na, xa, ra, na, 0.05, true);
    /* rows listing the whole cloud (one cell then) */
    ra[0] = ra[na / 2] = rb[0] = 2 * size;
    ck_assert_int_gt(check_build(dim, xa, ra, na, xb, rb, nb, 0.05, false), pairs + nb);
    ej_nbrlist *L1 = NULL, *L2 = NULL;
    ck_assert_int_eq(ej_nbrlist_create(&L1), EJ_OK);
    ck_assert_int_eq(ej_nbrlist_create(&L2), EJ_OK);
    omp_set_num_threads(1);
    ck_assert_int_eq(ej_nbrlist_build(L1, dim, xb, rb, nb, xb, rb, nb, 0.05, true), EJ_OK);
    for (int th = 2; th <= 3; th++) {
      omp_set_num_threads(th);
      ck_assert_int_eq(ej_nbrlist_build(L2, dim, xb, rb, nb, xb, rb, nb, 0.05, true), EJ_OK);
      ck_assert(!memcmp(L1->pub.off, L2->pub.off, ((size_t)nb + 1) * sizeof *L1->pub.off));
      ck_assert(!memcmp(L1->pub.idx, L2->pub.idx, (size_t)L1->pub.off[nb] * sizeof *L1->pub.idx));
    }
    omp_set_num_threads(1);
    ej_off longest = 0;
    for (ej_idx i = 0; i < nb; i++)
      if (L1->pub.off[i + 1] - L1->pub.off[i] > longest) longest = L1->pub.off[i + 1] - L1->pub.off[i];
    ck_assert_int_gt(longest, 4096); /* past the first buffer size of the one-pass build */
    ej_nbrlist_destroy(L2);
    ej_nbrlist_destroy(L1);
    ej_free(rb);
    ej_free(ra);
    ej_free(xb);
    ej_free(xa);
  }
}
END_TEST

START_TEST(test_degenerate)
{
  uint64_t s = 7;
  ej_real *x = cloud(&s, 200, 3, 0, 10);
  ej_real *r = radii(&s, 200, 1, 3);
  for (int dim = 1; dim <= 3; dim++) {
    /* Empty sets. */
    ck_assert_int_eq(check_build(dim, x, r, 0, x, r, 0, 0.1, true), 0);
    ck_assert_int_eq(check_build(dim, x, r, 50, x, r, 0, 0.1, false), 0);
    ck_assert_int_eq(check_build(dim, x, r, 0, x, r, 50, 0.1, false), 0);
    ck_assert_int_eq(check_build(dim, NULL, NULL, 0, NULL, NULL, 0, 0.1, true), 0);
    /* One point. */
    ck_assert_int_eq(check_build(dim, x, r, 1, x, r, 1, 0.1, true), 0);
    ck_assert_int_eq(check_build(dim, x, r, 1, x, r, 1, 0.1, false), 1);
  }

  /* Dense rows (over a thousand neighbours in random order) take the long-row sort path. */
  ej_real *dense = cloud(&s, 2500, 3, 0, 6);
  ej_real *rd = radii(&s, 2500, 2, 1.5);
  ck_assert_int_gt(check_build(3, dense, rd, 2500, dense, rd, 2500, 0.5, true), 2500 * 600);
  ej_free(rd);
  ej_free(dense);

  /* All points identical. */
  enum { NI = 60 };
  ej_real xs[3 * NI], rs[NI], zero[NI];
  for (int i = 0; i < NI; i++) {
    xs[3 * i] = 1.5, xs[3 * i + 1] = -2, xs[3 * i + 2] = 4;
    rs[i] = 0.1 * (1 + i % 3);
    zero[i] = 0;
  }
  for (int dim = 1; dim <= 3; dim++) {
    ck_assert_int_eq(check_build(dim, xs, rs, NI, xs, rs, NI, 0, true), NI * (NI - 1));
    /* Zero radius and skin: no pair is closer than zero. */
    ck_assert_int_eq(check_build(dim, xs, zero, NI, xs, zero, NI, 0, true), 0);
    ck_assert_int_eq(check_build(dim, xs, zero, NI, xs, zero, NI, 0.5, true), NI * (NI - 1));
  }

  /* Points on a line in 3D: a flat box in two directions. */
  ej_real *line = cloud(&s, 400, 3, 0, 50);
  for (int i = 0; i < 400; i++) line[3 * i + 1] = line[3 * i + 2] = 3;
  ej_real *rl = radii(&s, 400, 0.2, 3);
  ck_assert_int_gt(check_build(3, line, rl, 400, line, rl, 400, 0.05, true), 400);
  /* Zero radii with a skin on a line: the skin alone sizes the cells. */
  ej_real *rz = ej_calloc(400, sizeof *rz);
  ck_assert_int_gt(check_build(3, line, rz, 400, line, rz, 400, 0.3, true), 0);
  ej_free(rz);

  /* Rows far outside the candidates' box, on every side, and rows just outside. */
  ej_real *far = cloud(&s, 300, 3, 0, 10);
  for (int i = 0; i < 100; i++) far[3 * i + i % 3] += (i % 2 ? 1e6 : -1e6);
  for (int i = 100; i < 200; i++) far[3 * i + i % 3] += (i % 2 ? 10.5 : -10.5);
  ej_real *rf = radii(&s, 300, 1, 3);
  for (int dim = 1; dim <= 3; dim++) {
    check_build(dim, far, rf, 300, x, r, 200, 0.1, false);
    check_build(dim, x, r, 200, far, rf, 300, 0.1, false);
  }

  /* A huge box with few points, some of them in close pairs. */
  ej_real *huge = cloud(&s, 40, 3, -1e9, 2e9);
  for (int i = 20; i < 40; i++)
    for (int d = 0; d < 3; d++) huge[3 * i + d] = huge[3 * (i - 20) + d] + 0.5 * (rng_uniform(&s) - 0.5);
  ej_real *rh = radii(&s, 40, 0.3, 3);
  for (int dim = 1; dim <= 3; dim++) {
    ck_assert_int_ge(check_build(dim, huge, rh, 40, huge, rh, 40, 0.01, true), 20);
    ej_nbrlist *L = NULL;
    ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
    ck_assert_int_eq(ej_nbrlist_build(L, dim, huge, rh, 40, huge, rh, 40, 0.01, true), EJ_OK);
    ck_assert_int_le(L->cell_cap, 4 * 40 + 64);
    ej_nbrlist_destroy(L);
  }
  ej_free(rh);
  ej_free(huge);
  ej_free(rf);
  ej_free(far);
  ej_free(rl);
  ej_free(line);
  ej_free(r);
  ej_free(x);
}
END_TEST

START_TEST(test_bad_arguments)
{
  ej_real x[6] = {0, 0, 0, 1, 1, 1}, r[2] = {1, -1}, rinf[2] = {1, INFINITY};
  ej_real xinf[6] = {0, 0, 0, INFINITY, 0, 0};
  ej_nbrlist *L = NULL;
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, 4, x, r, 2, x, r, 2, 0, true), EJ_ERR_ARG);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, 2, x, r, 2, 0, true), EJ_ERR_ARG);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, rinf, 2, x, rinf, 2, 0, true), EJ_ERR_ARG);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, rinf, 1, x, rinf, 1, -1, true), EJ_ERR_ARG);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, xinf, rinf, 1, xinf, rinf, 1, 0, true), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, 1, xinf, rinf, 1, xinf, r, 2, 0, false), EJ_ERR_ARG);
  ej_real rr[2] = {1, 1};
  ck_assert_int_eq(ej_nbrlist_build(L, 1, xinf, rr, 2, xinf, rr, 2, 0, false), EJ_ERR_NUMERIC);
  /* The list stays usable after a failed build. */
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, rr, 2, x, rr, 2, 1, true), EJ_OK);
  ck_assert_int_eq(L->pub.off[2], 2);
  ej_idx perm[2] = {0, 0};
  ck_assert_int_eq(ej_nbrlist_permute(L, perm), EJ_ERR_ARG);
  ej_nbrlist_destroy(L);
  ej_nbrlist_destroy(NULL);
  ck_assert_int_eq(ej_nbr_sort_order(3, x, 2, 0, perm), EJ_ERR_ARG);
  ej_error_clear();
}
END_TEST

/* ------------------------------------------------------------------ determinism and reuse */

/* Random clouds against brute force, covering the AVX2 path (four candidates at a time) and
 * its scalar tails: cell-ordered and unordered particles, constant radii (rows as wide as
 * every candidate) and graded ones, mirror ghosts appended to the candidates of a self list,
 * set-to-set lists, pairs at exactly the cut-off distance, coincident points, and 1 and 2
 * threads giving the same arrays. */
START_TEST(test_random_reference)
{
  for (int dim = 1; dim <= 3; dim++) {
    for (int variant = 0; variant < 4; variant++) {
      uint64_t s = 9001 + 17 * (uint64_t)dim + (uint64_t)variant;
      const ej_idx na = 700 + 111 * variant;
      const ej_real size = dim == 1 ? 140 : dim == 2 ? 27 : 8.5;
      ej_real *x = cloud(&s, na, dim, 0, size);
      ej_real *r = radii(&s, na, 1.0, variant & 1 ? 2.5 : 1.0);
      if (variant >= 2) { /* cell order, as the core leaves each set before a build */
        ej_idx *perm = ej_malloc((size_t)na * sizeof *perm);
        ej_real *xs = ej_malloc(3 * (size_t)na * sizeof *xs), *rs = ej_malloc((size_t)na * sizeof *rs);
        /* cell R_max + skin: the list's grid is then aligned with the sort's */
        ck_assert_int_eq(ej_nbr_sort_order(dim, x, na, variant & 1 ? 2.75 : 1.25, perm), EJ_OK);
        for (ej_idx i = 0; i < na; i++) {
          memcpy(xs + 3 * i, x + 3 * perm[i], 3 * sizeof *xs);
          rs[i] = r[perm[i]];
        }
        memcpy(x, xs, 3 * (size_t)na * sizeof *x);
        memcpy(r, rs, (size_t)na * sizeof *r);
        ej_free(rs);
        ej_free(xs);
        ej_free(perm);
      }
      /* Exact ties: particle 1 at distance 1 + skin of particle 0 along x, particle 2 on
       * particle 3 (distance 0). */
      const ej_real skin = 0.25;
      for (int d = 0; d < dim; d++) x[3 + d] = x[d] + (d == 0 ? (r[0] > r[1] ? r[0] : r[1]) + skin : 0);
      for (int d = 0; d < 3; d++) x[6 + d] = x[9 + d];
      /* Candidates: the set plus mirror ghosts of the particles within 3 of the plane x = 0. */
      ej_idx ng = 0;
      for (ej_idx i = 0; i < na; i++) ng += x[3 * i] < 3;
      const ej_idx nb = na + ng;
      ej_real *xb = ej_malloc(3 * (size_t)nb * sizeof *xb), *rb = ej_malloc((size_t)nb * sizeof *rb);
      memcpy(xb, x, 3 * (size_t)na * sizeof *xb);
      memcpy(rb, r, (size_t)na * sizeof *rb);
      for (ej_idx i = 0, g = na; i < na; i++)
        if (x[3 * i] < 3) {
          memcpy(xb + 3 * g, x + 3 * i, 3 * sizeof *xb);
          xb[3 * g] = -x[3 * i];
          rb[g++] = r[i];
        }
      for (int thr = 1; thr <= 2; thr++) {
        omp_set_num_threads(thr);
        const int64_t p_self = check_build(dim, x, r, na, x, r, na, skin, true);
        const int64_t p_ghost = check_build(dim, x, r, na, xb, rb, nb, skin, true);
        ck_assert_int_gt(p_self, 4 * (int64_t)na);
        ck_assert_int_gt(p_ghost, p_self);
        /* Set to set: the first 300 particles against a second cloud over the same box. */
        uint64_t s2 = s + 1;
        const ej_idx nc = 400;
        ej_real *xc = cloud(&s2, nc, dim, -1, size + 2);
        ej_real *rc = radii(&s2, nc, 0.6, variant & 1 ? 4.0 : 1.0);
        ck_assert_int_gt(check_build(dim, x, r, 300, xc, rc, nc, skin, false), 300);
        ck_assert_int_gt(check_build(dim, xc, rc, nc, xb, rb, nb, skin, false), nc);
        ej_free(rc);
        ej_free(xc);
      }
      omp_set_num_threads(1);
      ej_free(rb);
      ej_free(xb);
      ej_free(r);
      ej_free(x);
    }
  }
}
END_TEST

START_TEST(test_thread_determinism)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 555 + dim;
    const ej_idx n = 20000;
    const ej_real size = dim == 1 ? 8000 : dim == 2 ? 120 : 24;
    ej_real *x = cloud(&s, n, dim, 0, size);
    ej_real *r = radii(&s, n, 0.5, 3);
    ej_nbrlist *L1 = NULL, *L2 = NULL;
    ck_assert_int_eq(ej_nbrlist_create(&L1), EJ_OK);
    ck_assert_int_eq(ej_nbrlist_create(&L2), EJ_OK);
    omp_set_num_threads(1);
    ck_assert_int_eq(ej_nbrlist_build(L1, dim, x, r, n, x, r, n, 0.1, true), EJ_OK);
    omp_set_num_threads(2);
    ck_assert_int_eq(ej_nbrlist_build(L2, dim, x, r, n, x, r, n, 0.1, true), EJ_OK);
    ck_assert_int_eq(L1->pub.off[n], L2->pub.off[n]);
    ck_assert_int_gt(L1->pub.off[n], n);
    ck_assert(!memcmp(L1->pub.off, L2->pub.off, ((size_t)n + 1) * sizeof *L1->pub.off));
    ck_assert(!memcmp(L1->pub.idx, L2->pub.idx, (size_t)L1->pub.off[n] * sizeof *L1->pub.idx));
    omp_set_num_threads(3);
    ck_assert_int_eq(ej_nbrlist_build(L2, dim, x, r, n, x, r, n, 0.1, true), EJ_OK);
    ck_assert(!memcmp(L1->pub.idx, L2->pub.idx, (size_t)L1->pub.off[n] * sizeof *L1->pub.idx));
    ej_nbrlist_destroy(L2);
    ej_nbrlist_destroy(L1);
    ej_free(r);
    ej_free(x);
  }
}
END_TEST

START_TEST(test_rebuild_reuses_scratch)
{
  uint64_t s = 99;
  const ej_idx n = 5000;
  ej_real *x = cloud(&s, n, 3, 0, 18);
  ej_real *r = radii(&s, n, 0.6, 2);
  ej_nbrlist *L = NULL;
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n, x, r, n, 0.1, true), EJ_OK);
  const void *p[5] = {L->off, L->idx, L->cell_start, L->cell_items, L->cell_of};
  const ej_off pairs = L->pub.off[n];
  /* Same cloud, then the cloud slightly moved (as between Verlet rebuilds), then fewer rows. */
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n, x, r, n, 0.1, true), EJ_OK);
  ck_assert_int_eq(L->pub.off[n], pairs);
  for (ej_idx i = 0; i < 3 * n; i++) x[i] += 0.01 * (rng_uniform(&s) - 0.5);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n, x, r, n, 0.1, true), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n / 2, x, r, n, 0.1, true), EJ_OK);
  const void *q[5] = {L->off, L->idx, L->cell_start, L->cell_items, L->cell_of};
  for (int k = 0; k < 5; k++) ck_assert_msg(p[k] == q[k], "scratch array %d was reallocated", k);
  ck_assert(L->pub.off == L->off && L->pub.idx == L->idx);
  ej_nbrlist_destroy(L);
  ej_free(r);
  ej_free(x);
}
END_TEST

/* ------------------------------------------------------------------ sort order and permute */

START_TEST(test_sort_order)
{
  for (int dim = 1; dim <= 3; dim++) {
    uint64_t s = 4242 + dim;
    const ej_idx n = 3000;
    const ej_real size = 20, cell = 1.7;
    ej_real *x = cloud(&s, n, dim, -7, size);
    /* Duplicated points share a cell: stability is visible. */
    for (ej_idx i = n / 2; i < n; i += 3)
      for (int d = 0; d < 3; d++) x[3 * i + d] = x[3 * (i - n / 2) + d];
    ej_idx *perm = ej_malloc(n * sizeof *perm);
    ck_assert_int_eq(ej_nbr_sort_order(dim, x, n, cell, perm), EJ_OK);
    ej_real lo[3] = {0, 0, 0};
    int64_t nc[3] = {1, 1, 1};
    for (int d = 0; d < dim; d++) {
      ej_real l = INFINITY, h = -INFINITY;
      for (ej_idx i = 0; i < n; i++) {
        l = fmin(l, x[3 * i + d]);
        h = fmax(h, x[3 * i + d]);
      }
      lo[d] = l;
      nc[d] = (int64_t)floor((h - l) / cell) + 1;
    }
    unsigned char *seen = ej_calloc(n, 1);
    int64_t prev_cell = -1;
    ej_idx prev = -1;
    for (ej_idx k = 0; k < n; k++) {
      const ej_idx i = perm[k];
      ck_assert(i >= 0 && i < n && !seen[i]);
      seen[i] = 1;
      int64_t c = 0;
      for (int d = dim - 1; d >= 0; d--) {
        /* The grid multiplies by the inverse cell size: rounding must match at cell edges. */
        int64_t cd = (int64_t)floor((x[3 * i + d] - lo[d]) * (1 / cell));
        if (cd > nc[d] - 1) cd = nc[d] - 1;
        c = c * nc[d] + cd;
      }
      ck_assert_msg(c >= prev_cell, "cells decrease at %d", (int)k);
      if (c == prev_cell) ck_assert_msg(i > prev, "not stable at %d", (int)k);
      prev_cell = c;
      prev = i;
    }
    /* A huge cell-index space is capped rather than allocated. */
    x[0] = 1e12;
    ck_assert_int_eq(ej_nbr_sort_order(dim, x, n, 1e-3, perm), EJ_OK);
    memset(seen, 0, n);
    for (ej_idx k = 0; k < n; k++) {
      ck_assert(perm[k] >= 0 && perm[k] < n && !seen[perm[k]]);
      seen[perm[k]] = 1;
    }
    ej_free(seen);
    ej_free(perm);
    ej_free(x);
  }
}
END_TEST

/* Rebuilding on permuted points equals renumbering the original list; ghosts (candidate
 * indices >= n_rows) keep their numbers. */
static void check_permute(int dim, ej_idx n, ej_idx n_ghost, uint64_t seed)
{
  uint64_t s = seed;
  const ej_idx nb = n + n_ghost;
  const ej_real size = dim == 1 ? 400 : dim == 2 ? 40 : 12;
  ej_real *x = cloud(&s, nb, dim, 0, size);
  ej_real *r = radii(&s, nb, 0.6, 3);
  ej_idx *perm = ej_malloc(n * sizeof *perm);
  for (ej_idx i = 0; i < n; i++) perm[i] = i;
  for (ej_idx i = n - 1; i > 0; i--) { /* Fisher-Yates */
    ej_idx k = (ej_idx)(rng_next(&s) % (uint64_t)(i + 1)), t = perm[i];
    perm[i] = perm[k];
    perm[k] = t;
  }
  ej_real *xp = ej_malloc(3 * (size_t)nb * sizeof *xp);
  ej_real *rp = ej_malloc((size_t)nb * sizeof *rp);
  memcpy(xp, x, 3 * (size_t)nb * sizeof *xp);
  memcpy(rp, r, (size_t)nb * sizeof *rp);
  for (ej_idx i = 0; i < n; i++) {
    memcpy(xp + 3 * i, x + 3 * perm[i], 3 * sizeof *xp);
    rp[i] = r[perm[i]];
  }
  ej_nbrlist *L = NULL, *Lp = NULL;
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_create(&Lp), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(L, dim, x, r, n, x, r, nb, 0.2, true), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(Lp, dim, xp, rp, n, xp, rp, nb, 0.2, true), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_permute(L, perm), EJ_OK);
  ck_assert_int_eq(L->pub.n_rows, n);
  ck_assert_int_eq(L->pub.off[n], Lp->pub.off[n]);
  ck_assert(!memcmp(L->pub.off, Lp->pub.off, ((size_t)n + 1) * sizeof *L->pub.off));
  ck_assert(!memcmp(L->pub.idx, Lp->pub.idx, (size_t)L->pub.off[n] * sizeof *L->pub.idx));
  /* The renumbered list is still a valid list to rebuild into. */
  ck_assert_int_eq(ej_nbrlist_build(L, dim, x, r, n, x, r, nb, 0.2, true), EJ_OK);
  ej_nbrlist_destroy(Lp);
  ej_nbrlist_destroy(L);
  ej_free(rp);
  ej_free(xp);
  ej_free(perm);
  ej_free(r);
  ej_free(x);
}

START_TEST(test_permute)
{
  for (int dim = 1; dim <= 3; dim++) {
    check_permute(dim, 2000, 0, 77 + dim);
    check_permute(dim, 1500, 400, 177 + dim);
    check_permute(dim, 1, 0, 3);
  }
  ej_nbrlist *L = NULL; /* an empty list permutes to itself */
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_permute(L, NULL), EJ_OK);
  ej_nbrlist_destroy(L);
}
END_TEST

/* ------------------------------------------------------------------ timing (printout only) */

static double time_build(ej_nbrlist *L, const ej_real *x, const ej_real *r, ej_idx n, int reps)
{
  ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n, x, r, n, 0, true), EJ_OK); /* warm scratch */
  double best = INFINITY;
  for (int k = 0; k < reps; k++) {
    const double t0 = omp_get_wtime();
    ck_assert_int_eq(ej_nbrlist_build(L, 3, x, r, n, x, r, n, 0, true), EJ_OK);
    best = fmin(best, omp_get_wtime() - t0);
  }
  return best;
}

START_TEST(test_timing_100k)
{
  /* Jittered cubic lattice, spacing 1, radius 2.6: the SPH-like case of the brief. */
  const int nx = 47, ny = 46, nz = 46;
  const ej_idx n = nx * ny * nz;
  uint64_t s = 2024;
  ej_real *x = ej_malloc(3 * (size_t)n * sizeof *x);
  ej_real *r = ej_malloc((size_t)n * sizeof *r);
  ej_idx *perm = ej_malloc((size_t)n * sizeof *perm);
  ej_real *xs = ej_malloc(3 * (size_t)n * sizeof *xs);
  ej_idx m = 0;
  for (int i = 0; i < nx; i++)
    for (int j = 0; j < ny; j++)
      for (int k = 0; k < nz; k++, m++) {
        x[3 * m] = i + 0.2 * (rng_uniform(&s) - 0.5);
        x[3 * m + 1] = j + 0.2 * (rng_uniform(&s) - 0.5);
        x[3 * m + 2] = k + 0.2 * (rng_uniform(&s) - 0.5);
        r[m] = 2.6;
      }
  ej_nbrlist *L = NULL;
  ck_assert_int_eq(ej_nbrlist_create(&L), EJ_OK);
  const char *order[3] = {"lattice order", "cell order", "random order"};
  for (int o = 0; o < 3; o++) {
    if (o == 1) {
      ck_assert_int_eq(ej_nbr_sort_order(3, x, n, 2.6, perm), EJ_OK);
    } else if (o == 2) {
      for (ej_idx i = 0; i < n; i++) perm[i] = i;
      for (ej_idx i = n - 1; i > 0; i--) {
        ej_idx k = (ej_idx)(rng_next(&s) % (uint64_t)(i + 1)), t = perm[i];
        perm[i] = perm[k];
        perm[k] = t;
      }
    }
    if (o > 0)
      for (ej_idx i = 0; i < n; i++) memcpy(xs + 3 * i, x + 3 * perm[i], 3 * sizeof *xs);
    const ej_real *xx = o ? xs : x;
    omp_set_num_threads(1);
    const double t1 = time_build(L, xx, r, n, 3);
    const double pairs = (double)L->pub.off[n];
    omp_set_num_threads(2);
    const double t2 = time_build(L, xx, r, n, 3);
    printf("neighbours: %d particles, %.1f neighbours each, %s: build %.1f ms (1 thread), %.1f ms (2 "
           "threads); %.1f ns per pair (1 thread)\n",
           (int)n, pairs / n, order[o], 1e3 * t1, 1e3 * t2, 1e9 * t1 / pairs);
  }
  fflush(stdout);
  ej_nbrlist_destroy(L);
  ej_free(xs);
  ej_free(perm);
  ej_free(r);
  ej_free(x);
}
END_TEST

static Suite *neighbours_suite(void)
{
  Suite *s = suite_create("neighbours");
  TCase *tc = tcase_create("core");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_self_constant_radius);
  tcase_add_test(tc, test_self_variable_radius);
  tcase_add_test(tc, test_set_to_set);
  tcase_add_test(tc, test_graded_radius);
  tcase_add_test(tc, test_degenerate);
  tcase_add_test(tc, test_bad_arguments);
  tcase_add_test(tc, test_random_reference);
  tcase_add_test(tc, test_thread_determinism);
  tcase_add_test(tc, test_rebuild_reuses_scratch);
  tcase_add_test(tc, test_sort_order);
  tcase_add_test(tc, test_permute);
  tcase_add_test(tc, test_timing_100k);
  suite_add_tcase(s, tc);
  return s;
}

int main(void)
{
  SRunner *sr = srunner_create(neighbours_suite());
  srunner_run_all(sr, CK_NORMAL);
  const int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
