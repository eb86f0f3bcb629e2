"""Fast versions of the stability rows (validation/stability.py) and its classification."""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from validation import stability

PLATE = stability.PLATE


@pytest.mark.parametrize("over", [
    ["case.dx=0.01", "solid.plate.clamp=[{origin=[-0.02,-0.01],size=[0.02,0.02]}]"],
    ["case.dx=0.004", "solid.plate.material.nu=0.49"],
    ["case.dx=0.004", "solid.plate.material.E=1.99875e10",
     "solid.plate.initial_velocity.tip_speed=57.0088"],
], ids=["two_particles_thick", "nu_0.49", "E_x1e4"])
def test_extreme_plate_runs_bounded(over):
    sim = Simulation(load_config(PLATE, over))
    sim.run(out_dir=None, max_steps=300, progress=False)
    sim.check()  # finite, inside the domain, energy bounded
    tip = sim.probes[0].sample()
    assert np.hypot(tip[0], tip[1]) < 0.05


def test_row_classification(tmp_path):
    rows = [
        stability.Row("ok", PLATE, ["case.dx=0.004", "case.t_end=0.002"], "runs",
                      lambda f: stability.tip_bounded(f, 1.0)),
        stability.Row("stops", PLATE, ["case.dx=0.004", "case.t_end=0.05",
                                       "guard.domain={origin=[-0.03,-0.02],size=[0.25,0.021]}"],
                      "leaves a tight domain", None),
        stability.Row("fails", PLATE, ["case.dx=0.004", "case.t_end=0.002"], "bound too tight",
                      lambda f: stability.tip_bounded(f, 1e-9)),
    ]
    recs = {r.name: stability.run_row(r, False, tmp_path) for r in rows}
    assert recs["ok"]["values"]["status"] == "passed"
    assert recs["ok"]["values"]["n_sub_max"] == 1 and recs["ok"]["values"]["dt_min_s"] > 0
    assert recs["stops"]["values"]["status"] == "stopped"
    assert "left the domain" in recs["stops"]["values"]["cause"]
    assert recs["fails"]["values"]["status"] == "failed"
    assert "tip displacement" in recs["fails"]["values"]["cause"]


def test_fluid_inside_counts_only_particles_between_body_centres():
    dx = 0.01
    X = np.array([[i * dx, j * dx] for i in range(2) for j in range(4)])  # 2 x 4 lattice
    quads = stability.lattice_quads(X, dx)
    assert len(quads) == 3
    # the body bent: shear the lattice; a fluid particle between the two columns is inside
    x = X + np.column_stack([0.5 * X[:, 1], np.zeros(len(X))])
    fluid = np.array([[0.5 * dx + 0.5 * 1.5 * dx, 1.5 * dx],   # between the columns
                      [-0.3 * dx, 1.5 * dx],                     # beside the body, close
                      [0.5 * dx, 5.0 * dx]])                     # far away
    assert stability.fluid_inside(fluid, x, quads) == 1
    assert stability.fluid_inside(fluid[1:], x, quads) == 0
