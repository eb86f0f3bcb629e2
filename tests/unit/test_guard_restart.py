"""Blow-up guard (NaN, domain, energy) with a last good snapshot; restart bit for bit."""

import h5py
import numpy as np
import pytest

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.errors import SimulationError
from fsi_sph.output import read_probe, read_restart
from fsi_sph.simulation import Simulation
from fsi_sph.solid.tlsph import ElasticBody

CASE = """
[case]
t_end = 0.01
dx = 0.01
output_every = 0.002
gravity = [0.0, -9.81]
[solid.bar]
material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.04] }]
clamp = [{ origin = [0.0, 0.0], size = [0.03, 0.04] }]
initial_velocity = { profile = "cantilever_mode", root_x = 0.03, length = 0.17, tip_speed = 0.5 }
[[probes]]
name = "tip"
kind = "point_displacement"
body = "bar"
at = [0.2, 0.02]
"""


@pytest.fixture
def case_file(tmp_path):
    p = tmp_path / "bar.toml"
    p.write_text(CASE)
    return p


def test_particle_leaving_domain(case_file, tmp_path):
    cfg = load_config(case_file, ["guard.domain={origin=[-0.1,-0.1],size=[0.4,0.2]}",
                                  "case.gravity=[0.0,0.0]", "solid.bar.clamp=[]",
                                  # the whole bar flies off upwards
                                  'solid.bar.initial_velocity={profile="uniform",value=[0,20.0]}'])
    sim = Simulation(cfg)
    with pytest.raises(SimulationError, match=r"left the domain at t = .*body 'bar', particle"):
        sim.run(out_dir=tmp_path / "o", progress=False)
    with h5py.File(tmp_path / "o" / "run.h5", "r") as f:
        assert f.attrs["status"].startswith("failed: particle left the domain")
        last = f["snapshots"][sorted(f["snapshots"])[-1]]
        assert last.attrs.get("last_good") == 1
        assert (last["bar/x"][()][:, 1] <= 0.1).all()  # the saved state is still inside


def test_runaway_energy(case_file, tmp_path, monkeypatch):
    """Velocities growing 30 % a sub-step: stopped by the energy bound, with a diagnostic, and a
    last good snapshot that is finite and earlier than the failure."""
    substeps = ElasticBody.substeps

    def unstable(self, dt, n):
        for _ in range(n):
            substeps(self, dt, 1)
            self.body["v"] *= 1.3

    monkeypatch.setattr(ElasticBody, "substeps", unstable)
    sim = Simulation(load_config(case_file))
    with pytest.raises(SimulationError, match=r"kinetic energy .* past the bound .* fastest "
                                              r"particle \d+ at speed"):
        sim.run(out_dir=tmp_path / "o", progress=False)
    with h5py.File(tmp_path / "o" / "run.h5", "r") as f:
        last = f["snapshots"][sorted(f["snapshots"])[-1]]
        assert last.attrs.get("last_good") == 1
        assert np.isfinite(last["bar/v"][()]).all()
        t_good = last.attrs["t"]
    assert 0 < t_good < sim.t
    clock, state = read_restart(tmp_path / "o" / "run.h5")
    assert clock["t"] == t_good  # the restart state is the last good one
    assert np.isfinite(state["bar"]["v"]).all()


def test_restart_is_bit_identical(case_file, tmp_path, capsys):
    """A run stopped after 23 steps and restarted from its file (from its last scheduled
    snapshot, the restart point) ends exactly where an uninterrupted run ends: every array
    and every probe sample equal bit for bit."""
    full = Simulation(load_config(case_file))
    full.run(out_dir=tmp_path / "full", progress=False)

    assert main(["run", str(case_file), "--out", str(tmp_path / "part"), "--max-steps", "23",
                 "--no-progress"]) == 0
    part = tmp_path / "part" / "run.h5"
    with h5py.File(part, "r") as f:
        snap_steps = [int(g.attrs["step"]) for g in f["snapshots"].values()]
    assert read_restart(part)[0]["step"] == max(s for s in snap_steps if s < 23)
    assert main(["run", "--restart", str(part), "--no-progress"]) == 0  # stored config

    clock, state = read_restart(part)
    assert clock["step"] == full.n_steps and clock["t"] == full.t
    for k, v in full.structures["bar"].body.arrays.items():
        np.testing.assert_array_equal(state["bar"][k], v, err_msg=k)
    t_full, c_full = read_probe(tmp_path / "full" / "run.h5", "tip")
    t_part, c_part = read_probe(part, "tip")
    np.testing.assert_array_equal(t_part, t_full)
    np.testing.assert_array_equal(c_part["uy"], c_full["uy"])
    with h5py.File(part, "r") as f:
        assert f.attrs["status"] == "completed"
        assert f["steps"].shape[0] == full.n_steps


def test_restart_bad_input(case_file, tmp_path, capsys):
    assert main(["run", "--restart", str(tmp_path / "none.h5")]) == 2
    (tmp_path / "junk.h5").write_text("not hdf5")
    assert main(["run", "--restart", str(tmp_path / "junk.h5")]) == 2
    Simulation(load_config(case_file)).run(out_dir=tmp_path / "a", progress=False, max_steps=3)
    other = case_file.read_text().replace("size = [0.2, 0.04]", "size = [0.3, 0.04]")
    (tmp_path / "other.toml").write_text(other)
    assert main(["run", str(tmp_path / "other.toml"), "--restart",
                 str(tmp_path / "a" / "run.h5"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "shape" in err


def test_loading_a_state_with_another_number_of_periodic_images():
    """The periodic images come and go between steps, so a saved ``p_all`` (fluid, walls,
    images) may be longer or shorter than the scene's: the guard's last-good write and a
    restart load the fluid and wall part (a periodic run that failed used to end in a
    traceback here instead of writing its last good state)."""
    import numpy as np

    from fsi_sph.config import load_config
    from fsi_sph.simulation import Simulation

    text = """
[case]
t_end = 0.01
dx = 0.05
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.5, 0.3] }]
periodic_x = [0.0, 0.5]
[walls]
boxes = [{ origin = [0.0, -0.15], size = [0.5, 0.15] }]
"""
    sim = Simulation(load_config(None, text=text))
    sim.step()
    fluid = sim.fluid
    n = fluid.nf + fluid.n_walls
    for extra in (1, -1):
        saved = np.arange(len(fluid.p_all) + extra, dtype=float)
        fluid.load_extra_state({"p_all": saved})
        assert np.array_equal(fluid.p_all[:n], saved[:n])
        assert np.array_equal(fluid.walls.body["p"], saved[fluid.nf:n])


DAM = """
[case]
t_end = 0.01
dx = 0.005
output_every = 0.005
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.2] }]
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.6, 0.4] }]
"""


def test_a_pressure_solve_that_fails_ends_the_run_as_failed(tmp_path, capsys):
    """A PPE that misses its tolerance (here: one iteration allowed; 1 900 rows, more than
    the coarsest level's direct solve takes) is a failed run like a
    guard's stop: exit 1, one line that says what failed and when, no traceback, the file's
    status "failed" and the state before the failed step to restart from (it raised a bare
    RuntimeError before, and the run file said "completed")."""
    case = tmp_path / "dam.toml"
    case.write_text(DAM)
    out = tmp_path / "o"
    rc = main(["run", str(case), "--no-progress", "--out", str(out),
               "--set", "fluid.ppe.maxiter=1", "--set", "fluid.ppe.rebuild_every=1"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "Traceback" not in err
    assert "PPE: no convergence in 1 iterations" in err and "in the step from t = 0 s" in err
    with h5py.File(out / "run.h5", "r") as f:
        assert f.attrs["status"].startswith("failed: PPE: no convergence")
    clock, state = read_restart(out / "run.h5")  # the state before the failed step
    assert clock["t"] == 0.0 and np.isfinite(state["fluid"]["x"]).all()
