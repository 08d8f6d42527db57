/* Empirical air-blast loading: the Kingery-Bulmash (1984) curves as CONWEP evaluates them, and the
 * pressure on a face at an angle to the charge (docs/core.md "Pressure loads").
 *
 * Sources. C. N. Kingery, G. Bulmash, "Airblast parameters from TNT spherical air burst and
 * hemispherical surface burst", BRL-TR-02555 (1984), as the high-order polynomials
 * log10 Y = sum_k C_k U^k, U = K0 + K1 log10 Z of CONWEP (D. W. Hyde, ARL-TR-1310, App. A), in its
 * imperial units (Z in ft/lb^(1/3), psi, ms/lb^(1/3)); the coefficients are those transcribed in
 * shared/reference/README.md section 3 (their metric form, kingery_bulmash_freeair_spherical_
 * coefficients_metric.csv, agrees with these to < 0.01 %; erratum there: positive-duration branch 2
 * has C0 = +0.2303..., not the negative value of one public copy). The same curves are UFC 3-340-02
 * Figs 2-7 (free air) and 2-15 (surface burst).
 * Pressure at incidence angle theta (the angle between the face's outward normal and the direction
 * to the charge): G. Randers-Pehrson, K. A. Bannister, "Airblast loading model for DYNA2D and
 * DYNA3D", ARL-TR-1310 (1997): p = p_r cos^2 theta + p_i (1 + cos^2 theta - 2 cos theta) for
 * cos theta >= 0, and p_i on a face turned away from the charge (as LS-DYNA's *LOAD_BLAST).
 * Each of p_i(t) and p_r(t) is a modified Friedlander pulse p(tau) = P (1 - tau/t_d) exp(-a tau/t_d),
 * 0 <= tau = t - t_a <= t_d, with its own decay a such that its integral is the curves' impulse
 * (ej_blast_decay); no negative phase. */
#include <math.h>

#include "core_impl.h"

/* Horner evaluation of sum_k c[k] u^k, n coefficients. */
static double kb_poly(const double *c, int n, double u)
{
  double y = c[n - 1];
  for (int k = n - 2; k >= 0; --k) y = y * u + c[k];
  return y;
}

/* One fitted quantity: log10 Y = poly(K0 + K1 log10 Z). */
typedef struct kb_fit {
  double k0, k1;
  int n;
  double c[12];
} kb_fit;

static double kb_eval(const kb_fit *f, double lz) { return pow(10.0, kb_poly(f->c, f->n, f->k0 + f->k1 * lz)); }

/* [0] surface (hemispherical) burst, [1] free-air (spherical) burst; imperial units. */
static const kb_fit kb_pso[2] = {
    {-0.756579301809, 1.35034249993, 12,
     {1.9422502013, -1.6958988741, -0.154159376846, 0.514060730593, 0.0988534365274, -0.293912623038,
      -0.0268112345019, 0.109097496421, 0.00162846756311, -0.0214631030242, 0.0001456723382, 0.00167847752266}},
    {-0.756579301809, 1.35034249993, 9,
     {1.77284970457, -1.69012801396, 0.00804973591951, 0.336743114941, -0.00516226351334, -0.0809228619888,
      -0.00478507266747, 0.00793030472242, 0.0007684469735}}};
static const kb_fit kb_pr[2] = {
    {-0.789312405513, 1.36637719229, 12,
     {2.56431321138, -2.21030870597, -0.218536586295, 0.895319589372, 0.24989009775, -0.569249436807,
      -0.11791682383, 0.224131161411, 0.0245620259375, -0.0455116002694, -0.00190930738887, 0.00361471193389}},
    {-0.756579301809, 1.35034249993, 10,
     {2.39106134946, -2.21400538997, 0.035119031446, 0.657599992109, 0.0141818951887, -0.243076636231,
      -0.0158699803158, 0.0492741184234, 0.00227639644004, -0.00397126276058}}};
static const kb_fit kb_ta[2] = {
    {-0.755684472698, 1.37784223635, 10,
     {-0.173607601251, 1.35706496258, 0.052492798645, -0.196563954086, -0.0601770052288, 0.0696360270891,
      0.0215297490092, -0.0161658930785, -0.00232531970294, 0.00147752067524}},
    {-0.80501734056, 1.37407043777, 8,
     {-0.0423733936826, 1.36456871214, -0.0570035692784, -0.182832224796, 0.0118851436014, 0.0432648687627,
      -0.0007997367834, -0.00436073555033}}};
static const kb_fit kb_ir[2] = {
    {-0.781951689212, 1.33422049854, 4, {1.75291677799, -0.949516092853, 0.112136118689, -0.0250659183287}},
    {-0.757659920369, 1.37882996018, 4, {1.60579280091, -0.903118886091, 0.101771877942, -0.0242139751146}}};
/* incident impulse: two branches, split at log10 Z = kb_is_split */
static const double kb_is_split[2] = {0.382017, 0.30103};
static const kb_fit kb_is[2][2] = {
    {{0.832468843425, 3.0760329666, 5,
      {1.57159240621, -0.502992763686, 0.171335645235, 0.0450176963051, -0.0118964626402}},
     {-2.91358616806, 2.40697745406, 8,
      {0.719852655584, -0.384519026965, -0.0280816706301, 0.00595798753822, 0.014544526107, -0.00663289334734,
       -0.00284189327204, 0.0013644816227}}},
    {{1.04504877747, 3.24299066475, 5,
      {1.43534136453, -0.443749377691, 0.168825414684, 0.0348138030308, -0.010435192824}},
     {-2.67912519532, 2.30629231803, 9,
      {0.599008468099, -0.40463292088, -0.0142721946082, 0.00912366316617, -0.0006750681404, -0.00800863718901,
       0.00314819515931, 0.00152044783382, -0.0007470265899}}}};
/* positive duration: a constant below log10 Z = -0.34, then three branches */
static const double kb_td_low[2] = {-0.725, -0.824};
static const double kb_td_split[2][2] = {{0.4048337, 0.845098}, {0.350248, 0.7596678}};
static const kb_fit kb_td[2][3] = {
    {{-0.1790217052, 5.25099193925, 6,
      {-0.728671776005, 0.130143717675, 0.134872511954, 0.0391574276906, -0.00475933664702, -0.00428144598008}},
     {-5.85909812338, 9.2996288611, 9,
      {0.20096507334, -0.0297944268976, 0.030632954288, 0.0183405574086, -0.0173964666211, -0.00106321963633,
       0.00562060030977, 0.0001618217499, -0.0006860188944}},
     {-4.92699491141, 3.46349745571, 6,
      {0.572462469964, 0.0933035304009, -0.0005849420883, -0.00226884995013, -0.00295908591505,
       0.00148029868929}}},
    {{0.209440059933, 5.11588554305, 9,
      {-0.801052722864, 0.164953518069, 0.127788499497, 0.00291430135946, 0.00187957449227, 0.0173413962543,
       0.00269739758043, -0.00361976502798, -0.00100926577934}},
     {-5.06778493835, 9.2996288611, 9,
      {0.115874238335, -0.0297944268969, 0.0306329542941, 0.018340557407, -0.0173964666286, -0.00106321963576,
       0.0056206003128, 0.0001618217499, -0.0006860188944}},
     {-4.39590184126, 3.1524725264, 8,
      {0.50659210403, 0.0967031995552, -0.00801302059667, 0.00482705779732, 0.00187587272287,
       -0.00246738509321, -0.000841116668, 0.0006193291052}}}};

/* Unit conversions (exact definitions: 1 ft = 0.3048 m, 1 lb = 0.45359237 kg, 1 psi = 6894.75729 Pa). */
#define KB_LB 0.45359237
#define KB_PSI 6894.757293168
static double kb_z_ft(void) { return (1.0 / 0.3048) / cbrt(1.0 / KB_LB); } /* Z_ft = Z_m * this */
static double kb_t_s(void) { return 1e-3 * cbrt(1.0 / KB_LB); }          /* ms/lb^(1/3) -> s/kg^(1/3) */

void ej_blast_range(int burst, ej_real *z_min, ej_real *z_max)
{
  /* BRL-TR-02555's fitted range, m/kg^(1/3) (shared/reference: 0.0531-40 free air; the surface
   * curves from 0.0674) */
  *z_min = burst == EJ_BURST_SURFACE ? 0.0674 : 0.0531;
  *z_max = 40.0;
}

void ej_blast_curves(int burst, ej_real z, ej_blast_kb *out)
{
  const int b = burst == EJ_BURST_SURFACE ? 0 : 1;
  ej_real zmin, zmax;
  ej_blast_range(burst, &zmin, &zmax);
  z = z < zmin ? zmin : z > zmax ? zmax : z;
  const double lz = log10(z * kb_z_ft()), ts = kb_t_s();
  out->p_i = kb_eval(&kb_pso[b], lz) * KB_PSI;
  out->p_r = kb_eval(&kb_pr[b], lz) * KB_PSI;
  out->t_a = kb_eval(&kb_ta[b], lz) * ts;
  out->i_r = kb_eval(&kb_ir[b], lz) * KB_PSI * ts;
  out->i_i = kb_eval(&kb_is[b][lz < kb_is_split[b] ? 0 : 1], lz) * KB_PSI * ts;
  double ltd;
  if (lz < -0.34) ltd = kb_td_low[b];
  else {
    const int k = lz < kb_td_split[b][0] ? 0 : lz < kb_td_split[b][1] ? 1 : 2;
    ltd = kb_poly(kb_td[b][k].c, kb_td[b][k].n, kb_td[b][k].k0 + kb_td[b][k].k1 * lz);
  }
  out->t_d = pow(10.0, ltd) * ts;
}

/* f(a) = integral_0^1 (1 - s) exp(-a s) ds = 1/a - (1 - exp(-a))/a^2: 1/2 at a = 0, decreasing to 0. */
static double kb_friedlander_f(double a)
{
  if (a < 1e-2) return 0.5 - a / 6.0 + a * a / 24.0 - a * a * a / 120.0;
  return 1.0 / a - (1.0 - exp(-a)) / (a * a);
}

ej_real ej_blast_decay(ej_real P, ej_real I, ej_real *t_d)
{
  if (!(P > 0) || !(I > 0) || !(*t_d > 0)) return 0.0;
  const double r = I / (P * *t_d);
  if (r >= 0.5) { /* even the triangle (a = 0) over t_d holds less: lengthen it to carry I */
    *t_d = 2.0 * I / P;
    return 0.0;
  }
  /* f is monotone: bisection on [0, hi], then the root to round-off */
  double lo = 0.0, hi = 1.0;
  while (kb_friedlander_f(hi) > r && hi < 1e8) hi *= 2.0;
  for (int k = 0; k < 200 && hi - lo > 1e-14 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (kb_friedlander_f(mid) > r) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

ej_real ej_blast_friedlander(ej_real P, ej_real a, ej_real t_d, ej_real tau)
{
  if (!(tau >= 0) || !(tau <= t_d) || !(t_d > 0)) return 0.0;
  const double s = tau / t_d;
  return P * (1.0 - s) * exp(-a * s);
}

/* The curves at x (distance R from the charge, R > 0) and the angle rule's weights of the reflected
 * and incident overpressures for the face's outward normal n. */
static void kb_face(int burst, ej_real w3, const ej_real charge[3], const ej_real x[3], const ej_real n[3], ej_real *R,
                    ej_blast_kb *kb, ej_real *fr, ej_real *fi)
{
  const ej_real d[3] = {charge[0] - x[0], charge[1] - x[1], charge[2] - x[2]};
  *R = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  ej_blast_curves(burst, *R / w3, kb);
  const ej_real c = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / *R; /* cos of the incidence angle */
  *fr = c < 0 ? 0.0 : c * c;
  *fi = c < 0 ? 1.0 : 1.0 + c * c - 2.0 * c;
}

void ej_blast_point(int burst, ej_real w_tnt, const ej_real charge[3], ej_real t_det, const ej_real x[3],
                    const ej_real n[3], ej_blast_pt *o)
{
  const ej_real w3 = cbrt(w_tnt);
  *o = (ej_blast_pt){.t0 = INFINITY};
  if (!(w_tnt > 0) || (x[0] == charge[0] && x[1] == charge[1] && x[2] == charge[2])) return;
  ej_real R, fr, fi;
  ej_blast_kb kb;
  kb_face(burst, w3, charge, x, n, &R, &kb, &fr, &fi);
  o->t0 = t_det + kb.t_a * w3;
  o->td_r = o->td_i = kb.t_d * w3;
  o->a_r = ej_blast_decay(kb.p_r, kb.i_r * w3, &o->td_r);
  o->a_i = ej_blast_decay(kb.p_i, kb.i_i * w3, &o->td_i);
  o->p_r = fr * kb.p_r;
  o->p_i = fi * kb.p_i;
}

ej_real ej_blast_eval(const ej_blast_pt *b, ej_real t)
{
  const ej_real tau = t - b->t0;
  if (!(tau >= 0)) return 0.0;
  return ej_blast_friedlander(b->p_r, b->a_r, b->td_r, tau) + ej_blast_friedlander(b->p_i, b->a_i, b->td_i, tau);
}

ej_real ej_blast_pressure(int burst, ej_real w_tnt, const ej_real charge[3], ej_real t_det, const ej_real x[3],
                         const ej_real n[3], ej_real t)
{
  ej_blast_pt b;
  ej_blast_point(burst, w_tnt, charge, t_det, x, n, &b);
  return ej_blast_eval(&b, t);
}

void ej_blast_peak(int burst, ej_real w_tnt, const ej_real charge[3], const ej_real x[3], const ej_real n[3],
                   ej_blast_face *out)
{
  const ej_real w3 = cbrt(w_tnt);
  ej_real R, fr, fi;
  ej_blast_kb kb;
  kb_face(burst, w3, charge, x, n, &R, &kb, &fr, &fi);
  out->z = R / w3;
  out->t_a = kb.t_a * w3;
  out->p = fr * kb.p_r + fi * kb.p_i;
  out->impulse = (fr * kb.i_r + fi * kb.i_i) * w3; /* each pulse carries its curve's impulse exactly */
}
