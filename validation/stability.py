"""Stability suite: stiff and extreme cases (issue 7). Each row either runs to the end with no
NaN, no particle leaving the domain, bounded energy (the blow-up guard checks all three) and
its own criterion, or stops with a message that names the cause (a SimulationError from the
guard). ``values.failed_rows`` counts the rows that do neither.

The coupled rows run the elastic gate (cases/dam_break_elastic_gate.toml) at dx = 2.5 mm,
i.e. a gate two particles thick, and also check that no fluid particle ends inside the gate.
The violent impact row sets a water column standing free 2 cm from the left wall and from the
gate moving at 10 m/s towards the gate at t = 0 (``fluid.initial_velocity``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from validation.common import CASES, log, machine, make_record, run_case

PLATE = CASES / "oscillating_plate.toml"
GATE = CASES / "dam_break_elastic_gate.toml"
SLOPE2 = CASES / "slope_2_cohesive.toml"
DAM = CASES / "dam_break.toml"
TANK = CASES / "hydrostatic_tank.toml"
T_PLATE = 0.254  # s, first-mode period of the plate (thin-plate theory)


@dataclass
class Row:
    name: str
    case: object
    overrides: list
    why: str
    criterion: object = None  # f(run_file) -> (ok, {metric: value}, message)
    quick_overrides: list = field(default_factory=list)


def energy_drift(run_file, limit_pct):
    """Largest |E(t) - E(0)| / E(0) of the 'energy' probe (kinetic + strain + penalty)."""
    from fsi_sph.output import read_probe

    _, e = read_probe(run_file, "energy")
    drift = 100 * float(np.max(np.abs(e["total"] - e["total"][0])) / e["total"][0])
    return drift < limit_pct, {"energy_drift_pct": drift}, f"energy drift {drift:.3g} % " \
        f"(limit {limit_pct} %)"


def tip_bounded(run_file, limit_m, probe="tip"):
    from fsi_sph.output import read_probe

    _, c = read_probe(run_file, probe)
    u = float(np.max(np.hypot(c["ux"], c["uy"])))
    return u < limit_m, {"max_tip_displacement_m": u}, f"tip displacement {u:.3g} m " \
        f"(bound {limit_m} m)"


def fastest_below(run_file, limit):
    """Largest fluid particle speed of the 'stats' probe (every step) below ``limit`` (m/s)."""
    from fsi_sph.output import read_probe

    _, cols = read_probe(run_file, "stats")
    top = float(np.max(cols["max_speed"]))
    return (top < limit, {"max_speed_m_s": top},
            f"fastest particle {top:.3g} m/s (bound {limit:.3g} m/s)")


def lattice_quads(X0, dx):
    """Index quadruples of the lattice cells of a body whose reference positions ``X0`` lie on a
    square lattice of spacing ``dx``: the cells whose four corners are all particles."""
    ij = np.round((X0 - X0.min(axis=0)) / dx).astype(np.int64)
    index = {(int(i), int(j)): k for k, (i, j) in enumerate(ij)}
    quads = []
    for (i, j), k in index.items():
        corners = [k, index.get((i + 1, j)), index.get((i + 1, j + 1)), index.get((i, j + 1))]
        if None not in corners:
            quads.append(corners)
    return np.array(quads, dtype=np.int64).reshape(-1, 4)


def fluid_inside(xf, xg, quads):
    """Number of fluid particles inside the deformed lattice cells of a body (the region
    between its particle centres: a fluid particle there has crossed the interface)."""
    from matplotlib.path import Path as Polygon
    from scipy.spatial import cKDTree

    if not len(quads):
        return 0
    centres = xg[quads].mean(axis=1)
    reach = float(np.max(np.linalg.norm(xg[quads] - centres[:, None, :], axis=2)))
    inside = np.zeros(len(xf), dtype=bool)
    tree = cKDTree(xf)
    for q, c in zip(quads, centres, strict=True):
        near = tree.query_ball_point(c, reach)
        if near:
            inside[near] |= Polygon(xg[q]).contains_points(xf[near])
    return int(inside.sum())


def no_penetration(run_file, dx=0.0025, tip_bound=0.1):
    """No fluid particle inside the gate at any snapshot: inside one of the deformed lattice
    cells spanned by the gate's particles (the body minus its dx/2 skin); and the gate's tip
    displacement bounded."""
    import h5py

    with h5py.File(run_file, "r") as f:
        snaps = [f["snapshots"][k] for k in sorted(f["snapshots"])]
        quads = lattice_quads(snaps[0]["gate/x"][()], dx)
        inside = max(fluid_inside(s["fluid/x"][()], s["gate/x"][()], quads) for s in snaps)
    ok, metrics, msg = tip_bounded(run_file, tip_bound, probe="gate_tip")
    metrics["fluid_inside_gate"] = inside
    return ok and inside == 0, metrics, f"{msg}; at most {inside} fluid particles inside the gate"


def rows():
    plate = ["case.dx=0.004", "case.output_every=0.5"]
    gate = ["case.dx=0.0025", "case.output_every=0.01"]
    return [
        Row("plate_undamped_20_periods", PLATE,
            plate + [f"case.t_end={20 * T_PLATE}", "case.probe_every=0.002",
                     "solid.plate.artificial_viscosity.alpha=0.0",
                     "solid.plate.hourglass.model=conservative"],
            "long undamped run: energy drift < 1 % over 20 periods",
            lambda f: energy_drift(f, 1.0),
            quick_overrides=[f"case.t_end={4 * T_PLATE}"]),
        Row("plate_nu_0.49", PLATE,
            plate + ["solid.plate.material.nu=0.49", "case.t_end=0.3"],
            "nearly incompressible solid (nu = 0.49)", lambda f: tip_bounded(f, 0.05)),
        Row("plate_E_x100", PLATE,
            plate + ["solid.plate.material.E=1.99875e8", "case.t_end=0.0508",
                     "case.output_every=0.01", "case.probe_every=1e-5",
                     "solid.plate.initial_velocity.tip_speed=5.70088"],
            "stiff solid, E x 100 (same initial strain rate scaled with c0)",
            lambda f: tip_bounded(f, 0.05)),
        Row("plate_E_x1e4", PLATE,
            plate + ["solid.plate.material.E=1.99875e10", "case.t_end=0.00508",
                     "case.output_every=0.001", "case.probe_every=1e-6",
                     "solid.plate.initial_velocity.tip_speed=57.0088"],
            "stiff solid, E x 10^4", lambda f: tip_bounded(f, 0.05),
            quick_overrides=["case.t_end=0.001"]),
        Row("plate_two_particles_thick", PLATE,
            ["case.dx=0.01", "case.t_end=0.3", "case.output_every=0.1",
             "solid.plate.clamp=[{origin=[-0.02,-0.01],size=[0.02,0.02]}]"],
            "a structure only two particles thick", lambda f: tip_bounded(f, 0.1)),
        Row("gate_two_particles_thick", GATE, gate + ["case.t_end=0.1"],
            "the elastic gate, two particles thick, 0.1 s", no_penetration,
            quick_overrides=["case.t_end=0.03"]),
        Row("gate_E_x100", GATE, gate + ["solid.gate.material.E=1.2e9", "case.t_end=0.03"],
            "stiff gate, E x 100", no_penetration, quick_overrides=["case.t_end=0.01"]),
        Row("gate_E_x1e4", GATE, gate + ["solid.gate.material.E=1.2e11", "case.t_end=0.005"],
            "stiff gate, E x 10^4 (about 3000 solid sub-steps per fluid step)", no_penetration,
            quick_overrides=["case.t_end=0.002"]),
        Row("gate_nu_0.49", GATE, gate + ["solid.gate.material.nu=0.49", "case.t_end=0.05"],
            "nearly incompressible gate", no_penetration, quick_overrides=["case.t_end=0.02"]),
        Row("gate_heavy_rho_ratio_10", GATE,
            gate + ["solid.gate.material.rho0=10000.0", "case.t_end=0.05"],
            "heavy structure, rho_s / rho_f = 10", no_penetration,
            quick_overrides=["case.t_end=0.02"]),
        Row("gate_light_rho_ratio_0.5", GATE,
            gate + ["solid.gate.material.rho0=500.0", "case.t_end=0.05"],
            "light structure, rho_s / rho_f = 0.5 (added mass ~30 x its own)", no_penetration,
            quick_overrides=["case.t_end=0.02"]),
        Row("gate_impact_10_m_s", GATE,
            gate + ["fluid.initial_velocity=[10.0, 0.0]", "case.t_end=0.02",
                    # the column stands free, 2 cm from the left wall and from the gate
                    "fluid.blocks=[{origin=[0.02,0.0],size=[0.06,0.14]}]",
                    "case.output_every=0.005", "case.probe_every=0.0002"],
            "violent impact: the water column hits the gate at 10 m/s",
            # the tip can swing through at most twice the gate's free length (0.079 m)
            lambda f: no_penetration(f, tip_bound=0.16),
            quick_overrides=["case.t_end=0.01"]),
        Row("dam_break_front", DAM,
            ["case.dx=0.025", "case.output_every=0.2", "case.t_end=0.8"],
            "dam break to T = 2.5: no particle outruns the inviscid front of the column's "
            "height, 2 sqrt(2 g a) = 8.86 m/s (a particle thrown at 14 m/s without the "
            "umbrella scan)",
            lambda f: fastest_below(f, 2.0 * math.sqrt(2.0 * 9.81 * 1.0)),
            quick_overrides=["case.t_end=0.55"]),
        Row("still_water_10s", TANK, ["case.t_end=10.0", "case.output_every=2.0"],
            "water at rest in a tank for 10 s at the force limit's time step (dt ~ 0.012 s): "
            "stays at rest, max speed below 1e-3 sqrt(g H) = 3.1 mm/s (it blew up after "
            "2.9 s with the plain Morris Laplacian and the trapezoidal move, 2026-12-01f)",
            lambda f: fastest_below(f, 1e-3 * math.sqrt(9.81 * 1.0)),
            quick_overrides=["case.t_end=5.0"]),
        Row("slope_high_cohesion", SLOPE2,
            ["soil.clay.material.cohesion=110000.0", "case.t_end=2.0", "case.output_every=0.5"],
            "cohesive slope with 10 x the cohesion (stands; tensile instability)",
            None, quick_overrides=["case.t_end=0.5"]),
    ]


PENDING: list[str] = []


def _steps_summary(run_file):
    import h5py

    with h5py.File(run_file, "r") as f:
        st = f["steps"][()] if "steps" in f else np.zeros((0, 3))
    if not len(st):
        return {}
    return {"dt_min_s": float(st[:, 1].min()), "dt_max_s": float(st[:, 1].max()),
            "n_sub_max": int(st[:, 2].max())}


def run_row(row, quick, out_dir):
    from fsi_sph.errors import SimulationError

    over = row.overrides + (row.quick_overrides if quick else [])
    run_dir = out_dir / row.name
    try:
        _, s = run_case(row.case, over, out_dir=run_dir)
    except SimulationError as e:
        status, cause = "stopped", str(e)
        s = {"n_particles": 0, "steps": 0, "wall_time_s": math.nan,
             "particle_steps_per_s": math.nan}
        metrics = {}
    else:
        status, cause, metrics = "passed", "", {}
        if row.criterion is not None:
            ok, metrics, msg = row.criterion(s["output"])
            if not ok:
                status, cause = "failed", msg
            else:
                cause = msg
    values = {"status": status, "cause": cause, "why": row.why}
    run_file = run_dir / "run.h5"
    if run_file.exists():
        values.update(_steps_summary(run_file))
    rec = make_record(row.name, 0.0, s, metrics, values)
    return rec


def validate(quick=False, data_dir=None, out_dir="validation/results/stability"):
    from pathlib import Path

    out = Path(out_dir)
    records = [run_row(r, quick, out) for r in rows()]
    failed = [r["label"] for r in records if r["values"]["status"] == "failed"]
    result = {"case": "stability", "reference": "runs to the end or stops with a named cause",
              "machine": machine(), "records": records,
              "values": {"failed_rows": len(failed), "failed": failed, "pending_rows": PENDING}}
    out.mkdir(parents=True, exist_ok=True)
    (out / "result.json").write_text(json.dumps(result, indent=1))
    (out / "table.md").write_text("# Stability suite\n\n" + status_table(result))
    log.info("stability: failed_rows = %d %s", len(failed), failed)
    for line in status_table(result).splitlines():
        log.info("%s", line)
    return result


def status_table(result) -> str:
    """One line per row: status, cause, time step range and sub-cycling, wall time."""
    lines = ["| row | status | dt (s) | sub-steps (max) | particles | wall time (s) | detail |",
             "|---|---|---|---|---|---|---|"]
    for r in result["records"]:
        v = r["values"]
        dt = (f"{v['dt_min_s']:.3g} .. {v['dt_max_s']:.3g}" if "dt_min_s" in v else "")
        lines.append(f"| {r['label']} | {v['status']} | {dt} | {v.get('n_sub_max', '')} | "
                     f"{r['n_particles']} | {r['wall_time_s']:.1f} | {v['cause']} |")
    for name in result["values"]["pending_rows"]:
        lines.append(f"| {name} | pending | | | | | fluid blocks have no initial velocity yet |")
    return "\n".join(lines) + "\n"
