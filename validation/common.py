"""Shared helpers of the validation scripts: run a case with overrides, write records.

Generic on purpose (any case, any physics): ``run_case`` runs one case file and returns the
simulation and its summary; ``write_outputs`` writes the JSON record and a small text table.
Wall times and particle-steps per second cover the stepping loop only (set-up and JIT
compilation excluded), as the shared record format asks.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

log = logging.getLogger(__name__)


def run_case(case_path, overrides=(), out_dir=None, max_steps=None, progress=False):
    """Load ``case_path`` with ``--set``-style ``overrides``, run it (writing
    ``out_dir/run.h5`` if ``out_dir`` is given) and return ``(sim, summary)``."""
    cfg = load_config(case_path, list(overrides))
    sim = Simulation(cfg)
    summary = sim.run(out_dir=out_dir, max_steps=max_steps, progress=progress,
                      case_file=str(case_path))
    log.info("%s %s: %d steps, %d particles, loop %.1f s, %.3g particle-steps/s",
             Path(case_path).stem, " ".join(overrides), summary["steps"], summary["n_particles"],
             summary["loop_time_s"], summary["particle_steps_per_s"])
    return sim, summary


def record(label, dx, summary, errors, values):
    """One entry of the shared JSON record format."""
    return {"label": label, "dx": dx, "n_particles": int(summary["n_particles"]),
            "steps": int(summary["steps"]), "wall_time_s": float(summary["loop_time_s"]),
            "particle_steps_per_s": float(summary["particle_steps_per_s"]),
            "errors": {k: float(v) for k, v in errors.items()},
            "values": {k: (float(v) if isinstance(v, (int, float)) else v)
                       for k, v in values.items()}}


def write_outputs(result, out_dir):
    """Write ``result`` (``{"case", "reference", "records"}``) as ``out_dir/<case>.json`` and a
    plain-text table ``out_dir/<case>.txt``; returns the JSON path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{result['case']}.json"
    path.write_text(json.dumps(result, indent=1))
    recs = result["records"]
    keys_e = sorted({k for r in recs for k in r["errors"]})
    keys_v = sorted({k for r in recs for k in r["values"]
                     if isinstance(r["values"][k], (int, float))})
    head = ["label", "dx", "n_particles", "steps", "wall_time_s", "particle_steps_per_s",
            *keys_e, *keys_v]
    lines = [f"# {result['case']}: {result['reference']}", "\t".join(head)]
    for r in recs:
        row = [r["label"], f"{r['dx']:g}", str(r["n_particles"]), str(r["steps"]),
               f"{r['wall_time_s']:.2f}", f"{r['particle_steps_per_s']:.4g}"]
        row += [f"{r['errors'].get(k, float('nan')):.4g}" for k in keys_e]
        row += [f"{r['values'].get(k, float('nan')):.4g}" for k in keys_v]
        lines.append("\t".join(row))
    (out / f"{result['case']}.txt").write_text("\n".join(lines) + "\n")
    log.info("wrote %s", path)
    return path
