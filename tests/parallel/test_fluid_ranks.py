"""Scenes split over MPI ranks (fsi_sph/parallel/ranks.py): the dam break on 2, 3 and 4
ranks, the Poiseuille channel (open boundaries) on 2 and 3, the elastic gate, Turek-Hron
FSI2, the soil column, the granular collapse, a free body, a shaken tank and a mu(I) heap on
2 are the serial run bit for bit (fluid_checks.py under mpiexec), a
halo thinner than the step's chain of neighbour operators is not, and scenes that are not
split yet are refused with their reason."""

import json
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.errors import SimulationError
from fsi_sph.parallel import petsc_ppe
from fsi_sph.parallel.ranks import check_scene
from fsi_sph.simulation import Simulation
from tests.parallel.launch import ROOT, run_mpi

CHECKS = Path(__file__).with_name("fluid_checks.py")
TIMEOUT = 300


def run_checks(nprocs, *args):
    done = run_mpi(nprocs, CHECKS, [str(a) for a in args], TIMEOUT)
    return done.returncode, done.stdout + done.stderr


@pytest.mark.parametrize("nprocs, steps", [(2, 150), (3, 150), (4, 60)])
def test_dam_break_on_ranks_is_the_serial_run_bit_for_bit(nprocs, steps):
    """At dx 0.04 (150 steps: to t = 0.41 s, the column has collapsed onto the floor, the
    strips were cut anew several times; on 4 ranks the strips would be thinner
    than two halos, so boxes by recursive bisection): every field of every fluid particle
    and the walls' pressure equal to the serial run's in every bit."""
    code, out = run_checks(nprocs, "--steps", steps, "--dx", 0.04, "--identical")
    assert code == 0, out
    assert "identical True" in out and "rebalanced 0," not in out, out
    # the owners change only when a particle strays a support outside its strip (measured
    # on 2 ranks: 8 of 150 steps), so PETSc keeps its row layout in between
    migrated = int(re.search(r"migrated (\d+) of", out).group(1))
    assert 0 < migrated < steps // 3, out


@pytest.mark.skipif(not petsc_ppe.available(), reason="petsc4py not installed")
def test_dam_break_on_ranks_with_petsc_is_the_serial_run_within_the_solver_tolerance():
    """The PPE solved by PETSc over 2 ranks (BoomerAMG, another preconditioner than the
    serial pyamg): after 150 steps every position within 1e-7 of the domain's size (5 m) of
    the serial run's (measured 2.2e-7 m) and the clock within 1e-7 of it."""
    code, out = run_checks(2, "--steps", 150, "--dx", 0.04, "--ppe", "petsc")
    assert code == 0 and "(petsc)" in out, out


@pytest.mark.skipif(not petsc_ppe.available(), reason="petsc4py not installed")
def test_channel_on_ranks_with_petsc_is_the_serial_run_within_the_solver_tolerance():
    """The Poiseuille channel's PPE solved by PETSc over 2 ranks, its rows renumbered as
    particles come and go (150 steps): every position within 1e-7 of the channel's 0.58 m
    of the serial run's (measured 1.9e-8 m) and the clock within 1e-7 of it."""
    code, out = run_checks(2, "--case", "channel_poiseuille.toml", "--steps", 150, "--dx",
                           0.01, "--ppe", "petsc", "--size", 0.58)
    assert code == 0 and "(petsc)" in out, out


def test_elastic_gate_on_ranks_is_the_serial_run_bit_for_bit():
    """The dam break through the elastic gate (dx 2 mm) on 2 ranks over 100 steps: the gate
    whole on every rank, each of its particles' interface force from the rank that owns it;
    every field of the fluid, the walls' pressure and the gate equal to the serial run's."""
    code, out = run_checks(2, "--case", "dam_break_elastic_gate.toml", "--steps", 100,
                           "--dx", 0.002, "--identical")
    assert code == 0 and "identical True" in out, out


def test_soil_column_on_ranks_is_the_serial_run_bit_for_bit():
    """The soil column (Drucker-Prager, 3 200 particles) on 2 ranks over 300 sub-steps:
    every field of every particle equal to the serial run's in every bit (the neighbour
    search's cell grid is the serial run's on every rank: without it the sums over
    neighbours came in another order, 5e-15 Pa apart in the stress after one step)."""
    code, out = run_checks(2, "--case", "column_collapse.toml", "--steps", 300, "--dx",
                           0.0025, "--identical")
    assert code == 0 and "identical True" in out, out


ZOO = ROOT / "validation" / "scene_zoo"
SINKING = ZOO / "sinking_body.toml"


@pytest.mark.parametrize("scene, dx", [("sinking_body", 0.006), ("baffle_shaken", 0.01),
                                       ("mui_heap_on_slope", 0.004)])
def test_zoo_scene_on_ranks_is_the_serial_run_bit_for_bit(scene, dx):
    """Over 60 steps on 2 ranks, every field of fluid, walls and structure equal to the
    serial run's: the zoo's sinking block (a free body, 2.5 times water's density, in the
    middle of the tank: its particles on both sides of the cut), whose PPE's rigid-body
    terms are put together from both ranks in the serial order
    (fsi_sph/parallel/low_rank.py; summed per rank instead, the run left the serial one by
    1.2e-2 m in 60 steps), the shaken tank with its elastic baffle (the frame's body
    force from the clock), and the mu(I) heap on a slope (incremental projection, implicit
    viscous step gathered to rank 0)."""
    code, out = run_checks(2, "--case", ZOO / f"{scene}.toml", "--steps", 60, "--dx", dx,
                           "--identical")
    assert code == 0 and "identical True" in out, out


@pytest.mark.skipif(not petsc_ppe.available(), reason="petsc4py not installed")
def test_free_body_on_ranks_with_petsc_is_the_serial_run_within_the_solver_tolerance():
    """The sinking block with the PPE in PETSc (``A + U G`` as PETSc's low-rank-correction
    matrix) over 20 steps: positions within 1e-7 of 5 m of the serial run's (measured
    3.8e-8 m; the serial run with rtol 1e-7 instead of 1e-6 moves by 3.9e-8 m in 20 steps,
    and by 1.2e-2 m in 60: this scene amplifies the solver's tolerance, so the check is
    short)."""
    code, out = run_checks(2, "--case", SINKING, "--steps", 20, "--dx", 0.006, "--ppe",
                           "petsc")
    assert code == 0 and "(petsc)" in out, out


def test_granular_collapse_on_ranks_is_the_serial_run_bit_for_bit():
    """The granular collapse (mu(I), incremental projection, the implicit viscous step with
    the stress operator gathered to rank 0; 3 200 particles) on 2 ranks over 100 steps with
    its default halo of 6 supports: every field equal to the serial run's. (With 4 supports
    the positions differed by 6e-14 m: this step reads neighbours' results more times over
    than the Newtonian one.)"""
    code, out = run_checks(2, "--case", "granular_collapse.toml", "--steps", 100, "--dx",
                           0.0025, "--identical")
    assert code == 0 and "identical True" in out, out


def test_a_halo_of_one_support_is_not_enough():
    """The comparison can fail: with a halo of one kernel support the ghosts' truncated
    supports reach the owned particles within the step (measured: positions off by 2.6e-6 m
    after 40 steps at dx 0.02; docs/parallel.md)."""
    code, out = run_checks(2, "--steps", 40, "--dx", 0.04, "--halo", 1, "--identical")
    assert code == 1 and "identical False" in out, out


@pytest.mark.parametrize("nprocs, steps", [(2, 150), (3, 200)])
def test_channel_with_open_boundaries_on_ranks_is_the_serial_run_bit_for_bit(nprocs, steps):
    """The Poiseuille channel (dx 0.01, an inflow and an outflow; strips cut anew as the
    count changes): particles created at the inflow and deleted at the outflow on the ranks
    that hold them, global ids renumbered as the serial rows are; every field of every fluid
    particle, the walls' pressure and the buffers (positions, velocities, which outflow)
    equal to the serial run's in every bit."""
    code, out = run_checks(nprocs, "--case", "channel_poiseuille.toml", "--steps", steps,
                           "--dx", 0.01, "--identical")
    assert code == 0 and "identical True" in out, out
    owned = [int(n) for n in re.search(r"owned \[([\d, ]+)\]", out).group(1).split(",")]
    assert sum(owned) != 486, out  # (486 at the start: particles came and went)


def test_turek_hron_fsi2_on_ranks_is_the_serial_run_bit_for_bit():
    """The Turek-Hron FSI2 channel (D/dx 10: the elastic flag whole on every rank, its rows
    after the buffers', whose count changes) on 2 ranks over 60 steps: fluid, walls, buffers
    and flag equal to the serial run's in every bit (with the deeper halo of an open fluid:
    4 supports parted from the serial run at step 50)."""
    code, out = run_checks(2, "--case", "turek_hron_fsi2.toml", "--steps", 60, "--dx", 0.01,
                           "--identical")
    assert code == 0 and "identical True" in out, out


@pytest.mark.parametrize("case, sets, reason", [
    ("cases/oscillating_plate.toml", ["case.dx=0.004"], "structures without a fluid (plate)"),
    ("cases/bagnold.toml", [], "periodic fluid"),
])
def test_scenes_not_split_yet_are_refused(case, sets, reason, capsys):
    sim = Simulation(load_config(ROOT / case, sets))
    with pytest.raises(SimulationError, match="not yet on several MPI ranks") as err:
        check_scene(sim)
    assert reason in str(err.value)
    assert main(["info", str(ROOT / case), *[a for kv in sets for a in ("--set", kv)]]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines()
                if ln.startswith("several MPI ranks:"))
    assert line == ("several MPI ranks: refused, runs on one rank only (not split yet: "
                    f"{reason})"), line


def physical_datasets(path):
    """Every dataset of a run file but the wall-time columns of the step table, by name."""
    out = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            out[name] = obj[()]
    with h5py.File(path, "r") as f:
        f.visititems(visit)
        columns = json.loads(f["steps"].attrs["columns"])
    timed = [i for i, c in enumerate(columns) if c.endswith("_s")]
    out["steps"] = np.delete(out["steps"], timed, axis=1)
    return out


def test_run_on_two_ranks_writes_the_serial_run_file_and_restarts_across_ranks(tmp_path):
    """`mpiexec -n 2 fsi-sph run` writes the serial run's file (every snapshot, probe and
    step row equal, wall times aside); a run stopped on 2 ranks past a snapshot and
    restarted on 1 ends where the uninterrupted serial run does, bit for bit."""
    sets = ["--set", "case.dx=0.04", "--set", "case.t_end=0.15", "--no-progress",
            "--ppe", "gather"]
    case = str(ROOT / "cases" / "dam_break.toml")
    assert main(["run", case, "--out", str(tmp_path / "one"), *sets]) == 0
    done = run_mpi(2, "-m", ["fsi_sph", "run", case, "--out", str(tmp_path / "two"), *sets],
                   TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    one = physical_datasets(tmp_path / "one" / "run.h5")
    two = physical_datasets(tmp_path / "two" / "run.h5")
    assert sorted(one) == sorted(two)
    assert [k for k in one if not np.array_equal(one[k], two[k])] == []
    done = run_mpi(2, "-m", ["fsi_sph", "run", case, "--out", str(tmp_path / "cut"),
                             "--max-steps", "30", *sets], TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert main(["run", "--restart", str(tmp_path / "cut" / "run.h5"), "--no-progress",
                 "--ppe", "gather"]) == 0
    cut = physical_datasets(tmp_path / "cut" / "run.h5")
    last = max(k for k in one if k.startswith("snapshots/") and k.endswith("fluid/x"))
    assert cut[last].shape == one[last].shape and np.array_equal(cut[last], one[last])


def serial_two_and_cut(tmp_path, case, sets, cut_steps):
    """The serial run (``one``), the run on 2 ranks (``two``) and a run on 2 ranks stopped
    at ``cut_steps`` (``cut``) of ``case`` under ``tmp_path``."""
    assert main(["run", case, "--out", str(tmp_path / "one"), *sets]) == 0
    for name, extra in (("two", []), ("cut", ["--max-steps", str(cut_steps)])):
        done = run_mpi(2, "-m", ["fsi_sph", "run", case, "--out", str(tmp_path / name),
                                 *sets, *extra], TIMEOUT)
        assert done.returncode == 0, done.stdout + done.stderr


def test_open_channel_run_on_two_ranks_writes_the_serial_run_file_and_restarts(tmp_path):
    """The Poiseuille channel (dx 0.01, to 1.5 s) on 2 ranks writes the serial run's file
    (snapshots of changing size, the step table's fluid count and mass fluxes, probes), and
    a run stopped on 2 ranks restarts on 2 to the serial run's snapshots, bit for bit."""
    sets = ["--set", "case.dx=0.01", "--set", "case.t_end=1.5", "--no-progress", "--ppe",
            "gather"]
    serial_two_and_cut(tmp_path, str(ROOT / "cases" / "channel_poiseuille.toml"), sets, 50)
    done = run_mpi(2, "-m", ["fsi_sph", "run", "--restart", str(tmp_path / "cut" / "run.h5"),
                             "--no-progress", "--ppe", "gather"], TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    one = physical_datasets(tmp_path / "one" / "run.h5")
    two = physical_datasets(tmp_path / "two" / "run.h5")
    cut = physical_datasets(tmp_path / "cut" / "run.h5")
    assert sorted(one) == sorted(two)
    assert [k for k in one if not np.array_equal(one[k], two[k])] == []
    sizes = {one[k].shape for k in one if k.startswith("snapshots/") and k.endswith("fluid/x")}
    assert len(sizes) > 1  # (the count changed)
    later = [k for k in one if k.startswith(("snapshots/", "xdmf/")) and "fluid" in k]
    assert [k for k in later if not np.array_equal(one[k], cut[k])] == []


def test_granular_run_on_two_ranks_writes_the_serial_run_file(tmp_path):
    """The granular collapse's run file on 2 ranks is the serial run's (wall times aside),
    its step table's time-step limits included (each reduced over the ranks), and a run
    stopped on 2 ranks restarts on 1 to the serial run's last snapshot (the incremental
    projection's carried increment in the restart state)."""
    sets = ["--set", "case.dx=0.005", "--set", "case.t_end=0.2", "--no-progress", "--ppe",
            "gather"]
    serial_two_and_cut(tmp_path, str(ROOT / "cases" / "granular_collapse.toml"), sets, 40)
    assert main(["run", "--restart", str(tmp_path / "cut" / "run.h5"), "--no-progress",
                 "--ppe", "gather"]) == 0
    one = physical_datasets(tmp_path / "one" / "run.h5")
    two = physical_datasets(tmp_path / "two" / "run.h5")
    assert [k for k in one if not np.array_equal(one[k], two[k])] == []
    cut = physical_datasets(tmp_path / "cut" / "run.h5")
    last = max(k for k in one if k.startswith("snapshots/") and k.endswith("fluid/x"))
    assert np.array_equal(cut[last], one[last])


def test_one_rank_under_mpiexec_is_the_serial_run(tmp_path):
    """`mpiexec -n 1 fsi-sph run` is the serial run (no split, no gathered solve): the same
    run file, wall times aside."""
    sets = ["--set", "case.dx=0.04", "--set", "case.t_end=0.1", "--no-progress"]
    case = str(ROOT / "cases" / "dam_break.toml")
    assert main(["run", case, "--out", str(tmp_path / "plain"), *sets]) == 0
    done = run_mpi(1, "-m", ["fsi_sph", "run", case, "--out", str(tmp_path / "one"), *sets],
                   TIMEOUT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "split over" not in done.stdout + done.stderr
    plain = physical_datasets(tmp_path / "plain" / "run.h5")
    one = physical_datasets(tmp_path / "one" / "run.h5")
    assert sorted(plain) == sorted(one)
    assert [k for k in plain if not np.array_equal(plain[k], one[k])] == []


def test_errors_on_several_ranks_are_printed_once(tmp_path):
    """A scene that is not split yet, and a case file that does not exist, on 2 ranks: exit
    code 2 and the reason printed once (by rank 0; every rank finds it alike)."""
    for case, reason in [(ROOT / "cases" / "bagnold.toml", "periodic fluid"),
                         (tmp_path / "missing.toml", "file not found")]:
        done = run_mpi(2, "-m", ["fsi_sph", "run", str(case), "--out", str(tmp_path / "o"),
                                 "--no-progress"], TIMEOUT)
        assert done.returncode == 2, done.stdout + done.stderr
        assert done.stderr.count("fsi-sph: error:") == 1 and reason in done.stderr, done.stderr


def test_failed_run_on_ranks_says_so_once_and_keeps_the_serial_file(tmp_path, capsys):
    """The dam break with a guard domain that the collapsing column leaves (a particle past
    x = 1.1 m): on 2 ranks the run fails as the serial run does, at the same step with the
    same message, printed once; rank 0's file says why and holds what the serial run's
    holds (the snapshots and the last good state, wall times aside)."""
    sets = ["--set", "case.dx=0.04", "--set", "case.t_end=0.6", "--no-progress", "--ppe",
            "gather", "--set", "guard.domain={origin=[-0.5,-0.5],size=[1.6,3.0]}"]
    case = str(ROOT / "cases" / "dam_break.toml")
    assert main(["run", case, "--out", str(tmp_path / "one"), *sets]) == 1
    serial = [ln for ln in capsys.readouterr().err.splitlines() if "run failed" in ln]
    done = run_mpi(2, "-m", ["fsi_sph", "run", case, "--out", str(tmp_path / "two"), *sets],
                   TIMEOUT)
    assert done.returncode == 1, done.stdout + done.stderr
    failed = [ln for ln in done.stderr.splitlines() if "run failed" in ln]
    assert len(serial) == 1 and failed == serial and "left the domain" in serial[0]
    one = physical_datasets(tmp_path / "one" / "run.h5")
    two = physical_datasets(tmp_path / "two" / "run.h5")
    assert sorted(one) == sorted(two)
    assert [k for k in one if not np.array_equal(one[k], two[k])] == []
    with h5py.File(tmp_path / "two" / "run.h5", "r") as f:
        assert f.attrs["status"].startswith("failed")
