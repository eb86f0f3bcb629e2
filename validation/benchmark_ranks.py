"""Several MPI ranks against one (prints a table; not a validation): the dam break
(``cases/dam_break.toml``) at about 163 k, 500 k and 1 M fluid particles, each size run as
1 rank x 1 thread, 1 rank x 2 threads and P ranks x 1 thread (``mpiexec -n P``), each in its
own processes.

Per run: seconds per step (the mean of ``--steps`` steps after ``--warm`` warm-up steps:
set-up and JIT compilation excluded), fluid particle-steps per second, the step split into
the ghost exchange (migration, re-cut and ghosts: ``exchange``), the PPE (assembly, the
gather of the rows to rank 0, the solve there, the broadcast back: ``ppe``) and the rest
(``compute``), each the slowest rank's; the bytes and messages a rank sends per step (ghost
exchange; PPE rows); the largest peak resident memory of one rank's process; and the
speed-up and parallel efficiency against 1 rank x 1 thread.

Usage::

    python validation/benchmark_ranks.py [--sizes 163k,500k,1M] [--ranks 2] [--json FILE]

One run alone (used by the table): ``[mpiexec -n P] python validation/benchmark_ranks.py
--one DX --threads T`` prints one JSON line. The machine and its load are printed with the
table (the numbers depend on them).
"""

from __future__ import annotations

import os

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

CASE = Path(__file__).resolve().parents[1] / "cases" / "dam_break.toml"
SIZES = {"41k": 0.007, "163k": 0.0035, "500k": 0.002, "1M": 0.0014}


def one(dx, threads, warm, steps):
    """Time the stepping of one run in this process (one rank of it); returns the JSON
    record on rank 0, None elsewhere."""
    import numba

    from fsi_sph.config import load_config
    from fsi_sph.parallel.comm import world

    numba.set_num_threads(threads)
    comm = world()
    cfg = load_config(CASE, [f"case.dx={dx}"])
    if comm.size > 1:
        from fsi_sph.parallel.ranks import RankSimulation

        sim = RankSimulation(cfg, comm)
    else:
        from fsi_sph.simulation import Simulation

        sim = Simulation(cfg)
    nf = sim.fluid.nf if comm.size == 1 else sim.ranks.nf_global
    for _ in range(warm):
        sim.step()
    sim.timings.clear()
    traffic0 = list(sim.ranks.traffic) if comm.size > 1 else [0, 0]
    ppe_bytes0 = sim.ranks.ppe.sent_bytes if comm.size > 1 else 0
    comm.Barrier() if comm.size > 1 else None
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    phases = {"exchange": sim.timings.get("exchange", 0.0), "ppe": sim.timings.get("ppe", 0.0)}
    phases["compute"] = wall - phases["exchange"] - phases["ppe"]
    slowest = {k: max(comm.allgather(v)) if comm.size > 1 else v for k, v in phases.items()}
    sent = [0, 0, 0]
    if comm.size > 1:
        r = sim.ranks
        mine = [r.traffic[0] - traffic0[0], r.traffic[1] - traffic0[1],
                r.ppe.sent_bytes - ppe_bytes0]
        sent = [max(v) for v in zip(*comm.allgather(mine), strict=True)]
    walls = comm.allgather(wall) if comm.size > 1 else [wall]
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # this process's peak
    rss = max(comm.allgather(rss)) if comm.size > 1 else rss
    if comm.rank != 0:
        return None
    wall = max(walls)
    engine = sim.ranks.engine if comm.size > 1 else "serial"
    return {"dx": dx, "ranks": comm.size, "threads": threads, "n_fluid": nf, "ppe": engine,
            "s_per_step": wall / steps, "particle_steps_per_s": nf * steps / wall,
            "ms_per_step": {k: 1e3 * v / steps for k, v in slowest.items()},
            "halo_bytes_per_step": sent[0] / steps, "halo_messages_per_step": sent[1] / steps,
            "ppe_bytes_per_step": sent[2] / steps, "peak_rss_per_rank_mb": rss / 1e6}


def spawn(dx, ranks, threads, warm, steps):
    """One run in its own process(es); its JSON record."""
    cmd = [sys.executable, __file__, "--one", str(dx), "--threads", str(threads),
           "--warm", str(warm), "--steps", str(steps)]
    if ranks > 1:
        from fsi_sph.parallel.launch import mpiexec_command

        cmd = [*mpiexec_command(), "-n", str(ranks), *cmd]
    done = subprocess.run(cmd, capture_output=True, text=True, check=True, env=_env())
    return json.loads(done.stdout.strip().splitlines()[-1])


def _env():
    from fsi_sph.parallel.launch import launcher_env

    return launcher_env()


def table(sizes, ranks, warm, steps):
    rows = []
    print(f"{'size':>6} {'ranks x thr':>11} {'s/step':>8} {'p-steps/s':>10} "
          f"{'compute':>8} {'exchange':>8} {'ppe':>8} {'halo MB':>8} {'msgs':>5} "
          f"{'ppe MB':>7} {'RSS/rank MB':>11} {'speed-up':>8} {'eff.':>5}")
    for name in sizes:
        base = None
        for r, t in ((1, 1), (1, 2), (ranks, 1)):
            rec = spawn(SIZES[name], r, t, warm, steps)
            base = base or rec["s_per_step"]
            rec["speedup"] = base / rec["s_per_step"]
            rec["efficiency"] = rec["speedup"] / (r * t)
            rec["size"] = name
            ms = rec["ms_per_step"]
            print(f"{name:>6} {f'{r} x {t}':>11} {rec['s_per_step']:8.3f} "
                  f"{rec['particle_steps_per_s']:10.3g} {ms['compute']:8.0f} "
                  f"{ms['exchange']:8.0f} {ms['ppe']:8.0f} "
                  f"{rec['halo_bytes_per_step'] / 1e6:8.2f} "
                  f"{rec['halo_messages_per_step']:5.0f} {rec['ppe_bytes_per_step'] / 1e6:7.1f} "
                  f"{rec['peak_rss_per_rank_mb']:11.0f} "
                  f"{rec['speedup']:8.2f} {rec['efficiency']:5.2f}", flush=True)
            rows.append(rec)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="163k,500k,1M")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--warm", type=int, default=3)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--one", type=float, help="one run at this dx (under mpiexec for ranks)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", help="write the records here")
    args = ap.parse_args(argv)
    if args.one is not None:
        rec = one(args.one, args.threads, args.warm, args.steps)
        if rec is not None:
            print(json.dumps(rec), flush=True)
        return 0
    load0 = os.getloadavg()
    rows = table(args.sizes.split(","), args.ranks, args.warm, args.steps)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {load0} -> {os.getloadavg()}; ms per step are the slowest rank's; "
          "MB and messages: sent by one rank per step")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
