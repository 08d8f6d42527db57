#!/usr/bin/python3
"""Taylor bar one-variable variants (issue 6): the scene of check.py (examples/sph_taylor_bar.yaml)
at one spacing (default L0/40 = 0.635 mm), each variant changing ONE thing, one thread each,
OMP_WAIT_POLICY=passive. Prints L, D, W, Dmax (same measures as check.py), the CPU time and the
step count of every run, as a Markdown table for the README. Diagnostics only: PASS/FAIL is
check.py's (the scene itself).

    nice /usr/bin/python3 validation/taylor_bar/variants.py --build build [--only NAME ...] [--reuse]
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import check  # noqa: E402
import common  # noqa: E402

WALL = "{model: sph_wall, sets: [bar, wall], kernel: wendland_c2, slip: free_slip, alpha: 1, beta: 10, eta: 0.1}"


def wall(extra, slip="free_slip"):
    return [(WALL, WALL.replace("slip: free_slip", f"slip: {slip}").replace("eta: 0.1}", "eta: 0.1" + extra + "}"))]


# name -> (description, [(old, new), ...] applied to the scene text at the spacing)
VARIANTS = {
    "scene": ("the scene: free-slip dummy wall, no viscous wall term", []),
    "free_wallvisc": ("free slip, wall-pair viscosity on v_i - v_w (viscosity_velocity: wall)",
                      wall(", viscosity_velocity: wall")),
    "free_wallnormal": ("free slip, wall-pair viscosity on n.(v_i - v_w) along n (viscosity_velocity: wall_normal)",
                        wall(", viscosity_velocity: wall_normal")),
    "wall_rho_rest": ("free slip, wall density rho0 (density: rest) instead of the Shepard average",
                      wall(", density: rest")),
    "beta2": ("beta = 2 (Monaghan's usual 2 alpha) in the bar and (unused) on the wall - sensitivity only",
              [("    beta: 10\n", "    beta: 2\n"), ("beta: 10, eta: 0.1}", "beta: 2, eta: 0.1}")]),
    "alpha05": ("alpha = 0.5 in the bar (001: 1) - sensitivity only",
                [("    alpha: 1\n", "    alpha: 0.5\n")]),
    "no_slip": ("no slip, wall-pair viscosity on v_i - (2 v_w - v~_w) (Adami Eq 23)", wall("", "no_slip")),
    "no_slip_wallvisc": ("no slip, wall-pair viscosity on v_i - v_w (viscosity_velocity: wall)",
                         wall(", viscosity_velocity: wall", "no_slip")),
    "v221": ("impact speed 221 m/s (JC 1983 / JH 1988 recalled, shared/reference §4.2)",
             [("velocity: [0, 0, -220]", "velocity: [0, 0, -221]")]),
    "isothermal": ("cp = 0: no heating (JC thermal term off) - sensitivity only", [("    cp: 452\n", "    cp: 0\n")]),
    "eos_c0_K": ("MG C0 4559 m/s = sqrt(K/rho0) with the material's K 164 GPa (001 Table 3: 3630) - sensitivity only",
                 [("C0: 3630 m/s", "C0: 4559 m/s")]),
    "rate_total": ("JC rate term on the total equivalent deviatoric strain rate (rate: total) instead of deps_p/dt",
                   [("    taylor_quinney: 0.9\n", "    taylor_quinney: 0.9\n    rate: total\n")]),
    "rate_off": ("C = 0: JC rate term off - sensitivity only", [("    C: 0.060\n", "    C: 0\n")]),
    "correction": ("kernel gradient correction (correction: true, Bonet & Lok 1999) in the bar",
                   [("    art_stress: false\n", "    art_stress: false\n    correction: true\n")]),
    "fixed_h": ("constant smoothing length (variable_h: false) in the bar",
                [("    art_stress: false\n", "    art_stress: false\n    variable_h: false\n")]),
    "xsph": ("XSPH 0.5 in the bar", [("    art_stress: false\n", "    art_stress: false\n    xsph: 0.5\n")]),
    "balsara": ("Balsara viscosity switch in the bar (visc_switch: balsara): Pi_ij x (f_i + f_j)/2",
                [("    art_stress: false\n", "    art_stress: false\n    visc_switch: balsara\n")]),
    "temp_work": ("JC temperature from the plastic work alone (temperature: plastic_work, the scene before "
                  "2026-11-29): the artificial viscosity's heating does not count",
                  [("    temperature: internal_energy\n", "    temperature: plastic_work\n")]),
    "no_renorm": ("continuity without the divergence renormalisation (renormalize: false)",
                  [("    art_stress: false\n", "    art_stress: false\n    renormalize: false\n")]),
    "h12": ("h_factor 1.2 in the bar (the scene: 1.5, Wendland C2) - sensitivity only",
            [("    h_factor: 1.5\n", "    h_factor: 1.2\n")]),
    "h20": ("h_factor 2.0 in the bar (the scene: 1.5, Wendland C2) - sensitivity only",
            [("    h_factor: 1.5\n", "    h_factor: 2.0\n")]),
    "cubic": ("cubic spline kernel, h_factor 1.3, in the bar and the wall pairs (the scene: Wendland C2, 1.5)",
              [("    kernel: wendland_c2\n    h_factor: 1.5\n", "    kernel: cubic_spline\n    h_factor: 1.3\n"),
               ("kernel: wendland_c2, slip", "kernel: cubic_spline, slip")]),
    "art_stress": ("Monaghan artificial stress on in the bar (eps 0.3, n 4; 001: off)",
                   [("    art_stress: false\n", "    art_stress: true\n")]),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--spacing", type=float, default=check.L0 / 40)
    ap.add_argument("--only", nargs="+", choices=sorted(VARIANTS))
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    base = check.scene(open(os.path.join(common.ROOT, "examples", "sph_taylor_bar.yaml")).read(), args.spacing,
                       "free_slip")
    dx = args.spacing
    rows = []
    for name in args.only or list(VARIANTS):
        desc, subs = VARIANTS[name]
        text = base
        for old, new in subs:
            assert text.count(old) == 1, (name, old)
            text = text.replace(old, new)
        path, cpu, wall_s, steps = check.run(exe, text, f"variant_dx{dx * 1e6:.0f}um_{name}", args.out, args.reuse)
        d = common.read_frame(path, None, "bar")
        m = check.measure(d["x"], dx)
        e = {k: m[k] / check.REF[k] - 1 for k in check.REF}
        row = (f"| {name}: {desc} | {m['L'] * 1e3:.2f} ({e['L'] * 100:+.1f} %) | {m['D'] * 1e3:.2f} "
               f"({e['D'] * 100:+.1f} %) | {m['W'] * 1e3:.2f} ({e['W'] * 100:+.1f} %) | {m['Dmax'] * 1e3:.2f} | "
               f"{steps} | {cpu:.1f} |")
        print(row, flush=True)
        rows.append(row)
    print(f"\ndx {dx * 1e3:.4f} mm; experiment L 19.8, D 13.7, W 8.6 mm")
    print("| variant | L [mm] | D [mm] | W [mm] | Dmax [mm] | steps | CPU [s] |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
