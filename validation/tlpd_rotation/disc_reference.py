#!/usr/bin/python3
"""Continuum reference for the spinning disc started stress-free (README "Study").

Linear axisymmetric elastodynamics of a free disc of radius R in the frame rotating at omega:
displacements u_r(r, t), u_t(r, t) (t: tangential), Navier form with L[u] = u'' + u'/r - u/r^2,
  rho (u_r'' - 2 w du_t/dt - w^2 (r + u_r)) = (lam + 2G) L[u_r]
  rho (u_t'' + 2 w du_r/dt - w^2 u_t)       =  G L[u_t]
(centrifugal and Coriolis terms of the rotating frame), u = 0 at r = 0, sigma_rr = sigma_rt = 0
at r = R, started at rest in that frame (the rigid rotation, no stress). Plane strain (the
2-D scenes of ejecta) or plane stress (lam -> 2 lam G / (lam + 2G)). Finite differences on
N nodes, leapfrog. Prints for r0 = R/2, 3R/4, R the max over [0, t_end] of | |v|/(w r0) - 1 |,
| r/r0 - 1 | and | h/(w r0^2) - 1 |, h = r v_t the specific angular momentum: the Coriolis term
2 w du_r/dt turns a non-uniform radial expansion into a differential rotation, whose shear
stress sigma_rt changes h although the field stays axisymmetric.
"""
import argparse

import numpy as np


def solve(E, nu, rho, R, w, t_end, plane, N=400, cfl=0.4):
    G = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    if plane == "stress":
        lam = 2 * lam * G / (lam + 2 * G)
    M = lam + 2 * G
    h = R / N
    r = np.arange(N + 1) * h
    dt = cfl * h / np.sqrt(M / rho)
    nst = int(np.ceil(t_end / dt))
    dt = t_end / nst
    ur, ut, vr, vt = (np.zeros(N + 1) for _ in range(4))
    probes = [N // 2, (3 * N) // 4, N]
    r0 = r[probes]
    worst = np.zeros((3, 3))

    def lap(u, ghost):
        g = np.empty(N + 2)
        g[:N + 1] = u
        g[N + 1] = ghost
        out = np.zeros(N + 1)
        rr = r[1:N + 1]
        out[1:] = (g[2:N + 2] - 2 * g[1:N + 1] + g[0:N]) / h ** 2 + (g[2:N + 2] - g[0:N]) / (2 * h * rr) - g[1:N + 1] / rr ** 2
        return out

    def acc(ur, ut, vr, vt):
        # free edge: (lam + 2G) u_r' + lam u_r / R = 0, u_t' - u_t / R = 0 (central ghost)
        gr = ur[N - 1] - 2 * h * lam * ur[N] / (M * R)
        gt = ut[N - 1] + 2 * h * ut[N] / R
        ar = M / rho * lap(ur, gr) + 2 * w * vt + w * w * (r + ur)
        at = G / rho * lap(ut, gt) - 2 * w * vr + w * w * ut
        ar[0] = at[0] = 0
        return ar, at

    ar, at = acc(ur, ut, vr, vt)
    for _ in range(nst):
        vr += 0.5 * dt * ar
        vt += 0.5 * dt * at
        ur += dt * vr
        ut += dt * vt
        # the Coriolis term uses the half-step velocity (explicit, w dt << 1)
        ar, at = acc(ur, ut, vr, vt)
        vr += 0.5 * dt * ar
        vt += 0.5 * dt * at
        rad = r0 + ur[probes]
        vth = w * rad + vt[probes]
        sp = np.hypot(vr[probes], vth)
        hh = rad * vth
        worst[0] = np.maximum(worst[0], np.abs(sp / (w * r0) - 1))
        worst[1] = np.maximum(worst[1], np.abs(rad / r0 - 1))
        worst[2] = np.maximum(worst[2], np.abs(hh / (w * r0 ** 2) - 1))
    return r0, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--E", type=float, default=98.5e6)
    ap.add_argument("--nu", type=float, default=0.25)
    ap.add_argument("--rho", type=float, default=1700.0)
    ap.add_argument("--t_end", type=float, default=1e-3)
    ap.add_argument("--N", type=int, default=400)
    a = ap.parse_args()
    for plane in ("strain", "stress"):
        r0, wv = solve(a.E, a.nu, a.rho, 0.025, 1000.0, a.t_end, plane, N=a.N)
        print(f"plane {plane:6s} (E {a.E:.4g} Pa, N {a.N}): speed dev " + ", ".join(f"{100*x:.3f}" for x in wv[0]) +
              " %; radius dev " + ", ".join(f"{100*x:.3f}" for x in wv[1]) + " %; ang. mom. dev " +
              ", ".join(f"{100*x:.3f}" for x in wv[2]) + " % at r0 = R/2, 3R/4, R")


if __name__ == "__main__":
    main()
