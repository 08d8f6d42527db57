/* rkpm: essential boundaries by the mixed transformation method (README "Essential boundary
 * conditions"). Plugin-internal: rkpm.c builds the rows (it owns the kernel), this file solves.
 *
 * RK shape functions are not interpolating: the field at a node, v^h(x_K) = sum_J Psi_J(x_K) d_J,
 * is not its coefficient d_K. The core holds the velocity of a `fix` or `velocity` node, so with
 * the transformation that stored value is the nodal value v^h(x_K) (the generalised coordinate of
 * a held component), and the coefficients of the held nodes are the solution of
 *     sum_{J in B} Lambda_KJ d_J = v_K - sum_{J not in B} Lambda_KJ v_J     (K in B),
 * Lambda_KJ = Psi_J(x_K), one system per component (B = the nodes held in that component).
 * Forces follow from d = T q (Chen & Wang, CMAME 187 (2000) 441; Chen, Hillman & Chi, Arch Comput
 * Methods Eng 24 (2017) 563, section 3.3): f~ = T^T f, i.e. with Lambda_BB^T y = f_B the held nodes
 * take y and every other node I loses sum_K Lambda_KI y_K. */
#ifndef RK_ESSENTIAL_H
#define RK_ESSENTIAL_H

#include <stdint.h>

#include "ejecta/plugin.h"

typedef struct rk_ess {
  ej_idx n;       /* owned nodes the arrays are sized for */
  uint8_t *held;  /* [n] ej_set_held bits (1 x, 2 y, 4 z); bits of degenerate rows cleared */
  int32_t *bpos;  /* [n] position in blist, or -1 */
  ej_idx *blist;  /* [nb] held nodes */
  ej_idx nb;
  ej_off *roff;   /* [nb + 1] row K = blist[k]: entries roff[k] .. roff[k + 1] - 1 */
  ej_idx *rsrc;   /* [cap] the owned node the entry's particle is (a ghost: its source) */
  ej_real *rval;  /* [cap] Lambda_KJ = Psi_J(x_K), the self entry first */
  int8_t *rsgn;   /* [cap][3] sign of each vector component on the image (+1 for an owned J) */
  size_t cap;
  /* The system of component c over the held nodes (rk_ess_rows_done): row k = blist[k], entries
   * (column = position of the unknown, value = Lambda_KJ times the image's sign, images of one
   * node merged in row order), the identity row for a node not held in c; adiag = its diagonal. */
  ej_off *aoff[3];  /* [nb + 1] */
  ej_idx *acol[3];  /* [acap] */
  ej_real *aval[3]; /* [acap] */
  ej_real *adiag[3]; /* [nb] */
  size_t acap;
  ej_real *w;     /* [RK_ESS_NW][nb cap] solver vectors */
  ej_idx wcap;
  int64_t solves, iters, degenerate, maxit; /* run totals; maxit: most iterations of one solve */
} rk_ess;

ej_err rk_ess_create(rk_ess **e, ej_idx n);
void rk_ess_destroy(rk_ess *e);
/* The held nodes of this force evaluation (ej_set_held): fills held, bpos, blist, nb. */
ej_err rk_ess_held(rk_ess *e, const ej_set *set);
/* Room for nnz row entries (grows only: no allocation once the rows stop growing). */
ej_err rk_ess_reserve(rk_ess *e, size_t nnz);
/* After the rows: a held component whose row has no weight on its own unknown (a node on a
 * symmetry plane held normal to it: its mirror image cancels its own entry, and the field is zero
 * there by symmetry anyway) is dropped from the system and keeps its nodal value as coefficient.
 * Then builds the compact system of each component. */
ej_err rk_ess_rows_done(rk_ess *e);
/* Coefficients of the held components: for every held node K and held component c, out[3K + c]
 * such that the RK field of val (out on the held, val elsewhere; ghosts through their source and
 * sign) takes the value val[3K + c] at x_K. Other entries of out: val's. out may be val. */
ej_err rk_ess_coefficients(rk_ess *e, const char *set_name, const ej_real *val, ej_real *out);
/* The transformed forces: a (m a = the force on the coefficients) becomes T^T (m a) / m. */
ej_err rk_ess_forces(rk_ess *e, const char *set_name, const ej_real *m, ej_real *a);

#endif
