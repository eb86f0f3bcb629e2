"""A restart continues bit for bit, in every family of scene (issue 30): a run stopped with
``--max-steps`` past a scheduled snapshot and restarted from its file ends exactly where an
uninterrupted run ends, every field of every body equal bit for bit, on 1 and on 2 threads.

The restart point is the last scheduled snapshot (``Simulation.run``): there the solvers'
kept AMG hierarchies (the pressure solve's, the implicit viscous step's) are reset, as a
restarted run starts without them. Before, a stop wrote its own state as the restart point
and the restarted run rebuilt a hierarchy the uninterrupted one was still reusing: the dam
break (dx 0.04 m, 0.3 s) ended 1e-9 m and 3e-4 Pa apart."""

from pathlib import Path

import h5py
import numba
import numpy as np
import pytest

from fsi_sph.__main__ import main
from fsi_sph.output import read_restart

CASES = Path(__file__).resolve().parents[2] / "cases"

# family: (case, overrides): a few tens of steps at a coarse spacing, several snapshots
FAMILIES = {
    "fluid": ("dam_break.toml", ["case.dx=0.1", "case.t_end=0.3", "case.output_every=0.1"]),
    "coupled_elastic": ("dam_break_elastic_gate.toml",
                        ["case.dx=0.0025", "case.t_end=0.04", "case.output_every=0.01"]),
    "granular_mu_i": ("granular_collapse.toml",
                      ["case.dx=0.02", "case.t_end=0.08", "case.output_every=0.02"]),
    "drucker_prager_soil": ("column_collapse.toml",
                            ["case.dx=0.01", "case.t_end=0.006", "case.output_every=0.002"]),
    "floating_body": ("floating_box", ["case.dx=0.012", "case.t_end=0.02",
                                       "case.output_every=0.006"]),
}


def _run(args):
    assert main([*args, "--no-progress"]) == 0


def _sets(overrides):
    return [a for o in overrides for a in ("--set", o)]


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("family", list(FAMILIES))
def test_restart_continues_bit_for_bit(family, threads, tmp_path):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"{threads} numba threads not available")
    case, overrides = FAMILIES[family]
    if case == "floating_box":  # no shipped case: the safety net's scene
        from tests.regression.test_bit_identical import FLOATING_BOX

        (tmp_path / "box.toml").write_text(FLOATING_BOX)
        case = str(tmp_path / "box.toml")
    else:
        case = str(CASES / case)
    common = [*_sets(overrides), "--threads", str(threads)]
    _run(["run", case, "--out", str(tmp_path / "full"), *common])
    c_full, s_full = read_restart(tmp_path / "full" / "run.h5")
    with h5py.File(tmp_path / "full" / "run.h5", "r") as f:
        snaps = sorted(int(g.attrs["step"]) for g in f["snapshots"].values())
    # stop past a scheduled snapshot in the middle, between two snapshots
    stop = next(s + 1 for s in snaps[len(snaps) // 2 - 1:] if s + 1 not in snaps)
    last = max(s for s in snaps if s < stop)
    assert 0 < last and stop < snaps[-1], f"too few steps between snapshots: {snaps}"
    _run(["run", case, "--out", str(tmp_path / "part"), "--max-steps", str(stop), *common])
    part = tmp_path / "part" / "run.h5"
    assert read_restart(part)[0]["step"] == last, "the restart point: the last scheduled snapshot"
    _run(["run", "--restart", str(part), "--threads", str(threads)])
    c_part, s_part = read_restart(part)
    assert (c_part["step"], c_part["t"]) == (c_full["step"], c_full["t"])
    assert set(s_part) == set(s_full)
    for body, arrays in s_full.items():
        for k, v in arrays.items():
            np.testing.assert_array_equal(s_part[body][k], v, err_msg=f"{family}: {body}.{k}")


def test_restart_from_the_initial_state_continues_bit_for_bit(tmp_path):
    """A stop before the first scheduled snapshot restarts from the initial state, whose clock
    already names the first output time: before, it held 0, so the restarted run wrote a
    snapshot (and reset the kept pressure hierarchy) one step after the start, which the
    uninterrupted run did not (the channel with a post: 1e-7 m apart after 0.3 s)."""
    case = str(CASES / "dam_break.toml")
    common = _sets(["case.dx=0.1", "case.t_end=0.12", "case.output_every=0.1"])
    _run(["run", case, "--out", str(tmp_path / "full"), *common, "--threads", "1"])
    _run(["run", case, "--out", str(tmp_path / "part"), "--max-steps", "3", *common,
          "--threads", "1"])
    part = tmp_path / "part" / "run.h5"
    clock, _ = read_restart(part)
    assert clock["step"] == 0 and clock["next_out"] == pytest.approx(0.1)
    _run(["run", "--restart", str(part), "--threads", "1"])
    c_full, s_full = read_restart(tmp_path / "full" / "run.h5")
    c_part, s_part = read_restart(part)
    assert c_part["step"] == c_full["step"]
    for body, arrays in s_full.items():
        for k, v in arrays.items():
            np.testing.assert_array_equal(s_part[body][k], v, err_msg=f"{body}.{k}")


def test_a_restarted_run_reports_its_own_throughput(tmp_path):
    """Steps and particle-steps count from t = 0 in a restarted run too, but its throughput is
    its own: before, the particle-steps since t = 0 were divided by the continuation's loop
    time (the FSI2 channel continued from 10 to 15 s reported 5.2e5 instead of 1.9e5)."""
    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    case = CASES / "dam_break.toml"
    overrides = ["case.dx=0.1", "case.t_end=0.3", "case.output_every=0.1"]
    first = Simulation(load_config(case, overrides)).run(
        out_dir=tmp_path, max_steps=25, progress=False, case_file=str(case))
    clock, _ = read_restart(tmp_path / "run.h5")
    assert 0 < clock["step"] < first["steps"]
    sim = Simulation(load_config(case, overrides))
    s = sim.run(progress=False, case_file=str(case), resume=tmp_path / "run.h5")
    assert s["steps_this_run"] == s["steps"] - clock["step"] > 0
    own = s["particle_steps"] - clock["particle_steps"]
    assert 0 < own < s["particle_steps"]
    assert s["particle_steps_per_s"] == pytest.approx(own / s["loop_time_s"], rel=1e-12)
