"""A confined flow's pressure level out of the interface's pair terms (fsi_sph/fluid/gauge.py):
the pair terms do not change under a uniform shift of the pressure, the solve's extra terms
are the ones its rows imply, the gauge applies only to confined flows, and a flag held fixed
in the Turek-Hron channel no longer blows up in its first steps."""

import numpy as np
import scipy.sparse as sp

from fsi_sph.config import load_config
from fsi_sph.fluid.gauge import gauged_terms, level_weights
from fsi_sph.simulation import Simulation

FSI2 = "cases/turek_hron_fsi2.toml"
COARSE = ["case.dx=0.01"]
HELD = COARSE + ["solid.flag.clamp=[{origin=[0.24,0.19],size=[0.36,0.02]}]"]


def _stepped(over, steps=1):
    sim = Simulation(load_config(FSI2, over))
    for _ in range(steps):
        sim.step()
    return sim


def _pair_terms(sim):
    """The interface force on the flag and the fluid's pressure gradient, with the
    pressure level recomputed from the stacked pressure as the solve does."""
    fl = sim.fluid
    fl.p_gauge = float(level_weights(fl, fl.rows) @ fl.p_all)
    on_fluid = sim.coupling.forces().copy()
    grad = np.empty((fl.nf, 2))
    fl.gradient.apply(fl.p_all, grad, level=fl.p_gauge)
    return sim.coupling.on_structure.copy(), on_fluid, grad


def test_pair_terms_do_not_see_a_uniform_pressure_in_a_confined_flow():
    sim = _stepped(COARSE, 3)
    fl = sim.fluid
    assert fl.confined and fl.ns
    before = _pair_terms(sim)
    fl.p_all += 5000.0  # a uniform 5 kPa, as the channel's level moves from step to step
    after = _pair_terms(sim)
    for a, b in zip(before, after, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9 * np.abs(a).max())
    # without the gauge the same shift moves the flag's force (the pair form is not
    # invariant where the support is irregular)
    fl.p_gauge = 0.0
    sim.coupling.forces()
    assert np.abs(sim.coupling.on_structure - before[0]).max() > 1.0  # N/m


def test_gauged_terms_are_the_rows_pair_force_relative_to_the_level(rng):
    """On an implicit structure row ``w`` the term is ``-2 (A_ww - diag_ref) (m . p)``;
    the fluid and wall rows get none; a rigid row's ``G p`` becomes ``G (p - (m . p) 1)``."""

    class Ps:
        nf, n_walls, diag_ref = 5, 2, 3.0

    n = 10
    diag = np.r_[np.full(7, 3.0), 3.0, 4.5, 7.0]  # structure rows 7-9: no implicit term, two
    A = sp.csr_array(sp.diags(diag))
    m = np.r_[0.5, 0.0, 0.5, np.zeros(7)]
    terms = gauged_terms(A, Ps, m)
    p = rng.normal(size=n)
    extra = terms.U @ (terms.G() @ p)
    level = 0.5 * (p[0] + p[2])
    np.testing.assert_allclose(extra, np.r_[np.zeros(8), -3.0 * level, -8.0 * level])

    class Rigid:
        U = rng.normal(size=(n, 3))
        Gm = rng.normal(size=(3, n))

        def G(self):
            return self.Gm

    both = gauged_terms(A, Ps, m, Rigid())
    np.testing.assert_allclose(both.U @ (both.G() @ p),
                               Rigid.U @ (Rigid.Gm @ (p - level)) + extra, atol=1e-12)


def test_no_gauge_with_a_free_surface_or_without_structures():
    gate = Simulation(load_config("cases/dam_break_elastic_gate.toml", ["case.dx=0.0025"]))
    assert not gate.fluid.confined and level_weights(gate.fluid, gate.fluid.rows) is None
    cfd2 = Simulation(load_config("cases/turek_hron_cfd2.toml", ["case.dx=0.01"]))
    assert cfd2.fluid.confined and level_weights(cfd2.fluid, cfd2.fluid.rows) is None
    fl = _stepped(COARSE).fluid
    m = level_weights(fl, fl.rows)
    assert m is not None and abs(m.sum() - 1.0) < 1e-12 and (m >= 0).all()


def test_a_held_flag_in_the_channel_stays_at_rest():
    """The flag clamped everywhere is a fixed wall that happens to be coupled: the flow past
    it starts from rest under the ramped inflow. Without the gauge the channel's pressure
    level pushed the rows beside it and the run blew up at step 10 (a fluid particle at
    1.2e4 m/s at t = 0.11 s); the inflow's peak is 1.5 m/s."""
    sim = _stepped(HELD, 30)
    v = sim.fluid.body["v"]
    assert sim.t > 0.3
    assert np.sqrt(np.einsum("ij,ij->i", v, v)).max() < 0.5


def test_force_probe_of_a_confined_flow_does_not_see_a_uniform_pressure():
    """The CFD2 body force (cylinder and flag as walls) relative to the level beside the
    body: a uniform shift of the pressure leaves it as it was; taken with the absolute
    pressure (as in a flow with a free surface) the shift moves it."""
    sim = Simulation(load_config("cases/turek_hron_cfd2.toml", COARSE))
    for _ in range(3):
        sim.step()
    fl = sim.fluid
    probe = next(p for p in sim.probes if p.name == "body_force")
    before = np.array(probe.sample())
    fl.p_all += 5000.0
    fl.body["p"] += 5000.0  # (the probe syncs the stacked fluid pressure from the body's)
    np.testing.assert_allclose(probe.sample(), before, atol=1e-9 * np.abs(before).max())
    fl.confined = False
    assert np.abs(np.array(probe.sample()) - before).max() > 1.0  # N/m
