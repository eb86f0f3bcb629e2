"""fsi_sph: 2D SPH for fluid-structure interaction (ISPH fluid, TLSPH solid, soil).

The public names are imported lazily so that ``fsi-sph info`` or a config error does not
pay for compiling numba kernels.
"""

from fsi_sph.version import __version__

__all__ = ["__version__", "load_config", "Simulation", "run"]


def __getattr__(name):
    if name == "load_config":
        from fsi_sph.config import load_config

        return load_config
    if name in ("Simulation", "run"):
        from fsi_sph import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module 'fsi_sph' has no attribute {name!r}")
