"""Particles moved to the rank owning them, ghost (halo) layers, global ids and row offsets.

All functions taking ``comm`` are collective: every rank calls them in the same order.
"""

import numpy as np

from fsi_sph.parallel.comm import exchange_arrays, exchange_counts


def assign_gids(comm, n_local):
    """Global ids ``start, ..., start + n_local - 1`` (int64), ``start`` the number of
    particles on the lower ranks (exclusive scan): ids are unique and contiguous per rank."""
    start, _ = row_offsets(comm, n_local)
    return np.arange(start, start + int(n_local), dtype=np.int64)


def row_offsets(comm, n_owned):
    """(start, n_global): this rank owns global rows ``start .. start + n_owned - 1`` of a
    matrix distributed by blocks of rows in rank order, ``n_global`` rows in all."""
    counts = np.array(comm.allgather(int(n_owned)), dtype=np.int64)
    return int(counts[:comm.rank].sum()), int(counts.sum())


def record_dtype(arrays):
    """The structured dtype packing one row of every array of the dict (keys sorted)."""
    n = {len(a) for a in arrays.values()}
    if len(n) > 1:
        raise ValueError(f"arrays to migrate differ in length: {sorted(n)}")
    return np.dtype([(k, arrays[k].dtype, arrays[k].shape[1:]) for k in sorted(arrays)])


def check_migratable(comm, arrays, key):
    """Raises ValueError (on every rank alike) unless the dict holds an int64 ``gid`` and a
    position array ``key`` (n, 2) and its names, dtypes and shapes agree across ranks."""
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    if "gid" not in arrays or key not in arrays:
        raise ValueError(f"migrate needs a 'gid' and a {key!r} array, got {sorted(arrays)}")
    if arrays["gid"].dtype != np.int64 or arrays["gid"].ndim != 1:
        raise ValueError(f"'gid' must be a 1-d int64 array, got {arrays['gid'].dtype}")
    if arrays[key].shape[1:] != (2,):
        raise ValueError(f"{key!r} must have shape (n, 2), got {arrays[key].shape}")
    dtype = record_dtype(arrays)
    if len(set(comm.allgather(str(dtype)))) != 1:
        raise ValueError("the arrays to migrate differ between ranks")
    return arrays, dtype


def pack(arrays, dtype, index):
    """Rows ``index`` of every array, packed into one structured array of ``dtype``."""
    rec = np.empty(len(index), dtype=dtype)
    for k in dtype.names:
        rec[k] = arrays[k][index]
    return rec


def migrate(comm, strips, arrays, key="x"):
    """Every particle whose owner (``strips.owner`` of ``arrays[key]``) is another rank is
    sent there, all arrays of the dict moving together; collective.

    ``arrays`` maps names to arrays with one row per particle (any dtype except object, any
    trailing shape) and must hold an int64 ``"gid"`` and the positions ``key`` (n, 2).
    Returns a new dict (same names, dtypes, shapes) of the particles this rank owns: the
    kept ones first, in their previous order, then the received ones sorted by gid.
    """
    arrays, dtype = check_migratable(comm, arrays, key)
    owner = strips.owner(arrays[key])
    order = np.argsort(owner, kind="stable")
    counts = np.bincount(owner, minlength=comm.size)
    bounds = np.concatenate([[0], np.cumsum(counts)])
    sends = [pack(arrays, dtype, order[bounds[r]:bounds[r + 1]]) if r != comm.rank
             else np.empty(0, dtype=dtype) for r in range(comm.size)]
    received = np.concatenate(exchange_arrays(comm, sends))
    received = received[np.argsort(received["gid"], kind="stable")]
    kept = owner == comm.rank
    if len(received) == 0 and kept.all():  # nothing crossed a cut: the arrays as they are
        return dict(arrays)
    return {k: np.concatenate([arrays[k][kept], received[k]]) for k in arrays}


class Halo:
    """The ghost layer of one rank: which owned particles each other rank needs, and the
    exchange of their fields. Fixed by ``build`` until the next build (the owned particles
    must keep their rows in between).

    Ghost rows are ordered by source rank, then in the sender's row order; every exchange
    returns them in this same order. ``bytes_last`` and ``messages_last`` count the bytes
    and the non-empty messages this rank sent in the last exchange.
    """

    def __init__(self, comm, send_index, recv_counts, n_owned):
        self.comm = comm
        self.send_index = send_index
        self.recv_counts = np.asarray(recv_counts, dtype=np.int64)
        self.n_owned = int(n_owned)
        self.bytes_last = 0
        self.messages_last = 0

    @classmethod
    def build(cls, comm, strips, x_owned, width):
        """The halo of this rank's owned particles ``x_owned`` (n, 2): rank r (not this one)
        gets, in increasing row order, every particle whose distance along the strip axis to
        strip r is <= ``width``. A particle can go to several ranks (strips thinner than
        ``width``). Collective: the ghost counts are exchanged here."""
        x_owned = np.asarray(x_owned, dtype=np.float64).reshape(-1, 2)
        send_index = []
        for r in range(comm.size):
            near = strips.distance(x_owned, r) <= width
            send_index.append(np.flatnonzero(near) if r != comm.rank
                              else np.empty(0, dtype=np.int64))
        recv_counts = exchange_counts(comm, [len(i) for i in send_index])
        return cls(comm, send_index, recv_counts, len(x_owned))

    @property
    def n_ghost(self):
        """The number of ghost rows this rank receives."""
        return int(self.recv_counts.sum())

    @property
    def ghost_source(self):
        """The rank each ghost row comes from (int64, non-decreasing)."""
        return np.repeat(np.arange(self.comm.size, dtype=np.int64), self.recv_counts)

    def exchange(self, field_owned):
        """The ghost rows of a field of the owned particles (rows = particles, any dtype and
        trailing shape): an array of ``n_ghost`` rows, in the halo's fixed order."""
        field_owned = np.asarray(field_owned)
        if field_owned.shape[:1] != (self.n_owned,):
            raise ValueError(f"field has {field_owned.shape[:1]} rows, the halo was built "
                             f"for {self.n_owned} owned particles")
        sends = [field_owned[i] for i in self.send_index]
        others = [s for r, s in enumerate(sends) if r != self.comm.rank]
        self.bytes_last = int(sum(s.nbytes for s in others))
        self.messages_last = int(sum(1 for s in others if len(s)))
        return np.concatenate(exchange_arrays(self.comm, sends, self.recv_counts), axis=0)

    def exchange_into(self, field_all, n_owned):
        """Writes the ghost rows of ``field_all[:n_owned]`` into ``field_all[n_owned:]``
        (the array holds owned then ghost rows) and returns ``field_all``."""
        if len(field_all) != n_owned + self.n_ghost:
            raise ValueError(f"field has {len(field_all)} rows, need {n_owned} owned + "
                             f"{self.n_ghost} ghosts")
        field_all[n_owned:] = self.exchange(field_all[:n_owned])
        return field_all
