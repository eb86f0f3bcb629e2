"""The domain cut into strips along one axis, one strip per rank, balanced for equal work.

Strip r is the half-open interval ``[cuts[r], cuts[r+1])`` of the coordinate along
``axis``, with ``cuts[0] = -inf`` and ``cuts[-1] = +inf``: every point has exactly one owner.
The cuts are computed from allreduced quantities and broadcast from rank 0, so every rank
holds the same ``Strips``.
"""

from dataclasses import dataclass

import numpy as np

from fsi_sph.parallel.comm import global_reduce

#: bisection stops when the bracket of a cut is below this fraction of the mean spacing
#: along the axis (extent / number of particles)
CUT_TOLERANCE = 1e-3
#: at most this many bisection steps (each one small allreduce); float64 needs fewer
MAX_BISECTIONS = 200


@dataclass(frozen=True, eq=False)
class Strips:
    """``size`` strips along ``axis`` (0 = x, 1 = y) separated by ``cuts`` (size + 1 values,
    non-decreasing, ``-inf`` first and ``+inf`` last)."""

    axis: int
    cuts: np.ndarray

    def __post_init__(self):
        cuts = np.array(self.cuts, dtype=np.float64)
        if cuts.ndim != 1 or cuts.size < 2:
            raise ValueError("cuts need at least 2 entries (size + 1)")
        if cuts[0] != -np.inf or cuts[-1] != np.inf or np.any(np.diff(cuts) < 0):
            raise ValueError(f"cuts must rise from -inf to +inf, got {cuts}")
        if self.axis not in (0, 1):
            raise ValueError(f"axis must be 0 or 1, got {self.axis}")
        cuts.setflags(write=False)
        object.__setattr__(self, "cuts", cuts)

    @property
    def size(self):
        """The number of strips (ranks)."""
        return self.cuts.size - 1

    def interval(self, rank):
        """(lo, hi) of strip ``rank``: it holds ``lo <= coordinate < hi``."""
        return float(self.cuts[rank]), float(self.cuts[rank + 1])

    def owner(self, x):
        """The rank owning each point of ``x`` (shape (n, 2)): int64 array of length n."""
        v = np.asarray(x, dtype=np.float64).reshape(-1, 2)[:, self.axis]
        return np.searchsorted(self.cuts[1:-1], v, side="right").astype(np.int64)

    def distance(self, x, rank):
        """Distance along the axis from each point of ``x`` to strip ``rank`` (0 inside)."""
        v = np.asarray(x, dtype=np.float64).reshape(-1, 2)[:, self.axis]
        lo, hi = self.interval(rank)
        return np.maximum(np.maximum(lo - v, v - hi), 0.0)

    @classmethod
    def balanced(cls, comm, x, work=None, axis=None):
        """Strips with equal work per rank: collective over ``comm``. ``x`` (n, 2) are this
        rank's particles, ``work`` their work (default 1 each), ``axis`` the cut axis
        (default: the long axis of the global bounding box, x on a tie).

        Each cut is found by bisection on the coordinate, allreducing the work below the
        trial cuts, down to ``CUT_TOLERANCE`` of the mean spacing; the cut then sits at the
        bracket end whose work below is nearer the target. Particles sharing a coordinate
        (a lattice column) are never split, so the balance is exact up to one such group.
        """
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        w = np.ones(len(x)) if work is None else np.asarray(work, dtype=np.float64)
        if w.shape != (len(x),):
            raise ValueError(f"work needs one value per particle, got shape {w.shape}")
        lo, hi = global_box(comm, x)
        if axis is None:
            axis = int(np.argmax(np.nan_to_num(hi - lo, nan=0.0, neginf=0.0)))
        cuts = np.full(comm.size + 1, np.inf)
        cuts[0] = -np.inf
        if comm.size > 1:
            cuts[1:-1] = weighted_cuts(comm, x[:, axis], w, lo[axis], hi[axis])
        return cls(int(axis), comm.bcast(cuts, root=0))


def global_box(comm, x):
    """(lo, hi): the corners of the bounding box of all ranks' points (+inf/-inf if none)."""
    lo = x.min(axis=0) if len(x) else np.full(2, np.inf)
    hi = x.max(axis=0) if len(x) else np.full(2, -np.inf)
    return global_reduce(comm, lo, "min"), global_reduce(comm, hi, "max")


def weighted_cuts(comm, v, w, lo, hi):
    """The size - 1 inner cuts splitting the global work of coordinates ``v`` (weights
    ``w``) into equal parts; collective. Evenly spaced over [lo, hi] when there is no work."""
    order = np.argsort(v, kind="stable")
    v_sorted = v[order]
    cum = np.concatenate([[0.0], np.cumsum(w[order])])
    n_global, total = global_reduce(comm, np.array([len(v), cum[-1]], dtype=np.float64))
    inner = np.arange(1, comm.size)
    if n_global == 0:
        return np.zeros(comm.size - 1)
    if total <= 0.0 or hi <= lo:
        return lo + (hi - lo) * inner / comm.size
    steps = int(np.ceil(np.log2(n_global / CUT_TOLERANCE)))
    targets = total * inner / comm.size
    return bisect_cuts(comm, v_sorted, cum, targets, (lo, hi, total), min(steps, MAX_BISECTIONS))


def work_below(comm, v_sorted, cum, cuts):
    """The global work of the points with coordinate < each cut; collective."""
    local = cum[np.searchsorted(v_sorted, cuts, side="left")]
    return global_reduce(comm, local, "sum")


def bisect_cuts(comm, v_sorted, cum, targets, box, steps):
    """``steps`` bisections of all cuts at once over ``box = (lo, hi, total work)``: ``a``
    keeps work below <= target, ``b`` above it. Returns, per cut, the end of the final
    bracket whose work below is nearer its target. The step count is fixed beforehand, so
    every rank runs the same number of collectives whatever rounding the reductions do."""
    lo, hi, total = box
    a = np.full(targets.size, float(lo))
    b = np.full(targets.size, float(np.nextafter(hi, np.inf)))
    fa = np.zeros(targets.size)
    fb = np.full(targets.size, float(total))
    for _ in range(steps):
        mid = 0.5 * (a + b)
        f = work_below(comm, v_sorted, cum, mid)
        up = f <= targets
        a, fa = np.where(up, mid, a), np.where(up, f, fa)
        b, fb = np.where(up, b, mid), np.where(up, fb, f)
    cuts = np.where(targets - fa <= fb - targets, a, b)
    return np.maximum.accumulate(cuts)


def imbalance(comm, work_local):
    """max / mean - 1 of the work per rank (``work_local``: this rank's total, or an array
    of per-particle work that is summed); 0 when there is no work. Collective."""
    mine = float(np.sum(work_local))
    per_rank = np.array(comm.allgather(mine), dtype=np.float64)
    mean = per_rank.mean()
    return float(per_rank.max() / mean - 1.0) if mean > 0 else 0.0


def needs_rebalance(comm, work_local, tol=0.10):
    """True on every rank when ``imbalance`` exceeds ``tol``. Collective."""
    return imbalance(comm, work_local) > tol
