/* sph, gradient: shape_tensor: the kept-neighbour slots of the shape pass (plugins/methods/sph/README.md
 * "Passes"; they replaced the entry bit masks on 2026-11-28, hence the file name). The shape pass
 * stores, per row of at most 512 list entries with at most SPH_KEPT_MAX = 128 of them inside 2 hbar,
 * the indices of those entries; the pair pass then visits only those (blocks of up to 128 pairs). Any
 * other row is compacted again in the pair pass, every entry tested. Both paths must give the same
 * rates: the same cloud is evaluated once with a small skin (every row <= 512 entries) and once with
 * a skin larger than the box (every row 999 entries: compacted in the pair pass), for h_factor 1.2
 * (~60 pairs, one block, slots) and 2.0 (up to ~270 pairs: several blocks, more than a slot holds),
 * and for the three instantiations of the pair loop (symmetric form with the default options,
 * symmetric form with shape_viscosity: shape, paper form). The sums are taken in the same list
 * order but in different blocks, so they agree to round-off, not bitwise. */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"
#include "test_rng.h"

const ej_plugin_info *ej_plugin_sph_info(void);
const ej_plugin_info *ej_plugin_ideal_gas_info(void);

static const ej_param *mask_param(const ej_param *t, const char *name)
{
  for (; t && t->name; ++t)
    if (!strcmp(t->name, name)) return t;
  ck_abort_msg("no parameter '%s'", name);
  return NULL;
}

enum { SIDE = 10, N = SIDE * SIDE * SIDE };

typedef struct mask_out {
  ej_real a[3 * N], rho_dot[N], e_dot[N], w_dot[N], M[6 * N];
  ej_off max_row, min_row;
  int nfb;
} mask_out;

/* One evaluation of the 3D jittered lattice (spacing 0.1, jitter 0.2 spacing, smooth random v,
 * rho, e) with gradient: shape_tensor, the given form/viscosity, h_factor and list skin. */
static void mask_eval(int form, int visc, ej_real h_factor, ej_real skin, mask_out *o)
{
  ej_registry *reg;
  ck_assert_int_eq(ej_registry_create(&reg), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_sph_info()), EJ_OK);
  ck_assert_int_eq(ej_registry_add_static(reg, ej_plugin_ideal_gas_info()), EJ_OK);
  const void *ops;
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_METHOD, "sph", NULL, &ops), EJ_OK);
  const ej_method_ops *mops = ops;
  ck_assert_int_eq(ej_registry_require(reg, EJ_KIND_EOS, "ideal_gas", NULL, &ops), EJ_OK);
  const ej_eos_ops *eops = ops;
  void *mcfg = ej_calloc(1, mops->config_size), *ecfg = ej_calloc(1, eops->config_size), *estate, *mstate;
  ck_assert_int_eq(ej_params_defaults(mops->params, mcfg), EJ_OK);
  ck_assert_int_eq(ej_params_defaults(eops->params, ecfg), EJ_OK);
  *(int *)((char *)mcfg + mask_param(mops->params, "gradient")->offset) = 1;        /* shape_tensor */
  *(int *)((char *)mcfg + mask_param(mops->params, "shape_form")->offset) = form;   /* 0 symmetric, 1 paper */
  *(int *)((char *)mcfg + mask_param(mops->params, "shape_viscosity")->offset) = visc; /* 0 kernel, 1 shape */
  *(ej_real *)((char *)mcfg + mask_param(mops->params, "h_factor")->offset) = h_factor;
  ck_assert_int_eq(eops->create(ecfg, &estate), EJ_OK);
  struct ej_eos eos = {.ops = eops, .state = estate};
  struct ej_model model = {.name = "gas", .rho0 = 1.0, .eos = &eos, .mat = NULL};
  ej_set *set;
  ck_assert_int_eq(ej_set_create("gas", 0, 3, &set), EJ_OK);
  ck_assert_int_eq(ej_decl_probe(mops, mcfg, set), EJ_OK);
  ck_assert_int_eq(ej_set_reserve(set, N), EJ_OK);
  set->n = N;
  set->n_ghost = 0;
  int32_t *id = ej_set_field_int(set, "id");
  ej_real *x = ej_set_field(set, "x"), *v = ej_set_field(set, "v"), *m = ej_set_field(set, "m");
  ej_real *vol0 = ej_set_field(set, "vol0"), *rho = ej_set_field(set, "rho"), *e = ej_set_field(set, "e");
  const ej_real dx = 1.0 / SIDE;
  uint64_t seed = 4242u;
  for (ej_idx i = 0; i < N; ++i) {
    id[i] = (int32_t)i;
    ej_idx k = i;
    for (int d = 0; d < 3; ++d) {
      x[3 * i + d] = ((ej_real)(k % SIDE) + 0.5 + 0.2 * (rng_uniform(&seed) - 0.5)) * dx;
      k /= SIDE;
    }
    for (int d = 0; d < 3; ++d) v[3 * i + d] = sin(3.0 * x[3 * i + d] + d) + 0.3 * rng_uniform(&seed);
    vol0[i] = dx * dx * dx;
    rho[i] = 1.0 + 0.2 * sin(5.0 * x[3 * i]);
    e[i] = 1.0 + 0.5 * rng_uniform(&seed);
    m[i] = rho[i] * vol0[i];
  }
  ck_assert_int_eq(mops->create(mcfg, set, &model, &mstate), EJ_OK);
  ck_assert_int_eq(mops->setup(mstate, set), EJ_OK);
  ck_assert_int_eq(mops->support(mstate, set, (ej_range){0, N}, set->radius), EJ_OK);
  ej_nbrlist *list;
  ck_assert_int_eq(ej_nbrlist_create(&list), EJ_OK);
  ck_assert_int_eq(ej_nbrlist_build(list, 3, x, set->radius, N, x, set->radius, N, skin, true), EJ_OK);
  const char *zero[] = {"a", "rho_dot", "e_dot", "w_visc_dot"};
  for (int k = 0; k < 4; ++k) memset(ej_set_field(set, zero[k]), 0, (size_t)N * (k ? 1 : 3) * sizeof(ej_real));
  const int np = mops->pass_count ? mops->pass_count(mstate) : mops->n_passes;
  const ej_range halves[2] = {{0, N / 3}, {N / 3, N}};
  for (int pass = 0; pass < np; ++pass)
    for (int hh = 0; hh < 2; ++hh) ck_assert_int_eq(mops->compute(mstate, set, &list->pub, pass, halves[hh]), EJ_OK);
  memcpy(o->a, ej_set_field(set, "a"), sizeof o->a);
  memcpy(o->rho_dot, ej_set_field(set, "rho_dot"), sizeof o->rho_dot);
  memcpy(o->e_dot, ej_set_field(set, "e_dot"), sizeof o->e_dot);
  memcpy(o->w_dot, ej_set_field(set, "w_visc_dot"), sizeof o->w_dot);
  memcpy(o->M, ej_set_field(set, "M_inv"), sizeof o->M);
  const int32_t *fb = ej_set_field_int(set, "grad_fallback");
  o->nfb = 0;
  o->max_row = 0;
  o->min_row = (ej_off)1 << 30;
  for (ej_idx i = 0; i < N; ++i) {
    const ej_off len = list->pub.off[i + 1] - list->pub.off[i];
    o->max_row = len > o->max_row ? len : o->max_row;
    o->min_row = len < o->min_row ? len : o->min_row;
    o->nfb += fb[i];
  }
  ej_nbrlist_destroy(list);
  mops->destroy(mstate);
  ej_set_destroy(set);
  eops->destroy(estate);
  ej_free(mcfg);
  ej_free(ecfg);
  ej_registry_destroy(reg);
}

/* max |p - q| / max |p| over n values */
static double mask_rel(const ej_real *p, const ej_real *q, size_t n)
{
  double d = 0.0, s = 0.0;
  for (size_t k = 0; k < n; ++k) {
    d = fmax(d, fabs(p[k] - q[k]));
    s = fmax(s, fabs(p[k]));
  }
  return s > 0.0 ? d / s : d;
}

START_TEST(test_shape_masks)
{
  static mask_out A, B; /* 2 x ~0.4 MB: static, not on the stack */
  const int forms[3][2] = {{0, 0}, {0, 1}, {1, 0}}; /* defaults; shape_viscosity: shape; paper */
  const ej_real hfs[2] = {1.2, 2.0};
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 2; ++k) {
      mask_eval(forms[c][0], forms[c][1], hfs[k], 0.02, &A); /* rows <= 512 entries: masked */
      mask_eval(forms[c][0], forms[c][1], hfs[k], 10.0, &B); /* every row 999 entries: unmasked */
      ck_assert_msg(A.max_row <= 512, "masked run: a row of %ld entries", (long)A.max_row);
      ck_assert_msg(B.min_row > 512, "unmasked run: a row of %ld entries", (long)B.min_row);
      if (k == 1) /* several blocks of 128 and several mask words per row */
        ck_assert_msg(A.max_row > 256, "h_factor 2: longest row %ld entries", (long)A.max_row);
      ck_assert_int_eq(A.nfb, B.nfb);
      const double ea = mask_rel(A.a, B.a, 3 * N), er = mask_rel(A.rho_dot, B.rho_dot, N);
      const double ee = mask_rel(A.e_dot, B.e_dot, N), ew = mask_rel(A.w_dot, B.w_dot, N);
      const double em = mask_rel(A.M, B.M, 6 * N);
      ck_assert_msg(ea < 1e-12 && er < 1e-12 && ee < 1e-12 && ew < 1e-12 && em < 1e-12,
                    "form %d visc %d h_factor %g: masked vs full a %.2e rho_dot %.2e e_dot %.2e w_dot %.2e M %.2e",
                    forms[c][0], forms[c][1], hfs[k], ea, er, ee, ew, em);
    }
}
END_TEST

int main(void)
{
  Suite *s = suite_create("sph_shape_masks");
  TCase *tc = tcase_create("masks");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_shape_masks);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  const int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
