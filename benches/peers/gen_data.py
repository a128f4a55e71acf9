#!/usr/bin/env python3
"""Write a LAMMPS data file (atom_style sphere) for the Sable standard DEM scene.

Scene: N monodisperse spheres (default 20,000), d = 1 mm, density 2500 kg/m^3,
fully periodic cubic box whose side makes the solid packing fraction 0.57.
Positions are a random (seeded) subset of an FCC lattice of C x C x C cubic
cells spanning the box (C = 18 by default: 23,328 sites for 20,000 spheres;
nearest-neighbour distance ~1.036 mm > d, so nothing overlaps). Velocity
components are N(0, 0.2 m/s) with the mean removed (zero total momentum);
angular velocities are zero.

Standard library only. Usage:
    python3 gen_data.py [--out data.sable_bench] [--seed 42] [--n 20000]
"""

import argparse
import math
import random
import sys

DIAMETER = 1.0e-3  # m
DENSITY = 2500.0  # kg/m^3
PHI = 0.57  # solid packing fraction
VEL_SIGMA = 0.2  # m/s, std-dev of each velocity component

# FCC basis in units of the cubic cell side.
FCC_BASIS = ((0.0, 0.0, 0.0), (0.5, 0.5, 0.0), (0.5, 0.0, 0.5), (0.0, 0.5, 0.5))


def box_side(n, d=DIAMETER, phi=PHI):
    """Cubic box side giving packing fraction phi for n spheres of diameter d."""
    return (n * math.pi / 6.0 * d ** 3 / phi) ** (1.0 / 3.0)


def cells_for(n, d, side):
    """Cells per edge: the smallest C with 4*C^3 >= n. Fails if spheres would overlap."""
    c = 1
    while 4 * c ** 3 < n:
        c += 1
    nn = side / c / math.sqrt(2.0)
    if nn <= d:
        raise SystemExit(
            f"FCC with {c}^3 cells gives nearest-neighbour distance {nn:.6g} m <= d={d:g} m"
        )
    return c


def generate(n, seed):
    rng = random.Random(seed)
    side = box_side(n)
    c = cells_for(n, DIAMETER, side)
    a = side / c
    # Sites offset by a quarter cell so none sit exactly on a box face.
    sites = []
    for i in range(c):
        for j in range(c):
            for k in range(c):
                for bx, by, bz in FCC_BASIS:
                    sites.append(
                        ((i + bx + 0.25) * a, (j + by + 0.25) * a, (k + bz + 0.25) * a)
                    )
    chosen = rng.sample(range(len(sites)), n)
    chosen.sort()  # ids follow lattice order: deterministic and cache-friendly
    pos = [sites[s] for s in chosen]

    vel = [[rng.gauss(0.0, VEL_SIGMA) for _ in range(3)] for _ in range(n)]
    mean = [sum(v[k] for v in vel) / n for k in range(3)]
    for v in vel:
        for k in range(3):
            v[k] -= mean[k]
    return side, c, len(sites), pos, vel


def write_data(path, n, seed):
    side, c, nsites, pos, vel = generate(n, seed)
    mass = DENSITY * math.pi / 6.0 * DIAMETER ** 3
    ke = 0.5 * mass * sum(v[0] ** 2 + v[1] ** 2 + v[2] ** 2 for v in vel)
    out = sys.stdout if path == "-" else open(path, "w")
    try:
        w = out.write
        w(
            f"LAMMPS data file: Sable standard DEM scene, n={n} d={DIAMETER:g} m "
            f"rho={DENSITY:g} kg/m^3 phi={PHI} seed={seed} fcc={c}^3 ({nsites} sites) "
            f"ke0={ke:.9e} J\n\n"
        )
        w(f"{n} atoms\n")
        w("1 atom types\n\n")
        w(f"0.0 {side:.17g} xlo xhi\n")
        w(f"0.0 {side:.17g} ylo yhi\n")
        w(f"0.0 {side:.17g} zlo zhi\n\n")
        w("Atoms # sphere\n\n")
        for i, (x, y, z) in enumerate(pos, start=1):
            w(f"{i} 1 {DIAMETER:.17g} {DENSITY:.17g} {x:.17g} {y:.17g} {z:.17g}\n")
        w("\nVelocities\n\n")
        for i, (vx, vy, vz) in enumerate(vel, start=1):
            w(f"{i} {vx:.17g} {vy:.17g} {vz:.17g} 0 0 0\n")
    finally:
        if out is not sys.stdout:
            out.close()
    return side, c, nsites, mass, ke


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="data.sable_bench", help="output path ('-' = stdout)")
    p.add_argument("--seed", type=int, default=42, help="random seed (default 42)")
    p.add_argument("--n", type=int, default=20000, help="number of spheres (default 20000)")
    args = p.parse_args(argv)
    if args.n < 1:
        p.error("--n must be positive")
    side, c, nsites, mass, ke = write_data(args.out, args.n, args.seed)
    print(
        f"gen_data: wrote {args.out}: n={args.n} L={side:.9g} m fcc={c}^3 "
        f"({nsites} sites, nn={side / c / math.sqrt(2):.6g} m) "
        f"mass={mass:.6g} kg ke0={ke:.6e} J seed={args.seed}",
        file=sys.stderr,
    )


if __name__ == "__main__":
    main()
