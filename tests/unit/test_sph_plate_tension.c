/* Short version of validation/sph_plate_tension (issue 6): an aluminium 6061-T6 plate (Johnson-Cook
 * + Mie-Grueneisen of examples/materials/al6061_t6.yaml, failure off), 2D plane strain, 20 mm x 50 mm,
 * clamped grips (3 end rows each) at -+V, the free part starting with the homogeneous stretching
 * velocity, SPH with strength, Wendland C2, h = 1.5 dx. Coarse: dx = 1 mm (20 x 50 = 1000 particles).
 * The metrics of validation/sph_plate_tension/check.py, evaluated on the sim's final state:
 *  - stress (V = 6.25 m/s, the case's quasi-static 266 /s at dx 0.5 mm; 284 /s here): at 2.5 %
 *    nominal strain (before the closed form's maximum load) the gauge's engineering stress S = sum_{|Y| < 5 mm} sigma_yy m/rho / (gauge length) / W0 against the closed-form
 *    plane-strain flow stress at the gauge strain (check.py's closed_form), within 5 %;
 *  - to 30 % nominal strain with art_stress (V = 25 m/s, 1136 /s: the harsher and 4x cheaper run): every particle's nearest-neighbour distance over the
 *    affine-expected one (least-squares F of its reference neighbours within 3 dx) >= 0.5, one
 *    cluster (link 1.5 dx times the larger principal stretch, capped at 2), energy balance within
 *    1 % of the grips' work. */
#include "validation_common.h"

const ej_plugin_info *ej_plugin_johnson_cook_info(void);
const ej_plugin_info *ej_plugin_mie_gruneisen_info(void);

#define PT_W0 0.020
#define PT_L0 0.050
#define PT_DX 1e-3
#define PT_GRIP (3 * PT_DX)
#define PT_LFREE (PT_L0 - 2 * PT_GRIP)
#define PT_GAUGE 0.010
/* material (al6061_t6.yaml, failure off) */
#define PT_RHO0 2703.0
#define PT_E 68.9e9
#define PT_NU 0.33

static ej_err pt_vopen(vscene *c, const char *fmt, ...)
{
  const ej_plugin_info *pl[] = {ej_plugin_sph_info(), ej_plugin_johnson_cook_info(), ej_plugin_mie_gruneisen_info()};
  va_list ap;
  va_start(ap, fmt);
  ej_err rc = vscene_open(c, "plate_tension", pl, 3, fmt, ap);
  va_end(ap);
  return rc;
}

/* The scene of check.py at PT_DX, grip speed V, ending at nominal strain e_end; art_stress on/off. */
static void pt_open(vscene *c, double V, double e_end, bool art)
{
  const int nrow = (int)lround(PT_L0 / PT_DX);
  size_t cap = 256 * (size_t)nrow + 4096, o = 0;
  char *strips = malloc(cap);
  ck_assert_ptr_nonnull(strips);
  strips[0] = 0;
  for (int k = 0; k < nrow; ++k) {
    const double y = -0.5 * PT_L0 + (k + 0.5) * PT_DX;
    const double vy = V * fmax(-1.0, fmin(1.0, y / (0.5 * PT_LFREE)));
    o += (size_t)snprintf(strips + o, cap - o,
                          "      - {region: {box: {min: [-1, %.9g], max: [1, %.9g]}}, velocity: [0, %.9g]}\n",
                          y - 0.5 * PT_DX, y + 0.5 * PT_DX, vy);
    ck_assert(o < cap);
  }
  const double t_end = e_end * PT_LFREE / (2 * V);
  ej_err rc = pt_vopen(
      c,
      "ejecta: 1\ndimension: 2\ntime: {end: %.17g, cfl: 0.3}\n"
      "output: {file: out.h5, every: 1, fields: [v]}\n"
      "materials:\n"
      "  al: {model: johnson_cook, rho0: 2703, E: 68.9 GPa, nu: 0.33, A: 324 MPa, B: 114 MPa, n: 0.42, C: 0.002,\n"
      "       m: 1.34, T_room: 293, T_melt: 925, cp: 896, taylor_quinney: 0.9, failure: false, volumetric: eos,\n"
      "       eos: {model: mie_gruneisen, rho0: 2703, C0: 5350, S1: 1.34, gamma0: 2.0, a: 0.48}}\n"
      "sets:\n"
      "  plate:\n"
      "    method: sph\n    strength: true\n    art_stress: %s\n    kernel: wendland_c2\n    h_factor: 1.5\n"
      "    material: al\n"
      "    shape: {box: {min: [%.9g, %.9g], max: [%.9g, %.9g]}}\n"
      "    spacing: %.9g\n"
      "    initial:\n%s"
      "boundaries:\n"
      "  - {set: plate, region: {box: {min: [-1, %.9g], max: [1, 1]}}, velocity: [0, %g]}\n"
      "  - {set: plate, region: {box: {min: [-1, -1], max: [1, %.9g]}}, velocity: [0, %g]}\n",
      t_end, art ? "true" : "false", -0.5 * PT_W0, -0.5 * PT_L0, 0.5 * PT_W0, 0.5 * PT_L0, PT_DX, strips,
      0.5 * PT_L0 - PT_GRIP, V, -0.5 * PT_L0 + PT_GRIP, -V);
  free(strips);
  if (rc != EJ_OK) ej_error_report("test");
  ck_assert_int_eq(rc, EJ_OK);
}

static ej_set *pt_set(vscene *c)
{
  ck_assert_int_eq(c->r.sim->n_sets, 1);
  return c->r.sim->sets[0];
}

/* Reference positions in id order (the set may be permuted): X[2 id + k]. */
static double *pt_reference(const ej_set *s)
{
  const ej_idx n = ej_set_count(s);
  double *X = malloc(2 * (size_t)n * sizeof *X);
  ck_assert_ptr_nonnull(X);
  const ej_real *x = ej_set_field(s, "x");
  const int32_t *id = ej_set_field_int(s, "id");
  ck_assert_ptr_nonnull(x);
  ck_assert_ptr_nonnull(id);
  for (ej_idx i = 0; i < n; ++i) {
    ck_assert(id[i] >= 0 && id[i] < n);
    X[2 * id[i]] = x[3 * i], X[2 * id[i] + 1] = x[3 * i + 1];
  }
  return X;
}

/* Closed-form engineering stress of plane-strain tension of the Johnson-Cook material at the
 * engineering strain e_at (check.py closed_form: rigid-plastic flow, elastic strain sigma (1 - nu^2)/E
 * subtracted, adiabatic heating at the previous T, rate term at (2/sqrt3) e_rate / (1 + e)). */
static double pt_closed_form(double e_rate, double e_at)
{
  const double k = 2 / sqrt(3.0), eps_ps = PT_E / (1 - PT_NU * PT_NU);
  const double A = 324e6, B = 114e6, n = 0.42, C = 0.002, m = 1.34, Tr = 293, Tm = 925, cp = 896, chi = 0.9;
  const int N = 20000;
  const double de = 0.35 / N;
  double temp = Tr, sig = 0, ep_prev = 0, S = 0, S_prev = 0, e_prev = 0;
  for (int i = 0; i <= N; ++i) {
    const double e = i * de, eps = log1p(e);
    const double rate = fmax(k * e_rate / (1 + e), 1.0);
    const double ts = fmin(fmax((temp - Tr) / (Tm - Tr), 0.0), 1.0);
    const double fac = (1 + C * log(rate)) * (1 - pow(ts, m));
    double s = sig;
    for (int it = 0; it < 50; ++it) {
      const double ep = fmax(0.0, k * (eps - s / eps_ps));
      const double s_new = fmin(eps_ps * eps, k * (A + B * pow(ep, n)) * fac);
      const bool done = fabs(s_new - s) < 1e-6;
      s = s_new;
      if (done) break;
    }
    sig = s;
    const double ep = fmax(0.0, k * (eps - s / eps_ps));
    if (ep > ep_prev) {
      temp += chi * (s / k) * (ep - ep_prev) / (PT_RHO0 * cp);
      ep_prev = ep;
    }
    S = s / (1 + e);
    if (e >= e_at) return S_prev + (S - S_prev) * (e_at - e_prev) / (e - e_prev);
    S_prev = S, e_prev = e;
  }
  return S;
}

START_TEST(test_plate_stress)
{
  const double V = 6.25, e_nom = 0.025, e_rate = 2 * V / PT_LFREE;
  vscene c;
  pt_open(&c, V, e_nom, true);
  ej_set *s = pt_set(&c);
  double *X = pt_reference(s);
  vrun_run(&c.r);
  const ej_idx n = ej_set_count(s);
  const ej_real *x = ej_set_field(s, "x"), *sig = ej_set_field(s, "stress"), *rho = ej_set_field(s, "rho"),
                *m = ej_set_field(s, "m");
  const int32_t *id = ej_set_field_int(s, "id");
  ck_assert_ptr_nonnull(sig);
  double ytop = 0, ybot = 0, force = 0;
  int ntop = 0, nbot = 0;
  const double yrow = 0.5 * PT_GAUGE - 0.5 * PT_DX;
  for (ej_idx i = 0; i < n; ++i) {
    const double Y = X[2 * id[i] + 1];
    if (fabs(Y - yrow) < 0.25 * PT_DX) ytop += x[3 * i + 1], ++ntop;
    if (fabs(Y + yrow) < 0.25 * PT_DX) ybot += x[3 * i + 1], ++nbot;
    if (fabs(Y) < 0.5 * PT_GAUGE) force += sig[6 * i + 1] * m[i] / rho[i];
  }
  ck_assert_int_eq(ntop, (int)lround(PT_W0 / PT_DX));
  ck_assert_int_eq(nbot, ntop);
  const double eg = (ytop / ntop - ybot / nbot) / (PT_GAUGE - PT_DX) - 1;
  const double S = force / (PT_GAUGE * (1 + eg)) / PT_W0, S_cf = pt_closed_form(e_rate, eg);
  fprintf(stderr, "plate tension dx 1 mm: nominal strain %.4f, gauge strain %.5f, S %.2f MPa, closed form %.2f MPa (%+.2f %%)\n",
          e_nom, eg, S / 1e6, S_cf / 1e6, 100 * (S / S_cf - 1));
  ck_assert_msg(eg > 0.01, "gauge strain %g: the gauge must be past the elastic range", eg);
  ck_assert_msg(fabs(S / S_cf - 1) <= 0.05, "engineering stress %g MPa, closed form %g MPa", S / 1e6, S_cf / 1e6);
  free(X);
  vscene_free(&c);
}
END_TEST

/* Nearest-distance ratio (min over particles), cluster count and largest stretch of the final
 * state against the reference X (O(n^2) pair search; n = 1000). */
static void pt_metrics(const ej_set *s, const double *X, double *rmin, int *nclusters, double *smax_all)
{
  const ej_idx n = ej_set_count(s);
  const ej_real *xs = ej_set_field(s, "x");
  const int32_t *id = ej_set_field_int(s, "id");
  double *x = malloc(2 * (size_t)n * sizeof *x), *F = calloc(4 * (size_t)n, sizeof *F),
         *A = calloc(4 * (size_t)n, sizeof *A), *dn = malloc((size_t)n * sizeof *dn), *sm = malloc((size_t)n * sizeof *sm);
  int *parent = malloc((size_t)n * sizeof *parent);
  ck_assert(x && F && A && dn && sm && parent);
  for (ej_idx i = 0; i < n; ++i) x[2 * id[i]] = xs[3 * i], x[2 * id[i] + 1] = xs[3 * i + 1];
  const double R = 3 * PT_DX;
  /* least-squares F_i = (sum dx dX^T)(sum dX dX^T)^-1 over reference neighbours within 3 dx */
  for (ej_idx i = 0; i < n; ++i)
    for (ej_idx j = 0; j < n; ++j) {
      const double dX0 = X[2 * j] - X[2 * i], dX1 = X[2 * j + 1] - X[2 * i + 1];
      if (j == i || dX0 * dX0 + dX1 * dX1 >= R * R) continue;
      const double d0 = x[2 * j] - x[2 * i], d1 = x[2 * j + 1] - x[2 * i + 1];
      double *a = A + 4 * i, *f = F + 4 * i;
      a[0] += dX0 * dX0, a[1] += dX0 * dX1, a[2] += dX1 * dX0, a[3] += dX1 * dX1;
      f[0] += d0 * dX0, f[1] += d0 * dX1, f[2] += d1 * dX0, f[3] += d1 * dX1;
    }
  *rmin = INFINITY, *smax_all = 0;
  for (ej_idx i = 0; i < n; ++i) {
    const double *a = A + 4 * i, det = a[0] * a[3] - a[1] * a[2];
    const double ai[4] = {a[3] / det, -a[1] / det, -a[2] / det, a[0] / det};
    double *f = F + 4 * i, g[4];
    g[0] = f[0] * ai[0] + f[1] * ai[2], g[1] = f[0] * ai[1] + f[1] * ai[3];
    g[2] = f[2] * ai[0] + f[3] * ai[2], g[3] = f[2] * ai[1] + f[3] * ai[3];
    memcpy(f, g, sizeof g);
    /* largest singular value of the 2 x 2 F */
    const double p = g[0] * g[0] + g[1] * g[1] + g[2] * g[2] + g[3] * g[3], q = g[0] * g[3] - g[1] * g[2];
    sm[i] = sqrt(0.5 * (p + sqrt(fmax(0.0, p * p - 4 * q * q))));
    *smax_all = fmax(*smax_all, sm[i]);
    dn[i] = INFINITY;
    parent[i] = (int)i;
  }
  for (ej_idx i = 0; i < n; ++i)
    for (ej_idx j = i + 1; j < n; ++j) {
      const double d = hypot(x[2 * j] - x[2 * i], x[2 * j + 1] - x[2 * i + 1]);
      if (d >= R) continue;
      dn[i] = fmin(dn[i], d), dn[j] = fmin(dn[j], d);
      if (d < 1.5 * PT_DX * fmin(2.0, fmax(sm[i], sm[j]))) {
        int ri = (int)i, rj = (int)j;
        while (parent[ri] != ri) ri = parent[ri];
        while (parent[rj] != rj) rj = parent[rj];
        if (ri != rj) parent[ri] = rj;
      }
    }
  int nc = 0;
  for (ej_idx i = 0; i < n; ++i) {
    nc += parent[i] == (int)i;
    const double *f = F + 4 * i;
    const double u[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
    double emin = INFINITY;
    for (int k = 0; k < 4; ++k)
      emin = fmin(emin, PT_DX * hypot(f[0] * u[k][0] + f[1] * u[k][1], f[2] * u[k][0] + f[3] * u[k][1]));
    *rmin = fmin(*rmin, dn[i] / emin);
  }
  *nclusters = nc;
  free(x), free(F), free(A), free(dn), free(sm), free(parent);
}

START_TEST(test_plate_30_percent)
{
  vscene c;
  pt_open(&c, 25.0, 0.30, true);
  ej_set *s = pt_set(&c);
  double *X = pt_reference(s);
  vrun_run(&c.r);
  double rmin, smax;
  int nc;
  pt_metrics(s, X, &rmin, &nc, &smax);
  const ej_energy *E = &c.r.sim->energy;
  fprintf(stderr,
          "plate tension dx 1 mm to 30 %%, art_stress on: t %.4g s, nn/affine-expected min %.3f, clusters %d, "
          "largest stretch %.3f; balance %.4g J/m, grips' work %.4g J/m (%.2e), plastic %.4g J/m\n",
          c.r.sim->t, rmin, nc, smax, E->balance, E->external, fabs(E->balance) / fabs(E->external), E->plastic);
  ck_assert_msg(rmin >= 0.5, "clumping: nearest distance %.3f of the affine-expected one", rmin);
  ck_assert_msg(nc == 1, "numerical fracture: %d clusters", nc);
  ck_assert_msg(fabs(E->balance) <= 0.01 * fabs(E->external), "energy balance %g J/m, grips' work %g J/m", E->balance,
                E->external);
  free(X);
  vscene_free(&c);
}
END_TEST

int main(void)
{
  Suite *su = suite_create("sph_plate_tension");
  TCase *tc = tcase_create("plate");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_plate_stress);
  tcase_add_test(tc, test_plate_30_percent);
  suite_add_tcase(su, tc);
  SRunner *sr = srunner_create(su);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
