"""The umbrella free-surface scan (Marrone et al. 2010; fluid.surface_scan) against a numpy
oracle, on a square block, and on the case it was added for: the face particle of a thin
front whose div r is raised by neighbours crowded behind it."""

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.free_surface import CHI, detect
from fsi_sph.neighbors import find_neighbors
from tests import fluid_reference as ref
from tests.conftest import lattice

H = 1.2
KIND = 0


def _detect(x, scan):
    n = len(x)
    s, j = find_neighbors(x, x, 2 * H, exclude_self=True)
    out = dict(divr=np.zeros(n), gc=np.zeros((n, 2)), sig=np.zeros(n), alpha=np.zeros(n),
               cls=np.zeros(n, dtype=np.int8), nrm=np.zeros((n, 2)))
    added = detect(x, np.ones(n), s, j, n, H, KIND, out["divr"], out["gc"], out["sig"],
                   out["alpha"], out["cls"], out["nrm"], scan=scan)
    return out, added


def test_umbrella_scan_matches_oracle():
    rng = np.random.default_rng(3)
    x = lattice(14, 12) + rng.uniform(-0.3, 0.3, (168, 2))
    x = x[np.hypot(x[:, 0] - 7.0, x[:, 1] - 6.0) > 2.5]  # a hole: inner surfaces too
    n = len(x)
    s, j = find_neighbors(x, x, 2 * H, exclude_self=True)
    divr, gc, sig = np.zeros(n), np.zeros((n, 2)), np.zeros(n)
    K.position_divergence(x, np.ones(n), s, j, H, KIND, divr, gc, sig)
    candidate = np.ones(n, dtype=bool)
    flag = np.empty(n, dtype=np.bool_)
    K.umbrella_scan(x, candidate, gc, s, j, n, H, flag)
    want = ref.umbrella_scan(x, candidate, gc, H, n)
    assert np.array_equal(flag, want)
    assert 10 < want.sum() < n // 2  # the test sees both answers


def test_scan_keeps_exactly_the_outer_layer_of_a_square_block():
    x = lattice(20, 20)
    plain, _ = _detect(x, scan=False)
    scanned, added = _detect(x, scan=True)
    outer = (x[:, 0] < 1) | (x[:, 0] > 19) | (x[:, 1] < 1) | (x[:, 1] > 19)
    assert added == 0
    assert np.array_equal(scanned["cls"] == K.SURFACE, outer)
    assert np.array_equal(scanned["alpha"], plain["alpha"])


def test_scan_flags_the_face_of_a_front_crowded_from_behind():
    """A block x < 10 (face row at 9.5) with a particle at x = 10.1 and five more crowded
    0.4-0.5 dx behind it (as traced at a dam break's front: clumped neighbours, div r 1.76):
    its div r (1.75) is above the [F 21] threshold, so div r alone makes it an interior
    Poisson row with nothing in front of it."""
    block = lattice(10, 11)
    face = np.array([10.1, 5.5])
    crowd = face + np.array([[-0.4, 0.35], [-0.4, -0.35], [-0.5, 0.0], [-0.4, 0.7],
                             [-0.4, -0.7]])
    x = np.vstack([block, crowd, face])
    i = len(x) - 1
    plain, _ = _detect(x, scan=False)
    assert plain["divr"][i] >= CHI and plain["cls"][i] != K.SURFACE and plain["alpha"][i] > 0
    scanned, added = _detect(x, scan=True)
    assert scanned["cls"][i] == K.SURFACE and scanned["alpha"][i] == 0.0
    assert scanned["nrm"][i][0] > 0.9  # its normal points out of the front
    # the crowd raises div r of the block's face row beside it too (1.69 at y = 3.5 and
    # 7.5, beside the crowd, not behind it): div r alone lost them, the scan has them
    face_row = block[:, 0] > 9.0
    beside = face_row & (np.abs(block[:, 1] - 5.5) > 1.5)
    assert np.sum(plain["cls"][:110][beside] != K.SURFACE) == 2
    assert np.all(scanned["cls"][:110][beside] == K.SURFACE)
    # and the rest of the block keeps its surface rows and its blend
    rest = ~face_row
    assert np.array_equal(scanned["cls"][:110][rest] == K.SURFACE,
                          plain["cls"][:110][rest] == K.SURFACE)
    assert np.array_equal(scanned["alpha"][:110][rest], plain["alpha"][:110][rest])
    assert 3 <= added <= 8
