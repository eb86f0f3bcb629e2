"""The domain cut into boxes by recursive bisection, one box per rank, balanced for equal
work; and the choice between strips and boxes.

A node of the bisection holds ranks ``[r0, r1)`` and a box; it is cut across the longer
side of its particles' global bounding box so that the work below the cut is the share of
its first ``(r1 - r0) // 2`` ranks, and each half goes on with its ranks, until one rank is
left in each box. Boxes are half-open (``lo <= x < hi``, the outer ones reaching to
infinity), so every point has exactly one owner. Every rank runs the same collectives in the
same order and holds the same boxes.

Strips (:class:`~fsi_sph.parallel.decomposition.Strips`) are kept while they serve: while
every inner strip is at least ``STRIP_MIN_HALOS`` halos wide. Thinner strips would hold more
ghosts than particles of their own (a ghost copied to several ranks, each halo crossing the
strip), and a square box has the least halo for its particles (docs/parallel.md, "Scaling").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsi_sph.parallel.comm import global_reduce
from fsi_sph.parallel.decomposition import (
    CUT_TOLERANCE,
    MAX_BISECTIONS,
    Strips,
    bisect_cuts,
    global_box,
)

#: strips serve while every inner strip is at least this many halo widths wide
STRIP_MIN_HALOS = 2.0


@dataclass(frozen=True, eq=False)
class Boxes:
    """One box per rank: rank r holds ``lo[r] <= x < hi[r]`` (both (P, 2))."""

    lo: np.ndarray
    hi: np.ndarray

    @property
    def size(self):
        return len(self.lo)

    def owner(self, x):
        """The rank owning each point of ``x`` (n, 2): int64 array of length n."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        out = np.full(len(x), -1, dtype=np.int64)
        for r in range(self.size):
            inside = np.all((self.lo[r] <= x) & (x < self.hi[r]), axis=1)
            out[inside] = r
        return out

    def distance(self, x, rank):
        """Distance from each point of ``x`` to box ``rank`` (0 inside)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        d = np.maximum(np.maximum(self.lo[rank] - x, x - self.hi[rank]), 0.0)
        return np.hypot(d[:, 0], d[:, 1])

    @classmethod
    def balanced(cls, comm, x, work=None):
        """Boxes with equal work per rank by recursive bisection (module docstring);
        collective. ``x`` (n, 2) are this rank's particles, ``work`` their work (1 each)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
        w = np.ones(len(x)) if work is None else np.asarray(work, dtype=np.float64)
        lo = np.full((comm.size, 2), -np.inf)
        hi = np.full((comm.size, 2), np.inf)
        nodes = [(0, comm.size)]
        while nodes:
            r0, r1 = nodes.pop(0)
            if r1 - r0 < 2:
                continue
            mid = r0 + (r1 - r0) // 2
            axis, cut = _bisect(comm, x, w, lo[r0], hi[r0], (mid - r0) / (r1 - r0))
            hi[r0:mid, axis] = cut
            lo[mid:r1, axis] = cut
            nodes += [(r0, mid), (mid, r1)]
        return cls(comm.bcast(lo, root=0), comm.bcast(hi, root=0))


def _bisect(comm, x, w, box_lo, box_hi, fraction):
    """The cut of the node ``box_lo <= x < box_hi``: across the longer side of its points'
    global bounding box, with ``fraction`` of their work below it; ``(axis, cut)``."""
    inside = np.all((box_lo <= x) & (x < box_hi), axis=1)
    xs, ws = x[inside], w[inside]
    lo, hi = global_box(comm, xs)
    axis = int(np.argmax(np.nan_to_num(hi - lo, nan=0.0, neginf=0.0, posinf=0.0)))
    v = xs[:, axis]
    order = np.argsort(v, kind="stable")
    cum = np.concatenate([[0.0], np.cumsum(ws[order])])
    n_global, total = global_reduce(comm, np.array([len(v), cum[-1]], dtype=np.float64))
    if n_global == 0 or total <= 0.0 or not hi[axis] > lo[axis]:
        return axis, float(0.5 * (lo[axis] + hi[axis])) if n_global else 0.0
    steps = min(int(np.ceil(np.log2(n_global / CUT_TOLERANCE))), MAX_BISECTIONS)
    cut = bisect_cuts(comm, v[order], cum, np.array([fraction * total]),
                      (lo[axis], hi[axis], total), steps)
    return axis, float(cut[0])


def partition(comm, x, width, work=None):
    """Strips while every inner strip is at least ``STRIP_MIN_HALOS`` halos of ``width``
    wide, else boxes (module docstring); collective."""
    strips = Strips.balanced(comm, x, work)
    inner = np.diff(strips.cuts[1:-1])
    if inner.size == 0 or float(inner.min()) >= STRIP_MIN_HALOS * width:
        return strips
    return Boxes.balanced(comm, x, work)
