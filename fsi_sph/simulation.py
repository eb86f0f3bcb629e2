"""Simulation: builds the bodies a scene declares and advances them.

:meth:`Simulation.step` is the one place where the order of operations of a time step is
written (DESIGN.md §4). A scene holds an ISPH fluid (with its walls), TLSPH solids, or
both (uncoupled for now); the coupling and the soil slot into ``step`` where marked.
"""

from __future__ import annotations

import logging
import math
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from fsi_sph.config import Config
from fsi_sph.probes import make_probe
from fsi_sph.solid.tlsph import ElasticBody

log = logging.getLogger(__name__)


class SimulationError(RuntimeError):
    """A run that cannot go on; the message says when, where and why."""


class Simulation:
    """A scene in memory: its bodies, probes, clock and timers."""

    def __init__(self, cfg: Config):
        self.cfg = cfg
        t0 = time.perf_counter()
        c = cfg.case
        self.fluid = None
        if cfg.fluid is not None:  # imported only when a scene has a fluid
            from fsi_sph.fluid.isph import IncompressibleFluid

            self.fluid = IncompressibleFluid(cfg.fluid, cfg.walls, c.dx, cfg.sph, c.gravity)
        self.structures = {name: ElasticBody(name, sec, c.dx, cfg.sph, c.gravity)
                           for name, sec in cfg.solid.items()}
        bodies = dict(self.structures)
        if self.fluid is not None:
            bodies["fluid"] = self.fluid
        self.probes = [make_probe(p, bodies) for p in cfg.probes]
        self.t = 0.0
        self.n_steps = 0
        self.particle_steps = 0
        self.timings: dict[str, float] = defaultdict(float)
        self.timings["setup"] = time.perf_counter() - t0

    @classmethod
    def from_config(cls, cfg: Config) -> Simulation:
        return cls(cfg)

    @property
    def n_particles(self) -> int:
        n = sum(b.body.n for b in self.structures.values())
        return n + (self.fluid.n if self.fluid is not None else 0)

    @property
    def step_columns(self):
        """Columns of the per-step table of the output (``/steps``)."""
        cols = ("t", "dt", "n_sub")
        if self.fluid is not None:
            cols += ("ppe_iterations", "ppe_residual", "ppe_assemble_s", "ppe_setup_s",
                     "ppe_solve_s", "ppe_rebuilt")
        return cols

    def _timed(self, phase, fn, *args):
        t0 = time.perf_counter()
        out = fn(*args)
        self.timings[phase] += time.perf_counter() - t0
        return out

    # ------------------------------------------------------------------ the time step
    def step(self, dt_max=math.inf):
        """Advance every body by one macro step; returns (dt, {body: n_sub})."""
        # 1. time step: the fluid's when there is a fluid; else the stiffest structure's
        fluid = self.fluid
        if fluid is not None:
            dt = min(dt_max, fluid.stable_dt())
        else:
            dt = min(dt_max, min(b.stable_dt() for b in self.structures.values()))
        # 2. fluid (PHYSICS.md §2-3): one projection step
        if fluid is not None:
            self._timed("neighbours", fluid.update_neighbors)
            self._timed("free_surface", fluid.detect_free_surface)
            if fluid.shifting is not None:
                self._timed("shift", fluid.shift, dt)
            self._timed("predict", fluid.predict, dt)
            stats = self._timed("ppe", fluid.solve_pressure, dt)
            self._timed("correct", fluid.correct, dt)
            self.timings["ppe_assemble"] += stats.assemble_time
            self.timings["ppe_setup"] += stats.setup_time
            self.timings["ppe_solve"] += stats.solve_time
            self.particle_steps += fluid.n
        # 3. structures, each sub-cycled to its own stability limit
        t0 = time.perf_counter()
        n_sub = {}
        for name, body in self.structures.items():
            n = max(1, math.ceil(dt / body.stable_dt() - 1e-12))
            for _ in range(n):
                body.substep(dt / n)
            n_sub[name] = n
            self.particle_steps += n * body.body.n
        if self.structures:
            self.timings["solid"] += time.perf_counter() - t0
        self.t += dt
        self.n_steps += 1
        return dt, n_sub

    # ------------------------------------------------------------------ guard
    def check(self):
        """Raise :class:`SimulationError` naming time, step, body, particle and quantity if a
        position or velocity is NaN or infinite."""
        bodies = dict(self.structures)
        if self.fluid is not None:
            bodies["fluid"] = self.fluid
        for name, body in bodies.items():
            for q in ("x", "v"):
                arr = body.body[q]
                bad = ~np.isfinite(arr).all(axis=1)
                if bad.any():
                    i = int(np.flatnonzero(bad)[0])
                    raise SimulationError(
                        f"non-finite {q} at t = {self.t:.6g} s, step {self.n_steps}, body "
                        f"{name!r}, particle {i} (of {int(bad.sum())} bad): {arr[i].tolist()}")

    # ------------------------------------------------------------------ run
    def run(self, out_dir=None, max_steps=None, progress=True, case_file=None):
        """Step to ``case.t_end`` (or ``max_steps``), writing ``out_dir/run.h5`` if given.

        Returns a summary dict (steps, wall times, particle-steps per second, status).
        """
        from fsi_sph.output import RunWriter

        c = self.cfg.case
        writer = None
        if out_dir is not None:
            static = {n: b.static() for n, b in self.structures.items()}
            if self.fluid is not None:
                static["fluid"] = self.fluid.static()
                if self.fluid.walls is not None:
                    static["walls"] = self.fluid.walls.static()
            writer = RunWriter(Path(out_dir) / "run.h5", self.cfg.to_json(), case_file, static,
                               step_columns=self.step_columns)
        rows = {p.name: (p.columns, []) for p in self.probes}
        step_rows = []
        next_out = 0.0
        next_probe = 0.0
        eps = 1e-12 * c.t_end
        last_snapshot = [-1.0]

        def sample():
            for p in self.probes:
                rows[p.name][1].append([self.t, *p.sample()])

        def flush(snapshot, status="running"):
            nonlocal step_rows
            t0 = time.perf_counter()
            if snapshot:
                last_snapshot[0] = self.t
            if writer is not None:
                snap = self._snapshot() if snapshot else None
                writer.write(self.t, self.n_steps, snap, rows, step_rows, self._timing_attrs(),
                             status)
            for _, r in rows.values():
                r.clear()
            step_rows = []
            self.timings["output"] += time.perf_counter() - t0

        bar = _progress(progress, c.t_end)
        loop_t0 = time.perf_counter()
        status = "completed"
        try:
            sample()
            next_probe += c.probe_every
            flush(True)
            next_out += c.output_every
            while self.t < c.t_end - eps:
                if max_steps is not None and self.n_steps >= max_steps:
                    status = f"stopped at max_steps = {max_steps}"
                    break
                dt, n_sub = self.step(dt_max=c.t_end - self.t)
                row = [self.t, dt, max(n_sub.values(), default=0)]
                if self.fluid is not None:
                    st = self.fluid.last_stats
                    row += [st.iterations, st.residual, st.assemble_time, st.setup_time,
                            st.solve_time, float(st.rebuilt)]
                step_rows.append(row)
                if bar is not None:
                    bar.update(dt)
                if self.t >= next_probe - eps:
                    t0 = time.perf_counter()
                    self.check()
                    sample()
                    next_probe = max(next_probe + c.probe_every, self.t)
                    self.timings["probes"] += time.perf_counter() - t0
                if self.t >= next_out - eps:
                    self.check()
                    flush(True)
                    next_out += c.output_every
            self.check()
        except SimulationError as e:
            status = f"failed: {e}"
            raise
        except KeyboardInterrupt:
            status = "failed: interrupted by the user"
            raise
        finally:
            self.timings["loop"] = time.perf_counter() - loop_t0 - self.timings["output"]
            if bar is not None:
                bar.close()
            if writer is not None:
                failed = status.startswith("failed")
                flush(not failed and last_snapshot[0] < self.t, status)
                writer.finish(status, self._timing_attrs())
        summary = {"status": status, "steps": self.n_steps, "t": self.t,
                   "n_particles": self.n_particles, "particle_steps": self.particle_steps,
                   "loop_time_s": self.timings["loop"], "setup_time_s": self.timings["setup"],
                   "particle_steps_per_s": self.particle_steps / max(self.timings["loop"], 1e-12),
                   "output": str(writer.path) if writer else None}
        return summary

    def _snapshot(self):
        snap = {n: b.snapshot() for n, b in self.structures.items()}
        if self.fluid is not None:
            snap["fluid"] = self.fluid.snapshot()
            if self.fluid.walls is not None:
                snap["walls"] = self.fluid.wall_snapshot()
        return snap

    def _timing_attrs(self):
        out = {f"{k}_s": float(v) for k, v in self.timings.items()}
        out["steps"] = self.n_steps
        out["particle_steps"] = self.particle_steps
        return out


def _progress(enabled, total):
    if not enabled:
        return None
    from tqdm import tqdm

    # shown only when the run lasts more than 2 s; off when stderr is not a terminal
    return tqdm(total=total, unit="s(sim)", delay=2.0, disable=None,
                bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s [{elapsed}<{remaining}]")


def run(case, out_dir=None, overrides=None, max_steps=None, progress=True):
    """Load ``case`` (a path), build the simulation and run it; returns the summary."""
    from fsi_sph.config import load_config

    cfg = load_config(case, overrides)
    sim = Simulation(cfg)
    return sim.run(out_dir=out_dir, max_steps=max_steps, progress=progress, case_file=str(case))
