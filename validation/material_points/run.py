#!/usr/bin/python3
"""Material-point stress paths against closed forms (drucker_prager, dp_cap, von_mises,
johnson_cook, soil_evp, jh2).

Runs the unit-test binaries with EJ_MP_CSV_DIR set: each path test then writes its path and the
closed-form reference as CSV (tests/unit/material_point_driver.h). This script plots every path
against its reference (material_points.png), prints the maximum error of each with its
tolerance and PASS/FAIL, and exits 1 on any FAIL.

References (closed forms, see each plugin README):
  dp_uniaxial_strain  Fan & Li 2017 Eqs 43-58: elastic nu/(1-nu), yield eps = A c/(2G sqrt(2/3) - B K)
  dp_triaxial         peak q = (2 c cos phi + 2 sc sin phi)/(1 - sin phi) (Mohr-Coulomb, beta = -1)
  dp_pure_shear       plateau A c / sqrt 2
  dp_apex             mean stress capped at the apex A c / B
  dp_relaxation       Duvaut-Lions: overstress x (1 + dt/tau)^-n (and exp(-t/tau) for comparison)
  dpc_hydrostatic     crush curve 000 Eq 76: I1 = X(eps_v_p), eps_v = eps_v_p + I1/(3K)
  vm_uniaxial         sigma_y0 + E H/(E + H) (eps - eps_y)
  jc_hardening        A + B eps_p^n
  evp_steady_shear    p [mu_s + (mu_2 - mu_s) g/(g + xi sqrt p)] (001 §2.5, sqrt(p) erratum)
  jh2_intact          sigma_HEL A (p* + T*)^N, the JH2 intact strength (002 Eq 21, granite of 002 Table 1)
  jh2_softening       sigma_HEL (sigma_i* - D (sigma_i* - sigma_f*)), D = eps_p / (D1 (p* + T*)^D2) at 80 MPa

Usage: /usr/bin/python3 validation/material_points/run.py --build BUILD_DIR
"""
import argparse
import atexit
import csv
import os
import shutil
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = ["test_drucker_prager", "test_dp_cap", "test_von_mises", "test_johnson_cook", "test_soil_evp", "test_jh2"]

# name: (x column, computed column, exact column, error scale, tolerance, axis labels)
CASES = {
    "dp_uniaxial_strain": ("eps_axial", "sxx", "sxx_exact", "max_abs", 1e-9, "axial strain", "sigma_xx [Pa]"),
    "dp_triaxial": ("eps_axial", "q", "q_peak_exact", "final", 1e-9, "axial strain", "deviator q [Pa]"),
    "dp_pure_shear": ("eps_xy", "sxy", "sxy_exact", "max_abs", 1e-9, "eps_xy", "sigma_xy [Pa]"),
    "dp_apex": ("eps_v", "p", "p_exact", "max_abs", 1e-9, "volumetric strain", "mean stress [Pa]"),
    "dp_relaxation": ("t", "sxy", "sxy_exact_discrete", "max_abs", 1e-9, "t [s]", "sigma_xy [Pa]"),
    "dpc_hydrostatic": ("eps_v", "I1", "I1_exact", "max_abs", 1e-8, "volumetric strain", "I1 [Pa]"),
    "vm_uniaxial": ("eps", "sxx", "sxx_exact", "max_abs", 1e-9, "axial strain", "sigma_xx [Pa]"),
    "jc_hardening": ("eps_p", "sxx", "sxx_exact", "max_abs", 1e-9, "plastic strain", "sigma_xx [Pa]"),
    "evp_steady_shear": ("gamma_dot", "tau", "tau_exact", "max_abs", 1e-8, "shear rate [1/s]", "tau [Pa]"),
    "jh2_intact": ("p", "seq", "seq_exact", "max_abs", 1e-9, "pressure [Pa]", "yield sigma_eq [Pa]"),
    "jh2_softening": ("eps_p", "seq", "seq_exact", "max_abs", 1e-9, "plastic strain", "sigma_eq [Pa]"),
}


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=HERE)
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="ej_mp_")
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)  # scratch: removed at exit
    env = dict(os.environ, EJ_MP_CSV_DIR=tmp, CK_FORK="no")
    ok = True
    for t in TESTS:
        exe = os.path.join(a.build, "tests", t)
        r = subprocess.run([exe], env=env, capture_output=True, text=True)
        last = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""
        print(f"{t}: exit {r.returncode} ({last})")
        ok = ok and r.returncode == 0
    fig, axes = plt.subplots(3, 4, figsize=(18, 11))
    for ax, (name, (xc, yc, ec, mode, tol, xl, yl)) in zip(axes.flat, CASES.items()):
        path = os.path.join(tmp, name + ".csv")
        if not os.path.exists(path):
            print(f"{name}: FAIL (no output)")
            ok = False
            continue
        d = read(path)
        x, y, ex = d[xc], d[yc], d[ec]
        scale = max(np.max(np.abs(ex)), 1e-300)
        if mode == "final":  # triaxial: the peak at the end of each confining pressure
            errs = []
            for sc in np.unique(d["sc"]):
                m = d["sc"] == sc
                errs.append(abs(y[m][-1] - ex[m][-1]) / abs(ex[m][-1]))
                ax.plot(x[m], y[m], "-", label=f"ejecta sc = {sc / 1e3:g} kPa")
                ax.axhline(ex[m][-1], color="k", ls=":", lw=0.8)
            err = max(errs)
        else:
            err = float(np.max(np.abs(y - ex)) / scale)
            ax.plot(x, y, "o", ms=3, label="ejecta")
            ax.plot(x, ex, "-", lw=1, label="closed form")
            if name == "dp_relaxation":
                ax.plot(x, d["sxy_exp"], "--", lw=1, label="exp(-t/tau)")
            if name == "evp_steady_shear":
                ax.plot(x, d["tau_as_printed"], "x", label="alpha as printed (p, not sqrt p)")
                ax.set_xscale("log")
        verdict = "PASS" if err <= tol else "FAIL"
        ok = ok and err <= tol
        print(f"{name}: max relative error {err:.3e} (tolerance {tol:g}) {verdict}")
        ax.set_title(f"{name}: err {err:.1e} {verdict}", fontsize=9)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(a.out, "material_points.png")
    fig.savefig(png, dpi=110)
    print(f"wrote {png}")
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
