"""HDF5 run file: round trip of config, static fields, snapshots, probes, timing; XDMF
sidecar; a failed or interrupted run still leaves a readable file that says why."""

import json
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.errors import SimulationError
from fsi_sph.output import read_probe
from fsi_sph.simulation import Simulation
from fsi_sph.solid.tlsph import ElasticBody

CASE = """
[case]
t_end = 0.004
dx = 0.01
output_every = 0.001
gravity = [0.0, -9.81]
[solid.bar]
material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.04] }]
clamp = [{ origin = [0.0, 0.0], size = [0.03, 0.04] }]
[[probes]]
name = "tip"
kind = "point_displacement"
body = "bar"
at = [0.2, 0.02]
[[probes]]
name = "energy"
kind = "energy"
body = "bar"
"""


@pytest.fixture
def case_file(tmp_path):
    p = tmp_path / "bar.toml"
    p.write_text(CASE)
    return p


def test_round_trip(case_file, tmp_path):
    cfg = load_config(case_file)
    sim = Simulation(cfg)
    s = sim.run(out_dir=tmp_path / "out", progress=False, case_file=str(case_file))
    assert s["status"] == "completed" and s["particle_steps_per_s"] > 0
    path = tmp_path / "out" / "run.h5"
    with h5py.File(path, "r") as f:
        assert json.loads(f.attrs["config"]) == json.loads(cfg.to_json())
        assert f.attrs["status"] == "completed"
        assert "numba" in json.loads(f.attrs["versions"])
        st = f["bodies/bar/static"]
        np.testing.assert_array_equal(st["x0"][()], sim.structures["bar"].body["x0"])
        assert st["clamped"][()].sum() == 3 * 4
        snaps = sorted(f["snapshots"])
        assert len(snaps) == 5  # t = 0, 1, 2, 3, 4 ms
        last = f["snapshots"][snaps[-1]]
        assert abs(last.attrs["t"] - 0.004) < 1e-12
        np.testing.assert_array_equal(last["bar/x"][()], sim.structures["bar"].body["x"])
        assert {"x", "v", "u", "sigma", "von_mises", "J"} <= set(last["bar"])
        assert f["timing"].attrs["steps"] == sim.n_steps
        assert f["timing"].attrs["solid_s"] > 0
        assert f["steps"].shape == (sim.n_steps, 3)
    t, cols = read_probe(path, "tip")
    assert t[0] == 0.0 and abs(t[-1] - 0.004) < 1e-12 and len(t) == sim.n_steps + 1
    assert cols["uy"][-1] < 0  # sags under gravity
    # XDMF: every referenced dataset exists in the .h5
    root = ET.parse(path.with_suffix(".xmf")).getroot()
    items = [d.text for d in root.iter("DataItem")]
    assert items
    with h5py.File(path, "r") as f:
        for item in items:
            fname, ds = item.split(":")
            assert fname == "run.h5" and ds in f


def fault_after_substep(monkeypatch, count, fault):
    """The elastic bodies' sub-steps, with ``fault(body)`` called after the ``count``-th."""
    calls = {"n": 0}
    substeps = ElasticBody.substeps

    def patched(self, dt, n):
        for _ in range(n):
            substeps(self, dt, 1)
            calls["n"] += 1
            if calls["n"] == count:
                fault(self)

    monkeypatch.setattr(ElasticBody, "substeps", patched)


def test_failed_run_keeps_readable_file(case_file, tmp_path, monkeypatch, capsys):
    """A NaN injected at the 6th sub-step: the CLI exits 1 with time, step, body, particle and
    quantity; the file is readable, says why, and keeps the snapshots written before."""
    def nan(body):
        body.body["v"][7, 1] = np.nan

    fault_after_substep(monkeypatch, 6, nan)
    out = tmp_path / "fail"
    rc = main(["run", str(case_file), "--out", str(out), "--no-progress",
               "--set", "case.probe_every=0.0"])
    assert rc == 1
    err = capsys.readouterr().err
    assert "run failed" in err and "particle 7" in err and "'bar'" in err and "v" in err
    with h5py.File(out / "run.h5", "r") as f:
        assert f.attrs["status"].startswith("failed") and "particle 7" in f.attrs["status"]
        assert len(f["snapshots"]) >= 1
        assert f["probes/tip"].shape[0] >= 1


def test_interrupted_run_keeps_readable_file(case_file, tmp_path, monkeypatch):
    def interrupt(body):
        raise KeyboardInterrupt

    fault_after_substep(monkeypatch, 20, interrupt)
    sim = Simulation(load_config(case_file))
    with pytest.raises(KeyboardInterrupt):
        sim.run(out_dir=tmp_path / "int", progress=False)
    with h5py.File(tmp_path / "int" / "run.h5", "r") as f:
        assert "interrupted" in f.attrs["status"]
        assert len(f["snapshots"]) >= 1


def test_guard_names_particle(case_file):
    sim = Simulation(load_config(case_file))
    sim.structures["bar"].body["x"][3, 0] = np.inf
    with pytest.raises(SimulationError, match="non-finite x .* body 'bar', particle 3"):
        sim.check()


def test_plot(case_file, tmp_path):
    Simulation(load_config(case_file)).run(out_dir=tmp_path / "o", progress=False)
    assert main(["plot", str(tmp_path / "o" / "run.h5"), "--max-snapshots", "2"]) == 0
    pngs = sorted(p.name for p in (tmp_path / "o" / "plots").glob("*.png"))
    assert pngs == ["probe_energy.png", "probe_tip.png", "snapshot_0000.png", "snapshot_0004.png"]
    assert main(["plot", str(tmp_path / "o" / "run.h5"), "--field", "nope"]) == 2
