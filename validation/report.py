"""validation/REPORT.md: for every validation case a table and a log-log plot of error against
wall time across resolutions, other codes' errors marked where known, and the machine.

Built from the ``result.json`` that each validation writes into ``validation/results/NAME/``;
``fsi-sph validate --all [--quick]`` runs them all and then calls :func:`write_report`.
"""

from __future__ import annotations

import datetime
import json
from pathlib import Path

from validation.common import markdown_table

HERE = Path(__file__).resolve().parent


def load_results(results_dir) -> dict:
    """{name: result} of every ``results_dir/NAME/result.json``."""
    out = {}
    if not Path(results_dir).is_dir():
        return out
    for folder in sorted(p for p in Path(results_dir).iterdir() if p.is_dir()):
        # result.json, or (the soil validations) the one JSON record file of the folder
        candidates = [folder / "result.json"] + sorted(folder.glob("*.json"))
        for p in candidates:
            if p.is_file():
                res = json.loads(p.read_text())
                if isinstance(res, dict) and "records" in res:
                    out[folder.name] = res
                    break
    return out


def scalar_values(values: dict) -> dict:
    """The single numbers and short strings of a record's values (no lists, tables or
    histories: those stay in result.json)."""
    return {k: v for k, v in values.items()
            if not k.startswith("history") and (isinstance(v, (int, float))
                                                or (isinstance(v, str) and len(v) < 120))}


def write_report(results: dict, path=HERE / "REPORT.md", fig_dir=HERE / "report",
                 failures=None, missing=()) -> Path:
    """Write the report and one PNG per case into ``fig_dir``; returns the report path."""
    from fsi_sph.plotting import error_vs_time

    path, fig_dir = Path(path), Path(fig_dir)
    fig_dir.mkdir(parents=True, exist_ok=True)
    lines = ["# Validation report", "",
             f"Generated {datetime.datetime.now().isoformat(timespec='seconds')} by "
             "`fsi-sph validate --all` or `--report` (regenerate with the same command; "
             "`--quick` runs the coarse end of each ladder). Errors are signed percentages "
             "unless the name says otherwise; wall time is the whole run (set-up + "
             "stepping); throughput is particle-steps per second of the stepping loop. "
             "`fsi-sph validate --report` rewrites this file from the stored results "
             "without running anything.", ""]
    machine = next((r.get("machine") for r in results.values() if r.get("machine")), None)
    if machine:
        v = machine.get("versions", {})
        lines += ["Machine: " + f"{machine.get('platform')}, {machine.get('cpus')} CPUs, "
                  f"{machine.get('numba_threads')} numba threads; git {machine.get('git_sha')}; "
                  + ", ".join(f"{k} {v[k]}" for k in sorted(v)), ""]
    for name, res in results.items():
        lines += [f"## {name}", "", f"Reference: {res['reference']}", ""]
        if res.get("targets"):
            lines += ["Targets: " + "; ".join(f"{k} {v}" for k, v in res["targets"].items()),
                      ""]
        m = res.get("machine") or {}
        if m:
            load = m.get("load_average_1min")
            load = f"{load:.1f}" if load is not None else "(not recorded)"
            lines += [f"Measured {m.get('date', '(date not recorded)')}, git "
                      f"{m.get('git_sha')}, {m.get('numba_threads')} numba threads, load "
                      f"average {load} at the end ({m.get('cpus')} CPUs; a load above the "
                      "CPU count means the wall times are inflated by other work).", ""]
        if not res["records"]:
            lines += ["(no records)", ""]
            continue
        if "failed_rows" in res.get("values", {}):  # the stability suite: a status table
            from validation.stability import status_table

            lines += [status_table(res), f"failed_rows = {res['values']['failed_rows']}", ""]
            continue
        lines.append(markdown_table(res))
        keys = list(dict.fromkeys(k for r in res["records"] for k in r["errors"]))
        fig = fig_dir / f"{name}.png"
        error_vs_time(res["records"], keys, f"{name}: error vs wall time", fig,
                      marks=res.get("marks"))
        if res.get("marks"):
            lines.append("Rows in italics: published models and peer codes (their errors by "
                         "the same measure; no run time known), drawn as horizontal lines on "
                         "the plot.")
            lines.append("")
        lines += [f"![{name}]({fig.relative_to(path.parent).as_posix()})", ""]
        values = scalar_values(res["records"][-1].get("values", {}))
        if values:
            lines.append("Finest resolution, other measured values (histories, tables and "
                         "trial lists are in the case's result.json): " + ", ".join(
                             f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
                             for k, v in values.items()))
            lines.append("")
    lines += scaling_section(HERE / "results" / "benchmark_scaling.json")
    for name, why in (failures or {}).items():
        lines += [f"## {name}", "", f"**Did not run to the end**: {why}", ""]
    for name in missing:
        lines += [f"## {name}", "", "**No stored result yet**: run `fsi-sph validate "
                  f"{name} [--quick]`.", ""]
    path.write_text("\n".join(lines))
    return path


def scaling_section(path) -> list[str]:
    """The fluid scaling table of ``validation/benchmark_scaling.py --json`` (stored as
    ``validation/results/benchmark_scaling.json``), or nothing when it is absent."""
    path = Path(path)
    if not path.exists():
        return []
    bench = json.loads(path.read_text())
    load = bench.get("load_average", [[None], [None]])
    lines = ["## Fluid scaling (benchmark, not a validation)", "",
             "`python validation/benchmark_scaling.py --json "
             "validation/results/benchmark_scaling.json`"
             f", dam break, {bench['threads']} threads, {bench['machine']}, load average "
             f"{load[0][0]:.2f} -> {load[1][0]:.2f} (1 min, before -> after); measured "
             f"{bench.get('date', '(date not recorded)')}. Mean of the steps after two warm-up "
             "steps; peak RSS of the whole process (one process per size).", "",
             "| size | fluid particles | s / step | particle-steps / s | peak RSS (MB) "
             "| kB / particle | neighbours | surface | shift | predict | PPE assembly "
             "| AMG set-up | Krylov | correct |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, r in bench["rows"].items():
        ph = r["phases_s_per_step"]
        ms = " | ".join(f"{1e3 * ph[k]:.1f}" for k in (
            "neighbours", "free_surface", "shift", "predict", "ppe_assemble", "ppe_setup",
            "ppe_solve", "correct"))
        lines.append(f"| {label} | {r['n_fluid']} | {r['s_per_step']:.3f} | "
                     f"{r['particle_steps_per_s']:.3g} | {r['peak_rss_bytes'] / 1e6:.0f} | "
                     f"{r['rss_per_particle_kB']:.2f} | {ms} |")
    lines += ["", "Phases in ms per step (AMG set-up: the hierarchy is kept between steps and "
              "rebuilt at snapshots or when the iterations grow: 0.0 where no rebuild fell in "
              "the timed steps).",
              ""]
    return lines
