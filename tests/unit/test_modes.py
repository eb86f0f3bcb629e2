"""Natural modes of a TLSPH body (fsi_sph/solid/modes.py): the plate's first period against the
converged 2D finite-element reference, mass-normalised modes, and the step compliance's
free-particle limit."""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from fsi_sph.solid.modes import Modes, difference_stiffness
from validation.plate_fem import converged_period

K, NU, RHO = 3.25e6, 0.3975, 1000.0  # cases/oscillating_plate.toml
E = 3 * K * (1 - 2 * NU)


def plate(dx):
    sim = Simulation(load_config("cases/oscillating_plate.toml", [f"case.dx={dx}"]))
    return sim.structures["plate"]


@pytest.fixture(scope="module")
def reference_period():
    return converged_period(0.2, 0.02, E, NU, RHO)[0]


def test_first_period_of_the_plate_converges_to_the_fem_reference(reference_period):
    errors = []
    for dx in (0.005, 0.004):
        modes = Modes(plate(dx))
        assert modes.omega[0] > 0.0
        errors.append(2 * math.pi / modes.omega[0] / reference_period - 1)
    assert 0.0 < errors[1] < errors[0] < 0.04  # +3.2 % and +2.8 % measured


def test_modes_are_mass_normalised_and_zero_on_the_clamp():
    body = plate(0.005)
    modes = Modes(body)
    m = np.repeat(body.body["m"], 2)
    np.testing.assert_allclose(modes.phi.T @ (m[:, None] * modes.phi), np.eye(modes.phi.shape[1]),
                               atol=1e-8)
    held = np.repeat(~body.body["free"], 2)
    assert held.any() and not modes.phi[held].any()


def test_stiffness_of_the_energy_forms_is_symmetric_and_positive_about_the_unstressed_state():
    """The stress term and the conservative hourglass control derive from an energy: their
    difference quotient is symmetric to its own error (1.5e-9 measured; the default
    Ganzenmueller control, not an energy form, 9e-4 at coefficient 0.1: symmetrised)."""
    sim = Simulation(load_config("cases/oscillating_plate.toml", [
        "case.dx=0.005", 'solid.plate.hourglass={model="conservative",coefficient=0.1}']))
    body = sim.structures["plate"]
    raw, dofs = difference_stiffness(body)
    assert len(dofs) == 2 * int(body.body["free"].sum())
    assert np.abs(raw - raw.T).max() < 1e-6 * np.abs(raw).max()
    m = np.repeat(body.body["m"], 2)[dofs]
    w2 = np.linalg.eigvalsh(0.5 * (raw + raw.T) / np.sqrt(np.outer(m, m)))
    assert w2.min() > -1e-6 * w2.max()


def test_step_compliance_is_the_free_particle_one_for_a_short_step_and_vanishes_for_a_long():
    body = plate(0.005)
    modes = Modes(body)
    free = np.repeat(body.body["free"], 2)
    inv_m = np.where(free, 1.0 / np.repeat(body.body["m"], 2), 0.0)
    short = modes.compliance(1e-9)
    np.testing.assert_allclose(short, np.diag(inv_m), atol=1e-9 * inv_m.max())
    long = modes.compliance(1e3)  # every mode far stiffer than the step: the mean motion is 0
    assert np.abs(long).max() < 1e-3 * inv_m.max()
    dt = 1e-3
    s = modes.weights(dt)
    first_lobe = modes.omega * dt < 2.0 * np.pi  # sinc^2 falls there, then has side lobes
    assert np.all((s >= 0.0) & (s <= 1.0)) and np.all(np.diff(s[first_lobe]) <= 1e-12)
    assert s[0] > 0.99 and (~first_lobe).any() and s[~first_lobe].max() < 0.05


def test_info_prints_the_lowest_natural_frequencies(capsys):
    """`fsi-sph info` prints a clamped elastic body's lowest frequencies: the plate's first,
    3.86 Hz at the case's spacing (period 0.259 s; thin-plate theory 0.254 s, the 2D
    finite-element reference 0.255 s)."""
    from fsi_sph.__main__ import main

    assert main(["info", "cases/oscillating_plate.toml"]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if "natural frequencies" in s)
    first = float(line.split("vacuum ")[1].split(",")[0])
    assert 1 / first == pytest.approx(0.2553, rel=0.03)


def test_no_frequencies_for_a_body_without_a_clamp():
    from fsi_sph.solid.modes import natural_frequencies

    sim = Simulation(load_config("cases/oscillating_plate.toml", ["case.dx=0.005",
                                                                   "solid.plate.clamp=[]"]))
    assert natural_frequencies(sim.structures["plate"]) is None


@pytest.mark.parametrize("hourglass", ["ganzenmueller", "conservative"])
def test_internal_acceleration_is_the_step_acceleration_at_rest(rng, hourglass):
    """``ElasticBody.internal_acceleration(x)`` is the acceleration the step computes at ``x``
    with the body at rest (the same kernels), and leaves the body's fields alone."""
    sim = Simulation(load_config("cases/oscillating_plate.toml", [
        "case.dx=0.005", f'solid.plate.hourglass={{model="{hourglass}",coefficient=0.1}}']))
    body = sim.structures["plate"]
    b = body.body
    x = b["x"] + 1e-4 * rng.normal(size=b["x"].shape)
    a_before = b["a"].copy()
    a = body.internal_acceleration(x)
    np.testing.assert_array_equal(b["a"], a_before)
    b["x"][:] = x
    b["v"][:] = 0.0
    body.update_stress()
    body._accelerations()
    np.testing.assert_array_equal(a, b["a"])
    assert np.abs(a).max() > 1.0  # the perturbation is felt


def _lattice(nx, ny, dx=0.01):
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    return dx * np.column_stack([i.ravel(), j.ravel()]).astype(float) + 0.3


@pytest.mark.parametrize("x0, across", [(_lattice(36, 2), 2), (_lattice(4, 50), 4),
                                        (_lattice(20, 5), 5),
                                        (np.vstack([_lattice(12, 3), _lattice(3, 12)]), 3)])
def test_particles_through_a_body(x0, across):
    """A flag, a plate standing up, a block, an L of two arms 3 thick (duplicate corner
    sites are the same lattice site)."""
    from fsi_sph.solid.modes import particles_through

    assert particles_through(x0, 0.01) == across


def test_particles_through_a_disc_is_its_diameter_order():
    from fsi_sph.solid.modes import particles_through

    x0 = _lattice(21, 21)
    c = x0.mean(axis=0)
    disc = x0[np.hypot(*(x0 - c).T) <= 0.1 + 1e-9]
    assert 10 <= particles_through(disc, 0.01) <= 21


@pytest.mark.parametrize("dx, warned", [(0.01, True), (0.004, False)])
def test_info_warns_of_a_structure_too_thin_to_bend(capsys, dx, warned):
    """The plate (0.02 m thick): 2 particles through it at dx 0.01 m, 5 at 0.004 m."""
    from fsi_sph.__main__ import main

    assert main(["info", "cases/oscillating_plate.toml", "--set", f"case.dx={dx}"]) == 0
    out = capsys.readouterr().out
    assert ("2 particles through it: its bending is poorly resolved" in out) is warned
    assert ("poorly resolved" in out) is warned
