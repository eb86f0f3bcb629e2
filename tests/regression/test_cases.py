"""Every case file runs a few steps at a coarse resolution without NaN; one subprocess smoke
test of the installed console script."""

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

CASES = sorted((Path(__file__).resolve().parents[2] / "cases").glob("*.toml"))
#: coarse resolution per case for the smoke runs
COARSE = {"oscillating_plate": 0.004, "turek_hron_fsi2": 0.01}


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_case_runs(case):
    over = [f"case.dx={COARSE[case.stem]}"] if case.stem in COARSE else []
    sim = Simulation(load_config(case, over))
    s = sim.run(out_dir=None, max_steps=20, progress=False)
    assert s["steps"] == 20
    sim.check()


def test_cli_smoke(tmp_path):
    """``fsi-sph run`` with no case runs the default scene (here cut to 5 steps)."""
    out = tmp_path / "run"
    p = subprocess.run([sys.executable, "-m", "fsi_sph", "run", "--max-steps", "5",
                        "--set", "case.dx=0.0025", "--out", str(out), "--no-progress"],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "stopped at max_steps = 5" in p.stderr
    with h5py.File(out / "run.h5", "r") as f:
        assert f["timing"].attrs["steps"] == 5
        assert f.attrs["case_file"].endswith("dam_break_elastic_gate.toml")
        assert np.isfinite(f["probes/gate_tip"][()]).all()
