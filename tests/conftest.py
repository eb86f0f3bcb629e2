import numpy as np
import pytest


def lattice(nx, ny, dx=1.0, origin=(0.0, 0.0)):
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    x = np.column_stack([ix.ravel(), iy.ravel()]).astype(np.float64)
    return (x + 0.5) * dx + np.asarray(origin)


@pytest.fixture
def perturbed():
    """A 12 x 10 lattice (dx = 1) perturbed by up to 0.2 dx, fixed seed."""
    rng = np.random.default_rng(7)
    x = lattice(12, 10)
    return x + rng.uniform(-0.2, 0.2, x.shape)
