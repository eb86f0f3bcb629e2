"""Command line: ``fsi-sph run | info | plot | validate``.

Exit codes: 0 success; 1 a run that failed (the message says when and why); 2 bad input
(case file, override, option, file to plot, validation name).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import os
import sys
from pathlib import Path

log = logging.getLogger("fsi_sph")

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CASE = REPO / "cases" / "oscillating_plate.toml"
VALIDATION_DIR = REPO / "validation"


class UsageError(Exception):
    """Bad input given on the command line (exit code 2)."""


def _parser():
    p = argparse.ArgumentParser(prog="fsi-sph", description=__doc__.splitlines()[0])
    p.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("run", help="run a case file (default: the built-in default scene)")
    r.add_argument("case", nargs="?", help=f"TOML case file (default: {DEFAULT_CASE.name})")
    r.add_argument("--out", help="output folder (default: runs/<case name>)")
    r.add_argument("--set", dest="overrides", action="append", default=[], metavar="K=V",
                   help="override a case key, e.g. --set case.dx=0.004 (repeatable)")
    r.add_argument("--max-steps", type=int, help="stop after N steps")
    r.add_argument("--threads", type=int, help="numba threads (default: all cores)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")

    i = sub.add_parser("info", help="print the resolved config and the enabled physics")
    i.add_argument("case")
    i.add_argument("--set", dest="overrides", action="append", default=[], metavar="K=V")

    pl = sub.add_parser("plot", help="PNG snapshots and probe time series of a run")
    pl.add_argument("run_file", metavar="RUN.h5")
    pl.add_argument("--field", default="von_mises",
                    help="field that colours the particles (default: von_mises)")
    pl.add_argument("--out", help="folder for the PNGs (default: beside RUN.h5)")
    pl.add_argument("--max-snapshots", type=int, default=12,
                    help="at most this many snapshot images, evenly spaced (default 12)")

    v = sub.add_parser("validate", help="run a validation case against its reference")
    v.add_argument("name", help="validation name, e.g. oscillating_plate")
    v.add_argument("--quick", action="store_true", help="only the coarse end of the ladder")
    v.add_argument("--json", dest="json_file", help="write the validation record here")
    v.add_argument("--data", default=str(REPO.parent / "shared" / "validation_data"),
                   help="folder of reference data (default: ../shared/validation_data)")
    v.add_argument("--out", help="folder for tables, plots and runs "
                   "(default: validation/results/<name>)")
    v.add_argument("--threads", type=int)
    return p


def _set_threads(n):
    if n is None:
        return
    import numba

    if not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
        raise UsageError(f"--threads {n}: allowed 1 .. {numba.config.NUMBA_NUM_THREADS}")
    numba.set_num_threads(n)


def cmd_run(args):
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    case = Path(args.case) if args.case else DEFAULT_CASE
    if args.max_steps is not None and args.max_steps < 0:
        raise UsageError(f"--max-steps {args.max_steps}: must be >= 0")
    cfg = load_config(case, args.overrides)
    _set_threads(args.threads)
    out = Path(args.out) if args.out else Path("runs") / cfg.case.name
    log.info("case %s: %s", case, ", ".join(cfg.modules()))
    sim = Simulation(cfg)
    log.info("%d particles, set-up %.2f s (JIT compile included)", sim.n_particles,
             sim.timings["setup"])
    s = sim.run(out_dir=out, max_steps=args.max_steps, progress=not args.no_progress,
                case_file=str(case))
    log.info("%s: %d steps to t = %.4g s in %.2f s (%.3g particle-steps/s); output %s",
             s["status"], s["steps"], s["t"], s["loop_time_s"], s["particle_steps_per_s"],
             s["output"])
    for p in sim.probes:
        log.info("probe %s: %s", p.name,
                 ", ".join(f"{c} = {v:.6g}" for c, v in zip(p.columns, p.sample(), strict=True)))
    return 0


def cmd_info(args):
    from fsi_sph.config import load_config

    cfg = load_config(args.case, args.overrides)
    print(f"case file: {args.case}")
    print("physics modules enabled: " + ", ".join(cfg.modules()))
    print("resolved config:")
    print(json.dumps(cfg.model_dump(mode="json"), indent=2))
    return 0


def cmd_plot(args):
    from fsi_sph.plotting import plot_run

    path = Path(args.run_file)
    if not path.is_file():
        raise UsageError(f"{path}: no such run file")
    out = Path(args.out) if args.out else path.parent / "plots"
    files = plot_run(path, out, field=args.field, max_snapshots=args.max_snapshots)
    for f in files:
        log.info("wrote %s", f)
    return 0


def available_validations():
    return sorted(p.stem for p in VALIDATION_DIR.glob("*.py")
                  if not p.stem.startswith(("_", "common", "report", "benchmark")))


def cmd_validate(args):
    names = available_validations()
    if args.name not in names:
        raise UsageError(f"validate {args.name!r}: unknown validation; available: "
                         f"{', '.join(names) or 'none (validation/ folder not found)'}")
    _set_threads(args.threads)
    path = VALIDATION_DIR / f"{args.name}.py"
    if str(VALIDATION_DIR.parent) not in sys.path:
        sys.path.insert(0, str(VALIDATION_DIR.parent))
    spec = importlib.util.spec_from_file_location(f"validation.{args.name}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = Path(args.out) if args.out else VALIDATION_DIR / "results" / args.name
    result = mod.validate(quick=args.quick, data_dir=Path(args.data), out_dir=out)
    if args.json_file:
        Path(args.json_file).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json_file).write_text(json.dumps(result, indent=1))
        log.info("wrote %s", args.json_file)
    return 0


def _single_threaded_blas():
    """One BLAS thread (unless the user set one): the Krylov loop of the PPE makes many
    short vector operations (dot, norm) for which multi-threaded OpenBLAS only adds
    synchronisation cost; measured 10x slower PPE solves with it on a busy 2-core machine.
    Must run before numpy is first imported, which the CLI only does inside commands."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")


def main(argv=None):
    _single_threaded_blas()
    from fsi_sph.config import ConfigError

    args = _parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    commands = {"run": cmd_run, "info": cmd_info, "plot": cmd_plot, "validate": cmd_validate}
    try:
        return commands[args.command](args)
    except (ConfigError, UsageError) as e:
        print(f"fsi-sph: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fsi-sph: interrupted; the output file keeps every snapshot written so far",
              file=sys.stderr)
        return 130
    except Exception as e:  # a failed run: say what happened, no traceback unless asked
        from fsi_sph.simulation import SimulationError

        if isinstance(e, SimulationError):
            print(f"fsi-sph: run failed: {e}", file=sys.stderr)
            return 1
        raise


if __name__ == "__main__":
    sys.exit(main())
