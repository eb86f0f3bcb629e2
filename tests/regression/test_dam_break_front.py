"""No particle of the dam break (cases/dam_break.toml, a / dx = 40, to T = t sqrt(g/a) = 1.7,
~10 s) outruns the inviscid dam-break front of the column's height, 2 sqrt(g H) with
H = 2a (Ritter): 2.83 sqrt(g a).

Without the umbrella scan (fluid.surface_scan) a particle on the face of the thin front, its
div r raised to 1.7-1.9 by clumped neighbours behind it, was an interior Poisson row with
nothing in front of it; its pressure ran away (-1.1 -> -8.3 kPa in eight steps) and threw it
off at 4.6 sqrt(g a) at T = 1.64 (measured), which also cut the time step for the rest of
the run (920 steps against 687 with the scan, to T = 2.5).
"""

import math
from pathlib import Path

import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation

CASE = Path(__file__).resolve().parents[2] / "cases" / "dam_break.toml"
T_END = 1.7


def fastest(scan):
    t_end = T_END / math.sqrt(9.81)
    sim = Simulation(load_config(CASE, ["case.dx=0.025", f"case.t_end={t_end}",
                                        f"fluid.surface_scan={str(scan).lower()}"]))
    top = 0.0
    while sim.t < t_end - 1e-12:
        sim.step(t_end - sim.t, to_end=True)
        top = max(top, sim.fluid.max_speed())
    return top / math.sqrt(9.81)


def test_no_dam_break_particle_outruns_the_inviscid_front():
    top = fastest(scan=True)
    assert top < 2.0 * math.sqrt(2.0)
    assert top > 1.8  # the front did run (1.9-2.0 at T = 1.7)


@pytest.mark.xfail(reason="without the umbrella scan a front particle was thrown off "
                   "(4.6 sqrt(g a) measured); since the consistent Laplacian and the damped "
                   "move (2026-12-01f) this draw keeps below the bound (2.10 sqrt(g a); with "
                   "the scan 2.13), other draws not checked; kept to show what the scan was "
                   "for", strict=False)
def test_without_the_scan_a_front_particle_is_thrown():
    assert fastest(scan=False) < 2.0 * math.sqrt(2.0)
