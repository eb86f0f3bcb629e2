"""Fluid scaling benchmark (prints a table; not a validation): the dam break
(``cases/dam_break.toml``, a 1 x 2 m column) at about 10 k, 41 k, 163 k, 500 k and 1 M fluid
particles, each size in its own process so that its peak resident memory is its own.

Per size: seconds per step and fluid particle-steps per second (the mean over ``STEPS``
steps, or ``--steps``, after ``--warm`` warm-up steps: set-up and JIT compilation
excluded), the whole
process's peak RSS and that per fluid particle, the step's wall time by phase (neighbour
search, surface detection, shifting, predictor, PPE assembly, AMG set-up, Krylov solve,
correction), and at the largest size the bytes held by each group of arrays
(:func:`array_breakdown`).

Usage::

    python validation/benchmark_scaling.py [--sizes 10k,41k,...] [--threads N] [--json FILE]

The machine, thread count and load average are printed with the table (the numbers depend
on them). One size alone: ``--one DX`` (prints one JSON line; used by the table's runs).
"""

from __future__ import annotations

import os

# one BLAS thread before numpy loads (see fsi_sph.__main__._single_threaded_blas)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

CASE = Path(__file__).resolve().parents[1] / "cases" / "dam_break.toml"
#: label -> dx (m) of the 1 x 2 m column: n = 2 / dx^2 fluid particles
SIZES = {"10k": 0.014, "41k": 0.007, "163k": 0.0035, "500k": 0.002, "1M": 0.0014}
#: timed steps per size (more where a step is short: the machine's noise is tens of ms)
STEPS = {"10k": 40, "41k": 30, "163k": 10, "500k": 5, "1M": 5}
#: the step's phases as Simulation.timings names them, in the step's order
PHASES = ("neighbours", "free_surface", "shift", "predict", "ppe_assemble", "ppe_setup",
          "ppe_solve", "correct")


def cpu_model() -> str:
    """The CPU's model name (Linux), else the platform's machine name."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def peak_rss_bytes() -> int:
    """Peak resident set size of this process (Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def array_breakdown(root, depth: int = 8) -> dict[str, int]:
    """Bytes of the numpy arrays (and scipy sparse matrices' arrays) reachable from
    ``root``'s attributes, grouped by the attribute path of depth 1-3 (``fluid.body.x``,
    ``fluid.pressure.ppe``, ...); an array reached twice is counted once."""
    import scipy.sparse as sp

    seen: set[int] = set()
    out: dict[str, int] = {}

    def add(group, arr):
        base = arr if arr.base is None else arr.base
        if isinstance(base, np.ndarray) and id(base) not in seen:
            seen.add(id(base))
            out[group] = out.get(group, 0) + base.nbytes

    def walk(obj, path, level):
        group = ".".join(path[:3])
        if isinstance(obj, np.ndarray):
            add(group, obj)
            return
        if sp.issparse(obj):
            for a in (obj.data, obj.indices, obj.indptr):
                add(group, a)
            return
        if level >= depth or id(obj) in seen:
            return
        seen.add(id(obj))
        if isinstance(obj, dict):
            items = obj.items()
        elif isinstance(obj, (list, tuple)):
            items = enumerate(obj)
        elif hasattr(obj, "__dict__") and type(obj).__module__.startswith(("fsi_sph", "pyamg")):
            items = vars(obj).items()
        else:
            return
        for k, v in items:
            walk(v, [*path, str(k)], level + 1)

    walk(root, [], 0)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


class PhaseMemory:
    """Resident memory sampled every millisecond in a thread while the step runs, its
    largest value kept per phase of the step (``Simulation._timed``'s names): where the
    peak RSS is reached, transient arrays included (numba's allocations as well, which
    Python's tracemalloc does not see)."""

    def __init__(self, sim):
        import threading

        self.page = os.sysconf("SC_PAGE_SIZE")
        self.phase = "other"
        self.peak: dict[str, int] = {}
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._sample, daemon=True)
        timed = sim._timed

        def labelled(phase, fn, *args):
            self.phase = phase
            try:
                return timed(phase, fn, *args)
            finally:
                self.phase = "other"

        sim._timed = labelled

    def _sample(self):
        with open("/proc/self/statm") as f:
            while not self.stop.wait(0.001):
                f.seek(0)
                rss = int(f.read().split()[1]) * self.page
                self.peak[self.phase] = max(self.peak.get(self.phase, 0), rss)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()


def one_size(dx: float, warm: int, steps: int, breakdown: bool) -> dict:
    """Run the dam break at spacing ``dx``: timings, memory (see the module docstring)."""
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    t0 = time.perf_counter()
    sim = Simulation(load_config(CASE, [f"case.dx={dx}"]))
    setup = time.perf_counter() - t0
    for _ in range(warm):
        sim.step()
    sim.timings.clear()
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    phases = {k: sim.timings.get(k, 0.0) / steps for k in PHASES}
    with PhaseMemory(sim) as memory:  # (a step more, apart: the sampling costs time)
        sim.step()
    n = sim.fluid.n
    rss = peak_rss_bytes()
    out = {"dx": dx, "n_fluid": n, "n_wall": sim.fluid.nw, "steps": steps,
           "setup_s": setup, "s_per_step": wall / steps,
           "particle_steps_per_s": n * steps / wall, "peak_rss_bytes": rss,
           "rss_per_particle_kB": rss / n / 1e3,
           "peak_rss_by_phase_bytes": dict(sorted(memory.peak.items(), key=lambda kv: -kv[1])),
           "phases_s_per_step": phases}
    out["phases_s_per_step"]["other"] = wall / steps - sum(out["phases_s_per_step"].values())
    if breakdown:
        out["arrays_bytes"] = array_breakdown(sim)
    return out


def run_sizes(labels, warm, steps, threads):
    rows = {}
    for label in labels:
        cmd = [sys.executable, __file__, "--one", str(SIZES[label]), "--warm", str(warm),
               "--steps", str(steps or STEPS[label]), "--threads", str(threads)]
        if label == labels[-1]:
            cmd.append("--breakdown")
        res = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if res.returncode != 0:
            print(f"{label}: failed\n{res.stderr[-2000:]}", flush=True)
            continue
        rows[label] = json.loads(res.stdout.strip().splitlines()[-1])
        print_row(label, rows[label])
    return rows


def print_row(label, r):
    ph = r["phases_s_per_step"]
    share = "  ".join(f"{k} {1e3 * v:.1f}" for k, v in ph.items())
    print(f"{label:>5}: {r['n_fluid']:>8} fluid  {r['s_per_step']:.3f} s/step  "
          f"{r['particle_steps_per_s']:.3g} particle-steps/s  peak RSS "
          f"{r['peak_rss_bytes'] / 1e6:.0f} MB = {r['rss_per_particle_kB']:.2f} kB/particle  "
          f"(set-up {r['setup_s']:.1f} s)\n       ms per step: {share}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(SIZES))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--warm", type=int, default=2)
    ap.add_argument("--steps", type=int, help="timed steps (default: by size, STEPS)")
    ap.add_argument("--json")
    ap.add_argument("--one", type=float, help="one size: its dx (prints one JSON line)")
    ap.add_argument("--breakdown", action="store_true", help="with --one: bytes by array")
    args = ap.parse_args(argv)
    import numba

    numba.set_num_threads(args.threads)
    if args.one is not None:
        print(json.dumps(one_size(args.one, args.warm, args.steps or 5, args.breakdown)))
        return None
    labels = [s for s in args.sizes.split(",") if s]
    unknown = [s for s in labels if s not in SIZES]
    if unknown:
        ap.error(f"--sizes: unknown {unknown}; allowed: {', '.join(SIZES)}")
    load0 = os.getloadavg()
    rows = run_sizes(labels, args.warm, args.steps, args.threads)
    last = rows.get(labels[-1], {})
    if "arrays_bytes" in last:
        n = last["n_fluid"]
        print(f"bytes per fluid particle by array group at {labels[-1]}:")
        for k, v in list(last["arrays_bytes"].items())[:15]:
            print(f"  {k:40s} {v / n:8.1f} B  ({v / 1e6:.0f} MB)")
        total = sum(last["arrays_bytes"].values())
        phases = ", ".join(f"{k} {v / n:.0f}" for k, v in last["peak_rss_by_phase_bytes"].items())
        print(f"  peak RSS per fluid particle (B) while in each phase: {phases}")
        print(f"  {'(all arrays found)':40s} {total / n:8.1f} B; peak RSS "
              f"{last['peak_rss_bytes'] / n:.1f} B")
    machine = f"{cpu_model()}, {os.cpu_count()} cores"
    print(f"threads {args.threads}, {machine}, load average {load0} -> {os.getloadavg()}")
    if args.json:
        import datetime

        date = datetime.date.today().isoformat()
        Path(args.json).write_text(json.dumps({"threads": args.threads, "machine": machine,
                                               "date": date,
                                               "load_average": [load0, os.getloadavg()],
                                               "rows": rows}, indent=1))
    return rows


if __name__ == "__main__":
    main()
