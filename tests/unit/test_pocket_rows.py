"""Pockets of Poisson rows in the free-surface detection (fluid.surface_pocket_rows): the
Poisson rows of a connected set of fewer than N Poisson rows with a surface row beside it
become surface rows. The loop against a numpy oracle (connected components); a square block, a
layer on a floor and a filled box without a surface row are unchanged."""

import numba
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.free_surface import detect
from fsi_sph.neighbors import find_neighbors
from tests.conftest import lattice

H = 1.2
KIND = 0


def test_pocket_rows_match_oracle():
    rng = np.random.default_rng(7)
    nf = 300
    x = lattice(20, 15) + rng.uniform(-0.3, 0.3, (300, 2))
    s, j = find_neighbors(x, x, 2 * H, exclude_self=True)
    for frac, nmin in ((0.7, 5), (0.8, 5), (0.75, 10)):
        is_surface = rng.random(nf) < frac
        out = np.empty(nf, dtype=np.bool_)
        K.pocket_rows(is_surface, s, j, nf, np.empty((numba.config.NUMBA_NUM_THREADS, nmin), dtype=np.int64), out)
        # oracle: connected components of the Poisson rows over fluid pairs; every member
        # of the small ones that have a surface row beside one of their rows
        cnt = np.diff(s)
        poisson = ~is_surface & (cnt > 0)
        i = np.repeat(np.arange(nf), cnt)
        g = coo_matrix((np.ones(len(j)), (i, j)), shape=(nf, nf)).tocsr()
        _, lab = connected_components(g[poisson][:, poisson], directed=False)
        size = np.bincount(lab)
        rows = np.flatnonzero(poisson)
        edge = np.zeros(nf, dtype=bool)
        np.logical_or.at(edge, i, is_surface[j])
        touch = np.zeros(len(size), dtype=bool)
        touch[lab[edge[rows]]] = True
        want = rows[(size[lab] < nmin) & touch[lab]]
        assert np.array_equal(np.flatnonzero(out), want)
        assert 0 < out.sum() < poisson.sum()  # both answers occur


def _detect(x, nf, pocket):
    s, j = find_neighbors(x[:nf], x, 2 * H, exclude_self=True)
    out = dict(divr=np.zeros(nf), gc=np.zeros((nf, 2)), sig=np.zeros(nf), alpha=np.zeros(nf),
               cls=np.zeros(nf, dtype=np.int8), nrm=np.zeros((nf, 2)))
    detect(x, np.ones(len(x)), s, j, nf, H, KIND, out["divr"], out["gc"], out["sig"],
           out["alpha"], out["cls"], out["nrm"], scan=True, isolated=True, pocket=pocket)
    return out


def test_block_layer_and_filled_box_are_unchanged():
    block = lattice(20, 20)
    layer = np.vstack([lattice(30, 3), lattice(36, 3) - [3.0, 3.0]])  # three rows on a floor
    walls = np.vstack([lattice(12, 3) - [3.0, 3.0], lattice(12, 3) + [-3.0, 6.0],
                       lattice(3, 6) - [3.0, 0.0], lattice(3, 6) + [6.0, 0.0]])
    box = np.vstack([lattice(6, 6), walls])  # 6 x 6 fluid rows, walls all round
    for x, nf in ((block, len(block)), (layer, 90), (box, 36)):
        plain, new = _detect(x, nf, 0), _detect(x, nf, 5)
        assert np.array_equal(plain["cls"], new["cls"])
        assert np.array_equal(plain["alpha"], new["alpha"])


def test_a_pocket_in_a_thin_sheet_becomes_surface_rows():
    """Three rows of a sheet with a bulge: the bulge's Poisson rows (fewer than 5, joined to
    no other Poisson row) become surface rows; with the rule off they are Poisson rows."""
    sheet = lattice(24, 2)
    bulge = np.array([[11.5, 2.0], [12.5, 2.0], [12.0, -1.0]])
    x = np.vstack([sheet, bulge])
    nf = len(x)
    plain, new = _detect(x, nf, 0), _detect(x, nf, 5)
    pocket = plain["alpha"] > 0
    assert 0 < pocket.sum() < 5
    assert np.all(new["alpha"] == 0.0) and np.all(new["cls"][pocket] == K.SURFACE)
