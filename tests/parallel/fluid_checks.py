"""Run under ``mpiexec -n P``: the dam break stepped on P ranks against the serial run.

``python tests/parallel/fluid_checks.py --steps N --dx DX --halo S [--identical]``: every
rank steps its strip (:class:`fsi_sph.parallel.ranks.RankSimulation`, halo ``S`` kernel
supports); rank 0 also runs the serial scene and compares the fields of every fluid
particle and the walls' pressure after ``N`` steps. Prints the largest differences; exits
1 when ``--identical`` is asked and a field differs in any bit (or a position by more than
1e-7 of the domain size without it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fsi_sph.config import load_config
from fsi_sph.parallel.ranks import RankSimulation
from fsi_sph.simulation import Simulation

CASE = Path(__file__).resolve().parents[2] / "cases" / "dam_break.toml"
FIELDS = ("x", "v", "p", "a", "divr", "class")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--dx", type=float, default=0.02)
    ap.add_argument("--halo", type=float, default=None)
    ap.add_argument("--identical", action="store_true")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    sets = [f"case.dx={args.dx}"]
    kw = {} if args.halo is None else {"halo_supports": args.halo}
    par = RankSimulation(load_config(CASE, sets), comm, **kw)
    for _ in range(args.steps):
        par.step()
    got = {k: par.ranks.gathered(k) for k in FIELDS}
    walls_p = par.fluid.walls.body["p"].copy()
    n_own = comm.gather(len(par.ranks.own["gid"]), root=0)
    if comm.rank != 0:
        return 0
    ser = Simulation(load_config(CASE, sets))
    for _ in range(args.steps):
        ser.step()
    worst = {}
    for k in FIELDS:
        worst[k] = float(np.max(np.abs(got[k].astype(float) - ser.fluid.body[k].astype(float))))
    worst["walls.p"] = float(np.max(np.abs(walls_p - ser.fluid.walls.body["p"])))
    same = all(np.array_equal(got[k], ser.fluid.body[k]) for k in FIELDS)
    same = same and np.array_equal(walls_p, ser.fluid.walls.body["p"])
    print(f"ranks {comm.size}: owned {n_own}, rebalanced {par.ranks.rebalanced}, t {par.t:.6g} vs {ser.t:.6g}, "
          f"identical {same}, largest differences {worst}", flush=True)
    if par.t != ser.t:
        return 1
    if args.identical:
        return 0 if same else 1
    return 0 if worst["x"] <= 1e-7 * 5.0 else 1


if __name__ == "__main__":
    sys.exit(main())
