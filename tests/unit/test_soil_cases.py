"""Every soil case file loads and runs a few steps from the file alone (coarse dx)."""

from pathlib import Path

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

CASES = Path(__file__).resolve().parents[2] / "cases"
COARSE = {"column_collapse": 0.01, "slope_1_granular": 0.1, "slope_2_cohesive": 1.0,
          "slope_3_cohesive_layer": 1.5}


@pytest.mark.parametrize("name", sorted(COARSE))
def test_soil_case_runs(name, tmp_path):
    cfg = load_config(CASES / f"{name}.toml", [f"case.dx={COARSE[name]}"])
    assert any(m.startswith("drucker_prager_soil") for m in cfg.modules())
    sim = Simulation(cfg)
    s = sim.run(out_dir=tmp_path, max_steps=5, progress=False)
    assert s["steps"] == 5
    for body in sim.structures.values():
        assert np.isfinite(body.body["x"]).all() and np.isfinite(body.body["sigma"]).all()
    assert (tmp_path / "run.h5").exists()
