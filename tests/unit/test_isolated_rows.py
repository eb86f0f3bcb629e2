"""Isolated Poisson rows in the free-surface detection (fluid.surface_isolated_rows): a row
whose fluid neighbours are all surface rows is a surface row. The loop against a numpy
oracle; a square block and a two-row layer on a floor are unchanged; the case it was added
for: a particle on the floor, its div r raised by the wall particles under it, with only
surface particles of a thin patch around it."""

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.free_surface import detect
from fsi_sph.neighbors import find_neighbors
from tests.conftest import lattice

H = 1.2
KIND = 0


def _detect(x, nf, isolated):
    """Free-surface fields of the first ``nf`` rows of ``x`` (the rest: wall particles)."""
    s, j = find_neighbors(x[:nf], x, 2 * H, exclude_self=True)
    out = dict(divr=np.zeros(nf), gc=np.zeros((nf, 2)), sig=np.zeros(nf), alpha=np.zeros(nf),
               cls=np.zeros(nf, dtype=np.int8), nrm=np.zeros((nf, 2)))
    detect(x, np.ones(len(x)), s, j, nf, H, KIND, out["divr"], out["gc"], out["sig"],
           out["alpha"], out["cls"], out["nrm"], isolated=isolated)
    return out


def test_isolated_rows_match_oracle():
    rng = np.random.default_rng(4)
    nf = 100
    x = lattice(12, 10) + rng.uniform(-0.3, 0.3, (120, 2))
    s, j = find_neighbors(x[:nf], x, 2 * H, exclude_self=True)
    is_surface = rng.random(nf) < 0.8
    out = np.empty(nf, dtype=np.bool_)
    K.isolated_rows(is_surface, s, j, nf, out)
    want = np.zeros(nf, dtype=bool)
    for i in range(nf):
        nb = j[s[i]:s[i + 1]]
        fl = nb[nb < nf]
        want[i] = (not is_surface[i]) and len(nb) > 0 and bool(np.all(is_surface[fl]))
    assert np.array_equal(out, want)
    assert 0 < want.sum() < (~is_surface).sum()  # both answers occur


def test_square_block_and_two_row_layer_are_unchanged():
    block = lattice(20, 20)
    layer = np.vstack([lattice(30, 2), lattice(36, 3) - [3.0, 3.0]])  # on 3 wall rows
    for x, nf in ((block, len(block)), (layer, 60)):
        plain, new = _detect(x, nf, False), _detect(x, nf, True)
        assert np.array_equal(plain["cls"], new["cls"])
        assert np.array_equal(plain["alpha"], new["alpha"])


def test_a_lone_poisson_row_among_surface_rows_is_a_surface_row():
    floor = lattice(16, 3) - [3.0, 3.0]
    patch = np.array([[3.8, 0.6], [6.2, 0.6], [4.4, 1.5], [5.6, 1.5]])  # surface rows
    x = np.vstack([patch, [[5.0, 0.45]], floor])
    nf = len(patch) + 1
    plain, new = _detect(x, nf, False), _detect(x, nf, True)
    i = nf - 1
    assert plain["divr"][i] > 1.6 and plain["cls"][i] != K.SURFACE and plain["alpha"][i] > 0
    assert np.all(plain["cls"][:i] == K.SURFACE)
    assert new["cls"][i] == K.SURFACE and new["alpha"][i] == 0.0
