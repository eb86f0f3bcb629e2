"""O(N) cell-linked-list neighbour search producing CSR pair lists.

For destination points ``xd`` and source points ``xs`` the result is
``(nbr_start, nbr_j)``: the sources within ``radius`` of destination ``i`` are
``nbr_j[nbr_start[i]:nbr_start[i+1]]``, in increasing index order. With
``exclude_self`` (same set as source and destination) ``j == i`` is left out.
"""

import numpy as np
from numba import njit, prange


@njit(cache=True)
def _build_cells(xs, lo, cell, ncx, ncy):
    """Sort sources into cells: returns (cell_start, cell_items) in CSR form."""
    n = xs.shape[0]
    cid = np.empty(n, dtype=np.int64)
    count = np.zeros(ncx * ncy + 1, dtype=np.int64)
    for j in range(n):
        cx = min(max(int((xs[j, 0] - lo[0]) / cell), 0), ncx - 1)
        cy = min(max(int((xs[j, 1] - lo[1]) / cell), 0), ncy - 1)
        cid[j] = cx * ncy + cy
        count[cid[j] + 1] += 1
    for c in range(ncx * ncy):
        count[c + 1] += count[c]
    fill = count[:-1].copy()
    items = np.empty(n, dtype=np.int64)
    for j in range(n):  # j increasing: items stay sorted within a cell
        items[fill[cid[j]]] = j
        fill[cid[j]] += 1
    return count, items


@njit(cache=True)
def _scan_row(i, xd, xs, lo, cell, ncx, ncy, cstart, citems, r2max, exclude_self, out_j, at):
    """Neighbours of destination ``i``: counted, and written to ``out_j[at:]`` if ``at >= 0``."""
    cx = int((xd[i, 0] - lo[0]) / cell)
    cy = int((xd[i, 1] - lo[1]) / cell)
    k = 0
    for ax in range(max(cx - 1, 0), min(cx + 2, ncx)):
        for ay in range(max(cy - 1, 0), min(cy + 2, ncy)):
            c = ax * ncy + ay
            for s in range(cstart[c], cstart[c + 1]):
                j = citems[s]
                if exclude_self and j == i:
                    continue
                dx0 = xd[i, 0] - xs[j, 0]
                dx1 = xd[i, 1] - xs[j, 1]
                if dx0 * dx0 + dx1 * dx1 < r2max:
                    if at >= 0:
                        out_j[at + k] = j
                    k += 1
    return k


@njit(cache=True)
def _bounds(x, lo, hi):
    """Smallest and largest coordinates of the points ``x`` (into ``lo``, ``hi``): one pass
    (numpy's ``min(axis=0)`` on an (n, 2) array costs several times more)."""
    for k in range(2):
        lo[k] = x[0, k]
        hi[k] = x[0, k]
    for j in range(x.shape[0]):
        for k in range(2):
            lo[k] = min(lo[k], x[j, k])
            hi[k] = max(hi[k], x[j, k])


@njit(cache=True, parallel=True)
def _candidates(xd, lo, cell, ncx, ncy, cstart, out_count):
    """Upper bound of each destination's neighbour count: the sources in its 3 x 3 cells."""
    for i in prange(xd.shape[0]):
        cx = int((xd[i, 0] - lo[0]) / cell)
        cy = int((xd[i, 1] - lo[1]) / cell)
        k = 0
        for ax in range(max(cx - 1, 0), min(cx + 2, ncx)):
            c0 = ax * ncy + max(cy - 1, 0)
            c1 = ax * ncy + min(cy + 2, ncy)
            k += cstart[c1] - cstart[c0]
        out_count[i] = k


@njit(cache=True, parallel=True)
def _fill(xd, xs, lo, cell, ncx, ncy, cstart, citems, r2max, exclude_self, slot_start, slots,
          out_count):
    """Neighbours of every destination written to its slots; their number to out_count."""
    for i in prange(xd.shape[0]):
        out_count[i] = _scan_row(i, xd, xs, lo, cell, ncx, ncy, cstart, citems, r2max,
                                 exclude_self, slots, slot_start[i])


@njit(cache=True, parallel=True)
def _compact(slot_start, slots, start, out_j):
    for i in prange(start.shape[0] - 1):
        a = slot_start[i]
        for k in range(start[i + 1] - start[i]):
            out_j[start[i] + k] = slots[a + k]


def find_neighbors(xd, xs, radius, exclude_self=False, origin=None):
    """Neighbours of each destination point among the sources, within ``radius``.

    Parameters
    ----------
    xd : (nd, 2) float64 array, destination positions.
    xs : (ns, 2) float64 array, source positions.
    radius : float, search radius (kernel support, ``2 h``).
    exclude_self : bool, leave out ``j == i`` (only meaningful when ``xd is xs``).
    origin : (2,) lower corner of the cell grid (default: the points' lower corner less
        ``radius``); it must lie below and left of every point. The order of the sources
        within a row depends on it, so a body split over ranks gives every rank the serial
        run's corner (fsi_sph/parallel/split.py).

    Returns
    -------
    nbr_start : (nd + 1,) int64, nbr_j : (npairs,) int64. Within each row the
    sources are grouped by cell and sorted by index inside a cell.
    """
    xd = np.ascontiguousarray(xd, dtype=np.float64)
    xs = np.ascontiguousarray(xs, dtype=np.float64)
    nd = xd.shape[0]
    if nd == 0 or xs.shape[0] == 0:
        return np.zeros(nd + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    lo_d, hi_d, lo_s, hi_s = (np.empty(2) for _ in range(4))
    _bounds(xd, lo_d, hi_d)
    _bounds(xs, lo_s, hi_s)
    lo = np.minimum(lo_d, lo_s) - radius if origin is None else np.asarray(origin, np.float64)
    hi = np.maximum(hi_d, hi_s) + radius
    ncx = max(int((hi[0] - lo[0]) / radius) + 1, 1)
    ncy = max(int((hi[1] - lo[1]) / radius) + 1, 1)
    cstart, citems = _build_cells(xs, lo, radius, ncx, ncy)
    # one pass: each row writes into slots sized by its candidate count, then compaction
    cand = np.empty(nd, dtype=np.int64)
    _candidates(xd, lo, radius, ncx, ncy, cstart, cand)
    slot_start = np.zeros(nd + 1, dtype=np.int64)
    np.cumsum(cand, out=slot_start[1:])
    # candidates: about 9 / pi times the pairs (3 x 3 cells against a circle), the search's
    # largest array; int32 where the indices fit (half its memory; the result stays int64)
    slots = np.empty(slot_start[-1], dtype=np.int32 if len(xs) < 2**31 else np.int64)
    count = np.empty(nd, dtype=np.int64)
    _fill(xd, xs, lo, radius, ncx, ncy, cstart, citems, radius * radius, exclude_self,
          slot_start, slots, count)
    start = np.zeros(nd + 1, dtype=np.int64)
    np.cumsum(count, out=start[1:])
    nbr_j = np.empty(start[-1], dtype=np.int64)
    _compact(slot_start, slots, start, nbr_j)
    return start, nbr_j


@njit(cache=True)
def transpose_order(start, idx, n_cols):
    """The transpose of the CSR pattern ``(start, idx)`` by a counting sort: ``(t_start,
    t_idx, perm)``, each row of the transpose sorted (the original rows in increasing order)
    and ``perm[e]`` the position in ``idx`` of the transpose's entry ``e`` (so its values
    are ``data[perm]``)."""
    t_start = np.zeros(n_cols + 1, dtype=np.int64)
    for k in range(len(idx)):
        t_start[idx[k] + 1] += 1
    for c in range(n_cols):
        t_start[c + 1] += t_start[c]
    fill = t_start[:-1].copy()
    t_idx = np.empty(len(idx), dtype=np.int64)
    perm = np.empty(len(idx), dtype=np.int64)
    for r in range(len(start) - 1):
        for k in range(start[r], start[r + 1]):
            e = fill[idx[k]]
            t_idx[e] = r
            perm[e] = k
            fill[idx[k]] += 1
    return t_start, t_idx, perm


def transpose_csr(nbr_start, nbr_j, n_sources):
    """The reverse pair list: for each source ``j``, the destinations ``i`` that list it
    (sorted), as ``(start, i)``. Same pairs, so a pair force gathered on both sides from a
    list and its transpose cancels exactly."""
    start, rows, _ = transpose_order(nbr_start, nbr_j, n_sources)
    return start, rows
