#!/usr/bin/python3
"""Writes the particle file of the LAMMPS peri examples (in.peri.pmb / in.peri.lps):
`lattice sc 0.0005` anchored at the origin, `region target cylinder y 0 0 0.005 -0.005 0`,
every lattice point with x^2 + z^2 <= R^2 and -0.005 <= y <= 0 (boundaries included, as
LAMMPS's create_atoms does here): 317 points per layer x 11 layers = 3487 particles, volume
lc^3 = 1.25e-10 m^3 each (`set group all volume 1.25e-10`).

ejecta's cubic lattice fill is cell-centred (lo + (i + 1/2) s), so it cannot produce this
vertex lattice: the scenes import this CSV instead.

Usage: make_target.py [OUT.csv] [--scale N]   (N > 1: the target enlarged N times in every
direction, same spacing, for the throughput runs)."""
import sys


def points(scale=1):
    lc = 0.0005
    nr = 10 * scale          # radius in lattice spacings
    out = []
    for j in range(-10 * scale, 1):
        for i in range(-nr, nr + 1):
            for k in range(-nr, nr + 1):
                if i * i + k * k <= nr * nr:
                    out.append((i * lc, j * lc, k * lc))
    return out


def write(path, scale=1):
    pts = points(scale)
    with open(path, "w") as f:
        f.write("x,y,z,vol\n")
        for x, y, z in pts:
            f.write(f"{x:.17g},{y:.17g},{z:.17g},1.25e-10\n")
    return len(pts)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    scale = 1
    if "--scale" in sys.argv:
        scale = int(sys.argv[sys.argv.index("--scale") + 1])
        args = [a for a in args if a != str(scale)]
    path = args[0] if args else "examples/peri_target.csv"
    print(path, write(path, scale), "particles")
