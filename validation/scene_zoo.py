"""The scene zoo: scenes no validation uses, written as a user would (physics, geometry,
resolution and output only; every numerical choice is a default or picked from the declared
physics, fsi_sph/config/numerics.py), each run for a fixed simulated time.

A scene passes when it runs to its end with the blow-up guard idle (no stop), no particle lost
(none non-finite, none through a wall: below the lowest or beside the outermost initial
particle by more than two spacings) and, in a closed scene, the total mechanical energy
(kinetic + potential + stored elastic, fsi_sph/energy.py) never above its initial value by
more than ``ENERGY_BOUND_PCT`` per cent of it (the potential from the lowest initial particle:
the initial total is what the scene can release). Gravity does no net work on a closed scene
and dissipation may only take energy away. A shaken scene (``case.shaking``) is driven: its
energy is reported, not bounded.

Scenes are the ``*.toml`` files of ``validation/scene_zoo/``. ``--quick`` runs them at their
own spacing, the full run at 1/1.5 of it. Records: ``errors.energy_rise_pct`` (the largest
rise of the total above its initial value, in per cent; <= 0 when the scene only dissipated),
``errors.energy_final_pct`` (the total at the end), ``values.passed``, ``values.status``,
``values.lost``.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

from validation.common import make_record, write_outputs

log = logging.getLogger("fsi_sph.validation")

ZOO = Path(__file__).resolve().parent / "scene_zoo"
ENERGY_BOUND_PCT = 1.0
REFINEMENT = 1.5


def lost_particles(sim, lo, hi, dx) -> tuple[int, list]:
    """Particles that are not finite or have left through a wall (below ``lo[1]`` or beside
    ``[lo[0], hi[0]]`` by more than two spacings): their number and the first one's body and
    position."""
    lost, first = 0, []
    for name, obj in sim.bodies().items():
        x = obj.body["x"]
        bad = ~np.isfinite(x).all(axis=1)
        bad |= (x[:, 0] < lo[0] - 2 * dx) | (x[:, 0] > hi[0] + 2 * dx) | (x[:, 1] < lo[1] - 2 * dx)
        if bad.any() and not first:
            first = [name, *x[np.flatnonzero(bad)[0]].tolist()]
        lost += int(bad.sum())
    return lost, first


def _worst(lost, where, now, t):
    """The largest loss so far and where its first particle was (body, x, y, t)."""
    n, first = now
    return (n, [*first, t]) if n > lost else (lost, where)


def scene_extent(sim):
    """Lower-left and upper-right corners of every particle at the start, walls included."""
    xs = [o.body["x"] for o in sim.bodies().values()]
    if sim.fluid is not None and sim.fluid.walls is not None:
        xs.append(sim.fluid.walls.body["x"])
    x = np.concatenate(xs)
    return x.min(axis=0), x.max(axis=0)


def run_scene(path: Path, overrides=()) -> dict:
    """Run one zoo scene to its ``t_end``; the energy history, status and pass/fail."""
    from fsi_sph.config import load_config
    from fsi_sph.energy import SceneEnergy
    from fsi_sph.errors import ConfigError, SimulationError
    from fsi_sph.scene_checks import check_scene
    from fsi_sph.simulation import Simulation

    t0 = time.perf_counter()
    try:
        cfg = load_config(path, list(overrides))
        check_scene(cfg, str(path))   # the checks `fsi-sph run` makes before a run
        sim = Simulation(cfg)
    except ConfigError as e:  # a scene the checks refuse: recorded, the zoo goes on
        log.info("scene %s refused: %s", path.stem, e)
        return make_record(path.stem, 0.0, {"n_particles": 0, "steps": 0, "wall_time_s": 0.0,
                                            "particle_steps_per_s": 0.0}, {},
                           {"passed": False, "status": f"refused: {e}", "lost": 0})
    energy = SceneEnergy(sim)
    lo, hi = scene_extent(sim)
    dx, t_end = cfg.case.dx, cfg.case.t_end
    history, status, lost, where = [(0.0, 0.0)], "completed", 0, []
    loop_t0 = time.perf_counter()
    try:
        sim.check()
        while sim.t < t_end - 1e-12 * t_end:
            sim.step(dt_max=t_end - sim.t, to_end=True)
            history.append((sim.t, energy.drift_pct(sim)))
            if sim.n_steps % cfg.guard.check_every == 0:
                sim.check()
                lost, where = _worst(lost, where, lost_particles(sim, lo, hi, dx), sim.t)
        sim.check()
        lost, where = _worst(lost, where, lost_particles(sim, lo, hi, dx), sim.t)
    except SimulationError as e:
        status = f"failed: {str(e).splitlines()[0]}"
    loop = time.perf_counter() - loop_t0
    drift = np.array(history)
    rise = float(drift[:, 1].max())
    driven = cfg.case.shaking is not None   # the shaken frame does work: no energy bound
    passed = status == "completed" and lost == 0 and (driven or rise <= ENERGY_BOUND_PCT)
    summary = {"n_particles": sim.n_particles, "steps": sim.n_steps,
               "wall_time_s": time.perf_counter() - t0,
               "particle_steps_per_s": sim.particle_steps / max(loop, 1e-12)}
    log.info("scene %s: %s, energy rise %.3g %%, final %.3g %%, lost %d, %.1f s wall",
             path.stem, status, rise, drift[-1, 1], lost, summary["wall_time_s"])
    return make_record(path.stem, dx, summary, {"energy_rise_pct": rise,
                                                "energy_final_pct": float(drift[-1, 1])}, {
        "passed": passed, "status": status, "lost": lost, "lost_first": where,
        "driven": driven, "t_end_s": t_end,
        "t_reached_s": sim.t,
        "energy_initial_J_per_m": energy.initial,
        "history_t_s": drift[:, 0].tolist(), "history_energy_pct": drift[:, 1].tolist(),
        "picked": [str(p) for p in cfg.numerics_picked()]})


def plot_energy(records, out_dir: Path):
    """Energy drift against time, one line per scene."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    for r in records:
        v = r["values"]
        ax.plot(v["history_t_s"], v["history_energy_pct"], label=r["label"], lw=1)
    ax.axhline(ENERGY_BOUND_PCT, color="k", ls="--", lw=0.8, label="bound")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("total energy - initial (% of initial)")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out_dir / "energy_drift.png", dpi=120)
    plt.close(fig)


def validate(quick, data_dir, out_dir):
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    records = []
    for path in sorted(ZOO.glob("*.toml")):
        over = []
        if not quick:
            from fsi_sph.config import load_config

            over = [f"case.dx={load_config(path).case.dx / REFINEMENT!r}"]
        records.append(run_scene(path, over))
    plot_energy(records, out_dir)
    passed = sum(r["values"]["passed"] for r in records)
    result = {"case": "scene_zoo",
              "reference": f"every scene completes, guard idle, no particle lost, energy rise "
                           f"<= {ENERGY_BOUND_PCT} % of the initial total",
              "targets": {"scenes passed": f"{passed} / {len(records)}"},
              "records": records}
    write_outputs(result, out_dir)
    return result
