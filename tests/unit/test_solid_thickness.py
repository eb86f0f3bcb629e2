"""A TLSPH body one particle thick is refused before it runs (its deformation gradient
[F 34] would be singular), naming the body and what would do."""

import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.simulation import Simulation
from tests.unit.test_energy import BLOCK


def test_a_solid_one_particle_thick_is_refused_with_its_name():
    thin = BLOCK.replace("size = [0.1, 0.05]", "size = [0.01, 0.05]")
    with pytest.raises(ConfigError, match="solid.block: at dx = 0.01 m the body is one "
                                          "particle thick"):
        Simulation(load_config(None, text=thin))
    Simulation(load_config(None, text=thin.replace("dx = 0.01", "dx = 0.005")))  # two: fine
