"""Fluid throughput and PPE scaling benchmark (prints a table; not a validation).

1. Dam break (cases/dam_break.toml) at about 10k and 40k fluid particles: fluid
   particle-steps per second over ``STEPS`` steps after ``WARM`` warm-up steps (set-up and JIT
   compilation excluded), the share of the step spent in the PPE (assembly + AMG set-up +
   Krylov solve), and per step the mean Krylov iterations, AMG V-cycle applications and
   products with A (residuals included), and the hierarchy rebuilds.
2. PPE iterations at about 10k, 40k and 160k unknowns: the PPE of the dam break's first step
   solved from a zero initial guess to the case's tolerance (rtol = 1e-6 on
   ||b - A p|| / ||b||) with a freshly built AMG hierarchy; also the "effective" iterations
   ``n log(rtol) / log(residual)``, the (fractional) count the mean convergence factor needs
   for exactly rtol, which is not rounded up to whole iterations. Each Krylov method
   (flexible GMRES: one V-cycle per iteration; BiCGStab: two) on the same system.
3. Per solve, GMRES against BiCGStab at the same sizes on the PPE of step ``LATER`` started
   from the previous step's pressure (as in a run), one fresh hierarchy shared by both:
   V-cycles, products with A, and the wall and CPU time of the solve (best of ``REPS``,
   the methods alternating).

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
LATER = 10
REPS = 3
METHODS = ("gmres", "bicgstab")


def throughput(dx):
    sim = Simulation(load_config(CASE, [f"case.dx={dx}"]))
    for _ in range(WARM):
        sim.step()
    sim.timings.clear()
    per_step = []
    t0 = time.perf_counter()
    for _ in range(STEPS):
        sim.step()
        st = sim.fluid.last_stats
        per_step.append((st.iterations, st.vcycles, st.matvecs, st.rebuilt))
    wall = time.perf_counter() - t0
    f = sim.fluid
    its, vcyc, mv, rebuilt = (np.array(c, dtype=float) for c in zip(*per_step, strict=True))
    return {"dx": dx, "n_fluid": f.n, "n_wall": f.nw, "steps": STEPS, "wall_time_s": wall,
            "fluid_particle_steps_per_s": f.n * STEPS / wall,
            "ppe_share": sim.timings["ppe"] / wall,
            "ppe_assemble_s": sim.timings["ppe_assemble"], "ppe_setup_s": sim.timings["ppe_setup"],
            "ppe_solve_s": sim.timings["ppe_solve"],
            "krylov": sim.cfg.fluid.ppe.krylov,
            "iterations_per_step": float(its.mean()), "vcycles_per_step": float(vcyc.mean()),
            "matvecs_per_step": float(mv.mean()), "rebuilds": int(rebuilt.sum()),
            "phases_s": {k: round(v, 4) for k, v in sim.timings.items()}}


def _solve(cfg, method, A, b, x0, nf, solver=None):
    """One solve with ``method``; a fresh hierarchy unless ``solver`` (one that holds a
    hierarchy for ``A``) is given."""
    ppe = cfg.fluid.ppe.model_copy(update={"krylov": method})
    if solver is None:
        solver = PressureSolver(ppe)
    else:
        solver.cfg = ppe
    c0 = time.process_time()
    p, stats = solver.solve(A, b, x0, nf)
    stats.cpu_time = time.process_time() - c0
    return solver, stats


def ppe_iterations(dx):
    cfg = load_config(CASE, [f"case.dx={dx}"])
    sim = Simulation(cfg)
    sim.step()  # builds the first step's PPE (fluid.pressure.A, .rhs)
    f = sim.fluid.pressure
    nf = sim.fluid.nf
    out = {"dx": dx, "unknowns": int(f.A.shape[0]), "nnz": int(f.A.nnz),
           "rtol": cfg.fluid.ppe.rtol, "zero_guess": {}, "warm": {}}
    for m in METHODS:
        _, stats = _solve(cfg, m, f.A, f.rhs, np.zeros(f.A.shape[0]), nf)
        # iterations the mean convergence factor needs for exactly rtol (not rounded up)
        effective = stats.iterations * np.log(cfg.fluid.ppe.rtol) / np.log(stats.residual)
        out["zero_guess"][m] = {
            "iterations": stats.iterations, "effective_iterations": float(effective),
            "vcycles": stats.vcycles, "matvecs": stats.matvecs, "residual": stats.residual,
            "setup_s": stats.setup_time, "solve_s": stats.solve_time}
    # a later step, started from the previous pressure, one hierarchy for both methods
    for _ in range(LATER - 2):
        sim.step()
    x0 = sim.fluid.p_all.copy()
    sim.step()
    A, b = f.A, f.rhs
    solver, _ = _solve(cfg, METHODS[0], A, b, x0, nf)  # builds the hierarchy
    for _ in range(REPS):
        for m in METHODS:
            solver.base_iterations = solver.last_iterations = solver.age = 0  # no rebuild
            _, st = _solve(cfg, m, A, b, x0, nf, solver)
            assert not st.rebuilt
            r = out["warm"].setdefault(m, {"iterations": st.iterations, "vcycles": st.vcycles,
                                           "matvecs": st.matvecs, "residual": st.residual,
                                           "solve_s": [], "cpu_s": []})
            r["solve_s"].append(st.solve_time)
            r["cpu_s"].append(st.cpu_time)
    for r in out["warm"].values():
        r["solve_s"] = min(r["solve_s"])
        r["cpu_s"] = min(r["cpu_s"])
    return out


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
              f"{r['wall_time_s']:.2f} s); per step ({r['krylov']}) {r['iterations_per_step']:.2f}"
              f" iterations, {r['vcycles_per_step']:.2f} V-cycles, {r['matvecs_per_step']:.2f} "
              f"products with A; {r['rebuilds']} hierarchy rebuilds", flush=True)
    for label, dx in UNKNOWNS_DX.items():
        r = ppe_iterations(dx)
        out["ppe_iterations"][label] = r
        for m, z in r["zero_guess"].items():
            print(f"PPE {label} ({m}): {r['unknowns']} unknowns, first step from zero: "
                  f"{z['iterations']} iterations to rtol {r['rtol']:g} (residual "
                  f"{z['residual']:.2e}; effective iterations {z['effective_iterations']:.2f}), "
                  f"{z['vcycles']} V-cycles, {z['matvecs']} products with A, set-up "
                  f"{z['setup_s']:.2f} s, solve {z['solve_s']:.2f} s", flush=True)
        for m, w in r["warm"].items():
            print(f"PPE {label} ({m}): step {LATER} from the previous pressure: "
                  f"{w['iterations']} iterations, {w['vcycles']} V-cycles, {w['matvecs']} "
                  f"products with A, solve {1e3 * w['solve_s']:.1f} ms wall, "
                  f"{1e3 * w['cpu_s']:.1f} ms CPU (best of {REPS})", flush=True)
    for m in METHODS:
        z = [out["ppe_iterations"][k]["zero_guess"][m] for k in UNKNOWNS_DX]
        growth = z[-1]["iterations"] / max(z[0]["iterations"], 1) - 1
        eff = z[-1]["effective_iterations"] / z[0]["effective_iterations"] - 1
        out.setdefault("ppe_iteration_growth_10k_to_160k", {})[m] = growth
        out.setdefault("ppe_effective_iteration_growth_10k_to_160k", {})[m] = eff
        print(f"PPE iterations growth 10k -> 160k unknowns ({m}): {100 * growth:.0f} % "
              f"(effective, from the convergence factor: {100 * eff:.0f} %)")
    print(f"threads {out['threads']}, load average {out['load_average']}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
