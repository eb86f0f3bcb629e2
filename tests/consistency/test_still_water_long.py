"""Water at rest stays at rest, for long runs and at the largest stable time step.

Found 2026-12-01f: the hydrostatic tank (cases/hydrostatic_tank.toml, which the validation
runs for 1 s) blew up after 2.9 s, still water beside a floating box after ~3.5 s. The
one-step map of the scheme linearised about the state at rest (finite differences of
``Simulation.step``, below) had eigenvalues of modulus 1.08 at the tank's time step: rows of
particles oscillating against each other (the plain Morris Laplacian is not exact for the
hydrostatic pressure at displaced particles, so displacing them gives a pressure that is not
a restoring one), and short free-surface waves (the trapezoidal move [F 19] with the
pressure solved at r^n amplifies an oscillation by (1 + (omega dt)^2 / 2)^(1/2) per step).
The defaults (``fluid.laplacian = "consistent"``, ``fluid.position_update = "damped"``) make
the map's spectral radius 1 (neutral: particles can be rearranged at rest).
"""

import copy

import numpy as np

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from validation.common import CASES

TANK = CASES / "hydrostatic_tank.toml"


def small_tank(side, extra=()):
    over = [f"fluid.blocks=[{{origin=[0.0,0.0],size=[{side},{side}]}}]",
            f"walls.tanks=[{{origin=[0.0,0.0],size=[{side},{side + 0.1}]}}]",
            "case.t_end=100.0", *extra]
    return Simulation(load_config(TANK, over))


def spectral_radius(extra, side=0.12, dt=0.0123):
    """Largest |eigenvalue| of the linearised one-step map (x, v) -> (x', v') about still
    water, by forward differences of ``Simulation.step`` at the fixed step ``dt`` (the
    tank's force limit, 0.25 sqrt(h / g), at dx = 0.02 m)."""
    sim = small_tank(side, ["fluid.ppe.rtol=1e-13", *extra])
    for _ in range(3):
        sim.step(dt_max=dt)
    clock, state = sim.clock(), sim.state()
    f = sim.fluid.body
    n = f.n

    def step_from(k=None, eps=0.0):
        sim.load_state(copy.deepcopy(clock), copy.deepcopy(state))
        if k is not None:
            arr = f["x"] if k < 2 * n else f["v"]
            arr.reshape(-1)[k % (2 * n)] += eps
        sim.step(dt_max=dt)
        return np.concatenate([f["x"].ravel(), f["v"].ravel()])

    base = step_from()
    jac = np.empty((4 * n, 4 * n))
    for k in range(4 * n):
        eps = 1e-7 if k < 2 * n else 1e-5
        jac[:, k] = (step_from(k, eps) - base) / eps
    return float(np.max(np.abs(np.linalg.eigvals(jac))))


def test_still_water_one_step_map_is_not_amplifying():
    """Default scheme: spectral radius 1 (measured 1.00003, the finite differences' noise);
    with the plain Morris Laplacian and the trapezoidal move [F 19] it is above 1.05 (1.08
    measured on a 10 x 10 tank), so this test tells the two apart."""
    assert spectral_radius([]) < 1.002
    # (without shifting, as measured: the default shifting damps the amplification)
    assert spectral_radius(["fluid.laplacian=morris", "fluid.position_update=trapezoid",
                            "fluid.shifting=false"]) > 1.02


def _fastest_over_10_s(extra=()):
    sim = small_tank(0.2, ["case.t_end=10.0", "fluid.ppe.rtol=1e-8", *extra])
    top, at_5 = 0.0, None
    while sim.t < 10.0 - 1e-9:
        sim.step(dt_max=10.0 - sim.t, to_end=True)
        top = max(top, sim.fluid.max_speed())
        if at_5 is None and sim.t >= 5.0:
            at_5 = top
    sim.check()
    return at_5, top


def test_small_tank_stays_at_rest_for_10_s():
    """10 x 10 particles at the force limit's step for 10 s (about 800 steps): before the fix
    the fastest particle reached 1e-4 m/s at 2.8 s and the run blew up at 4.5 s. The
    projection alone (no density relaxation) holds the solver's noise."""
    # the solve at 1e-8 (the tank's setting when this was measured): at the default 1e-6 the
    # speed holds at the solver's noise, 2.5e-6 m/s, with or without shifting (no growth)
    assert _fastest_over_10_s(["fluid.density_relaxation=0"])[1] < 1e-6


def test_small_tank_on_the_defaults_is_stirred_slowly():
    """With the default density relaxation (both signs, 2026-12-06) the same tank is stirred:
    the shifting reshapes the supports at the surface's corners (in a 1 m tank without the
    relaxation, interior kernel sums there fall to -2.3e-4 by 0.5 s) and the relaxation
    answers. Measured: fastest 3.2e-5 m/s by 0.5 s, 4.5e-5 by 4 s, 5.4e-5 by 6 s, 7.0e-5 by
    10 s (1e-5 sqrt(g H)): a slow drift, not the exponential growth of the instability above
    (1e-4 by 2.8 s, then a blow-up)."""
    at_5, top = _fastest_over_10_s()
    assert top < 1e-4
    assert top < 2.0 * at_5  # no growth faster than linear
