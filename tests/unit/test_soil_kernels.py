"""Soil particle loops against dense O(N^2) numpy references (random perturbed lattice)."""

import math

import numpy as np
import pytest

from fsi_sph.neighbors import find_neighbors
from fsi_sph.soil import _kernels as K
from fsi_sph.sph.kernels import CUBIC_SPLINE, KERNELS, cubic_dw, cubic_w

DX = 0.1
H = 1.2 * DX


def lattice(nx=12, ny=10, seed=0):
    rng = np.random.default_rng(seed)
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    x = np.column_stack([(ix.ravel() + 0.5) * DX, (iy.ravel() + 0.5) * DX])
    return x + rng.uniform(-0.15, 0.15, size=x.shape) * DX, rng


def dense_pairs(xd, xs, exclude_self=True):
    """All (i, j, x_ij, r) with r < 2h, by brute force."""
    d = xd[:, None, :] - xs[None, :, :]
    r = np.sqrt((d**2).sum(-1))
    mask = r < 2 * H
    if exclude_self:
        np.fill_diagonal(mask[:, : len(xd)], False)
    i, j = np.nonzero(mask)
    return i, j, d[i, j], r[i, j]


def grad_w(d, r):
    dw = np.array([cubic_dw(rr, H) for rr in r])
    return dw[:, None] * d / r[:, None]


@pytest.fixture(scope="module")
def state():
    x, rng = lattice()
    n = len(x)
    ng = 30  # pretend the last 30 rows are ghosts: loops must treat them as sources only
    tot = n + ng
    xa = np.vstack([x, rng.uniform(0, 1.2, size=(ng, 2)) * [1.0, -0.2]])
    v = rng.normal(size=(tot, 2))
    rho = 2000.0 * (1 + 0.05 * rng.normal(size=tot))
    m = 2000.0 * DX * DX * (1 + 0.1 * rng.uniform(size=tot))
    sig = rng.normal(size=(tot, 2, 2)) * 1e4
    sig = 0.5 * (sig + sig.transpose(0, 2, 1))
    R = rng.normal(size=(tot, 2, 2)) * 1e-3
    R = 0.5 * (R + R.transpose(0, 2, 1))
    start, nbr = find_neighbors(x, xa, 2 * H, exclude_self=True)
    return dict(n=n, x=xa, v=v, rho=rho, m=m, sig=sig, R=R, start=start, nbr=nbr)


def test_momentum_matches_dense(state):
    s = state
    n = s["n"]
    c0, al, be, asn = 50.0, 0.3, 0.2, 2.55
    wdx = cubic_w(DX, H)
    out = np.zeros((n, 2))
    ng = len(s["x"]) - n
    gwall = np.arange(ng) % 3 - 1  # walls 0, 1 and corner ghosts (-1)
    aw = np.zeros((n, 2, 2))
    K.momentum(n, s["x"], s["v"], s["rho"], s["m"], s["sig"], s["R"], s["start"], s["nbr"], H,
               CUBIC_SPLINE, c0, al, be, asn, wdx, gwall, out, aw)
    i, j, d, r = dense_pairs(s["x"][:n], s["x"])
    gw = grad_w(d, r)
    rho, m, sig, R, v = s["rho"], s["m"], s["sig"], s["R"], s["v"]
    T = sig[i] / rho[i, None, None] ** 2 + sig[j] / rho[j, None, None] ** 2
    vx = ((v[i] - v[j]) * d).sum(-1)
    mu = H * vx / (r**2 + 0.01 * H * H)
    pi = np.where(vx < 0, (-al * c0 * mu + be * mu * mu) / (0.5 * (rho[i] + rho[j])), 0.0)
    T = T - pi[:, None, None] * np.eye(2)
    f = (np.array([cubic_w(rr, H) for rr in r]) / wdx) ** asn
    T = T + (R[i] + R[j]) * f[:, None, None]
    ref = np.zeros((n, 2))
    contrib = m[j, None] * np.einsum("kab,kb->ka", T, gw)
    np.add.at(ref, i, contrib)
    np.testing.assert_allclose(out, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())
    for w in (0, 1):
        sel = (j >= n) & (gwall[np.maximum(j - n, 0)] == w)
        refw = np.zeros((n, 2))
        np.add.at(refw, i[sel], contrib[sel])
        np.testing.assert_allclose(aw[:, w], refw, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_velocity_gradient_and_continuity_match_dense(state):
    s = state
    n = s["n"]
    L = np.zeros((n, 2, 2))
    drho = np.zeros(n)
    vk = s["v"][::-1].copy()  # the continuity's (kinematic) velocities, distinct from v
    K.velocity_gradient(n, s["x"], s["v"], vk, s["rho"], s["m"], s["start"], s["nbr"], H,
                        CUBIC_SPLINE, L, drho)
    i, j, d, r = dense_pairs(s["x"][:n], s["x"])
    gw = grad_w(d, r)
    vol = s["m"] / s["rho"]
    v = s["v"]
    raw = np.zeros((n, 2, 2))
    M = np.zeros((n, 2, 2))
    np.add.at(raw, i, vol[j, None, None] * np.einsum("ka,kb->kab", v[j] - v[i], gw))
    np.add.at(M, i, vol[j, None, None] * np.einsum("ka,kb->kab", -d, gw))
    ref = np.einsum("nab,nbc->nac", raw, np.linalg.inv(M))
    np.testing.assert_allclose(L, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    dref = np.zeros(n)
    np.add.at(dref, i, s["m"][j] * ((vk[i] - vk[j]) * gw).sum(-1))
    np.testing.assert_allclose(drho, dref, rtol=1e-10, atol=1e-12 * np.abs(dref).max())


def test_velocity_gradient_exact_for_linear_field():
    x, _ = lattice(seed=3)
    n = len(x)
    A = np.array([[0.3, -1.2], [0.7, -0.1]])
    v = x @ A.T + [0.5, -0.2]
    start, nbr = find_neighbors(x, x, 2 * H, exclude_self=True)
    L = np.zeros((n, 2, 2))
    K.velocity_gradient(n, x, v, v, np.full(n, 2000.0), np.full(n, 2000.0 * DX * DX), start,
                        nbr, H, CUBIC_SPLINE, L, np.zeros(n))
    np.testing.assert_allclose(L, np.broadcast_to(A, L.shape), atol=1e-10)


def test_continuity_of_a_block_sliding_on_a_no_slip_floor():
    """A block translating rigidly along a no-slip floor: the mirrored configuration moves
    rigidly too, so the continuity [S 4-5] must give zero density rate everywhere, also at
    the block's ends, whose neighbourhood is one-sided. The no-slip ghosts' reversed
    tangential velocity must still give the shear rate at the floor in ``L``."""
    x, _ = lattice(nx=8, ny=4, seed=4)
    n = len(x)
    side = np.array([K.BOTTOM])
    pos = np.array([0.0])
    fric = np.array([K.NO_SLIP])
    cap = 4 * n
    xa = np.zeros((n + cap, 2))
    xa[:n] = x
    src, wa, wb = (np.zeros(cap, np.int64) for _ in range(3))
    ng = K.make_ghosts(xa, n, side, pos, 2 * H, xa, src, wa, wb)
    tot = n + ng
    v = np.zeros((tot, 2))
    v[:n] = [0.7, 0.0]
    vk = v.copy()
    sig = np.zeros((tot, 2, 2))
    szz = np.zeros(tot)
    rho = np.full(tot, 2000.0)
    m = np.full(tot, 2000.0 * DX * DX)
    K.fill_ghosts(n, ng, src, wa, wb, side, fric, np.zeros(1), 0.0, -9.81, xa[:tot], v, sig,
                  szz, rho, m, vk)
    start, nbr = find_neighbors(x, xa[:tot], 2 * H, exclude_self=True)
    L = np.zeros((n, 2, 2))
    drho = np.zeros(n)
    K.velocity_gradient(n, xa[:tot], v, vk, rho, m, start, nbr, H, CUBIC_SPLINE, L, drho)
    np.testing.assert_array_equal(drho, 0.0)
    near = x[:, 1] < DX  # bottom row: sheared against the no-slip ghosts
    assert np.all(L[near, 0, 1] > 0.7 / (2 * H))
    # with the ghosts' no-slip velocity in the continuity (the former scheme) the ends of the
    # bottom row would see a density rate of the order rho v / h
    drho_v = np.zeros(n)
    K.velocity_gradient(n, xa[:tot], v, v, rho, m, start, nbr, H, CUBIC_SPLINE, L, drho_v)
    assert np.abs(drho_v).max() > 0.1 * 2000.0 * 0.7 / H


def test_xsph_matches_dense(state):
    s = state
    n = s["n"]
    out = np.zeros((n, 2))
    K.xsph(n, s["x"], s["v"], s["rho"], s["m"], s["start"], s["nbr"], H, CUBIC_SPLINE, 0.5, out)
    i, j, d, r = dense_pairs(s["x"][:n], s["x"])
    w = np.array([cubic_w(rr, H) for rr in r])
    ref = s["v"][:n].copy()
    f = 0.5 * s["m"][j] / (0.5 * (s["rho"][i] + s["rho"][j])) * w
    np.add.at(ref, i, f[:, None] * (s["v"][j] - s["v"][i]))
    np.testing.assert_allclose(out, ref, rtol=1e-12)


def test_artificial_stress_principal_frame():
    rng = np.random.default_rng(5)
    sig = rng.normal(size=(50, 2, 2)) * 1e4
    sig = 0.5 * (sig + sig.transpose(0, 2, 1))
    rho = np.full(50, 2000.0)
    R = np.zeros((50, 2, 2))
    K.artificial_stress(50, sig, rho, 0.3, R)
    lam, vec = np.linalg.eigh(sig)
    rl = np.where(lam > 0, -0.3 * lam / 2000.0**2, 0.0)
    ref = np.einsum("nab,nb,ncb->nac", vec, rl, vec)
    np.testing.assert_allclose(R, ref, atol=1e-12 * np.abs(ref).max())


def test_ghosts_mirror_positions_velocity_and_stress():
    """Ghosts of a particle near a floor/left-wall corner: one per wall plus the corner one;
    velocities and shear stress follow each wall's friction law."""
    x = np.array([[0.05, 0.07], [0.5, 0.03], [0.5, 0.5]])
    n = 3
    side = np.array([K.BOTTOM, K.LEFT])
    pos = np.array([0.0, 0.0])
    cap = 10
    xa = np.zeros((n + cap, 2))
    xa[:n] = x
    src, wa, wb = (np.zeros(cap, np.int64) for _ in range(3))
    ng = K.make_ghosts(xa, n, side, pos, 0.24, xa, src, wa, wb)
    assert ng == 4  # particle 0: floor, floor+left corner, left; particle 1: floor
    assert src[:ng].tolist() == [0, 0, 0, 1]
    np.testing.assert_allclose(xa[n:n + ng], [[0.05, -0.07], [-0.05, -0.07], [-0.05, 0.07],
                                                [0.5, -0.03]])
    v = np.zeros((n + cap, 2))
    v[:n] = [[1.0, -2.0], [3.0, -4.0], [0.0, 0.0]]
    sig = np.zeros((n + cap, 2, 2))
    sig[:n] = [[-1e3, 300.0], [300.0, -2e3]]
    szz = np.zeros(n + cap)
    rho = np.full(n + cap, 2000.0)
    m = np.ones(n + cap)
    tan_d = math.tan(math.radians(5.0))
    for fric, vt_sign, tau in [(K.FREE_SLIP, 1, 0.0), (K.NO_SLIP, -1, 300.0),
                               (K.COULOMB, 1, 0.0)]:
        fr = np.array([fric, K.FREE_SLIP])
        mu = np.array([tan_d, 0.0])
        vk = v.copy()
        K.fill_ghosts(n, ng, src, wa, wb, side, fr, mu, 0.0, -9.81, xa, v, sig, szz, rho, m,
                      vk)
        g = n + 3  # floor ghost of particle 1
        assert v[g].tolist() == [vt_sign * 3.0, 4.0]
        assert vk[g].tolist() == [3.0, 4.0]  # the mirror's own motion, any friction
        assert vk[n + 1].tolist() == [-1.0, 2.0]  # corner ghost of particle 0: both reversed
        assert sig[g, 0, 1] == pytest.approx(2 * tau - 300.0)
        # floor-normal stress extrapolated with gravity: sigma_yy - rho g (y_g - y_i)
        assert sig[g, 1, 1] == pytest.approx(-2e3 - 2000.0 * 9.81 * 0.06)
        assert sig[g, 0, 0] == -1e3
    assert KERNELS["cubic_spline"] == CUBIC_SPLINE


def test_coulomb_friction_stops_but_never_reverses():
    side = np.array([K.BOTTOM, K.LEFT])
    fric = np.array([K.COULOMB, K.COULOMB])
    mu = np.array([0.5, 0.5])
    v = np.array([[2.0, 0.0], [0.01, 0.0], [-1.0, 3.0]])
    aw = np.zeros((3, 2, 2))
    aw[:, 0, 1] = [10.0, 10.0, -5.0]  # floor pushes particles 0 and 1 up; 2 is pulled
    aw[2, 1, 0] = 4.0  # left wall pushes particle 2 off it: friction on its v_y
    K.coulomb_friction(3, v, aw, side, fric, mu, 0.1)
    np.testing.assert_allclose(v, [[1.5, 0.0], [0.0, 0.0], [-1.0, 2.8]])


def test_shepard_stress_matches_dense(state):
    s = state
    n = s["n"]
    szz = np.linspace(-1e4, 1e4, len(s["x"]))
    out = np.zeros((n, 2, 2))
    outz = np.zeros(n)
    K.shepard_stress(n, s["x"], s["rho"], s["m"], s["sig"], szz, s["start"], s["nbr"], H,
                     CUBIC_SPLINE, out, outz)
    i, j, d, r = dense_pairs(s["x"][:n], s["x"])
    vol = s["m"] / s["rho"]
    wv = vol[j] * np.array([cubic_w(rr, H) for rr in r])
    num = vol[:n, None, None] * cubic_w(0.0, H) * s["sig"][:n]
    den = vol[:n] * cubic_w(0.0, H)
    numz = den * szz[:n]
    np.add.at(num, i, wv[:, None, None] * s["sig"][j])
    np.add.at(numz, i, wv * szz[j])
    np.add.at(den, i, wv)
    np.testing.assert_allclose(out, num / den[:, None, None], rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(outz, numz / den, rtol=1e-11, atol=1e-9)


def test_coincident_particles_give_finite_results():
    """Two particles at the same place (both put back into a wall corner by the wall guard):
    grad W(0) = 0, so the pair adds nothing, instead of 0/0."""
    x = np.array([[0.0, 0.0], [0.0, 0.0], [0.05, 0.02]])
    n = 3
    v = np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])
    rho = np.full(n, 2000.0)
    m = np.full(n, 2000.0 * DX * DX)
    sig = np.zeros((n, 2, 2))
    sig[:, 0, 0] = sig[:, 1, 1] = -1e3
    start, nbr = find_neighbors(x, x, 2 * H, exclude_self=True)
    a = np.zeros((n, 2))
    K.momentum(n, x, v, rho, m, sig, np.zeros((n, 2, 2)), start, nbr, H, CUBIC_SPLINE, 50.0,
               0.1, 0.1, 0.0, 1.0, np.full(0, -1), a, np.zeros((n, 1, 2)))
    L = np.zeros((n, 2, 2))
    drho = np.zeros(n)
    K.velocity_gradient(n, x, v, v, rho, m, start, nbr, H, CUBIC_SPLINE, L, drho)
    assert np.isfinite(a).all() and np.isfinite(L).all() and np.isfinite(drho).all()
    # particle 2 sees the pair as two ordinary neighbours at the same place
    assert np.abs(a[2]).max() > 0.0
