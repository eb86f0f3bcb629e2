"""TLSPH solid throughput: particle-steps per second of the oscillating plate's stepping loop
at 5, 10 and 20 particles through the thickness, on 1 and on all numba threads.

    python validation/benchmark_solid.py [--steps N]

Set-up and JIT compile are excluded (the kernels are compiled before timing). One sub-step of
one particle is one particle-step. Prints a table and the 2-thread/1-thread speed-up.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

CASE = Path(__file__).resolve().parents[1] / "cases" / "oscillating_plate.toml"


def throughput(dx, steps, threads):
    import numba

    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    numba.set_num_threads(threads)
    sim = Simulation(load_config(CASE, [f"case.dx={dx}"]))
    sim.step()  # warm
    n0 = sim.particle_steps
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    return sim.n_particles, (sim.particle_steps - n0) / wall


def main(argv=None):
    import numba

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=2000)
    args = p.parse_args(argv)
    nmax = numba.config.NUMBA_NUM_THREADS
    print(f"{'dx (m)':>8} {'particles':>9} {'threads':>7} {'particle-steps/s':>17}")
    for dx in (0.004, 0.002, 0.001):
        rates = {}
        for th in sorted({1, nmax}):
            n, r = throughput(dx, args.steps, th)
            rates[th] = r
            print(f"{dx:8g} {n:9d} {th:7d} {r:17.3g}")
        if nmax > 1:
            print(f"{'':8} {'':9} speed-up {rates[nmax] / rates[1]:.2f} on {nmax} threads")


if __name__ == "__main__":
    main()
