#!/usr/bin/python3
"""Colliding rubber rings (Gray, Monaghan & Swift, CMAME 190 (2001) 6641, section 6): two elastic
rings (inner/outer radius 3/4 cm) approach at 0.059 c0 each. With the artificial stress they
bounce back intact; without it the tensile instability fragments them. Runs both cases of
examples/sph_rubber_rings.yaml (one sph set, the union of the two rings, as in the paper) and
measures, at the end, for each ring (its particles by id: x < 0 in the first frame is the left ring):
  * rebound: mean x velocity of the left ring (negative = moving back, bounced);
  * integrity: the largest cluster of a ring (particles linked when closer than 1.5 dx) as a
    fraction of the ring's particles, and the number of clusters.
PASS when art_stress: true rebounds with one cluster holding >= 99 % of each ring, and
art_stress: false ends with < 99 % (fragmented) or fails to run (the instability blew up).
Writes rubber_rings.png (final particle positions of both runs)."""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DX = 1e-3
SET = "rings"


def clusters(x, link):
    """Connected components of the points x (n x 2) linked below distance link: their number and
    the largest one's share."""
    i, j, _ = common.pairs_within(x, link)
    return common.cluster_count(len(x), i, j)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    exe = common.ejecta_binary(args.build)
    base = open(os.path.join(common.ROOT, "examples", "sph_rubber_rings.yaml")).read()
    results = {}
    for art in (True, False):
        name = "rings_art_on" if art else "rings_art_off"
        text = base.replace("art_stress: true", f"art_stress: {'true' if art else 'false'}")
        try:
            path, _ = common.run(exe, text, name, args.out, reuse=args.reuse)
        except RuntimeError as e:
            print(f"  {name}: run failed ({e})")
            results[art] = None
            continue
        res = {}
        first = common.read_frame(path, common.frames(path)[0], SET)
        last = common.read_frame(path, None, SET)
        assert first["time"] == 0.0, "the first frame is not the initial state"
        left_ids = first["id"][first["x"][:, 0] < 0]
        in_left = np.isin(last["id"], left_ids)
        print(f"  {name}: {in_left.sum()} + {(~in_left).sum()} particles (left + right)")
        for s, sel in (("left", in_left), ("right", ~in_left)):
            x = last["x"][sel, :2]
            nc, frac = clusters(x, 1.5 * DX)
            res[s] = (x, last["v"][sel, 0].mean(), nc, frac, last["time"])
        results[art] = res
        e = common.read_series(path)
        e0 = e["kinetic"][0] + e["internal"][0]
        print(f"  {name}: energy balance |error| max {np.abs(e['balance']).max() / e0:.2e}, end "
              f"{e['balance'][-1] / e0:+.2e} of the initial total; kinetic at the end {e['kinetic'][-1] / e0:.3f}")
        common.energy_figure(path, os.path.join(HERE, f"{name}_energy.png"),
                             title=f"Rubber rings, art_stress {'on' if art else 'off'}: energy budget")
        print(f"  art_stress {art}: t = {res['left'][4]:.4f} s, left ring <vx> = {res['left'][1]:+.3f} m/s, "
              f"clusters left/right = {res['left'][2]}/{res['right'][2]}, largest cluster "
              f"{res['left'][3]:.4f}/{res['right'][3]:.4f}, right ring <vx> = {res['right'][1]:+.3f} m/s")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, art in zip(axs, (True, False)):
        ax.set_aspect("equal")
        ax.set_title(f"art_stress {'on' if art else 'off'}")
        if results[art] is None:
            ax.text(0.5, 0.5, "run failed", transform=ax.transAxes, ha="center")
            continue
        for s, col in (("left", "C0"), ("right", "C3")):
            x = results[art][s][0]
            ax.plot(x[:, 0], x[:, 1], ".", ms=1, color=col)
    fig.suptitle("Colliding rubber rings (Gray, Monaghan & Swift 2001), final state")
    fig.savefig(os.path.join(HERE, "rubber_rings.png"), dpi=120)
    on, off = results[True], results[False]
    ok_on = on is not None and on["left"][1] < 0 and min(on["left"][3], on["right"][3]) >= 0.99
    ok_off = off is None or min(off["left"][3], off["right"][3]) < 0.99
    print(f"with artificial stress: {'bounced intact' if ok_on else 'NOT bounced intact'}; "
          f"without: {'fragmented' if ok_off else 'NOT fragmented'}")
    print("PASS" if ok_on and ok_off else "FAIL")
    return 0 if ok_on and ok_off else 1


if __name__ == "__main__":
    sys.exit(main())
