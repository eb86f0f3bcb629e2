"""TLSPH particle loops against the dense numpy oracles of tests/reference_impl.py."""

import numpy as np
import pytest

from fsi_sph.solid import _kernels as K
from tests import reference_impl as ref


@pytest.fixture
def deformed(make_body, rng):
    """A 12 x 8 block, randomly deformed (positions and velocities perturbed)."""
    b = make_body(dx=0.05, w=0.6, hgt=0.4)
    x = b.body["x0"] + 0.008 * rng.standard_normal(b.body["x0"].shape)
    x = x @ np.array([[1.05, 0.1], [-0.02, 0.97]]).T
    b.body["x"][:] = x
    b.body["v"][:] = rng.standard_normal(x.shape)
    b.update_stress()
    return b


def test_correction_matrix(deformed):
    b = deformed.body
    np.testing.assert_allclose(deformed.L, ref.correction(b["x0"], b["vol"], deformed.h),
                               rtol=1e-12, atol=1e-12)


def test_deformation_gradient_and_stress(deformed):
    b = deformed.body
    F = ref.deformation_gradient(b["x"], b["x0"], b["vol"], deformed.h)
    np.testing.assert_allclose(b["F"], F, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(b["P"], ref.stvk_pk1(F, deformed.lam, deformed.mu), rtol=1e-10,
                               atol=1e-6)


def _acc(b, alpha=0.0, hg=0.0):
    x = b.body
    out = np.zeros_like(x["a"])
    K.accelerations(x["x"], x["v"], x["x0"], x["vol"], x["F"], x["P"], b.nbr_start, b.nbr_j,
                    b.gi, b.gj, b.w, b.rho0, b.c0, b.h, alpha, 0.0, hg, b.youngs, out)
    return out


def test_stress_accelerations(deformed):
    b = deformed.body
    want = ref.stress_accelerations(b["x"], b["x0"], b["vol"], b["P"], deformed.rho0, deformed.h)
    np.testing.assert_allclose(_acc(deformed), want, rtol=1e-9, atol=1e-9 * np.abs(want).max())


def test_hourglass_accelerations(deformed):
    b = deformed.body
    want = ref.hourglass_accelerations(b["x"], b["x0"], b["vol"], b["F"], deformed.rho0,
                                       deformed.h, 10.0, deformed.youngs)
    got = _acc(deformed, hg=10.0) - _acc(deformed)
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-9 * np.abs(want).max())


def test_viscous_accelerations(deformed):
    b = deformed.body
    want = ref.viscous_accelerations(b["x"], b["v"], b["F"], b["vol"], b["x0"], deformed.rho0,
                                     deformed.c0, deformed.h, 1.0, 0.0)
    got = _acc(deformed, alpha=1.0) - _acc(deformed)
    assert np.abs(want).max() > 0
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-9 * np.abs(want).max())
