"""Run under ``mpiexec -n P``: a scene stepped on P ranks against the serial run.

``python tests/parallel/fluid_checks.py [--case CASE] --steps N --dx DX --halo S
[--identical] [--ppe gather|petsc] [--size M] [--set KEY=VALUE ...]``: every rank steps its strips
(:class:`fsi_sph.parallel.ranks.RankSimulation`, halo ``S`` kernel supports); rank 0 also
runs the serial scene and compares every field of every particle of each split body (the
dam break's fluid and the walls' pressure; a soil scene's soils), of every structure and
of the open boundaries' buffers after ``N`` steps. Prints
the largest differences; exits 1 when ``--identical`` is asked and a field differs in any
bit (or, without it, a position by more than 1e-7 of the domain size or the clock by more
than 1e-7 of itself).
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

CASES = Path(__file__).resolve().parents[2] / "cases"


def fields_of(sim, gathered):
    """{body.field: array} of every split body, gathered in global-id order (``gathered``)
    or as the serial run holds them."""
    out = {}
    for name, part in sim.split.items() if gathered else []:
        for k in part.obj.body.arrays:
            out[f"{name}.{k}"] = part.gathered(k)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="dam_break.toml")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--dx", type=float, default=0.02)
    ap.add_argument("--halo", type=float, default=None)
    ap.add_argument("--identical", action="store_true")
    ap.add_argument("--ppe", default="gather", help="auto, petsc or gather")
    ap.add_argument("--size", type=float, default=5.0, help="the domain's size (m)")
    ap.add_argument("--set", action="append", default=[], help="KEY=VALUE of the case")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    case = Path(args.case) if Path(args.case).is_file() else CASES / args.case
    sets = [f"case.dx={args.dx}", *args.set]
    kw = {"ppe": args.ppe} if args.halo is None else {"halo": args.halo,
                                                      "ppe": args.ppe}
    par = RankSimulation(load_config(case, sets), comm, **kw)
    for _ in range(args.steps):
        par.step()
    got = fields_of(par, True)
    for name, body in par.structures.items():  # the structures every rank holds whole
        if name not in par.split:
            got.update({f"{name}.{k}": a.copy() for k, a in body.body.arrays.items()})
    if par.fluid is not None:
        got["walls.p"] = par.fluid.walls.body["p"].copy()
    if par.fluid is not None and par.fluid.open is not None:
        got.update({f"open.{k}": np.asarray(v) for k, v in par.fluid.open.state().items()})
    n_own = comm.gather(len(par.ranks.own["gid"]), root=0)
    if comm.rank != 0:
        return 0
    ser = Simulation(load_config(case, sets))
    for _ in range(args.steps):
        ser.step()
    bodies = ser.bodies()
    buffers = ser.fluid.open.state() if ser.fluid is not None and ser.fluid.open else {}
    want = {k: (ser.fluid.walls.body["p"] if k == "walls.p" else
                np.asarray(buffers[k[5:]]) if k.startswith("open.") else
                bodies[k.split(".")[0]].body[k.split(".", 1)[1]]) for k in got}
    worst = {k: float(np.max(np.abs(got[k].astype(float) - want[k].astype(float)), initial=0))
             if got[k].shape == want[k].shape else np.inf for k in got}
    same = all(np.array_equal(got[k], want[k]) for k in got)
    engine = getattr(par.ranks, "engine", "-")
    print(f"ranks {comm.size} ({engine}): owned {n_own}, rebalanced {par.ranks.rebalanced}, "
          f"migrated {par.ranks.migrations} of {args.steps} steps, "
          f"t {par.t:.12g} vs {ser.t:.12g}, identical {same}, largest differences "
          f"{ {k: f'{v:.3g}' for k, v in worst.items() if v > 0} }", flush=True)
    if args.identical:
        return 0 if same and par.t == ser.t else 1
    # another solver's iterates (rtol 1e-6): positions within 1e-7 of the domain's size
    # (--size, the dam break's 5 m by default) after the same number of steps, whose sizes
    # (from the fastest particle) differ too
    x_worst = max(v for k, v in worst.items() if k.endswith(".x"))
    return 0 if x_worst <= 1e-7 * args.size and abs(par.t - ser.t) <= 1e-7 * ser.t else 1


if __name__ == "__main__":
    sys.exit(main())
