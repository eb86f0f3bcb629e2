"""Cell-linked neighbour search against brute force."""

import numpy as np
import pytest

from fsi_sph.neighbors import find_neighbors


def brute(xd, xs, radius, exclude_self):
    d = np.linalg.norm(xd[:, None] - xs[None], axis=2)
    m = d < radius
    if exclude_self:
        np.fill_diagonal(m, False)
    return [set(np.flatnonzero(row)) for row in m]


@pytest.mark.parametrize("same", [True, False])
def test_matches_brute_force(rng, same):
    xs = rng.uniform([-1.0, 0.0], [2.0, 0.5], size=(700, 2))
    xd = xs if same else rng.uniform([-1.5, -0.2], [2.5, 1.0], size=(300, 2))
    radius = 0.11
    start, nbr = find_neighbors(xd, xs, radius, exclude_self=same)
    want = brute(xd, xs, radius, same)
    assert start[0] == 0 and start[-1] == len(nbr)
    for i, w in enumerate(want):
        got = nbr[start[i]:start[i + 1]]
        assert len(got) == len(set(got)), "duplicate neighbour"
        assert set(got) == w


def test_empty_and_degenerate():
    s, j = find_neighbors(np.zeros((0, 2)), np.zeros((5, 2)), 1.0)
    assert s.tolist() == [0] and len(j) == 0
    # all points on one line: a 1 x N cell grid
    x = np.column_stack([np.linspace(0, 1, 50), np.zeros(50)])
    s, j = find_neighbors(x, x, 0.05, exclude_self=True)
    assert all(set(j[s[i]:s[i + 1]]) == {k for k in (i - 2, i - 1, i + 1, i + 2)
                                           if 0 <= k < 50 and abs(x[k, 0] - x[i, 0]) < 0.05}
               for i in range(50))


def test_transpose_csr(rng):
    from fsi_sph.neighbors import transpose_csr

    xd = rng.uniform(0, 1, (80, 2))
    xs = rng.uniform(0, 1, (120, 2))
    s, j = find_neighbors(xd, xs, 0.15)
    ts, ti = transpose_csr(s, j, len(xs))
    rs, ri = find_neighbors(xs, xd, 0.15)
    np.testing.assert_array_equal(ts, rs)
    for k in range(len(xs)):
        assert sorted(ti[ts[k]:ts[k + 1]]) == sorted(ri[rs[k]:rs[k + 1]])
