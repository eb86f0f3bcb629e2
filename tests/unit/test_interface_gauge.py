"""A confined flow's pressure level and the interface's pair terms (fsi_sph/fluid/gauge.py):
the force probe of a confined flow does not see a uniform pressure; a flag held fixed as a
coupled structure in the Turek-Hron channel stays at rest."""

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

COARSE = ["case.dx=0.01"]
HELD = COARSE + ["solid.flag.clamp=[{origin=[0.24,0.19],size=[0.36,0.02]}]"]


def test_force_probe_of_a_confined_flow_does_not_see_a_uniform_pressure():
    """The CFD2 body force (cylinder and flag as walls) relative to the level beside the
    body: a uniform shift of the pressure leaves it as it was; taken with the absolute
    pressure (as in a flow with a free surface) the shift moves it."""
    sim = Simulation(load_config("cases/turek_hron_cfd2.toml", COARSE))
    for _ in range(3):
        sim.step()
    fl = sim.fluid
    assert fl.confined
    probe = next(p for p in sim.probes if p.name == "body_force")
    before = np.array(probe.sample())
    fl.p_all += 5000.0
    fl.body["p"] += 5000.0  # (the probe syncs the stacked fluid pressure from the body's)
    np.testing.assert_allclose(probe.sample(), before, atol=1e-9 * np.abs(before).max())
    fl.confined = False
    assert np.abs(np.array(probe.sample()) - before).max() > 1.0  # N/m


def test_a_held_flag_in_the_channel_stays_at_rest():
    """The flag clamped everywhere is a fixed wall that happens to be coupled: the flow past
    it starts from rest under the ramped inflow, whose peak is 1.5 m/s. With the pair form
    [F 10] on the rows beside it, the channel's pressure level (about 0.6 kPa by 0.2 s, the
    column's acceleration) pushed the fluid at the flag's root, and the run blew up at step
    10 (1.2e4 m/s at 0.11 s); those rows now take their own pressure out of their pairs."""
    sim = Simulation(load_config("cases/turek_hron_fsi2.toml", HELD))
    for _ in range(12):
        sim.step()
    v = sim.fluid.body["v"]
    assert np.sqrt(np.einsum("ij,ij->i", v, v)).max() < 0.5
