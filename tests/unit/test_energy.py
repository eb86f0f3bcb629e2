"""The scene energy (fsi_sph/energy.py) against a hand sum, and a free elastic block falling
in vacuum, where gravity's work goes into kinetic energy and the total holds."""

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.energy import SceneEnergy, body_energy
from fsi_sph.simulation import Simulation


class Blob:
    def __init__(self, x, v, m, stored=0.0):
        self.body = {"x": np.asarray(x, float), "v": np.asarray(v, float),
                     "m": np.asarray(m, float)}
        self._stored = stored

    def strain_energy(self):
        return self._stored


def test_body_energy_is_the_hand_sum():
    x = [[0.0, 1.0], [2.0, 3.0]]
    v = [[1.0, 0.0], [0.0, -2.0]]
    m = [2.0, 0.5]
    e = body_energy(Blob(x, v, m, stored=7.0), (0.0, -9.81), datum=(0.0, 0.5))
    assert np.isclose(e["kinetic"], 0.5 * 2.0 * 1.0 + 0.5 * 0.5 * 4.0)
    assert np.isclose(e["potential"], 2.0 * 9.81 * 0.5 + 0.5 * 9.81 * 2.5)
    assert e["stored"] == 7.0


BLOCK = """
[case]
t_end = 0.05
dx = 0.01
gravity = [0.0, -9.81]
[solid.block]
material = { model = "neo_hookean", rho0 = 1000.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.1, 0.05] }]
"""


def test_a_falling_block_keeps_its_energy_and_the_datum_does_not_matter():
    sim = Simulation(load_config(None, text=BLOCK))
    energy = SceneEnergy(sim)
    b = sim.structures["block"].body
    y = b["x"][:, 1]
    assert np.isclose(energy.sample(sim)["potential"], 9.81 * np.sum(b["m"] * (y - y.min())))
    while sim.t < 0.05 - 1e-12:
        sim.step(dt_max=0.05 - sim.t, to_end=True)
    e = energy.sample(sim)
    assert e["kinetic"] > 0.1 * energy.initial          # gravity did work on it ...
    assert abs(energy.drift_pct(sim)) < 0.1             # ... which the potential gave up
    shifted = Simulation(load_config(None, text=BLOCK.replace("[0.0, 0.0]", "[5.0, 100.0]")))
    assert np.isclose(SceneEnergy(shifted).initial, energy.initial)

