"""The communicator and the one all-to-all exchange of numpy arrays the parallel layer uses.

``world()`` gives MPI ``COMM_WORLD`` when the process was started by an MPI launcher (or
mpi4py is already imported), else a ``SerialComm``: one rank, the same method names, so the
decomposition, migration and halo code has no serial special case. Serial runs never import
mpi4py (importing it initialises MPI).

The collective helpers (``exchange_counts``, ``exchange_arrays``, ``global_reduce``) must be
called by every rank of the communicator, in the same order, like any MPI collective.
"""

import os
import sys
from contextlib import contextmanager

import numpy as np

#: environment variables set by mpiexec/mpirun (MPICH hydra, PMIx, Open MPI, Intel MPI)
LAUNCHER_RANK_VARS = ("PMI_RANK", "PMIX_RANK", "OMPI_COMM_WORLD_RANK", "MPI_LOCALRANKID")
LAUNCHER_SIZE_VARS = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")


class SerialComm:
    """A one-rank stand-in for an mpi4py communicator (rank 0 of size 1).

    Only the methods the parallel layer uses; each returns what MPI would on one rank.
    """

    rank = 0
    size = 1

    def Get_rank(self):
        return 0

    def Get_size(self):
        return 1

    def allreduce(self, value, op=None):
        """The value itself (the reduction over one rank)."""
        return value

    def allgather(self, value):
        """``[value]``."""
        return [value]

    def alltoall(self, values):
        """The list itself: the one entry this rank sends to itself."""
        values = list(values)
        if len(values) != 1:
            raise ValueError(f"alltoall on one rank takes 1 value, got {len(values)}")
        return values

    def gather(self, value, root=0):
        """``[value]`` (this rank is the root)."""
        return [value]

    def bcast(self, value, root=0):
        """The value itself."""
        return value

    def Barrier(self):
        """Nothing to wait for."""


def launched_size():
    """The number of ranks the MPI launcher announced in the environment (0 if none)."""
    for var in LAUNCHER_SIZE_VARS:
        if var in os.environ:
            try:
                return int(os.environ[var])
            except ValueError:
                return 1
    return 1 if any(var in os.environ for var in LAUNCHER_RANK_VARS) else 0


def launched_rank():
    """This process's rank as the MPI launcher announced it in the environment (0 if none),
    known without starting MPI."""
    for var in LAUNCHER_RANK_VARS:
        if os.environ.get(var, "").isdigit():
            return int(os.environ[var])
    return 0


def world():
    """MPI ``COMM_WORLD`` under an MPI launcher (or when mpi4py.MPI is already imported),
    else a ``SerialComm``. Raises ImportError when launched on several ranks without mpi4py:
    each process would otherwise run the whole case as rank 0."""
    launched = launched_size()
    if not launched and "mpi4py.MPI" not in sys.modules:
        return SerialComm()
    try:
        from mpi4py import MPI
    except ImportError as err:
        if launched > 1:
            raise ImportError("started on several MPI ranks but mpi4py is not installed "
                              "(pip install 'fsi_sph[mpi]')") from err
        return SerialComm()
    return MPI.COMM_WORLD


def mpi_op(name):
    """The mpi4py reduction operation ``MPI.<NAME>`` (``"sum"``, ``"max"``, ``"min"``)."""
    from mpi4py import MPI

    return getattr(MPI, name.upper())


def global_reduce(comm, values, op="sum"):
    """Element-wise reduction (``"sum"``, ``"max"`` or ``"min"``) of a numeric array over the
    ranks; every rank gets the same result, an array of the input's shape and dtype."""
    values = np.array(values, copy=True)
    if comm.size == 1:
        return values
    out = np.ascontiguousarray(values)
    comm.Allreduce(comm_in_place(), out, op=mpi_op(op))
    return out


def comm_in_place():
    """``MPI.IN_PLACE``."""
    from mpi4py import MPI

    return MPI.IN_PLACE


def exchange_counts(comm, send_counts):
    """All-to-all of one integer per rank pair: ``send_counts[r]`` goes to rank r; returns
    the int64 array whose entry s is what rank s sent to this rank."""
    send = np.ascontiguousarray(send_counts, dtype=np.int64)
    if send.shape != (comm.size,):
        raise ValueError(f"need {comm.size} counts, got shape {send.shape}")
    if comm.size == 1:
        return send.copy()
    recv = np.empty(comm.size, dtype=np.int64)
    comm.Alltoall(send, recv)
    return recv


def check_sends(comm, sends):
    """The (dtype, trailing shape) shared by the arrays to send; raises if they differ."""
    if len(sends) != comm.size:
        raise ValueError(f"need one array per rank ({comm.size}), got {len(sends)}")
    first = np.asarray(sends[0])
    dtype, trailing = first.dtype, first.shape[1:]
    if first.ndim == 0:
        raise ValueError("arrays to exchange need a leading (row) axis")
    if dtype.hasobject:
        raise TypeError("object arrays cannot be exchanged as bytes")
    for s in sends:
        s = np.asarray(s)
        if s.dtype != dtype or s.shape[1:] != trailing:
            raise ValueError(f"arrays to exchange differ: {s.dtype}{s.shape[1:]} vs "
                             f"{dtype}{trailing}")
    return dtype, trailing


def exchange_arrays(comm, sends, recv_counts=None):
    """All-to-all of numpy arrays: ``sends[r]`` (rows of any dtype and trailing shape, the
    same on every rank and for every r) goes to rank r; returns the list whose entry s is the
    array rank s sent here, rows in the sender's order. ``recv_counts`` (rows per source, as
    returned by ``exchange_counts``) skips the count exchange when the caller knows them.

    One ``Alltoallv`` on contiguous byte buffers; on one rank the input comes back (copied).
    """
    dtype, trailing = check_sends(comm, sends)
    if comm.size == 1:
        return [np.array(sends[0], copy=True)]
    sends = [np.ascontiguousarray(s) for s in sends]
    send_rows = np.array([s.shape[0] for s in sends], dtype=np.int64)
    if recv_counts is None:
        recv_counts = exchange_counts(comm, send_rows)
    recv_rows = np.asarray(recv_counts, dtype=np.int64)
    row_bytes = dtype.itemsize * int(np.prod(trailing, dtype=np.int64))
    send_buf = np.concatenate(sends, axis=0)
    recv_buf = np.empty((int(recv_rows.sum()), *trailing), dtype=dtype)
    comm.Alltoallv(byte_spec(send_buf, send_rows * row_bytes),
                   byte_spec(recv_buf, recv_rows * row_bytes))
    starts = np.concatenate([[0], np.cumsum(recv_rows)])
    return [recv_buf[starts[s]:starts[s + 1]] for s in range(comm.size)]


def byte_spec(buf, byte_counts):
    """The mpi4py buffer specification ``[bytes, counts, displacements, MPI.BYTE]`` of a
    contiguous array cut into consecutive blocks of ``byte_counts`` bytes."""
    from mpi4py import MPI

    raw = buf.reshape(-1).view(np.uint8)
    displs = np.concatenate([[0], np.cumsum(byte_counts)[:-1]]).astype(np.int64)
    return [raw, (byte_counts.astype(np.int64), displs), MPI.BYTE]


#: seconds between two tests of a pending request in :func:`wait_quietly`
POLL_S = 1e-4


def wait_quietly(request):
    """Wait for an MPI request by testing it every ``POLL_S`` seconds instead of in MPI's
    busy loop, so that the waiting rank leaves its core to the one at work (the PPE
    gathered to rank 0: :mod:`fsi_sph.parallel.ppe_gather`)."""
    import time

    while not request.Test():
        time.sleep(POLL_S)


@contextmanager
def node_threads(node_ranks):
    """Within: this rank's numba threads times ``node_ranks`` (the cores of the ranks of
    its node that wait for it quietly, :func:`wait_quietly`)."""
    import numba

    threads = numba.get_num_threads()
    numba.set_num_threads(min(numba.config.NUMBA_NUM_THREADS, threads * node_ranks))
    try:
        yield
    finally:
        numba.set_num_threads(threads)


def ranks_on_this_node(comm):
    """How many ranks of ``comm`` share this node (1 for a serial communicator)."""
    if comm.size == 1:
        return 1
    from mpi4py import MPI

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        return node.size
    finally:
        node.Free()


def gather_rows(comm, index, values, n):
    """The ``n`` rows of which every rank holds some (``values`` at rows ``index``; each row
    on exactly one rank), on every rank: an all-gather; collective."""
    values = np.asarray(values)
    return placed(comm.allgather((np.asarray(index), values)), n, values)


def gather_rows_to_root(comm, index, values, n):
    """:func:`gather_rows` to rank 0 alone (the other ranks get None); collective."""
    values = np.asarray(values)
    parts = comm.gather((np.asarray(index), values), root=0)
    return None if parts is None else placed(parts, n, values)


def placed(parts, n, like):
    """``n`` rows (dtype and trailing shape of ``like``) from ``(index, values)`` parts."""
    out = np.empty((n, *like.shape[1:]), like.dtype)
    for idx, vals in parts:
        out[idx] = vals
    return out
