"""Fluid throughput and PPE scaling benchmark (prints a table; not a validation).

1. Dam break (cases/dam_break.toml) at about 10k and 40k fluid particles: fluid
   particle-steps per second over ``STEPS`` steps after ``WARM`` warm-up steps (set-up and JIT
   compilation excluded), and the share of the step spent in the PPE (assembly + AMG set-up +
   Krylov solve).
2. PPE iterations at about 10k, 40k and 160k unknowns: the PPE of the dam break's first step
   solved from a zero initial guess to the case's tolerance (rtol = 1e-6 on
   ||b - A p|| / ||b||) with a freshly built AMG hierarchy; also the "effective" iterations
   ``n log(rtol) / log(residual)``, the (fractional) count the mean convergence factor needs
   for exactly rtol, which is not rounded up to whole iterations.

Usage: ``python validation/benchmark_fluid.py [--threads N] [--json FILE]``. Machine load is
printed with the results (the numbers depend on it).
"""

from __future__ import annotations

import os

# one BLAS thread before numpy loads (see fsi_sph.__main__._single_threaded_blas)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path

import numpy as np  # noqa: E402

from fsi_sph.config import load_config  # noqa: E402
from fsi_sph.fluid.ppe import PressureSolver  # noqa: E402
from fsi_sph.simulation import Simulation  # noqa: E402

CASE = Path(__file__).resolve().parents[1] / "cases" / "dam_break.toml"
THROUGHPUT_DX = {"10k": 0.014, "40k": 0.007}    # 1 x 2 column: 10.2k and 40.8k fluid
UNKNOWNS_DX = {"10k": 0.0145, "40k": 0.0072, "160k": 0.00355}
WARM = 10
STEPS = 30


def throughput(dx):
    sim = Simulation(load_config(CASE, [f"case.dx={dx}"]))
    for _ in range(WARM):
        sim.step()
    sim.timings.clear()
    t0 = time.perf_counter()
    for _ in range(STEPS):
        sim.step()
    wall = time.perf_counter() - t0
    f = sim.fluid
    return {"dx": dx, "n_fluid": f.n, "n_wall": f.nw, "steps": STEPS, "wall_time_s": wall,
            "fluid_particle_steps_per_s": f.n * STEPS / wall,
            "ppe_share": sim.timings["ppe"] / wall,
            "ppe_assemble_s": sim.timings["ppe_assemble"], "ppe_setup_s": sim.timings["ppe_setup"],
            "ppe_solve_s": sim.timings["ppe_solve"],
            "phases_s": {k: round(v, 4) for k, v in sim.timings.items()}}


def ppe_iterations(dx):
    cfg = load_config(CASE, [f"case.dx={dx}"])
    sim = Simulation(cfg)
    sim.step()  # builds the first step's PPE (fluid.A, fluid.rhs)
    f = sim.fluid
    solver = PressureSolver(cfg.fluid.ppe)
    p, stats = solver.solve(f.A, f.rhs, np.zeros(f.A.shape[0]), f.nf)
    # iterations the mean convergence factor needs for exactly rtol (not rounded up)
    effective = stats.iterations * np.log(cfg.fluid.ppe.rtol) / np.log(stats.residual)
    return {"dx": dx, "unknowns": int(f.A.shape[0]), "nnz": int(f.A.nnz),
            "iterations": stats.iterations, "effective_iterations": float(effective),
            "residual": stats.residual,
            "rtol": cfg.fluid.ppe.rtol, "setup_s": stats.setup_time, "solve_s": stats.solve_time}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    if args.threads:
        import numba

        numba.set_num_threads(args.threads)
    import numba

    out = {"threads": numba.get_num_threads(), "load_average": os.getloadavg(),
           "throughput": {}, "ppe_iterations": {}}
    for label, dx in THROUGHPUT_DX.items():
        r = throughput(dx)
        out["throughput"][label] = r
        print(f"dam break {label}: {r['n_fluid']} fluid particles, "
              f"{r['fluid_particle_steps_per_s']:.3g} fluid particle-steps/s, PPE share "
              f"{100 * r['ppe_share']:.0f} % (assemble {r['ppe_assemble_s']:.2f} s, AMG set-up "
              f"{r['ppe_setup_s']:.2f} s, solve {r['ppe_solve_s']:.2f} s of "
              f"{r['wall_time_s']:.2f} s)", flush=True)
    for label, dx in UNKNOWNS_DX.items():
        r = ppe_iterations(dx)
        out["ppe_iterations"][label] = r
        print(f"PPE {label}: {r['unknowns']} unknowns, {r['iterations']} iterations to rtol "
              f"{r['rtol']:g} (residual {r['residual']:.2e}; effective iterations "
              f"{r['effective_iterations']:.2f}), set-up {r['setup_s']:.2f} s, "
              f"solve {r['solve_s']:.2f} s", flush=True)
    it = [out["ppe_iterations"][k]["iterations"] for k in UNKNOWNS_DX]
    growth = it[-1] / max(it[0], 1) - 1
    out["ppe_iteration_growth_10k_to_160k"] = growth
    eff = [out["ppe_iterations"][k]["effective_iterations"] for k in UNKNOWNS_DX]
    out["ppe_effective_iteration_growth_10k_to_160k"] = eff[-1] / eff[0] - 1
    print(f"PPE iterations growth 10k -> 160k unknowns: {100 * growth:.0f} % "
          f"(effective, from the convergence factor: {100 * (eff[-1] / eff[0] - 1):.0f} %)")
    print(f"threads {out['threads']}, load average {out['load_average']}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
