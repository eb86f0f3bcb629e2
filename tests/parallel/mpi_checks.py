"""Checks of fsi_sph.parallel on several ranks: ``mpiexec -n P python mpi_checks.py NAME...``.

Each check asserts; a failure on any rank prints the traceback and aborts the whole job with a
non-zero exit code (tests/parallel/test_decomposition.py runs these). The expected results are
computed by brute force from the data of all ranks (allgather), not with the layer's helpers.
"""

import sys
import traceback

import numpy as np

from fsi_sph.parallel.comm import exchange_arrays, exchange_counts, world
from fsi_sph.parallel.decomposition import Strips, imbalance, needs_rebalance
from fsi_sph.parallel.halo import Halo, assign_gids, migrate, row_offsets

WIDTH = 0.05


def scalar(gid):
    return np.sin(gid) + 1e-3 * gid


def vector(gid):
    return np.column_stack([np.cos(gid), gid * 0.5])


def tensor(gid):
    return np.stack([vector(gid), vector(gid + 7) * 3.0], axis=1)


def initial_particles(comm, seed=0):
    """Uneven counts: rank 0 has 3000 particles on [0,2]x[0,1], rank 1 500 on [1.5,3.5]x[0,1],
    further ranks none. Fields are functions of gid; ``work`` in [0.5, 3]."""
    rng = np.random.default_rng(seed + 17 * comm.rank)
    n, box = {0: (3000, (0.0, 2.0)), 1: (500, (1.5, 3.5))}.get(comm.rank, (0, (0.0, 1.0)))
    x = np.column_stack([rng.uniform(*box, n), rng.uniform(0.0, 1.0, n)])
    gid = assign_gids(comm, n)
    return {"x": x, "gid": gid, "f": scalar(gid), "v": vector(gid), "t": tensor(gid),
            "flag": gid % 3 == 0, "code": (gid * 7 % 1000).astype(np.int32),
            "work": 0.5 + 2.5 * ((gid * 2654435761) % 1000) / 999.0}


def gathered(comm, a):
    """The concatenation over ranks of ``a`` (in rank order)."""
    return np.concatenate(comm.allgather(a))


def check_exchange(comm):
    """exchange_arrays: any dtype and trailing shape, empty messages, known recv counts."""
    def block(src, dst, dtype, trailing):
        n = (3 * src + 5 * dst) % 4 + (src == dst)
        base = np.arange(n * int(np.prod(trailing)), dtype=np.float64) + 1000 * src + 100 * dst
        return base.reshape((n, *trailing)).astype(dtype)

    for dtype, trailing in [(np.float64, ()), (np.int32, (2, 2)), (bool, (3,)),
                            (np.complex128, (2,)), (np.int64, (0,))]:
        sends = [block(comm.rank, r, dtype, trailing) for r in range(comm.size)]
        got = exchange_arrays(comm, sends)
        counts = exchange_counts(comm, [len(s) for s in sends])
        again = exchange_arrays(comm, sends, recv_counts=counts)
        for s in range(comm.size):
            want = block(s, comm.rank, dtype, trailing)
            assert got[s].dtype == want.dtype and got[s].shape == want.shape, (got[s], want)
            assert np.array_equal(got[s], want) and np.array_equal(again[s], want)
    empty = exchange_arrays(comm, [np.empty((0, 2))] * comm.size)
    assert all(e.shape == (0, 2) for e in empty)


def check_gids(comm):
    """assign_gids and row_offsets: contiguous blocks in rank order covering 0..N-1."""
    n = 10 + 7 * comm.rank
    gid = assign_gids(comm, n)
    every = gathered(comm, gid)
    assert np.array_equal(every, np.arange(every.size))
    start, n_global = row_offsets(comm, n)
    assert n_global == every.size and start == sum(10 + 7 * r for r in range(comm.rank))
    assert gid[0] == start and gid.dtype == np.int64


def within(a, b, tol, unit):
    return abs(a - b) <= tol * b + unit


def check_balance(comm):
    """Strips.balanced + migrate give each rank half (1/size) of the count, and of the work."""
    p = initial_particles(comm)
    counts = np.array(comm.allgather(len(p["x"])), dtype=np.float64)
    assert np.isclose(imbalance(comm, len(p["x"])), counts.max() / counts.mean() - 1.0)
    assert needs_rebalance(comm, len(p["x"]))
    n_total = counts.sum()
    strips = Strips.balanced(comm, p["x"])
    assert strips.axis == 0 and strips.size == comm.size
    assert all(np.array_equal(c, strips.cuts) for c in comm.allgather(strips.cuts))
    mine = migrate(comm, strips, p)
    assert within(len(mine["x"]), n_total / comm.size, 0.01, 1), (len(mine["x"]), n_total)
    assert not needs_rebalance(comm, len(mine["x"]), tol=0.03)
    w_total = float(np.sum(gathered(comm, p["work"])))
    w_max = float(np.max(gathered(comm, p["work"])))
    strips = Strips.balanced(comm, mine["x"], work=mine["work"])
    mine = migrate(comm, strips, mine)
    w_mine = float(mine["work"].sum())
    assert within(w_mine, w_total / comm.size, 0.01, w_max), (w_mine, w_total)
    assert imbalance(comm, mine["work"]) < 0.03
    tall = Strips.balanced(comm, p["x"][:, ::-1])
    assert tall.axis == 1


def check_migrate(comm):
    """No particle lost or doubled, each on its owner, every array moved with it, order."""
    p = initial_particles(comm)
    x_of = gathered(comm, p["x"])  # x of gid g is x_of[g] (gids are 0..N-1 in rank order)
    strips = Strips.balanced(comm, p["x"])
    mine = migrate(comm, strips, p)
    every = gathered(comm, mine["gid"])
    assert np.array_equal(np.sort(every), np.arange(x_of.shape[0])), "lost or doubled"
    g = mine["gid"]
    lo, hi = strips.cuts[comm.rank], strips.cuts[comm.rank + 1]
    assert np.all((mine["x"][:, 0] >= lo) & (mine["x"][:, 0] < hi)), "not on its owner"
    assert np.array_equal(mine["x"], x_of[g])
    for name, fun in [("f", scalar), ("v", vector), ("t", tensor)]:
        assert np.array_equal(mine[name], fun(g)), name
    assert np.array_equal(mine["flag"], g % 3 == 0)
    assert np.array_equal(mine["code"], (g * 7 % 1000).astype(np.int32))
    assert all(mine[k].dtype == p[k].dtype for k in p)
    stay = p["gid"][(p["x"][:, 0] >= lo) & (p["x"][:, 0] < hi)]
    assert np.array_equal(g[:stay.size], stay), "kept particles reordered"
    came = g[stay.size:]
    assert np.all(np.diff(came) > 0) and not np.isin(came, p["gid"]).any()
    again = migrate(comm, strips, mine)
    assert all(np.array_equal(again[k], mine[k]) for k in mine), "second migrate moved"


def near(v, lo, hi, width):
    """Coordinates ``v`` within ``width`` of the interval [lo, hi] (infinite ends allowed)."""
    return (v >= lo - width) & (v <= hi + width)


def expected_ghosts(comm, strips, x, gid, width):
    """Brute force: for every rank s != me, the gids (in s's row order) of s's particles within
    ``width`` of my strip along the axis; also the number I send to every rank."""
    xs, gs = comm.allgather(x), comm.allgather(gid)
    cuts, me, ax = strips.cuts, comm.rank, strips.axis
    sent = np.array([0 if r == me else np.count_nonzero(near(x[:, ax], cuts[r], cuts[r + 1], width))
                     for r in range(comm.size)])
    ghosts = [gs[s][near(xs[s][:, ax], cuts[me], cuts[me + 1], width)]
              for s in range(comm.size) if s != me]
    return np.concatenate(ghosts), sent


def check_halo_of(comm, strips, mine, width):
    """Ghost set and order, every field kind, exchange_into and the counters."""
    halo = Halo.build(comm, strips, mine["x"], width)
    want, sent = expected_ghosts(comm, strips, mine["x"], mine["gid"], width)
    g = halo.exchange(mine["gid"])
    assert np.array_equal(g, want), (g.size, want.size)
    assert halo.n_ghost == want.size and np.unique(g).size == g.size
    assert not np.isin(g, mine["gid"]).any()
    assert np.all(np.diff(halo.ghost_source) >= 0)
    x_of = dict(zip(gathered(comm, mine["gid"]).tolist(), gathered(comm, mine["x"]), strict=True))
    assert np.array_equal(halo.exchange(mine["x"]), np.array([x_of[k] for k in g.tolist()]))
    for name, fun in [("f", scalar), ("v", vector), ("t", tensor)]:
        assert np.array_equal(halo.exchange(mine[name]), fun(g).reshape(-1, *mine[name].shape[1:]))
    assert halo.bytes_last == int(sent.sum()) * 4 * 8
    assert halo.messages_last == int(np.count_nonzero(sent))
    n = len(mine["x"])
    full = np.zeros((n + halo.n_ghost, 2, 2))
    full[:n] = mine["t"]
    assert halo.exchange_into(full, n) is full and np.array_equal(full[n:], tensor(g))
    return halo, g


def check_halo(comm):
    p = initial_particles(comm)
    strips = Strips.balanced(comm, p["x"])
    mine = migrate(comm, strips, p)
    halo, g = check_halo_of(comm, strips, mine, WIDTH)
    assert halo.n_ghost > 0


def check_repeat(comm):
    """The owners change their values; each new exchange brings the new values, same order."""
    p = initial_particles(comm)
    strips = Strips.balanced(comm, p["x"])
    mine = migrate(comm, strips, p)
    halo = Halo.build(comm, strips, mine["x"], WIDTH)
    g = halo.exchange(mine["gid"])
    n = len(mine["x"])
    full = np.zeros((n + halo.n_ghost, 2))
    for step in range(1, 4):
        mine["f"] = scalar(mine["gid"]) * step + 10.0 * step
        mine["v"] = vector(mine["gid"]) - step
        assert np.array_equal(halo.exchange(mine["f"]), scalar(g) * step + 10.0 * step)
        full[:n] = mine["v"]
        halo.exchange_into(full, n)
        assert np.array_equal(full[n:], vector(g) - step)
        assert np.array_equal(halo.exchange(mine["gid"]), g)


def check_thin(comm):
    """Strips thinner than the halo width: a particle is a ghost on several ranks."""
    rng = np.random.default_rng(5 + comm.rank)
    x = np.column_stack([rng.uniform(0.0, 2.0, 1200), rng.uniform(0.0, 1.0, 1200)])
    gid = assign_gids(comm, len(x))
    p = {"x": x, "gid": gid, "f": scalar(gid), "v": vector(gid), "t": tensor(gid)}
    inner = 1.0 + 0.05 * np.arange(comm.size - 1)
    strips = Strips(0, np.concatenate([[-np.inf], inner, [np.inf]]))
    mine = migrate(comm, strips, p)
    halo, g = check_halo_of(comm, strips, mine, 0.2)
    every = gathered(comm, g)
    if comm.size >= 3:
        _, times = np.unique(every, return_counts=True)
        assert times.max() >= 2, "no particle is a ghost on two ranks"


CHECKS = {"exchange": check_exchange, "gids": check_gids, "balance": check_balance,
          "migrate": check_migrate, "halo": check_halo, "repeat": check_repeat,
          "thin": check_thin}


def main(names):
    comm = world()
    assert comm.size > 1, "run under mpiexec -n 2 (or more)"
    for name in names:
        try:
            CHECKS[name](comm)
        except Exception:
            sys.stderr.write(f"rank {comm.rank}: check {name} failed\n{traceback.format_exc()}")
            sys.stderr.flush()
            comm.Abort(1)
        comm.Barrier()
        if comm.rank == 0:
            print(f"ok {name} on {comm.size} ranks", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or list(CHECKS))
