"""TLSPH body [F 34-45]: zero stress under rigid motion, Hooke under uniform strain,
momentum conservation, hourglass control, energy conservation of the Verlet step."""

import numpy as np
import pytest


def rot(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


@pytest.mark.parametrize("model", ["stvk", "hooke_almansi", "neo_hookean"])
def test_rigid_motion_gives_zero_stress(make_body, model):
    b = make_body(model=model, dx=0.05, w=0.6, hgt=0.3, hg=10.0, alpha=1.0)
    x0 = b.body["x0"]
    b.body["x"][:] = x0 @ rot(0.9).T + np.array([3.0, -1.0])
    b.update_stress()
    np.testing.assert_allclose(b.body["F"], np.broadcast_to(rot(0.9), b.body["F"].shape),
                               atol=1e-12)
    assert np.abs(b.body["P"]).max() < 1e-8 * b.youngs
    b._accelerations()
    assert np.abs(b.body["a"]).max() < 1e-8 * b.youngs / b.rho0


def test_uniform_small_strain_gives_hooke(make_body):
    """x = (I + eps) X: F = I + eps at every particle (edges included, thanks to the
    correction [F 13-14]) and sigma = lam tr(eps) I + 2 mu eps (plane strain)."""
    b = make_body(dx=0.05, w=0.6, hgt=0.3)
    eps = 1e-6 * np.array([[2.0, 0.5], [0.5, -1.0]])
    b.body["x"][:] = b.body["x0"] @ (np.eye(2) + eps).T
    b.update_stress()
    np.testing.assert_allclose(b.body["F"], np.broadcast_to(np.eye(2) + eps, b.body["F"].shape),
                               atol=1e-14)
    sigma = b.snapshot()["sigma"]
    want = b.lam * np.trace(eps) * np.eye(2) + 2 * b.mu * eps
    np.testing.assert_allclose(sigma, np.broadcast_to(want, sigma.shape), rtol=1e-5,
                               atol=1e-3 * np.abs(want).max())


def test_free_body_conserves_momentum(make_body, rng):
    """Pairwise forms (stress, viscosity, hourglass) cancel in sum: momentum to round-off."""
    b = make_body(dx=0.05, w=0.6, hgt=0.4, alpha=1.0, hg=10.0, E=1e5)
    x = b.body
    x["x"][:] = x["x0"] + 0.005 * rng.standard_normal(x["x0"].shape)
    x["v"][:] = rng.standard_normal(x["x0"].shape)
    b.update_stress()
    b._accelerations()
    p0 = b.momentum()
    force = np.sum(x["m"][:, None] * x["a"], axis=0)
    scale = np.sum(x["m"][:, None] * np.abs(x["a"]), axis=0)
    assert np.all(np.abs(force) < 1e-12 * scale)
    for _ in range(200):
        b.substep(0.5 * b.stable_dt())
    assert np.allclose(b.momentum(), p0, rtol=0, atol=1e-12 * np.abs(p0).max())


def _sawtooth(b, amp):
    """Alternating displacement u_y = amp (-1)^(ix + iy): an SPH zero-energy mode. By the
    lattice symmetry F = I at every interior particle, so stress alone cannot see it."""
    x0 = b.body["x0"]
    idx = np.rint((x0 - x0.min(axis=0)) / (x0[1, 1] - x0[0, 1])).astype(int)
    sign = np.where((idx[:, 0] + idx[:, 1]) % 2 == 0, 1.0, -1.0)
    b.body["x"][:, 1] = x0[:, 1] + amp * sign
    # F = I needs a full support; zero stress needs the neighbours' full support too: 4 h
    interior = np.all((x0 > x0.min(0) + 4.5 * b.h) & (x0 < x0.max(0) - 4.5 * b.h), axis=1)
    return sign, interior


def _mode_amplitude(b, sign, interior):
    u = b.body["x"][:, 1] - b.body["x0"][:, 1]
    return float(np.mean(u[interior] * sign[interior]))


@pytest.mark.parametrize("hg", [0.0, 10.0])
def test_hourglass_control_removes_zero_energy_mode(make_body, hg):
    """With hourglass control off the sawtooth mode is invisible to the stress (F = I inside)
    and survives; with it on, it is pushed back and, with the artificial viscosity, decays."""
    b = make_body(dx=0.05, w=1.5, hgt=1.5, alpha=1.0, hg=hg)
    amp = 1e-3 * 0.05
    sign, interior = _sawtooth(b, amp)
    b.update_stress()
    np.testing.assert_allclose(b.body["F"][interior],
                               np.broadcast_to(np.eye(2), b.body["F"][interior].shape),
                               atol=1e-12)
    b._accelerations()
    restoring = -np.mean(b.body["a"][interior, 1] * sign[interior])
    steps = 0
    while steps < 400:
        b.substep(b.stable_dt())
        steps += 1
    left = _mode_amplitude(b, sign, interior) / amp
    if hg == 0.0:
        assert abs(restoring) < 1e-9, "stress alone must not see the zero-energy mode"
        assert left > 0.9, f"mode should survive without hourglass control, left {left:.3f}"
    else:
        assert restoring > 0, "hourglass control must push the mode back"
        assert abs(left) < 0.3, f"mode should be damped out with hourglass control, left {left:.3f}"


def test_undamped_energy_is_conserved(make_body):
    """Velocity Verlet is symplectic: total energy of an undamped free vibration stays put."""
    b = make_body(dx=0.05, w=1.0, hgt=0.2, alpha=0.0, hg=0.0, E=1e5)
    x0 = b.body["x0"]
    b.body["v"][:, 1] = 0.05 * np.sin(np.pi * x0[:, 0])
    b.update_stress()
    b._accelerations()
    e0 = b.kinetic_energy() + b.strain_energy()
    energies = []
    for _ in range(2000):
        b.substep(b.stable_dt())
        energies.append(b.kinetic_energy() + b.strain_energy())
    drift = np.max(np.abs(np.array(energies) - e0)) / e0
    assert drift < 1e-2


def test_rayleigh_damping_decays_rigid_motion(make_body):
    """Mass-proportional damping [F 45]: dv/dt = -xi v, so a stress-free translating body
    slows as exp(-xi t)."""
    b = make_body(dx=0.05, w=0.5, hgt=0.2, extra="damping = 20.0")
    b.body["v"][:] = [0.3, -0.1]
    t, dt = 0.0, 1e-4
    for _ in range(500):
        b.substep(dt)
        t += dt
    v0 = np.array([0.3, -0.1])
    # each half kick multiplies v by (1 - xi dt / 2): exact for the discrete scheme ...
    discrete = v0 * (1.0 - 0.5 * 20.0 * dt) ** 1000
    np.testing.assert_allclose(b.body["v"], np.broadcast_to(discrete, b.body["v"].shape),
                               rtol=1e-10)
    # ... and first-order accurate for the continuous law (error ~ xi^2 dt t / 4 = 5e-4)
    want = v0 * np.exp(-20.0 * t)
    np.testing.assert_allclose(b.body["v"], np.broadcast_to(want, b.body["v"].shape), rtol=1e-3)


def test_clamped_particles_never_move(make_body):
    b = make_body(dx=0.05, w=0.5, hgt=0.2, alpha=1.0, hg=10.0,
                  extra="clamp = [{ origin = [0.0, 0.0], size = [0.1, 0.2] }]")
    held = ~b.body["free"]
    assert held.sum() == 2 * 4
    b.body["v"][:] = [0.3, -0.1]
    b.body["v"][held] = 0.0
    for _ in range(300):
        b.substep(b.stable_dt())
    assert np.all(b.body["v"][held] == 0.0)
    assert np.all(b.body["x"][held] == b.body["x0"][held])
    assert np.abs(b.body["v"][~held]).max() > 0.01


def _conservative_hg_force(b):
    from fsi_sph.solid import _kernels as K

    x = b.body
    b.update_stress()
    a = np.zeros_like(x["x"])
    K.hourglass_moments(x["x"], x["x0"], x["vol"], x["F"], b.nbr_start, b.nbr_j, b.w, b.H)
    K.hourglass_conservative(x["x"], x["x0"], x["vol"], x["m"], x["F"], b.H, b.G, b.nbr_start,
                             b.nbr_j, b.gj, b.w, b.cfg.hourglass.coefficient * b.youngs, a)
    return x["m"][:, None] * a


def test_conservative_hourglass_is_energy_gradient(make_body, rng):
    """The conservative hourglass force is -dPhi/dx (central differences, every component),
    and vanishes under an affine motion."""
    b = make_body(dx=0.1, w=0.6, hgt=0.4, hg=10.0, hg_model="conservative")
    x = b.body["x"]
    x[:] = b.body["x0"] @ np.array([[1.1, 0.2], [-0.1, 0.95]]).T + 0.3
    assert np.abs(_conservative_hg_force(b)).max() < 1e-9 * b.youngs * 0.01
    x += 0.004 * rng.standard_normal(x.shape)
    f = _conservative_hg_force(b)
    eps = 1e-7
    fd = np.zeros_like(f)
    for k in range(len(x)):
        for d in range(2):
            x[k, d] += eps
            b.update_stress()
            ep = b.hourglass_energy()
            x[k, d] -= 2 * eps
            b.update_stress()
            em = b.hourglass_energy()
            x[k, d] += eps
            fd[k, d] = -(ep - em) / (2 * eps)
    assert np.abs(f).max() > 0
    np.testing.assert_allclose(f, fd, rtol=1e-5, atol=1e-6 * np.abs(f).max())
    assert np.all(np.abs(f.sum(axis=0)) < 1e-10 * np.abs(f).sum())  # momentum


@pytest.mark.parametrize("model", ["ganzenmueller", "conservative"])
def test_hourglass_models_energy(make_body, model):
    """A free vibration with hourglass control and no viscosity: the conservative model keeps
    kinetic + strain + penalty energy; Ganzenmueller's penalty drains it (what the option
    fixes)."""
    b = make_body(dx=0.05, w=1.0, hgt=0.2, alpha=0.0, E=1e5, hg=10.0, hg_model=model)
    x0 = b.body["x0"]
    b.body["v"][:, 1] = 0.05 * np.sin(np.pi * x0[:, 0])
    b.update_stress()
    b._accelerations()

    def energy():
        return b.kinetic_energy() + b.strain_energy() + b.hourglass_energy()

    e0 = energy()
    es = []
    for _ in range(3000):
        b.substep(b.stable_dt())
        es.append(energy())
    drift = np.max(np.abs(np.array(es) - e0)) / e0
    if model == "conservative":
        assert drift < 5e-3
    else:
        assert drift > 2e-2, f"expected Ganzenmueller's penalty to dissipate, drift {drift:.2e}"


def test_conservative_hourglass_removes_zero_energy_mode(make_body):
    b = make_body(dx=0.05, w=1.5, hgt=1.5, alpha=1.0, hg=10.0, hg_model="conservative")
    amp = 1e-3 * 0.05
    sign, interior = _sawtooth(b, amp)
    b.update_stress()
    b._accelerations()
    assert -np.mean(b.body["a"][interior, 1] * sign[interior]) > 0
    for _ in range(400):
        b.substep(b.stable_dt())
    assert abs(_mode_amplitude(b, sign, interior) / amp) < 0.3
