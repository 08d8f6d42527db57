"""Exact solution of the Riemann problem for the ideal gas (the Sod shock tube).

E. F. Toro, "Riemann Solvers and Numerical Methods for Fluid Dynamics", 3rd ed. (2009),
chapter 4: pressure functions f_K (Eqs 4.6-4.7), star pressure by Newton-Raphson iteration
from the two-rarefaction guess (Eqs 4.44-4.46), star velocity (Eq 4.9), star densities
(Eqs 4.53 and 4.60) and the sampling of the wave pattern (section 4.5, Eqs 4.52-4.64).

Usage as a module: `sample(x, t, left, right, gamma, x0=0.0)` returns (rho, u, p, e) arrays;
`left` and `right` are (rho, u, p) tuples. Run as a script it prints the star state of the Sod
problem (p* = 0.30313, u* = 0.92745 for gamma = 1.4, Toro table 4.3 test 1).
"""
import math

import numpy as np


def _f(p, rho, pk, ck, g):
    """Toro Eqs 4.6-4.7: f_K(p) and its derivative."""
    if p > pk:  # shock
        A = 2.0 / ((g + 1.0) * rho)
        B = (g - 1.0) / (g + 1.0) * pk
        s = math.sqrt(A / (p + B))
        return (p - pk) * s, s * (1.0 - 0.5 * (p - pk) / (p + B))
    # rarefaction
    r = p / pk
    return (2.0 * ck / (g - 1.0) * (r ** ((g - 1.0) / (2.0 * g)) - 1.0),
            1.0 / (rho * ck) * r ** (-(g + 1.0) / (2.0 * g)))


def star_state(left, right, g=1.4, tol=1e-12):
    """Star pressure and velocity (Toro section 4.3.1, Newton iteration, Eq 4.44)."""
    rl, ul, pl = left
    rr, ur, pr = right
    cl, cr = math.sqrt(g * pl / rl), math.sqrt(g * pr / rr)
    du = ur - ul
    if 2.0 * (cl + cr) / (g - 1.0) <= du:
        raise ValueError("vacuum is generated (Toro Eq 4.40)")
    # two-rarefaction initial guess (Eq 4.46)
    z = (g - 1.0) / (2.0 * g)
    p = ((cl + cr - 0.5 * (g - 1.0) * du) / (cl / pl ** z + cr / pr ** z)) ** (1.0 / z)
    p = max(p, tol)
    for _ in range(100):
        fl, dl = _f(p, rl, pl, cl, g)
        fr, dr = _f(p, rr, pr, cr, g)
        p_new = max(p - (fl + fr + du) / (dl + dr), tol)
        change = 2.0 * abs(p_new - p) / (p_new + p)
        p = p_new
        if change < tol:
            break
    fl, _ = _f(p, rl, pl, cl, g)
    fr, _ = _f(p, rr, pr, cr, g)
    u = 0.5 * (ul + ur) + 0.5 * (fr - fl)  # Eq 4.9
    return p, u


def sample(x, t, left, right, g=1.4, x0=0.0):
    """Density, velocity, pressure and specific internal energy at positions x and time t > 0
    (Toro section 4.5)."""
    x = np.asarray(x, dtype=float)
    rl, ul, pl = left
    rr, ur, pr = right
    cl, cr = math.sqrt(g * pl / rl), math.sqrt(g * pr / rr)
    ps, us = star_state(left, right, g)
    gm = (g - 1.0) / (g + 1.0)
    s = (x - x0) / t
    rho = np.empty_like(s)
    u = np.empty_like(s)
    p = np.empty_like(s)
    for i, si in enumerate(s):
        if si <= us:  # left of the contact
            if ps > pl:  # left shock (Eqs 4.50, 4.52)
                sl = ul - cl * math.sqrt((g + 1) / (2 * g) * ps / pl + (g - 1) / (2 * g))
                if si <= sl:
                    rho[i], u[i], p[i] = rl, ul, pl
                else:
                    rho[i], u[i], p[i] = rl * (ps / pl + gm) / (gm * ps / pl + 1), us, ps
            else:  # left rarefaction (Eqs 4.53-4.56)
                shl = ul - cl
                csl = cl * (ps / pl) ** ((g - 1) / (2 * g))
                stl = us - csl
                if si <= shl:
                    rho[i], u[i], p[i] = rl, ul, pl
                elif si >= stl:
                    rho[i], u[i], p[i] = rl * (ps / pl) ** (1 / g), us, ps
                else:
                    c = 2 / (g + 1) * (cl + 0.5 * (g - 1) * (ul - si))
                    rho[i] = rl * (c / cl) ** (2 / (g - 1))
                    u[i] = 2 / (g + 1) * (cl + 0.5 * (g - 1) * ul + si)
                    p[i] = pl * (c / cl) ** (2 * g / (g - 1))
        else:  # right of the contact
            if ps > pr:  # right shock (Eqs 4.57-4.59)
                sr = ur + cr * math.sqrt((g + 1) / (2 * g) * ps / pr + (g - 1) / (2 * g))
                if si >= sr:
                    rho[i], u[i], p[i] = rr, ur, pr
                else:
                    rho[i], u[i], p[i] = rr * (ps / pr + gm) / (gm * ps / pr + 1), us, ps
            else:  # right rarefaction (Eqs 4.60-4.64)
                shr = ur + cr
                csr = cr * (ps / pr) ** ((g - 1) / (2 * g))
                str_ = us + csr
                if si >= shr:
                    rho[i], u[i], p[i] = rr, ur, pr
                elif si <= str_:
                    rho[i], u[i], p[i] = rr * (ps / pr) ** (1 / g), us, ps
                else:
                    c = 2 / (g + 1) * (cr - 0.5 * (g - 1) * (ur - si))
                    rho[i] = rr * (c / cr) ** (2 / (g - 1))
                    u[i] = 2 / (g + 1) * (-cr + 0.5 * (g - 1) * ur + si)
                    p[i] = pr * (c / cr) ** (2 * g / (g - 1))
    e = p / ((g - 1.0) * rho)
    return rho, u, p, e


SOD_LEFT = (1.0, 0.0, 1.0)
SOD_RIGHT = (0.125, 0.0, 0.1)

if __name__ == "__main__":
    ps, us = star_state(SOD_LEFT, SOD_RIGHT)
    print(f"Sod, gamma 1.4: p* = {ps:.5f}, u* = {us:.5f} (Toro table 4.3: 0.30313, 0.92745)")
    x = np.linspace(-0.5, 0.5, 11)
    for xi, r, u, p, e in zip(x, *sample(x, 0.2, SOD_LEFT, SOD_RIGHT)):
        print(f"{xi:6.2f} {r:.5f} {u:.5f} {p:.5f} {e:.5f}")
