"""Reference for the first instants of C4 products pushing air (planar, 1D).

When the C4 detonation (Chapman-Jouguet state) reaches the charge/air interface, the interface
breaks up as a Riemann problem: a rarefaction runs back into the products along their isentrope
through the CJ point, and a shock runs into the air. The contact pressure p* and velocity u*
follow from u_products(p*) = u_air(p*) (E. F. Toro, "Riemann Solvers and Numerical Methods for
Fluid Dynamics", 3rd ed., ch. 4, for the ideal-gas shock branch, Eqs 4.6-4.7 written with the
upstream state at rest; the rarefaction branch is the Riemann invariant u + int c/rho drho,
integrated along the products' isentrope de = p/rho^2 drho for a general EOS).

JWL: p = A (1 - w/(R1 V)) exp(-R1 V) + B (1 - w/(R2 V)) exp(-R2 V) + w rho e, V = rho0/rho
(digest 001 Eq 13; C4 parameters of 001 Table 1, examples/materials/c4_001.yaml). The CJ point
is the tangency of the Rayleigh line with the products' Hugoniot centred on (rho0, p = 0, e0)
(plugins/eos/jwl/README.md, section "CJ state").

This holds until the Taylor wave behind the CJ front (and, for a charge lit at its far face,
the reflected rarefaction) reaches the interface: it is the air shock's pressure and the
product front's speed at the instant the detonation arrives. `python3 riemann.py` prints them.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

C4 = dict(A=6.098e11, B=1.3e10, R1=4.5, R2=1.4, omega=0.25, rho0=1601.0, e0=5.621e6)
AIR = dict(gamma=1.4, rho=1.2, p=101325.0)


def jwl_p(j, rho, e):
    V = j["rho0"] / rho
    w = j["omega"]
    return (j["A"] * (1 - w / (j["R1"] * V)) * math.exp(-j["R1"] * V)
            + j["B"] * (1 - w / (j["R2"] * V)) * math.exp(-j["R2"] * V) + w * rho * e)


def jwl_c(j, rho, e):
    """Isentropic sound speed by finite differences of p (independent of the plugin's formula)."""
    p = jwl_p(j, rho, e)
    dr = 1e-6 * rho
    de = 1e-6 * max(abs(e), 1.0)
    dpdr = (jwl_p(j, rho + dr, e) - jwl_p(j, rho - dr, e)) / (2 * dr)
    dpde = (jwl_p(j, rho, e + de) - jwl_p(j, rho, e - de)) / (2 * de)
    return math.sqrt(max(dpdr + p / rho ** 2 * dpde, 0.0))


def cj_state(j):
    """(D, p, rho, u, e) at the CJ point: minimum over eta = rho/rho0 of the Rayleigh speed."""
    r0, e0, w = j["rho0"], j["e0"], j["omega"]

    def hug(eta):
        rho = eta * r0
        V = 1 / eta
        pab = (j["A"] * (1 - w / (j["R1"] * V)) * math.exp(-j["R1"] * V)
               + j["B"] * (1 - w / (j["R2"] * V)) * math.exp(-j["R2"] * V))
        # p = pab + w rho (e0 + p (1/r0 - 1/rho)/2), solved for p
        return (pab + w * rho * e0) / (1 - w * rho * (1 / r0 - 1 / rho) / 2)

    def d2(eta):
        return hug(eta) / (r0 * (1 - 1 / eta))

    res = minimize_scalar(d2, bounds=(1.05, 2.0), method="bounded", options={"xatol": 1e-10})
    eta = res.x
    D = math.sqrt(d2(eta))
    p = hug(eta)
    rho = eta * r0
    e = e0 + 0.5 * p * (1 / r0 - 1 / rho)
    u = D * (1 - 1 / eta)
    return D, p, rho, u, e


def products_branch(j, rho_cj, e_cj, u_cj):
    """Isentrope from the CJ state down to low density: arrays (p, u) along the rarefaction."""
    def rhs(rho, y):
        e, u = y
        return [jwl_p(j, rho, e) / rho ** 2, -jwl_c(j, rho, e) / rho]

    rhos = np.geomspace(rho_cj, 1e-3 * j["rho0"], 4000)
    sol = solve_ivp(rhs, (rhos[0], rhos[-1]), [e_cj, u_cj], t_eval=rhos, rtol=1e-10, atol=1e-6)
    e, u = sol.y
    p = np.array([jwl_p(j, r, ee) for r, ee in zip(rhos, e)])
    return rhos, p, u


def air_shock_u(p, a=AIR):
    g, r, p0 = a["gamma"], a["rho"], a["p"]
    A, B = 2 / ((g + 1) * r), (g - 1) / (g + 1) * p0
    return (p - p0) * math.sqrt(A / (p + B))


def solve(j=C4, a=AIR):
    D, pcj, rcj, ucj, ecj = cj_state(j)
    rhos, p, u = products_branch(j, rcj, ecj, ucj)
    # p decreases and u increases along the branch; interpolate u(p) in log p
    lp = np.log(p[::-1])
    uu = u[::-1]

    def f(ps):
        return np.interp(math.log(ps), lp, uu) - air_shock_u(ps, a)

    ps = brentq(f, p[-1] * 1.0001, pcj)
    us = air_shock_u(ps, a)
    g = a["gamma"]
    # air shock speed (Toro Eq 4.59 with the upstream gas at rest)
    c0 = math.sqrt(g * a["p"] / a["rho"])
    S = c0 * math.sqrt((g + 1) / (2 * g) * ps / a["p"] + (g - 1) / (2 * g))
    rho_air = a["rho"] * (ps / a["p"] + (g - 1) / (g + 1)) / ((g - 1) / (g + 1) * ps / a["p"] + 1)
    return dict(D=D, p_cj=pcj, rho_cj=rcj, u_cj=ucj, p_star=ps, u_star=us, S_air=S, rho_air=rho_air)


if __name__ == "__main__":
    r = solve()
    print(f"CJ: D = {r['D']:.1f} m/s, p = {r['p_cj'] / 1e9:.3f} GPa, rho = {r['rho_cj']:.1f} kg/m^3, "
          f"u = {r['u_cj']:.1f} m/s")
    print(f"interface: p* = {r['p_star'] / 1e6:.2f} MPa, u* = {r['u_star']:.1f} m/s, "
          f"air shock speed {r['S_air']:.1f} m/s, shocked air density {r['rho_air']:.3f} kg/m^3")
