"""Command line: ``fsi-sph run | info | plot | validate | fos``.

Exit codes: 0 success; 1 a run that failed (the message says when and why); 2 bad input
(case file, override, option, file to plot, validation name).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import math
import os
import sys
from pathlib import Path

from fsi_sph.errors import ConfigError, SimulationError, UsageError

log = logging.getLogger("fsi_sph")

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CASE = REPO / "cases" / "dam_break_elastic_gate.toml"
VALIDATION_DIR = REPO / "validation"


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
    r.add_argument("--restart", metavar="RUN.h5",
                   help="continue this run from its last snapshot (appends to it unless --out "
                   "is given; without CASE the run's stored config is used)")
    r.add_argument("--threads", type=int,
                   help="numba threads (default: all cores; 1 per rank under mpiexec)")
    r.add_argument("--ppe", choices=["auto", "petsc", "gather"], default="auto",
                   help="on several MPI ranks: the pressure solve by PETSc over the ranks or "
                   "gathered to rank 0 (bit for bit the serial run); auto: PETSc when "
                   "petsc4py is installed")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--force", action="store_true",
                   help="run a scene even if its memory estimate exceeds the machine's memory")
    r.add_argument("--overwrite", action="store_true",
                   help="replace the run already in the output folder")

    i = sub.add_parser("info", help="what the scene will be (particles, memory, time step, "
                       "steps), the enabled physics and the resolved config")
    i.add_argument("case")
    i.add_argument("--set", dest="overrides", action="append", default=[], metavar="K=V")

    pl = sub.add_parser("plot", help="PNG snapshots and probe time series of a run")
    pl.add_argument("run_file", metavar="RUN.h5")
    pl.add_argument("--field", help="colour every body that has this field by it (default: "
                    "each body by its natural field: fluid p, elastic von_mises, soil eps_p)")
    pl.add_argument("--movie", action="store_true",
                    help="write movie.mp4 of every snapshot (movie.gif without an encoder)")
    pl.add_argument("--fps", type=int, default=10, help="movie frames per second (default 10)")
    pl.add_argument("--data", default=str(REPO.parent / "shared" / "validation_data"),
                    help="folder of the reference data the case's probes name")
    pl.add_argument("--out", help="folder for the PNGs (default: beside RUN.h5)")
    pl.add_argument("--max-snapshots", type=int, default=12,
                    help="at most this many snapshot images, evenly spaced (default 12)")

    v = sub.add_parser("validate", help="run a validation case against its reference")
    v.add_argument("name", nargs="?", help="validation name, e.g. oscillating_plate")
    v.add_argument("--all", action="store_true",
                   help="run every validation and write validation/REPORT.md")
    v.add_argument("--quick", action="store_true", help="only the coarse end of the ladder")
    v.add_argument("--report", action="store_true",
                   help="only rewrite validation/REPORT.md from the stored results "
                   "(validation/results/*/result.json), running nothing")
    v.add_argument("--json", dest="json_file", help="write the validation record here")
    v.add_argument("--data", default=str(REPO.parent / "shared" / "validation_data"),
                   help="folder of reference data (default: ../shared/validation_data)")
    v.add_argument("--out", help="folder for tables, plots and runs "
                   "(default: validation/results/<name>)")
    v.add_argument("--threads", type=int)

    f = sub.add_parser("fos", help="factor of safety of a soil slope: strength reduction "
                       "(sph) or Bishop's method (bishop)")
    f.add_argument("case")
    f.add_argument("--body", help="soil body to reduce (needed if the case has several)")
    f.add_argument("--out", help="output folder (default: runs/<case name>_fos)")
    f.add_argument("--set", dest="overrides", action="append", default=[], metavar="K=V")
    f.add_argument("--method", choices=["sph", "bishop"], default="sph")
    f.add_argument("--tol", type=float,
                   help="relative width of the final bracket of F (default 0.02)")
    f.add_argument("--threads", type=int)
    return p


def _set_threads(n):
    if n is None:
        return
    import numba

    if not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
        raise UsageError(f"--threads {n}: allowed 1 .. {numba.config.NUMBA_NUM_THREADS}")
    numba.set_num_threads(n)


def cmd_run(args):
    from fsi_sph.config import load_config, load_config_from_run
    from fsi_sph.output import read_restart, refuse_overwrite
    from fsi_sph.scene_checks import check_scene

    if args.max_steps is not None and args.max_steps < 0:
        raise UsageError(f"--max-steps {args.max_steps}: must be >= 0")
    resume = None
    if args.restart:
        resume = Path(args.restart)
        if not resume.is_file():
            raise UsageError(f"--restart {resume}: no such run file")
        try:
            read_restart(resume)
        except ValueError as e:
            raise UsageError(f"--restart {e}") from None
    if args.case or resume is None:
        case = Path(args.case) if args.case else DEFAULT_CASE
        cfg = load_config(case, args.overrides)
        label = str(case)
    else:
        case = resume
        cfg = load_config_from_run(resume, args.overrides)
        label = f"{resume} (stored config)"
    check_scene(cfg, label, force=args.force)
    comm = _ranks()
    if comm.size > 1 and args.threads is None:  # one numba thread per rank by default
        args.threads = 1
    _set_threads(args.threads)
    if resume is not None:
        out = Path(args.out) if args.out else None
    else:
        out = Path(args.out) if args.out else Path("runs") / cfg.case.name
    if out is not None and not args.overwrite:
        _on_rank_zero(comm, refuse_overwrite, out / "run.h5")
    log.info("case %s: %s", case, ", ".join(cfg.modules()))
    for pick in cfg.numerics_picked():
        log.info("picked %s", pick)
    sim = _build(cfg, case, comm, args.ppe)
    log.info("%d particles, set-up %.2f s (JIT compile included)%s", sim.n_particles,
             sim.timings["setup"], f"; {', '.join(sim.split)} split over {comm.size} ranks"
             + (f" ({sim.ranks.ppe_engine})" if sim.fluid is not None else "")
             if comm.size > 1 else "")
    try:
        s = sim.run(out_dir=out, max_steps=args.max_steps, progress=not args.no_progress,
                    case_file=str(case), resume=resume)
    except SimulationError as e:
        if "restart:" in str(e):  # the run file does not fit this scene: bad input
            raise UsageError(f"--restart {resume}: {e}") from None
        raise
    log.info("%s: %d steps to t = %.4g s%s in %.2f s (%.3g particle-steps/s); output %s",
             s["status"], s["steps"], s["t"],
             f" ({s['steps_this_run']} of them in this run)" if resume else "",
             s["loop_time_s"], s["particle_steps_per_s"], s["output"])
    for p in sim.probes:
        log.info("probe %s: %s", p.name,
                 ", ".join(f"{c} = {v:.6g}" for c, v in zip(p.columns, p.sample(), strict=True)))
    return 0


def _build(cfg, case, comm=None, ppe="auto"):
    """The scene's :class:`Simulation` (split over the ranks of ``comm`` when there are
    several); an error found while building it names the file."""
    from fsi_sph.simulation import Simulation

    try:
        if comm is None or comm.size == 1:
            return Simulation(cfg)
        from fsi_sph.parallel.ranks import RankSimulation

        try:
            return RankSimulation(cfg, comm, ppe=ppe)
        except SimulationError as e:  # a scene that is not split yet
            raise UsageError(f"{case}: {e}") from None
    except ConfigError as e:
        raise ConfigError(f"{case}: {e}") from None


def _ranks():
    """The MPI ranks this process runs with (:func:`fsi_sph.parallel.comm.world`: one
    without an MPI launcher); on ranks other than 0 only warnings are logged."""
    from fsi_sph.parallel.comm import world

    comm = world()
    if comm.rank != 0:
        logging.getLogger().setLevel(logging.WARNING)
    return comm


def _on_rank_zero(comm, check, *args):
    """``check(*args)`` on rank 0 only (a file check that rank 0's own output would
    otherwise change); its UsageError is raised on every rank."""
    failure = None
    if comm.rank == 0:
        try:
            check(*args)
        except UsageError as e:
            failure = str(e)
    failure = comm.bcast(failure, root=0)
    if failure is not None:
        raise UsageError(failure)


def cmd_info(args):
    from fsi_sph.config import load_config
    from fsi_sph.scene_checks import check_scene

    cfg = load_config(args.case, args.overrides)
    est = check_scene(cfg, args.case)
    print(f"case file: {args.case}")
    print("physics modules enabled: " + ", ".join(cfg.modules()))
    picks = cfg.numerics_picked()
    print("numerics picked from the declared physics" + (":" if picks else ": none"))
    for pick in picks:
        print(f"  {pick}")
    sim = _build(cfg, args.case)
    _print_scene(cfg, est, sim)
    print("several MPI ranks: " + _ranks_text(sim))
    print("resolved config:")
    print(json.dumps(cfg.model_dump(mode="json"), indent=2))
    return 0


def _print_scene(cfg, est, sim):
    """Particles per body, memory, first stable step and steps to t_end of the built scene."""
    from fsi_sph.scene_checks import machine_memory, size_text

    counts = {name: o.body.n for name, o in sim.bodies().items()}
    if sim.fluid is not None and sim.fluid.walls is not None:
        counts["walls"] = sim.fluid.walls.body.n
    print("particles: " + ", ".join(f"{k} {n}" for k, n in counts.items())
          + f" (total {sum(counts.values())})")
    if sim.fluid is not None and sim.fluid.open is not None:
        print("free surface: " + (
            "none (confined: the fluid fills its channel at the start and an outflow holds "
            "the pressure; every row a Poisson row, the density relaxation on every row "
            "away from the walls)" if sim.fluid.confined else
            "detected each step (the fluid has a free surface at the start, or no outflow)"))
    print(f"memory estimate: {size_text(est.memory)} (this machine: "
          f"{size_text(machine_memory())})")
    dt = sim.stable_dt()
    subs = {n: max(1, math.ceil(dt / b.stable_dt() - 1e-12)) for n, b in sim.structures.items()}
    print(f"first stable time step: {dt:.3g} s"
          + (" (sub-steps: " + ", ".join(f"{n} {k}" for n, k in subs.items()) + ")"
             if subs and sim.fluid is not None else ""))
    for name, body in sim.structures.items():
        _print_frequencies(name, body)
    dt_flow, why = _flow_step(sim, dt)
    print(f"steps to t_end = {cfg.case.t_end:g} s: about {math.ceil(cfg.case.t_end / dt_flow)} "
          f"({why})")


def _print_frequencies(name, body):
    """An elastic body's lowest natural frequencies in vacuum (fsi_sph/solid/modes.py): the
    time scales its sub-steps and the output interval must resolve."""
    from fsi_sph.solid.modes import MAX_MODAL_PARTICLES, natural_frequencies, particles_through
    from fsi_sph.solid.tlsph import ElasticBody

    if not isinstance(body, ElasticBody):  # (a soil body)
        return
    across = particles_through(body.body["x0"], math.sqrt(float(body.body["vol"][0])))
    if across < 4:
        print(f"solid.{name}: {across} particles through it: its bending is poorly resolved "
              f"(4 or more needed; with 2 the Turek-Hron flag is 32 % too stiff: "
              f"docs/numerics/solid.md § Natural modes)")
    f = natural_frequencies(body)
    if f is not None:
        print(f"solid.{name}: lowest natural frequencies in vacuum "
              + ", ".join(f"{v:.4g}" for v in f) + " Hz (about the initial shape)")
    elif body.body.n > MAX_MODAL_PARTICLES:
        print(f"solid.{name}: natural frequencies not computed ({body.body.n} particles, "
              f"above {MAX_MODAL_PARTICLES})")


def _ranks_text(sim):
    """What `mpiexec -n P fsi-sph run` does with this scene (fsi_sph/parallel/ranks.py)."""
    from fsi_sph.parallel.ranks import engine_text, halo_supports, not_split

    missing = not_split(sim)
    if missing:
        return "refused, runs on one rank only (not split yet: " + "; ".join(missing) + ")"
    if sim.fluid is None:
        return (f"the soils split into strips, a halo of {halo_supports(sim)} kernel supports")
    return (f"the fluid split into strips, a halo of {halo_supports(sim)} kernel supports, "
            f"{engine_text()}")


def _flow_step(sim, dt):
    """The fluid's advective step once it flows at the speed of its own height falling,
    ``sqrt(2 g H)`` (the dam break's front runs at about this speed), for the step estimate."""
    fluid = sim.fluid
    if fluid is None or fluid.body.n == 0:
        return dt, "at the first step"
    g = math.hypot(*(float(c) for c in fluid.gravity))
    y = fluid.body["x"][:, 1]
    u = math.sqrt(2.0 * g * float(y.max() - y.min()))
    if u <= 0.0:
        return dt, "at the first step"
    return min(dt, fluid.advective_dt(u)), (
        f"an estimate: the step of a flow at {u:.2g} m/s, the fluid's height falling")


def cmd_plot(args):
    from fsi_sph.plotting import plot_run

    path = Path(args.run_file)
    if not path.is_file():
        raise UsageError(f"{path}: no such run file")
    out = Path(args.out) if args.out else path.parent / "plots"
    if args.movie:
        from fsi_sph.movie import write_movie

        if args.fps < 1:
            raise UsageError(f"--fps {args.fps}: must be >= 1")
        log.info("wrote %s", write_movie(path, out, field=args.field, fps=args.fps))
        return 0
    files = plot_run(path, out, field=args.field, max_snapshots=args.max_snapshots,
                     data_dir=args.data)
    for f in files:
        log.info("wrote %s", f)
    return 0


def available_validations():
    """Modules of validation/ that define ``validate()`` (helpers and benchmarks do not)."""
    return sorted(p.stem for p in VALIDATION_DIR.glob("*.py")
                  if not p.stem.startswith("_")
                  and "\ndef validate(" in p.read_text(encoding="utf-8"))


def _load_validation(name):
    path = VALIDATION_DIR / f"{name}.py"
    if str(VALIDATION_DIR.parent) not in sys.path:
        sys.path.insert(0, str(VALIDATION_DIR.parent))
    try:  # the package import, so that `validation.X` modules share one identity
        return importlib.import_module(f"validation.{name}")
    except ImportError:
        spec = importlib.util.spec_from_file_location(f"validation.{name}", path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod  # dataclasses and pickling look the module up
        spec.loader.exec_module(mod)
        return mod


def cmd_validate(args):
    names = available_validations()
    if args.report:
        report = _load_validation("report")
        results_root = Path(args.out) if args.out else VALIDATION_DIR / "results"
        results = report.load_results(results_root)
        if not results:
            raise UsageError(f"validate --report: no results in {results_root}/*/result.json; "
                             "run `fsi-sph validate --all [--quick]` first")
        missing = sorted(set(names) - set(results) - {"report"})
        path = report.write_report(results, missing=missing)
        log.info("wrote %s from %d stored results%s", path, len(results),
                 f" (no results yet: {', '.join(missing)})" if missing else "")
        return 0
    if args.all == bool(args.name):
        raise UsageError("validate: give one validation NAME or --all; available: "
                         f"{', '.join(names) or 'none (validation/ folder not found)'}")
    if not args.all and args.name not in names:
        raise UsageError(f"validate {args.name!r}: unknown validation; available: "
                         f"{', '.join(names) or 'none (validation/ folder not found)'}")
    _set_threads(args.threads)
    data = Path(args.data)
    if not data.is_dir():
        log.warning("--data %s: no such folder; validations against experiments will fail",
                    data)
    results_root = Path(args.out) if args.out else VALIDATION_DIR / "results"
    results, failures = {}, {}
    for name in (names if args.all else [args.name]):
        mod = _load_validation(name)
        out = results_root / name if (args.all or not args.out) else Path(args.out)
        log.info("validation %s -> %s", name, out)
        try:
            results[name] = mod.validate(quick=args.quick, data_dir=data, out_dir=out)
        except Exception as e:  # one failed case must not lose the others' results
            if not args.all:
                raise
            log.error("validation %s failed: %s", name, e)
            failures[name] = f"{type(e).__name__}: {e}"
    if args.json_file:
        Path(args.json_file).parent.mkdir(parents=True, exist_ok=True)
        payload = results[args.name] if not args.all else results
        Path(args.json_file).write_text(json.dumps(payload, indent=1))
        log.info("wrote %s", args.json_file)
    if args.all:
        report = _load_validation("report")
        path = report.write_report(results, failures=failures)
        log.info("wrote %s", path)
        return 1 if failures else 0
    return 0


def cmd_fos(args):
    from fsi_sph.strength_reduction import SlopeInputError, fos_command

    _set_threads(args.threads)
    try:
        tol = {} if args.tol is None else {"tol": args.tol}
        return fos_command(args.case, args.body, args.out, args.overrides, args.method, **tol)
    except SlopeInputError as e:
        raise UsageError(str(e)) from None


def _single_threaded_blas():
    """One BLAS thread (unless the user set one): the Krylov loop of the PPE makes many
    short vector operations (dot, norm) for which multi-threaded OpenBLAS only adds
    synchronisation cost; measured 10x slower PPE solves with it on a busy 2-core machine.
    Must run before numpy is first imported, which the CLI only does inside commands."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")


def _quiet_stdout():
    """Point stdout at /dev/null, so that Python's own flush at exit does not raise the
    broken pipe again (the recipe of the Python docs, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # (a stdout without a file descriptor)
        pass


def main(argv=None):
    _single_threaded_blas()

    args = _parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    commands = {"run": cmd_run, "info": cmd_info, "plot": cmd_plot, "validate": cmd_validate,
                "fos": cmd_fos}
    try:
        return commands[args.command](args)
    except (ConfigError, UsageError) as e:
        _say_once(f"fsi-sph: error: {e}")
        return 2
    except MemoryError:
        print("fsi-sph: out of memory: the scene is too large for this machine (see `fsi-sph "
              "info CASE` for its memory estimate; raise case.dx)", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fsi-sph: interrupted; the output file keeps every snapshot written so far",
              file=sys.stderr)
        return 130
    except BrokenPipeError:  # `fsi-sph info CASE | head`: the reader has what it wanted
        _quiet_stdout()
        return 141  # the shell's code for a pipe closed by its reader (128 + SIGPIPE)
    except Exception as e:  # a failed run: say what happened, no traceback unless asked

        if isinstance(e, SimulationError):
            _say_once(f"fsi-sph: run failed: {e}")
            return 1
        raise


def _say_once(message):
    """``message`` to stderr from rank 0 only when several MPI ranks run the command: the
    input errors and the run's failures are found by every rank alike."""
    from fsi_sph.parallel.comm import launched_rank

    if launched_rank() == 0:
        print(message, file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
