"""Shared fixtures: small lattices and TLSPH bodies built from case text."""

import numpy as np
import pytest

from fsi_sph.config import load_config

PLATE = """
[case]
t_end = 0.01
dx = {dx}
gravity = [0.0, 0.0]
[solid.b]
material = {{ model = "{model}", rho0 = 1000.0, E = {E}, nu = {nu} }}
blocks = [{{ origin = [0.0, 0.0], size = [{w}, {hgt}] }}]
artificial_viscosity = {{ alpha = {alpha}, beta = 0.0 }}
hourglass = {{ model = "{hg_model}", coefficient = {hg} }}
{extra}
"""


def body_config(dx=0.1, w=1.0, hgt=0.5, model="stvk", E=1e6, nu=0.3, alpha=0.0, hg=0.0,
                hg_model="ganzenmueller", extra=""):
    """A one-body config (no gravity) as text -> Config."""
    return load_config(None, text=PLATE.format(dx=dx, w=w, hgt=hgt, model=model, E=E, nu=nu,
                                               alpha=alpha, hg=hg, hg_model=hg_model,
                                               extra=extra))


@pytest.fixture
def make_body():
    """make_body(**kw) -> ElasticBody ``b`` of a rectangle, built like the simulation does."""
    from fsi_sph.solid.tlsph import ElasticBody

    def make(**kw):
        cfg = body_config(**kw)
        return ElasticBody("b", cfg.solid["b"], cfg.case.dx, cfg.sph, cfg.case.gravity)

    return make


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


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
