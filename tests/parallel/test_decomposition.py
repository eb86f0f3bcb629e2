"""fsi_sph.parallel: serial unit tests, and the checks of mpi_checks.py run under mpiexec."""

import sys
from pathlib import Path

import numpy as np
import pytest

from fsi_sph.parallel import comm as comm_module
from fsi_sph.parallel.boxes import Boxes, partition
from fsi_sph.parallel.comm import SerialComm, exchange_arrays, exchange_counts, world
from fsi_sph.parallel.decomposition import Strips, imbalance, needs_rebalance
from fsi_sph.parallel.halo import Halo, assign_gids, migrate, row_offsets
from tests.parallel.launch import run_mpi

ROOT = Path(__file__).resolve().parents[2]
CHECKS = Path(__file__).with_name("mpi_checks.py")
MPI_CHECK_NAMES = ["exchange", "gids", "balance", "migrate", "halo", "repeat", "thin"]
MPI_TIMEOUT = 120


def particles(n, seed=0, box=(2.0, 1.0)):
    rng = np.random.default_rng(seed)
    return rng.random((n, 2)) * np.asarray(box)


# ---------------------------------------------------------------- communicator


def test_world_is_serial_without_launcher(monkeypatch):
    for var in comm_module.LAUNCHER_RANK_VARS + comm_module.LAUNCHER_SIZE_VARS:
        monkeypatch.delenv(var, raising=False)
    assert comm_module.launched_size() == 0
    if "mpi4py.MPI" not in sys.modules:
        c = world()
        assert isinstance(c, SerialComm) and (c.rank, c.size) == (0, 1)


def test_launched_rank_from_the_environment(monkeypatch):
    for var in comm_module.LAUNCHER_RANK_VARS:
        monkeypatch.delenv(var, raising=False)
    assert comm_module.launched_rank() == 0
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "3")
    assert comm_module.launched_rank() == 3
    monkeypatch.setenv("PMI_RANK", "1")  # MPICH's comes first
    assert comm_module.launched_rank() == 1


def test_world_refuses_several_ranks_without_mpi4py(monkeypatch):
    monkeypatch.setenv("PMI_SIZE", "2")
    monkeypatch.setitem(sys.modules, "mpi4py", None)
    monkeypatch.delitem(sys.modules, "mpi4py.MPI", raising=False)
    with pytest.raises(ImportError, match="mpi4py"):
        world()
    monkeypatch.setenv("PMI_SIZE", "1")
    assert isinstance(world(), SerialComm)


def test_serial_comm_collectives():
    c = SerialComm()
    assert c.allreduce(3.5) == 3.5 and c.allgather("a") == ["a"] and c.bcast(7) == 7
    assert c.alltoall([4]) == [4] and c.gather(2) == [2]
    with pytest.raises(ValueError):
        c.alltoall([1, 2])
    c.Barrier()


@pytest.mark.parametrize("dtype,trailing", [(np.float64, ()), (np.int64, (2,)), (bool, (2, 2)),
                                            (np.int32, (0,))])
def test_exchange_arrays_serial_returns_input(dtype, trailing):
    a = (np.arange(5 * int(np.prod(trailing))) % 3).reshape((5, *trailing)).astype(dtype)
    (got,) = exchange_arrays(SerialComm(), [a])
    assert got.dtype == a.dtype and got.shape == a.shape and np.array_equal(got, a)
    assert got is not a
    assert np.array_equal(exchange_counts(SerialComm(), [5]), [5])


def test_exchange_arrays_rejects_bad_input():
    c = SerialComm()
    with pytest.raises(ValueError, match="one array per rank"):
        exchange_arrays(c, [np.zeros(2), np.zeros(2)])
    with pytest.raises(TypeError):
        exchange_arrays(c, [np.array([None, 1], dtype=object)])
    with pytest.raises(ValueError, match="leading"):
        exchange_arrays(c, [np.float64(1.0)])


# ---------------------------------------------------------------- strips


def test_strips_owner_is_half_open():
    s = Strips(0, [-np.inf, 1.0, 2.0, np.inf])
    x = np.array([[-5.0, 0.0], [0.999, 9.0], [1.0, 0.0], [1.5, 0.0], [2.0, 0.0], [1e9, 0.0]])
    assert s.size == 3
    assert np.array_equal(s.owner(x), [0, 0, 1, 1, 2, 2])
    assert s.owner(x).dtype == np.int64
    assert s.interval(1) == (1.0, 2.0)
    assert np.allclose(s.distance(x, 1), [6.0, 0.001, 0.0, 0.0, 0.0, 1e9 - 2.0])
    assert np.array_equal(Strips(1, [-np.inf, 0.5, np.inf]).owner(x), [0, 1, 0, 0, 0, 0])


@pytest.mark.parametrize("cuts,axis", [([-np.inf, 2.0, 1.0, np.inf], 0), ([0.0, np.inf], 0),
                                       ([-np.inf, np.inf], 2), ([-np.inf], 0)])
def test_strips_reject_bad_cuts(cuts, axis):
    with pytest.raises(ValueError):
        Strips(axis, cuts)


def test_balanced_on_one_rank_is_one_strip_on_the_long_axis():
    c = SerialComm()
    wide = Strips.balanced(c, particles(200, box=(3.0, 1.0)))
    tall = Strips.balanced(c, particles(200, box=(1.0, 3.0)), work=np.full(200, 2.0))
    assert (wide.axis, tall.axis) == (0, 1)
    for s in (wide, tall):
        assert s.size == 1 and np.array_equal(s.cuts, [-np.inf, np.inf])
        assert np.all(s.owner(particles(50, seed=3)) == 0)
    assert Strips.balanced(c, np.empty((0, 2))).size == 1
    assert Strips.balanced(c, particles(10), axis=1).axis == 1


class AllDataComm(SerialComm):
    """One process posing as rank 0 of ``size`` ranks that hold no data: the reductions
    return the local values, so ``Strips.balanced`` cuts this rank's particles."""

    def __init__(self, size):
        self.size = size

    def Allreduce(self, sendbuf, recvbuf, op=None):
        """In place, nothing to add."""


@pytest.mark.parametrize("size", [2, 3, 5])
@pytest.mark.parametrize("weighted", [False, True])
def test_balanced_cuts_split_the_work_evenly(monkeypatch, size, weighted):
    monkeypatch.setattr(comm_module, "mpi_op", lambda name: name)
    monkeypatch.setattr(comm_module, "comm_in_place", lambda: None)
    x = particles(4000, seed=size, box=(4.0, 1.0)) ** [2.0, 1.0]  # denser near x = 0
    w = 0.5 + np.random.default_rng(1).random(4000) * 3.0 if weighted else np.ones(4000)
    s = Strips.balanced(AllDataComm(size), x, work=w)
    assert s.axis == 0 and s.size == size
    per_rank = np.bincount(s.owner(x), weights=w, minlength=size)
    assert np.all(np.abs(per_rank - w.sum() / size) <= 0.01 * w.sum() / size + w.max()), per_rank
    assert imbalance(SerialComm(), per_rank.max()) == 0.0


# ---------------------------------------------------------------- halo, migration, gids


def test_halo_on_one_rank_is_empty():
    x = particles(30)
    s = Strips.balanced(SerialComm(), x)
    h = Halo.build(SerialComm(), s, x, width=10.0)
    assert h.n_ghost == 0 and h.ghost_source.size == 0
    assert h.exchange(np.ones((30, 2, 2))).shape == (0, 2, 2)
    assert (h.bytes_last, h.messages_last) == (0, 0)
    full = np.arange(30.0)
    assert h.exchange_into(full, 30) is full and np.array_equal(full, np.arange(30.0))
    with pytest.raises(ValueError, match="owned"):
        h.exchange(np.ones(29))
    with pytest.raises(ValueError, match="ghosts"):
        h.exchange_into(np.ones(31), 30)


def test_migrate_on_one_rank_keeps_everything_in_order():
    x = particles(40)
    gid = assign_gids(SerialComm(), 40)[::-1].copy()
    arrays = {"x": x, "gid": gid, "t": np.arange(160.0).reshape(40, 2, 2), "b": gid % 2 == 0}
    out = migrate(SerialComm(), Strips.balanced(SerialComm(), x), arrays)
    assert sorted(out) == sorted(arrays)
    for k in arrays:
        assert out[k].dtype == arrays[k].dtype and np.array_equal(out[k], arrays[k]), k


def test_migrate_rejects_bad_arrays():
    c, x = SerialComm(), particles(4)
    s = Strips.balanced(c, x)
    with pytest.raises(ValueError, match="gid"):
        migrate(c, s, {"x": x})
    with pytest.raises(ValueError, match="int64"):
        migrate(c, s, {"x": x, "gid": np.arange(4, dtype=np.int32)})
    with pytest.raises(ValueError, match="length"):
        migrate(c, s, {"x": x, "gid": np.arange(4), "f": np.zeros(3)})
    with pytest.raises(ValueError, match="'pos'"):
        migrate(c, s, {"x": x, "gid": np.arange(4)}, key="pos")


def test_gids_and_row_offsets_on_one_rank():
    gid = assign_gids(SerialComm(), 7)
    assert gid.dtype == np.int64 and np.array_equal(gid, np.arange(7))
    assert assign_gids(SerialComm(), 0).size == 0
    assert row_offsets(SerialComm(), 7) == (0, 7)


def test_imbalance_on_one_rank():
    assert imbalance(SerialComm(), np.ones(10)) == 0.0
    assert not needs_rebalance(SerialComm(), 10.0)


# ---------------------------------------------------------------- several ranks


def run_checks(nprocs, names):
    done = run_mpi(nprocs, CHECKS, names, MPI_TIMEOUT)
    assert done.returncode == 0, f"exit {done.returncode}\n{done.stdout}\n{done.stderr}"
    for name in names:
        assert f"ok {name} on {nprocs} ranks" in done.stdout, done.stdout


@pytest.mark.parametrize("name", MPI_CHECK_NAMES)
def test_on_two_ranks(name):
    run_checks(2, [name])


def test_on_three_ranks():
    """All checks on 3 ranks (one run): the thin middle strip gives ghosts on two ranks."""
    run_checks(3, MPI_CHECK_NAMES)


# ---------------------------------------------------------------- boxes (recursive bisection)


@pytest.mark.parametrize("size", [2, 3, 4, 7])
def test_boxes_split_the_work_evenly_and_tile_the_plane(monkeypatch, size):
    """Recursive bisection: every point has one owner, each box holds its share of the work
    within 1 % + one particle, and a box's distance is 0 inside it and the Euclidean
    distance outside (checked against points placed at known offsets)."""
    monkeypatch.setattr(comm_module, "mpi_op", lambda name: name)
    monkeypatch.setattr(comm_module, "comm_in_place", lambda: None)
    x = particles(4000, seed=size, box=(2.0, 3.0)) ** [1.0, 2.0]  # denser near y = 0
    b = Boxes.balanced(AllDataComm(size), x)
    own = b.owner(x)
    assert b.size == size and np.all(own >= 0)
    per_rank = np.bincount(own, minlength=size)
    assert np.all(np.abs(per_rank - 4000 / size) <= 0.01 * 4000 / size + 1), per_rank
    r = int(own[0])
    assert b.distance(x[:1], r)[0] == 0.0
    corner = np.where(np.isfinite(b.hi[r]), b.hi[r], b.lo[r])  # a finite corner of box r
    outside = np.where(np.isfinite(b.hi[r]), corner + [0.3, 0.4], corner - [0.3, 0.4])
    if np.all(np.isfinite(corner)):
        assert b.distance(outside[None], r)[0] == pytest.approx(0.5)


def test_strips_serve_until_they_are_thinner_than_two_halos(monkeypatch):
    monkeypatch.setattr(comm_module, "mpi_op", lambda name: name)
    monkeypatch.setattr(comm_module, "comm_in_place", lambda: None)
    x = particles(4000, box=(1.0, 2.0))
    assert isinstance(partition(AllDataComm(2), x, 0.4), Strips)  # no inner strip
    assert isinstance(partition(AllDataComm(4), x, 0.1), Strips)  # inner strips 0.5 wide
    assert isinstance(partition(AllDataComm(4), x, 0.3), Boxes)  # 0.5 < 2 x 0.3


def test_box_owner_and_distance():
    b = Boxes(np.array([[-np.inf, -np.inf], [1.0, -np.inf]]),
              np.array([[1.0, np.inf], [np.inf, np.inf]]))
    x = np.array([[0.5, 3.0], [1.0, 0.0], [1.3, -7.0]])
    assert b.owner(x).tolist() == [0, 1, 1]  # half-open: x = 1 belongs to box 1
    assert b.distance(x, 0).tolist() == pytest.approx([0.0, 0.0, 0.3])
    box = Boxes(np.array([[0.0, 0.0]]), np.array([[1.0, 1.0]]))
    assert box.distance(np.array([[1.3, 1.4], [0.5, 0.5]]), 0).tolist() == pytest.approx(
        [0.5, 0.0])
