"""Shared pieces of the validation scripts: run a case, build the JSON record, write the
table, the error-vs-wall-time plot and the JSON file.

Record format (shared by every validation, records ordered coarse to fine)::

    {"case": str, "reference": str, "machine": {...}, "records": [
        {"label": str, "dx": float, "n_particles": int, "steps": int, "wall_time_s": float,
         "particle_steps_per_s": float, "errors": {...}, "values": {...}}]}

``wall_time_s`` is the run's whole wall time (set-up and stepping; the JIT compile of the
first run is excluded by compiling before timing); ``particle_steps_per_s`` is measured over
the stepping loop alone.
"""

from __future__ import annotations

import json
import logging
import os
import platform
import time
from pathlib import Path

log = logging.getLogger("fsi_sph.validation")

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"


def machine() -> dict:
    """Where the numbers were measured."""
    import datetime

    import numba

    from fsi_sph.output import git_sha, versions

    return {"platform": platform.platform(), "processor": platform.processor() or "unknown",
            "cpus": os.cpu_count(), "numba_threads": numba.get_num_threads(),
            "git_sha": git_sha(), "versions": versions(),
            # other work on the machine inflates wall times: say how busy it was
            "load_average_1min": os.getloadavg()[0],
            "date": datetime.datetime.now().isoformat(timespec="minutes")}


def run_case(case, overrides=(), out_dir=None, max_steps=None, progress=False):
    """Build and run ``case`` with ``--set``-style ``overrides`` (writing ``out_dir/run.h5``
    if given); returns (sim, summary) where summary adds ``wall_time_s`` (set-up + loop) to
    :meth:`Simulation.run`'s summary."""
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    t0 = time.perf_counter()
    cfg = load_config(case, list(overrides))
    sim = Simulation(cfg)
    summary = sim.run(out_dir=out_dir, max_steps=max_steps, progress=progress,
                      case_file=str(case))
    summary["wall_time_s"] = time.perf_counter() - t0
    log.info("%s %s: %d steps, %d particles, %.1f s, %.3g particle-steps/s",
             Path(case).stem, " ".join(overrides), summary["steps"], summary["n_particles"],
             summary["wall_time_s"], summary["particle_steps_per_s"])
    return sim, summary


def run_ladder(case, dxs, out_dir, measure, overrides=()):
    """One record per resolution ``dx`` of ``dxs``: the case run with ``case.dx = dx`` (and
    ``overrides``) into ``out_dir/dx=<dx>``, measured by ``measure(sim, run_file) ->
    (errors, values)``."""
    records = []
    for dx in dxs:
        label = f"dx={dx:g}"
        sim, summary = run_case(case, [f"case.dx={dx}", *overrides], Path(out_dir) / label)
        errors, values = measure(sim, Path(out_dir) / label / "run.h5")
        records.append(make_record(label, dx, summary, errors, values))
    return records


def make_record(label, dx, summary, errors, values=None) -> dict:
    """One entry of the shared record format (``summary`` from :func:`run_case`)."""
    return {"label": label, "dx": float(dx), "n_particles": int(summary["n_particles"]),
            "steps": int(summary["steps"]), "wall_time_s": float(summary["wall_time_s"]),
            "particle_steps_per_s": float(summary["particle_steps_per_s"]),
            "errors": {k: float(v) for k, v in errors.items()},
            "values": {k: (float(v) if isinstance(v, (int, float)) else v)
                       for k, v in (values or {}).items()}}


def record(label, dx, summary, errors, values=None) -> dict:
    """Alias of :func:`make_record` (the fluid scripts' name)."""
    return make_record(label, dx, summary, errors, values)


def markdown_table(result: dict) -> str:
    """One row per record: resolution, particles, steps, wall time, throughput, errors; then
    one row per published model or peer code of ``result["marks"]`` (``{label: {error_key:
    value}}``: the same errors, no resolution or time known), in italics."""
    recs = result["records"]
    marks = result.get("marks") or {}
    ekeys = list(dict.fromkeys(k for r in recs for k in r["errors"]))
    status = any("passed" in r.get("values", {}) for r in recs)  # pass/fail records
    head = ["label", "dx (m)", "particles", "steps", "wall time (s)", "particle-steps/s",
            *[f"{k}" for k in ekeys], *(["status"] if status else [])]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in recs:
        row = [r["label"], f"{r['dx']:g}", str(r["n_particles"]), str(r["steps"]),
               f"{r['wall_time_s']:.1f}", f"{r['particle_steps_per_s']:.3g}",
               *[f"{r['errors'][k]:+.3f}" if k in r["errors"] else "" for k in ekeys],
               *([_status(r["values"])] if status else [])]
        lines.append("| " + " | ".join(row) + " |")
    for label, vals in marks.items():
        if not any(k in vals for k in ekeys):
            continue
        row = [f"*{label}*", "", "", "", "", "",
               *[f"*{vals[k]:+.3f}*" if k in vals else "" for k in ekeys]]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def _status(values: dict) -> str:
    """``pass`` / ``FAIL (why)`` of a pass/fail record (the scene zoo)."""
    if values.get("passed"):
        return "pass"
    why = values.get("status", "")
    if why == "completed" and values.get("lost"):
        why = f"{values['lost']} particles lost"
    elif why == "completed":
        why = "energy bound"
    return f"FAIL ({why})"


def write_outputs(result: dict, out_dir, error_keys=None, title=None, marks=None) -> Path:
    """Write ``result.json``, ``table.md`` and ``error_vs_time.png`` into ``out_dir``
    (``error_keys``: the errors to plot, default all; ``marks``: other codes' errors)."""
    from fsi_sph.plotting import error_vs_time

    if error_keys is None:
        error_keys = list(dict.fromkeys(k for r in result["records"] for k in r["errors"]))
    title = title or f"{result['case']}: error vs wall time"
    marks = marks if marks is not None else result.get("marks")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "result.json").write_text(json.dumps(result, indent=1))
    table = markdown_table(result)
    (out / "table.md").write_text(f"# {title}\n\nReference: {result['reference']}\n\n{table}")
    if error_keys and result["records"]:
        error_vs_time(result["records"], error_keys, title, out / "error_vs_time.png",
                      marks=marks)
    for line in table.splitlines():
        log.info("%s", line)
    log.info("wrote %s", out)
    return out


def ladder_result(name, reference, case, ladder, out_dir, measure, overrides=()) -> dict:
    """Run ``ladder`` through :func:`run_ladder`, write the outputs and return the record."""
    result = {"case": name, "reference": reference,
              "records": run_ladder(case, ladder, out_dir, measure, list(overrides))}
    write_outputs(result, out_dir)
    return result
