#!/usr/bin/python3
"""Sphere drop into glass beads (Seguin et al. 2008 via Chi et al. 2017 §5.3, digest 003 B1;
reference README §7): a 19 mm steel ball hits a bed of glass beads at sqrt(2 g h), h = 100, 300,
500 mm. Quarter model (symmetry planes x = 0, y = 0), beads as semi-Lagrangian RKPM with
dp_damage (damage off = cohesionless Drucker-Prager), the ball as a `rigid_body` set (translation
locked in x and y, rotation locked: the quarter model's symmetry), kernel_contact between them
with the ball's level-set normal (`normal: body`, the default since 2026-12-01; --contact-normal pair
gives the point-to-point direction of the earlier runs), gravity. The bed uses rkpm's defaults (MSNNI, msnni_stress material, msnni_part deviatoric) unless
--integration / --msnni-stress / --msnni-part say otherwise, except the pairwise viscous
`stabilization`, 0 here (since 2026-11-29; --stabilization sets it): across a velocity jump it
transmits a traction 0.051 stabilization rho c dv at any spacing, 20 times the beads' shear strength
at this confinement (plugins/methods/rkpm/README.md "Scale of the stabilisation"); 003's MSNNI has
only the sub-box stabilisation. The ball has its own spacing (default d/8: 4 nodes across the radius). Final depth delta (lowest point of the ball below the
initial surface, when the ball has stopped) over d is compared with the experiment
delta/d = 1.4, 2.4, 2.85 (+-0.2), tolerance 20 % relative (and the ball must have stopped in its
crater: |v_z| < 5 % of v0 at the end, its lowest point below the surface), and with the Uehara et al. (2003) scaling law. Writes sphere_drop_msnni.png
(sphere_drop.png with --integration dni), prints PASS/FAIL per height with the measured errors.
--container seguin runs Seguin's Ø190 x 150 mm container instead of the narrow 42 x 42 x 84 mm
quarter bed; --contact-damping sets kernel_contact's normal damping (README, fourteenth session).
Each run's depth track (t, depth, v_z every 0.1 ms) is written as OUT/NAME_track.csv."""
import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

D = 0.019
R = D / 2
G = 9.80665
EXP = {0.1: 1.4, 0.3: 2.4, 0.5: 2.85}  # delta/d, +-0.2 (Seguin 2008 via 003 Table 12)
TOL = 0.20
# quarter bed (side, depth) [m]: the scene's narrow bed, and Seguin's Ø190 x 150 mm container (003's
# set-up, shared/reference §7) as the quarter box that contains its quarter cylinder
CONTAINERS = {"narrow": (0.042, 0.084), "seguin": (0.095, 0.15)}
# the bed's rkpm `stabilization` (the method's default is 0.1): 0 since 2026-11-29, see the docstring;
# validation/sphere_drop_methods uses the same value for its RKPM bed
STABILIZATION = 0.0
MU = 0.3  # kernel_contact friction between ball and beads: ejecta's choice, 003 gives none (digest 003 gap 28)


def uehara(h, mu=math.tan(math.radians(25)), rb=7800.0, rg=1500.0):
    """Uehara et al. 2003: d = 0.14/mu (rb/rg)^1/2 D^2/3 H^1/3, H = h + d (fixed point)."""
    d = 0.02
    for _ in range(200):
        d = 0.14 / mu * math.sqrt(rb / rg) * D ** (2 / 3) * (h + d) ** (1 / 3)
    return d


def surface(s, depth):
    """Free surface of the bed: the top lattice layer + s/2. The cubic lattice is anchored at the
    box's minimum (core/src/geometry.c ej_lattice_site: centres at lo + (k + 1/2) s) and a site is
    kept when it is inside the closed box, z <= 0 (ej_shape_contains), so the top layer is at -s/2
    only when depth/s is an integer (6, 4, 3 mm); at 5 mm (84 mm deep) it is at -1.5 mm and the
    surface at +1 mm, and when depth/s ends in .5 (150 mm at 4 mm) a layer sits on z = 0 and the
    surface is at +s/2. The same double arithmetic as the core (lo + (k + 1/2) s, kept when <= 0):
    before 2026-12-02 this function dropped a site on z = 0, so in the 150 mm container at 4 mm
    the ball started inside the bed's top layer (found by the SPH bed of
    validation/sphere_drop_methods, which blew up; `check_surface` now guards every run). Depths
    are measured from this surface (Seguin: depth of the ball's bottom below the free surface)."""
    k = math.floor(depth / s) + 1
    while -depth + (k + 0.5) * s > 0:  # the core keeps a site with z <= 0
        k -= 1
    zs = -depth + (k + 0.5) * s + 0.5 * s
    return 0.0 if abs(zs) < 1e-9 * s else zs


def check_surface(path, s, depth, set_name="bed"):
    """The bed's top layer in the run's first frame must be the one `surface` assumed (the ball was
    placed s/2 above it): raises RuntimeError otherwise, so that a misplaced ball cannot pass as a
    result."""
    z = common.read_frame(path, common.frames(path)[0], set_name)["x"][:, 2]
    top = surface(s, depth) - 0.5 * s
    if abs(float(np.max(z)) - top) > 1e-6 * s:
        raise RuntimeError(f"{path}: the bed's top layer is at z = {float(np.max(z)):.6g} m, the scene assumed "
                           f"{top:.6g} m (sphere_drop.surface): the ball was not placed s/2 above the bed")


def beads_material(phi, damage, model="dp"):
    """The beads: `dp` = dp_damage (cohesionless Drucker-Prager, 003 Table 10, the cone through
    triaxial compression, 003 Eq 51); `cap3_mc` = cap3 with the cap and the hardening off, the same
    cone in triaxial compression (M = beta / (3 sqrt 2), cap3 README) and the Gudehus Lode function
    with the Mohr-Coulomb ratio of the same phi, psi = (3 - sin phi) / (3 + sin phi), raised to
    7/9 where it is below (the smallest psi for which the Gudehus surface is convex)."""
    if model == "dp":
        return (f"{{model: dp_damage, rho0: 1500, E: 204.86 MPa, nu: 0.3227, friction_angle: {phi} deg,\n"
                f"          dilation_angle: 0 deg, cohesion: 0, damage: {str(damage).lower()}}}")
    assert model == "cap3_mc" and not damage
    sp = math.sin(math.radians(phi))
    beta = 2 * math.sqrt(6) * sp / (3 - sp)
    M = beta / (3 * math.sqrt(2))
    psi = max((3 - sp) / (3 + sp), 7.0 / 9.0)
    C = 1.0  # Pa: cap3 needs C > 0; the cone's apex at I1 = C/M = 5.5 Pa (dp_damage: cohesion 0)
    Mg = 1e-6 * M  # dilation ~ 0, as dp_damage's dilation_angle 0 (cap3 needs C_g = M_g Xi > 0)
    Xi, Cg = C / M, Mg * C / M
    return (f"{{model: cap3, rho0: 1500, E: 204.86 MPa, nu: 0.3227, psi: {psi:.6f}, cap: false, tau: 0,\n"
            f"          a_t: 0, a_c: 0, a_s: 0, M: {M:.8f}, M_g: {Mg:.6e},\n"
            f"          C_max: {C}, C_res: {C}, C_0: {C}, Xi_max: {Xi:.8f}, Xi_res: {Xi:.8f}, Xi_0: {Xi:.8f},\n"
            f"          C_maxg: {Cg:.8e}, C_resg: {Cg:.8e}, C_0g: {Cg:.8e}}}")


def scene(h, s, t_end, phi, damage, width, depth, ball_mod, sb, integration="msnni", msnni_stress="material",
          msnni_w=0.5, stabilization=None, extra_bed="", bed=None, mu=MU, every="0.5 ms", tag="sphere_drop",
          header=None, beads="dp", contact_damping=0.0, contact_normal="pair"):
    """The scene; bed (the bed set's method lines) and the rest let validation/sphere_drop_methods
    put another method under the same ball, material, contact and walls."""
    v = math.sqrt(2 * G * h)
    zc = surface(s, depth) + R + 0.5 * s  # ball just above the surface (gap s/2)
    stab = "" if stabilization is None else f"\n    stabilization: {stabilization}"
    cdamp = f", damping: {contact_damping:g}" if contact_damping else ""
    cdamp += "" if contact_normal == "pair" else f", normal: {contact_normal}"
    bnorm = "" if contact_normal == "pair" else "\n    normals: true"
    if bed is None:
        bed = (f"method: rkpm\n    integration: {integration}\n    msnni_stress: {msnni_stress}\n"
               f"    msnni_w: {msnni_w}{stab}{extra_bed}")
    if header is None:
        header = f"# generated by validation/sphere_drop/check.py: drop height {h} m, spacing {s} m"
    return f"""{header}
ejecta: 1
dimension: 3
time: {{end: {t_end}, cfl: 0.3}}
output: {{file: out/{tag}.h5, every: {every}, fields: [v]}}
gravity: [0, 0, -9.80665]
materials:
  beads: {beads_material(phi, damage, beads)}
  steel: {{rho0: 7800}}
sets:
  bed:
    {bed}
    material: beads
    shape: {{box: {{min: [0, 0, {-depth}], max: [{width}, {width}, 0]}}}}
    spacing: {s}
  ball:
    method: rigid_body
    material: steel
    modulus: {ball_mod}
    fix_translation: [1, 1, 0]
    fix_rotation: [1, 1, 1]{bnorm}
    shape: {{sphere: {{center: [0, 0, {zc}], radius: {R}}}, minus: [{{half_space: {{point: [0, 0, 0], normal: [1, 0, 0]}}}}, {{half_space: {{point: [0, 0, 0], normal: [0, 1, 0]}}}}]}}
    spacing: {sb}
    velocity: [0, 0, {-v}]
interactions:
  - {{model: kernel_contact, sets: [bed, ball], mu: {mu}{cdamp}}}
boundaries:
  - symmetry: {{point: [0, 0, 0], normal: [1, 0, 0]}}
  - symmetry: {{point: [0, 0, 0], normal: [0, 1, 0]}}
  - {{set: bed, region: {{half_space: {{point: [0, 0, {-depth + 0.75 * s}], normal: [0, 0, 1]}}}}, fix: all}}
  - {{set: bed, region: {{half_space: {{point: [{width - 0.75 * s}, 0, 0], normal: [-1, 0, 0]}}}}, fix: all}}
  - {{set: bed, region: {{half_space: {{point: [0, {width - 0.75 * s}, 0], normal: [0, -1, 0]}}}}, fix: all}}
"""


def ball_track(path):
    """Time, ball centre z and velocity from the rigid_body series (every step)."""
    sr = common.read_series(path, "ball")
    return common.read_series(path, "energy")["t"], sr["z_cm"], sr["v_z"], sr["force_z"], sr["mass"]


def write_track(path, t, pen, vz, every=1e-4):
    """The ball's depth and velocity every `every` seconds (and the last step) as CSV, so that runs at
    other spacings can be compared at equal times after the HDF5 output is gone (README: the 6 mm
    track was not kept). Columns: t [s], depth of the lowest point below the surface [m], v_z [m/s]."""
    keep = [0]
    for k in range(1, len(t)):
        if t[k] >= t[keep[-1]] + every - 1e-12 or k == len(t) - 1:
            keep.append(k)
    with open(path, "w") as f:
        f.write("t_s,depth_m,v_z_m_per_s\n")
        for k in keep:
            f.write(f"{t[k]:.9g},{pen[k]:.9g},{vz[k]:.9g}\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="out/sphere_drop")
    ap.add_argument("--spacing", type=float, default=0.006)
    ap.add_argument("--ball-spacing", type=float, default=D / 8)
    ap.add_argument("--heights", default="0.1,0.3,0.5")
    ap.add_argument("--t-end", type=float, default=0.06)  # 6 mm bed, stabilization 0: at rest by ~50 ms
    ap.add_argument("--phi", type=float, default=24.0)
    ap.add_argument("--damage", action="store_true")
    ap.add_argument("--beads", default="dp", choices=["dp", "cap3_mc"],
                    help="bed material: dp (dp_damage, the compression cone of 003 Eq 51) or cap3_mc (cap3 without "
                         "cap or hardening, the same cone in compression and the Mohr-Coulomb Lode ratio)")
    ap.add_argument("--container", default="narrow", choices=sorted(CONTAINERS),
                    help="bed size: narrow (the scene's 42 x 42 x 84 mm quarter, 2.2 d from the axis to the side "
                         "wall) or seguin (Seguin's Ø190 x 150 mm container as a 95 x 95 x 150 mm quarter box; "
                         "about 9 times the nodes and CPU); --width / --depth override either")
    ap.add_argument("--full", action="store_true",
                    help="make validate: Seguin's container (--container seguin) and t_end at least 80 ms")
    ap.add_argument("--width", type=float, default=None, help="quarter bed's side [m] (default: the container's)")
    ap.add_argument("--depth", type=float, default=None, help="bed depth [m] (default: the container's)")
    ap.add_argument("--ball-modulus", default="296 MPa",
                    help="rigid ball's contact modulus (kernel_contact penalty); 296 MPa = the beads' P-wave modulus")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--integration", default="msnni", choices=["msnni", "scni_box", "dni"],
                    help="rkpm domain integration of the bed (msnni = the method's default)")
    ap.add_argument("--msnni-w", type=float, default=0.5, help="rkpm msnni_w (sub-box stabilisation weight)")
    ap.add_argument("--msnni-stress", default="material", choices=["material", "elastic"],
                    help="MSNNI sub-box stress: through dp_damage (yield-limited, the default) or elastic Eq 46")
    ap.add_argument("--stabilization", type=float, default=STABILIZATION,
                    help="rkpm pairwise viscous `stabilization` of the bed (default 0; the method's own default is 0.1)")
    ap.add_argument("--msnni-part", default=None, choices=["full", "deviatoric"],
                    help="rkpm msnni_part (sub-box stabilisation on the full or deviatoric strain difference)")
    ap.add_argument("--contact-normal", default="body", choices=["pair", "body"],
                    help="kernel_contact `normal` (body, the default since 2026-12-01: the ball's level-set normal, "
                         "rigid_body normals: true; pair: the point-to-point direction, the runs before)")
    ap.add_argument("--contact-damping", type=float, default=0.0,
                    help="kernel_contact `damping` between ball and bed (fraction of critical per pair; default 0)")
    ap.add_argument("--mu", type=float, default=MU,
                    help=f"kernel_contact Coulomb friction between ball and beads (default {MU:g}; 003 gives none, "
                         "digest 003 gap 28: diagnostic runs only)")
    ap.add_argument("--essential", default="coefficients", choices=["coefficients", "transformation"],
                    help="rkpm essential: how the container's fixed nodes hold the field (diagnostic runs)")
    ap.add_argument("--no-figures", action="store_true", help="diagnostic runs: write no figures")
    ap.add_argument("--name-tag", default="", help="suffix for the run names (diagnostic runs)")
    ap.add_argument("--earlier", default="",
                    help="depths of the same scene from runs whose output is gone, drawn as open circles in the "
                         "depth/d panel (not judged): 'h_m:delta_mm,...', e.g. 0.3:36.1 (README)")
    a = ap.parse_args()
    if a.full:
        a.container, a.t_end = "seguin", max(a.t_end, 0.08)
    cw, cd = CONTAINERS[a.container]
    a.width = cw if a.width is None else a.width
    a.depth = cd if a.depth is None else a.depth
    ctag = "" if a.container == "narrow" else "_" + a.container
    exe = common.ejecta_binary(a.build)
    s = a.spacing
    rows, ok = [], True
    for h in [float(x) for x in a.heights.split(",")]:
        name = (f"drop_h{int(round(h * 1000))}_s{s * 1000:g}mm_b{a.ball_spacing * 1000:.3g}mm_{a.integration}"
                + ("_elastic-stab" if a.integration == "msnni" and a.msnni_stress == "elastic" else "")
                + (f"_w{a.msnni_w:g}" if a.integration == "msnni" and a.msnni_w != 0.5 else "")
                + ("_dmg" if a.damage else "")
                + ("" if a.beads == "dp" else "_" + a.beads)
                + ("" if not a.stabilization else f"_stab{a.stabilization:g}")
                + ("" if a.msnni_part is None else f"_{a.msnni_part[:3]}")
                + ("" if not a.contact_damping else f"_cd{a.contact_damping:g}")
                + ("" if a.contact_normal == "pair" else "_nbody")
                + ("" if a.mu == MU else f"_mu{a.mu:g}")
                + ("" if a.essential == "coefficients" else "_transf")
                + ctag + a.name_tag)
        r0 = os.times()
        path, wall = common.run(exe, scene(h, s, a.t_end, a.phi, a.damage, a.width, a.depth, a.ball_modulus,
                                                  a.ball_spacing, a.integration, a.msnni_stress,
                                                  a.msnni_w, a.stabilization,
                                                  ("" if a.msnni_part is None else f"\n    msnni_part: {a.msnni_part}")
                                                  + ("" if a.essential == "coefficients" else f"\n    essential: {a.essential}"),
                                                  beads=a.beads, contact_damping=a.contact_damping,
                                                  contact_normal=a.contact_normal, mu=a.mu),
                                name, a.out,
                                threads=a.threads, reuse=a.reuse)
        r1 = os.times()
        cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
        check_surface(path, s, a.depth)
        t, zc, vz, fz, mass = ball_track(path)
        pen = surface(s, a.depth) - (zc - R)  # depth of the (rigid, exact-sphere) ball's lowest point below the surface
        delta = float(np.max(pen))
        v_end = float(vz[-1])
        write_track(os.path.join(a.out, name + "_track.csv"), t, pen, vz)
        m_exact = 7800 * math.pi / 3 * R ** 3  # quarter sphere
        print(f"  ball: quarter mass {mass[-1]:.4g} kg (exact sphere {m_exact:.4g}, {100 * (mass[-1] / m_exact - 1):+.1f} %), "
              f"max contact force (quarter) {float(np.max(fz + mass * G)):.3g} N, steps {len(t)}")
        exp = EXP.get(h)
        err = (delta / D - exp) / exp if exp else float("nan")
        ue = uehara(h)
        # the depth is final only once the ball has stopped in its crater: slow at the end, and its lowest
        # point below the surface (a ball that rebounded out of the bed is slow only near its apex)
        stopped = abs(v_end) < 0.05 * math.sqrt(2 * G * h) and pen[-1] > 0
        passed = exp is not None and abs(err) <= TOL and stopped
        ok &= passed
        rows.append((h, t, pen, delta, exp, err, ue, cpu, v_end))
        if len(rows) == 1:
            first = (h, path)
        print(f"h = {h * 1000:.0f} mm: v0 = {math.sqrt(2 * G * h):.3f} m/s, delta = {delta * 1000:.1f} mm, "
              f"delta/d = {delta / D:.3f} (Seguin {exp} +-0.2, error {100 * err:+.1f} %), Uehara {ue * 1000:.1f} mm "
              f"(delta/d {ue / D:.2f}, ours {100 * (delta - ue) / ue:+.1f} %), ball v_z at end {v_end:.3f} m/s, "
              f"CPU {cpu:.0f} s{'' if stopped else ' (ball NOT stopped in its crater at the end: depth not final)'} -> "
              f"{'PASS' if passed else 'FAIL'}")
    if a.no_figures:
        print("PASS" if ok else "FAIL")
        return 0 if ok else 1
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for h, t, pen, *_ in rows:
            ax[0].plot(t * 1000, pen / D, label=f"h = {h * 1000:.0f} mm")
        ax[0].set_xlabel("t [ms]"), ax[0].set_ylabel("depth / d"), ax[0].legend()
        Hd = [(r[0] + r[3]) / D for r in rows]
        ax[1].plot(Hd, [r[3] / D for r in rows], "o-", label=f"ejecta RKPM bed {s * 1000:g} mm ({'DP cone' if a.beads == 'dp' else 'Mohr-Coulomb, cap3'}; "
                   f"{a.width * 2000:.0f} x {a.depth * 1000:.0f} mm), rigid ball {a.ball_spacing * 1000:.3g} mm")
        if a.earlier:
            pts = [tuple(float(v) for v in p.split(":")) for p in a.earlier.split(",")]
            ax[1].plot([(hh + dd / 1000) / D for hh, dd in pts], [dd / 1000 / D for hh, dd in pts], "o",
                       mfc="none", color="C0", label="the same scene, earlier run (README)")
        ax[1].errorbar([6.1, 16.86, 27.7], [1.4, 2.4, 2.85], yerr=0.2, fmt="s", label="Seguin 2008")
        ax[1].plot([6.1, 16.86, 27.7], [0.83, 1.07, 1.38], "x", label="Chi et al. 2017 (Table 12)")
        hh = np.linspace(0.05, 0.55, 30)
        ax[1].plot([(x + uehara(x)) / D for x in hh], [uehara(x) / D for x in hh], "--", label="Uehara 2003")
        ax[1].set_xlabel("H/d"), ax[1].set_ylabel("delta/d"), ax[1].set_ylim(top=3.9)
        ax[1].legend(loc="upper left", fontsize=7)
        fig.tight_layout()
        # figure names: dni "", msnni with the material sub-box stress "_msnni", elastic "_msnni_elastic"
        tag = "" if a.integration == "dni" else "_" + a.integration + ("_elastic" if a.msnni_stress == "elastic" else "")
        tag += f"_w{a.msnni_w:g}" if a.integration == "msnni" and a.msnni_w != 0.5 else ""
        tag += "_dev" if a.integration == "msnni" and a.msnni_part == "deviatoric" else ""
        tag += "" if not a.stabilization else f"_stab{a.stabilization:g}"
        tag += "" if a.beads == "dp" else "_" + a.beads
        tag += "" if not a.contact_damping else f"_cd{a.contact_damping:g}"
        tag += "" if a.contact_normal == "pair" else "_nbody"
        tag += ctag + a.name_tag
        fig.savefig(os.path.join(os.path.dirname(os.path.abspath(__file__)), f"sphere_drop{tag}.png"), dpi=110)
        # the first drop height through tools/plot_series.py: the energy budget and the ball's centre z
        here = os.path.dirname(os.path.abspath(__file__))
        common.energy_figure(first[1], os.path.join(here, f"sphere_drop_energy{tag}.png"),
                             title=f"sphere drop h = {first[0] * 1000:.0f} mm, bed {s * 1000:g} mm: energy budget")
        common.energy_figure(first[1], os.path.join(here, f"sphere_drop_ball{tag}.png"), series=["ball/z_cm"],
                             title=f"sphere drop h = {first[0] * 1000:.0f} mm: ball centre z (rigid_body series)")
    except Exception as e:  # noqa: BLE001
        print("figure not written:", e)
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
