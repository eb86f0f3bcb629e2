"""No particle is thrown ahead of a collapsing granular column (cases/granular_collapse.toml,
the a = 4 column at the quick resolution, 0.6 s, ~20 s).

Before the collision model and the walls without suction (docs/session_notes_2026-11-30d.md)
clumps of free-surface particles at the thin front and particles pulled into the floor by
Adami's wall pressure were thrown off at 4.6 m/s here (10-27 m/s at the full resolution),
above the free-fall speed from the top of the column, sqrt(2 g H0) = 2.8 m/s, which no
particle of a collapsing column should reach (measured with the fixes: 2.14 m/s)."""

import math

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from validation.granular_collapse import CASE, overrides


def test_no_particle_outruns_free_fall_from_the_column_top():
    a, t_end = 4.0, 0.6
    _, over = overrides(a, 800)
    sim = Simulation(load_config(CASE, over + [f"case.t_end={t_end}"]))
    fastest = 0.0
    while sim.t < t_end - 1e-12:
        sim.step(t_end - sim.t, to_end=True)
        fastest = max(fastest, sim.fluid.max_speed())
    assert fastest < math.sqrt(2.0 * 9.81 * a * 0.1)
    assert fastest > 1.0  # the column did collapse
