#!/usr/bin/python3
"""Diagnostics of a buried-charge run (issue 8, why the cap does not stay coherent).

    /usr/bin/python3 validation/buried_charge/diagnose.py OUT.h5 [--dob 0.03] [--rc 0.03]

Needs the output fields v, damage, failed (soil) and h, p (charge). Per frame it prints:
- the mass-weighted speed distribution of the soil within 0.1 m of the surface point above the charge (median, 90 %, 99 % of the mass below that speed, max);
- the cap (soil initially above the charge: r0 < rc, z0 > -dob): mass, z-momentum, mean v_z, its
  kinetic energy, and the Gurney-like estimate (open-faced / tamped sandwich, C4 sqrt(2E) = 2.68 km/s
  (Cooper, Explosives Engineering, Table 27.1, Composition C-4 value ~2.68 mm/us) with the cap mass
  over the charge's top face and the charge mass of the quarter);
- failure: point-failed soil particles (field failed: the pd_sph decohesion rule or the material),
  fully detached particles (damage = 1) and how many of them are not point-failed (broken by
  critical stretch alone), and the mean damage of the cap;
- leaks: charge particles above the initial soil surface, the largest gas h and 2 h.
"""
import argparse

import h5py
import numpy as np


def wq(v, w, q):
    o = np.argsort(v)
    c = np.cumsum(w[o]) / w.sum()
    return float(v[o][min(np.searchsorted(c, q), len(v) - 1)])


def lattice_mass(x, rho0):
    """Mass of lattice particles when the output has no m: rho0 times the cube of the initial
    nearest-neighbour distance (the lattice spacing)."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(x).query(x, k=2)
    return rho0 * d[:, 1] ** 3


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--dob", type=float, default=0.03)
    ap.add_argument("--rc", type=float, default=0.03)
    ap.add_argument("--rho-soil", type=float, default=1700.0)
    ap.add_argument("--rho-charge", type=float, default=1601.0)
    a = ap.parse_args()
    with h5py.File(a.out, "r") as f:
        keys = sorted(f["frames"].keys())
        f0 = f["frames"][keys[0]]
        x0 = f0["soil"]["x"][:]
        m = f0["soil"]["m"][:] if "m" in f0["soil"] else lattice_mass(x0, a.rho_soil)
        xg0 = f0["charge"]["x"][:]
        mg = f0["charge"]["m"][:] if "m" in f0["charge"] else lattice_mass(xg0, a.rho_charge)
        zs = x0[:, 2].max()
        r0 = np.hypot(x0[:, 0], x0[:, 1])
        cap = (r0 < a.rc) & (x0[:, 2] > zs - a.dob)
        near = (r0 < 0.1) & (x0[:, 2] > zs - 0.1)  # the speed distribution: soil within 0.1 m of the cap
        M = m[cap].sum()
        C = mg.sum() if mg is not None else float("nan")
        g = 2680.0
        mc = M / C
        v_open = g * (((1 + 2 * mc) ** 3 + 1) / (6 * (1 + mc)) + mc) ** -0.5
        v_tamp = g * (mc + 1.0 / 3.0) ** -0.5
        print(f"cap: {cap.sum()} particles, {M * 1e3:.2f} g (quarter); charge {C * 1e3:.2f} g; M/C {mc:.2f}; "
              f"Gurney open-faced {v_open:.0f} m/s, tamped {v_tamp:.0f} m/s -> cap momentum "
              f"{M * v_open:.2f}..{M * v_tamp:.2f} kg m/s")
        print("t_ms  v50  v90  v99  vmax | cap_pz  cap_vz  cap_KE_kJ soilKE_kJ gasKE_kJ | failed detached "
              "det_not_failed capdmg | gas_above maxh_mm")
        for k in keys:
            fr = f["frames"][k]
            t = float(fr.attrs["time"])
            v = fr["soil"]["v"][:]
            sp = np.sqrt((v ** 2).sum(axis=1))
            dmg = fr["soil"]["damage"][:] if "damage" in fr["soil"] else np.zeros(len(v))
            fl = fr["soil"]["failed"][:] if "failed" in fr["soil"] else np.zeros(len(v), int)
            det = dmg > 0.999
            xg = fr["charge"]["x"][:]
            vg = fr["charge"]["v"][:]
            hg = fr["charge"]["h"][:] if "h" in fr["charge"] else np.zeros(len(xg))
            mgs = mg
            above = int((xg[:, 2] > zs).sum())
            pz = float((m[cap] * v[cap, 2]).sum())
            ke_cap = 0.5 * float((m[cap] * sp[cap] ** 2).sum())
            ke_s = 0.5 * float((m * sp ** 2).sum())
            ke_g = 0.5 * float((mgs * (vg ** 2).sum(axis=1)).sum())
            print(f"{t * 1e3:5.3f} {wq(sp[near], m[near], .5):5.0f} {wq(sp[near], m[near], .9):5.0f} {wq(sp[near], m[near], .99):5.0f} {sp.max():5.0f} | "
                  f"{pz:6.2f} {pz / M:6.0f} {ke_cap / 1e3:8.2f} {ke_s / 1e3:8.2f} {ke_g / 1e3:8.2f} | "
                  f"{int((fl != 0).sum()):6d} {int(det.sum()):6d} {int((det & (fl == 0)).sum()):6d} "
                  f"{float(dmg[cap].mean()):5.2f} | {above:5d} {hg.max() * 1e3:6.1f}")


if __name__ == "__main__":
    main()
