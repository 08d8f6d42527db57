"""Self-similar Sedov-Taylor blast wave (uniform medium, spherical, ideal gas).

Similarity variables u = Rdot f(xi), rho = rho1 g(xi), p = rho1 Rdot^2 h(xi), xi = r/R(t),
R = xi0 (E t^2 / rho1)^(1/5) (L. I. Sedov, "Similarity and Dimensional Methods in Mechanics",
1959, ch. IV). Mass, momentum and entropy conservation give three ODEs linear in (g', f', h'):
    (f - xi) g' + g f'          = -2 g f / xi
    (f - xi) f' + h' / g        =  3/2 f
    (f - xi) (h'/h - gamma g'/g) = 3
integrated inwards from the strong-shock state f = 2/(gamma+1), g = (gamma+1)/(gamma-1),
h = 2/(gamma+1) at xi = 1. The energy integral E = 4 pi rho1 Rdot^2 R^3 I,
I = int_0^1 (g f^2/2 + h/(gamma-1)) xi^2 dxi, with Rdot = 2R/(5t) fixes
xi0 = (25 / (16 pi I))^(1/5): 1.0328 for gamma = 1.4 (the classic 1.033 of G. I. Taylor, Proc. R.
Soc. A 201 (1950) 159, and of Sedov) and 1.15167 for gamma = 5/3 (J. R. Kamm & F. X. Timmes,
LA-UR-07-2849, 2007, the standard test with j = 3, omega = 0). `python3 sedov_exact.py` prints both.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp


def profile(gamma=1.4, n=2000):
    def rhs(xi, y):
        g, f, h = y
        A = f - xi
        M = np.array([[A, g, 0.0], [0.0, A, 1.0 / g], [-gamma * A / g, 0.0, A / h]])
        b = np.array([-2.0 * g * f / xi, 1.5 * f, 3.0])
        return np.linalg.solve(M, b)

    y0 = [(gamma + 1) / (gamma - 1), 2 / (gamma + 1), 2 / (gamma + 1)]
    xi = np.linspace(1.0, 1e-3, n)
    sol = solve_ivp(rhs, (1.0, 1e-3), y0, t_eval=xi, rtol=1e-10, atol=1e-12, method="LSODA")
    g, f, h = sol.y
    xs, gs, fs, hs = xi[::-1], g[::-1], f[::-1], h[::-1]
    integrand = (0.5 * gs * fs ** 2 + hs / (gamma - 1)) * xs ** 2
    I = np.trapz(integrand, xs)
    xi0 = (25.0 / (16.0 * math.pi * I)) ** 0.2
    return xi0, xs, gs, fs, hs


def shock_radius(t, E=1.0, rho=1.0, xi0=1.03278):
    return xi0 * (E * t * t / rho) ** 0.2


if __name__ == "__main__":
    for g, ref in ((1.4, "1.033, Taylor 1950"), (5.0 / 3.0, "1.15167, Kamm & Timmes 2007")):
        print(f"xi0(gamma = {g:.4g}, spherical) = {profile(g)[0]:.5f} ({ref})")
