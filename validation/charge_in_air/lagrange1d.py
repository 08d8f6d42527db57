#!/usr/bin/python3
"""Independent reference for the charge-in-air case: a 1D spherical Lagrangian finite-difference
hydrocode (von Neumann-Richtmyer staggered grid), numpy only. A validation tool, not part of ejecta.

Same physics as the SPH scene of check.py:
* TNT: JWL of digest 001 Table 1 with the A/B erratum (examples/materials/tnt_001.yaml):
  A = 3.712e11 Pa, B = 3.231e9 Pa, R1 = 4.15, R2 = 0.95, omega = 0.30, rho0 = 1630 kg/m^3,
  e0 = 4.29e6 J/kg, D = 6930 m/s. p = A (1 - w/(R1 V)) exp(-R1 V) + B (1 - w/(R2 V)) exp(-R2 V)
  + w rho e, V = rho0/rho (digest 001 Eq 13; plugins/eos/jwl/README.md).
* Programmed burn as plugins/eos/jwl: lighting time t_L = r/D (zone centre), F_t = clamp((t - t_L) D /
  (burn_width dx), 0, 1), Wilkins' beta burn F_v = (1 - V)/(1 - V_CJ) under compression, F monotone,
  p = F p_JWL. Or `--burn instant`: the whole charge burnt at t = 0 (constant-volume explosion).
* Air: ideal gas gamma = 1.4, 1.225 kg/m^3, 101325 Pa.
* Charge radius r0 = (3 W / (4 pi rho0))^(1/3) = 52.7 mm for W = 1 kg.

Scheme (Richtmyer & Morton, "Difference methods for initial-value problems", 2nd ed. (1967), ch. 12;
Wilkins, Methods Comput. Phys. 3 (1964)): node radii r_j and velocities u_j (u at half steps), zone
masses m_i, specific volume v_i and energy e_i at whole steps.
  du_j/dt = -4 pi r_j^2 [(p + q)_{j+1/2} - (p + q)_{j-1/2}] / M_j,   M_j = (m_{j-1/2} + m_{j+1/2})/2
  e^{n+1} = e^n - [(p^n + p^{n+1})/2 + q^{n+1/2}] (v^{n+1} - v^n)    (p linear in e: solved exactly)
  q = rho [c_q du^2 + c_l c |du|]  for du = u_{j+1} - u_j < 0, else 0.
The outer node sees the ambient pressure p0 (the domain is large enough that the shock does not
reach it); the centre node is fixed (u_0 = 0). Total energy (internal + kinetic + p0 work on the
outer boundary) is reported as a check.

Gauges: at every step the zone pressure (without q) at the Eulerian radii R = Z W^(1/3) (linear
interpolation between zone centres), max over time = peak incident overpressure; also every
air zone's own max overpressure over the run against the radius where it occurred.

    /usr/bin/python3 validation/charge_in_air/lagrange1d.py --nc 80 --dr-air 2.5e-3 [--burn instant] [--save FD.npz]
"""
import argparse
import math
import os
import sys
import time

import numpy as np

P0 = 101325.0
RHO_AIR = 1.225
GAMMA = 1.4
JWL = dict(A=3.712e11, B=3.231e9, R1=4.15, R2=0.95, w=0.30, rho0=1630.0, e0=4.29e6, D=6930.0)
ZS = [1.0, 1.5, 2.0, 3.0, 4.0, 5.0]


def jwl_ab(rho, J=JWL):
    """p_JWL = a(rho) + b(rho) e; returns (a, b)."""
    V = J["rho0"] / rho
    a = (J["A"] * (1 - J["w"] / (J["R1"] * V)) * np.exp(-J["R1"] * V)
         + J["B"] * (1 - J["w"] / (J["R2"] * V)) * np.exp(-J["R2"] * V))
    return a, J["w"] * rho


def jwl_c2(rho, e, J=JWL):
    """Isentropic c^2 = (dp/drho)_e + (p/rho^2) w rho (plugins/eos/jwl/README.md)."""
    V = J["rho0"] / rho
    w = J["w"]
    s = 0.0
    for A, R in ((J["A"], J["R1"]), (J["B"], J["R2"])):
        s = s + A * np.exp(-R * V) * (w / (R * V * V) - R + w / V)
    dpdrho = -(V / rho) * s + w * e
    a, b = jwl_ab(rho, J)
    p = a + b * e
    c2 = dpdrho + p / rho * w
    return np.maximum(c2, w * (1 + w) * np.maximum(e, 0.0)) + 1e-6


def jwl_vcj(J=JWL):
    """CJ relative volume: minimum over eta of the Rayleigh-line speed on the Hugoniot
    centred on (rho0, 0, e0) (as plugins/eos/jwl `create`)."""
    eta = np.linspace(1.01, 2.0, 20001)
    rho = J["rho0"] * eta
    a, b = jwl_ab(rho, J)
    ph = (a + b * J["e0"]) / (1 - J["w"] * (eta - 1) / 2)
    D2 = ph / (J["rho0"] * (1 - 1 / eta))
    k = int(np.argmin(D2))
    return 1 / eta[k], math.sqrt(D2[k])


def kb_pso(Z):
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from check_3d import kb_pso as f
    return f(Z)


def kb_ta(Z, W=1.0):
    from check_3d import kb_ta as f
    return f(Z, W)


def mesh(nc, dr_air, r_out, grade):
    """Node radii: nc equal zones in the charge [0, r0], then air zones growing from the charge
    spacing by the factor `grade` per zone up to dr_air, uniform dr_air out to r_out."""
    r0 = (3.0 / (4 * math.pi * JWL["rho0"])) ** (1 / 3)
    dxc = r0 / nc
    rc = np.linspace(0, r0, nc + 1)
    ra = [r0]
    d = min(dxc, dr_air)
    while ra[-1] < r_out:
        d = min(d * grade, dr_air) if grade > 1 else dr_air
        ra.append(ra[-1] + d)
    return r0, dxc, np.concatenate([rc, np.array(ra[1:])])


def run(nc=100, dr_air=2e-3, r_out=7.0, t_end=10e-3, burn="programmed", burn_width=3.0, cq=2.0, cl=0.25,
        cfl=0.4, grade=1.05, profile_times=(0.02e-3, 0.05e-3, 0.1e-3, 0.3e-3, 0.6e-3, 1.2e-3), verbose=True):
    r0, dxc, r = mesh(nc, dr_air, r_out, grade)
    N = len(r) - 1
    nch = nc
    ischarge = np.zeros(N, bool)
    ischarge[:nch] = True
    vol = 4 * math.pi / 3 * (r[1:] ** 3 - r[:-1] ** 3)
    rho = np.where(ischarge, JWL["rho0"], RHO_AIR)
    m = rho * vol
    W = float(np.sum(m[:nch]))
    e = np.where(ischarge, JWL["e0"], P0 / ((GAMMA - 1) * RHO_AIR))
    rcen = 0.5 * (r[1:] + r[:-1])
    tl = rcen[:nch] / JWL["D"]
    Vcj, Dcj = jwl_vcj()
    F = np.ones(nch) if burn == "instant" else np.zeros(nch)
    M = np.zeros(N + 1)
    M[:-1] += 0.5 * m
    M[1:] += 0.5 * m
    u = np.zeros(N + 1)
    v = 1.0 / rho

    def pressure(rho, e, F):
        a, b = jwl_ab(rho[:nch])
        p = np.empty(N)
        p[:nch] = F * (a + b * e[:nch])
        p[nch:] = (GAMMA - 1) * rho[nch:] * e[nch:]
        return p

    def sound(rho, e, p):
        c2 = np.empty(N)
        c2[:nch] = jwl_c2(rho[:nch], e[:nch])
        c2[nch:] = GAMMA * np.maximum(p[nch:], 1e-3) / rho[nch:]
        return np.sqrt(c2)

    p = pressure(rho, e, F)
    c = sound(rho, e, p)
    q = np.zeros(N)
    E0 = float(np.sum(m * e))
    Eair0 = float(np.sum(m[nch:] * e[nch:]))
    wext = 0.0
    Rg = np.array(ZS) * W ** (1 / 3)
    gmax = np.full(len(ZS), -np.inf)
    gt = np.zeros(len(ZS))
    zmax = np.full(N, -np.inf)   # each zone's max overpressure
    zrad = np.zeros(N)           # radius of the zone at that max
    t = 0.0
    dt = 0.1 * cfl * dxc / float(np.max(c))
    nstep = 0
    profiles = {}
    pt = sorted(profile_times)
    cpu0 = time.process_time()
    while t < t_end:
        dr = r[1:] - r[:-1]
        du = u[1:] - u[:-1]
        dtc = cfl * float(np.min(dr / (c + 2 * cq * np.maximum(-du, 0) + 1e-30)))
        dt_new = min(dtc, 1.1 * dt, t_end - t + 1e-15)
        # nodal acceleration at t^n (p^n and q^{n-1/2})
        s = p + q
        f = np.zeros(N + 1)
        A = 4 * math.pi * r ** 2
        f[1:-1] = -A[1:-1] * (s[1:] - s[:-1])
        f[-1] = -A[-1] * (P0 - s[-1])
        f[0] = 0.0
        dth = 0.5 * (dt + dt_new) if nstep > 0 else 0.5 * dt_new
        u = u + dth * f / M
        u[0] = 0.0
        dt = dt_new
        rn = r + dt * u
        voln = 4 * math.pi / 3 * (rn[1:] ** 3 - rn[:-1] ** 3)
        wext += P0 * (voln.sum() - vol.sum())
        rhon = m / voln
        vn = 1.0 / rhon
        # artificial viscosity at n+1/2
        du = u[1:] - u[:-1]
        rhoh = 2.0 / (v + vn)
        comp = du < 0
        q = np.where(comp, rhoh * (cq * du * du + cl * c * np.abs(du)), 0.0)
        tn = t + dt
        # burn fraction at t^{n+1}
        if burn != "instant":
            Ft = np.clip((tn - tl) * JWL["D"] / (burn_width * dxc), 0, 1)
            Vn = JWL["rho0"] / rhon[:nch]
            Fv = np.where(Vn < 1, (1 - Vn) / (1 - Vcj), 0.0)
            F = np.minimum(np.maximum(np.maximum(Ft, Fv), F), 1.0)
        # energy: p^{n+1} = a + b e^{n+1} (F-scaled for the charge)
        dv = vn - v
        a = np.empty(N)
        b = np.empty(N)
        aj, bj = jwl_ab(rhon[:nch])
        a[:nch] = F * aj
        b[:nch] = F * bj
        a[nch:] = 0.0
        b[nch:] = (GAMMA - 1) * rhon[nch:]
        e = (e - (0.5 * p + q + 0.5 * a) * dv) / (1 + 0.5 * b * dv)
        r, vol, rho, v = rn, voln, rhon, vn
        p = a + b * e
        c = sound(rho, e, p)
        t = tn
        nstep += 1
        # gauges (zone pressure without q, linear between zone centres)
        rcen = 0.5 * (r[1:] + r[:-1])
        pg = np.interp(Rg, rcen, p) - P0
        better = pg > gmax
        gmax = np.where(better, pg, gmax)
        gt = np.where(better, t, gt)
        po = p - P0
        up = po > zmax
        zmax = np.where(up, po, zmax)
        zrad = np.where(up, rcen, zrad)
        while pt and t >= pt[0]:
            uc = 0.5 * (u[1:] + u[:-1])
            ez = m * (e + 0.5 * uc * uc)
            profiles[pt.pop(0)] = dict(t=t, r=rcen.copy(), p=p.copy(), rho=rho.copy(), u=uc, charge=ischarge.copy(),
                                       E_air=float(np.sum(ez[nch:]) - Eair0), E_charge=float(np.sum(ez[:nch])))
        if verbose and nstep % 20000 == 0:
            print(f"  step {nstep}, t = {1e3 * t:.3f} ms, dt = {dt:.2e}", flush=True)
    Ek = 0.5 * float(np.sum(M * u * u))
    Ei = float(np.sum(m * e))
    bal = (Ek + Ei + wext - E0) / E0
    return dict(W=W, Z=np.array(ZS), R=Rg, peak=gmax, tpeak=gt, zmax=zmax, zrad=zrad, ischarge=ischarge,
                steps=nstep, balance=bal, cpu=time.process_time() - cpu0, profiles=profiles,
                r_contact=float(r[nch]), N=N, nc=nc, dr_air=dr_air, burn=burn)


def table(res):
    print(f"nc = {res['nc']}, dr_air = {1e3 * res['dr_air']:.2f} mm, burn {res['burn']}, {res['N']} zones, "
          f"{res['steps']} steps, {res['cpu']:.1f} s CPU, energy balance {res['balance']:.1e}, "
          f"contact at t_end {res['r_contact']:.3f} m")
    print("   Z    KB Pso [kPa]  FD Pso [kPa]  error    t_peak [ms]  KB ta [ms]")
    for Z, pk, tp in zip(res["Z"], res["peak"], res["tpeak"]):
        kb = kb_pso(Z)
        print(f"  {Z:3.1f}   {kb / 1e3:9.1f}    {pk / 1e3:9.1f}   {100 * (pk - kb) / kb:+6.1f} %   {1e3 * tp:7.3f}"
              f"     {1e3 * kb_ta(Z, res['W']):7.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nc", type=int, default=100, help="zones across the charge radius")
    ap.add_argument("--dr-air", type=float, default=2e-3, help="air zone size far from the charge [m]")
    ap.add_argument("--grade", type=float, default=1000.0, help="air zone growth factor from the charge spacing "
                    "(default: uniform dr_air from the contact, as the README tables)")
    ap.add_argument("--r-out", type=float, default=7.0)
    ap.add_argument("--t-end", type=float, default=10e-3)
    ap.add_argument("--burn", choices=["programmed", "instant"], default="programmed")
    ap.add_argument("--burn-width", type=float, default=3.0)
    ap.add_argument("--cq", type=float, default=2.0)
    ap.add_argument("--cl", type=float, default=0.25)
    ap.add_argument("--save", help="npz file for the gauge peaks and profiles")
    a = ap.parse_args(argv)
    res = run(nc=a.nc, dr_air=a.dr_air, r_out=a.r_out, t_end=a.t_end, burn=a.burn, burn_width=a.burn_width,
              cq=a.cq, cl=a.cl, grade=a.grade)
    table(res)
    if a.save:
        save(res, a.save)
    return 0


def save(res, path):
    d = {k: res[k] for k in ("W", "Z", "R", "peak", "tpeak", "zmax", "zrad", "ischarge", "balance", "cpu")}
    for i, (tp, pr) in enumerate(sorted(res["profiles"].items())):
        for k in ("r", "p", "rho", "u", "charge", "E_air", "E_charge"):
            d[f"prof{i}_{k}"] = pr[k]
        d[f"prof{i}_t"] = pr["t"]
    np.savez_compressed(path, **d)


if __name__ == "__main__":
    sys.exit(main())
