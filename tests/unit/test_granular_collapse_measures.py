"""The deposit measures of validation/granular_collapse.py on synthetic deposits."""

import numpy as np
import pytest

from validation.granular_collapse import body_front, deposit_front, pile_height

DX = 0.01


def _deposit():
    """A wedge 6 rows high at the back wall tapering to 1 row at x = 0.1 m, then a carpet of
    single particles to x = 0.2 m, and one particle thrown ahead at x = 0.3 m."""
    pts = []
    for i in range(10):  # columns x = (i + 1/2) dx, heights 6 .. 1 rows
        rows = max(6 - i * 5 // 9, 1)
        pts += [((i + 0.5) * DX, (k + 0.5) * DX) for k in range(rows)]
    pts += [((i + 0.5) * DX, 0.5 * DX) for i in range(10, 20)]
    pts.append((0.3, 0.5 * DX))
    return np.array(pts)


def test_deposit_front_is_the_connected_deposit_without_the_thrown_particle():
    front, detached = deposit_front(_deposit(), DX)
    assert front == pytest.approx(0.195)
    assert detached == 1


def test_body_front_ends_where_the_columns_get_thinner_than_the_threshold():
    x = _deposit()
    counts = np.bincount(np.floor(x[:, 0] / DX).astype(int))
    first_thin = int(np.flatnonzero(counts < 3)[0])
    assert body_front(x, DX, rows=3) == pytest.approx(first_thin * DX)
    assert body_front(x, DX, rows=1) == pytest.approx(0.2)  # the carpet counts at 1 row
    assert body_front(x, DX, rows=7) == 0.0


def test_pile_height_ignores_a_particle_left_on_the_back_wall():
    x = np.vstack([_deposit(), [[0.5 * DX, 0.4]]])  # stuck 0.4 m up the back wall
    assert pile_height(x, DX) == pytest.approx(5.5 * DX)


def test_merged_summary_sums_the_realizations_and_keeps_their_throughput():
    from validation.granular_collapse import _merged_summary

    runs = [{"n_particles": 100, "steps": 10, "wall_time_s": 2.0, "particle_steps_per_s": 1e3},
            {"n_particles": 100, "steps": 30, "wall_time_s": 5.0, "particle_steps_per_s": 3e3}]
    m = _merged_summary(runs)
    assert m["steps"] == 40 and m["wall_time_s"] == 7.0 and m["n_particles"] == 100
    # loop times 1 s and 1 s: 4000 particle-steps in 2 s
    assert m["particle_steps_per_s"] == pytest.approx(2e3)


def test_realizations_differ_only_in_the_seed():
    from validation.granular_collapse import JITTER, realization_overrides

    assert realization_overrides(0) != realization_overrides(1)
    assert f"fluid.jitter={JITTER!r}" in realization_overrides(2)
