#!/usr/bin/python3
"""Pressure profiles of the 1D spherical SPH run (check.py scene) against the Lagrangian FD
reference (lagrange1d.py) at a few times: where does SPH lose the peak?

    /usr/bin/python3 validation/charge_in_air/compare_sph_fd.py SPH.h5 FD.npz [--png out.png]

SPH.h5: an ejecta output of check.scene() (frames with x, p, rho, v of the sets `charge` and `air`);
FD.npz: lagrange1d.py --save (profiles at 0.1, 0.3, 0.6, 1.2 ms).
"""
import argparse
import os
import sys

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def sph_frame(h5, t):
    """The frame nearest t: dict set -> (x, p, rho, v, m), and its time."""
    with h5py.File(h5, "r") as f:
        names = sorted(f["frames"].keys())
        ts = np.array([float(f["frames"][n].attrs["time"]) for n in names])
        k = int(np.argmin(np.abs(ts - t)))
        g = f["frames"][names[k]]
        out = {}
        for s in ("charge", "air"):
            out[s] = {q: g[s][q][()] for q in ("x", "p", "rho", "v") if q in g[s]}
            out[s]["x"] = out[s]["x"][:, 0]
            out[s]["v"] = out[s]["v"][:, 0]
        return out, ts[k]


def sph_air_energy(h5, t, gamma=1.4):
    """Energy of the air in the SPH frame nearest t: sum m (v^2/2 + p/((gamma-1) rho)) minus its
    initial internal energy (masses from the checkpoint, matched by id)."""
    with h5py.File(h5, "r") as f:
        cp = f["checkpoint"]["air"]
        mass = dict(zip(cp["id"][()].tolist(), cp["m"][()].tolist()))
        names = sorted(f["frames"].keys())
        ts = np.array([float(f["frames"][n].attrs["time"]) for n in names])
        out = []
        for k in (0, int(np.argmin(np.abs(ts - t)))):
            g = f["frames"][names[k]]["air"]
            m = np.array([mass[i] for i in g["id"][()].tolist()])
            v = g["v"][()][:, 0]
            out.append(float(np.sum(m * (0.5 * v * v + g["p"][()] / ((gamma - 1) * g["rho"][()])))))
        return out[1] - out[0]


def fd_profiles(npz):
    d = np.load(npz)
    out = []
    i = 0
    while f"prof{i}_t" in d:
        out.append({k: d[f"prof{i}_{k}"] for k in ("t", "r", "p", "rho", "u", "charge", "E_air", "E_charge")})
        i += 1
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sph")
    ap.add_argument("fd")
    ap.add_argument("--png", default=os.path.join(HERE, "charge_in_air_1d_profiles.png"))
    ap.add_argument("--label", default="sph")
    a = ap.parse_args(argv)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fds = fd_profiles(a.fd)
    fig, ax = plt.subplots(2, len(fds), figsize=(4.2 * len(fds), 7.5), squeeze=False)
    for k, fp in enumerate(fds):
        sp, ts = sph_frame(a.sph, float(fp["t"]))
        ch = fp["charge"].astype(bool)
        rc = float(fp["r"][ch].max())
        print(f"t = {1e3 * fp['t']:.3f} ms (sph frame {1e3 * ts:.3f} ms)")
        ia = np.argmax(fp["p"][~ch])
        print(f"  FD : contact r = {rc:.3f} m, air peak {fp['p'][~ch][ia] / 1e3:9.1f} kPa at r = {fp['r'][~ch][ia]:.3f} m,"
              f" products p at contact {fp['p'][ch][-1] / 1e3:9.1f} kPa")
        ja = np.argmax(sp["air"]["p"])
        xc = sp["charge"]["x"]
        print(f"  SPH: outermost charge r = {xc.max():.3f} m, innermost air r = {sp['air']['x'].min():.3f} m, "
              f"air peak {sp['air']['p'][ja] / 1e3:9.1f} kPa at r = {sp['air']['x'][ja]:.3f} m, "
              f"air inside products: {int(np.sum(sp['air']['x'] < xc.max()))}")
        print(f"  energy in the air: FD {float(fp['E_air']) / 1e6:.3f} MJ, SPH {sph_air_energy(a.sph, float(fp['t'])) / 1e6:.3f} MJ"
              f" (charge m e0 = 4.29 MJ)")
        for row, q, lab in ((0, "p", "p [Pa]"), (1, "rho", "rho [kg/m^3]")):
            axx = ax[row][k]
            axx.semilogy(fp["r"][ch], fp[q][ch], "k-", lw=1, label="FD products")
            axx.semilogy(fp["r"][~ch], fp[q][~ch], "b-", lw=1, label="FD air")
            axx.semilogy(sp["charge"]["x"], sp["charge"][q], "r.", ms=3, label=f"{a.label} products")
            axx.semilogy(sp["air"]["x"], sp["air"][q], "g.", ms=2, label=f"{a.label} air")
            axx.set_xlim(0, max(1.3 * fp["r"][~ch][ia], 0.3))
            axx.set_xlabel("r [m]")
            axx.set_ylabel(lab)
            axx.set_title(f"t = {1e3 * fp['t']:.2f} ms")
            axx.grid(True, alpha=0.3)
        if k == 0:
            ax[0][0].legend(fontsize=7)
    fig.suptitle("1 kg TNT in air, 1D spherical: SPH against the Lagrangian FD reference (lagrange1d.py)")
    fig.tight_layout()
    fig.savefig(a.png, dpi=100)
    print("wrote", a.png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
