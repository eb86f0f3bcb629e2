"""Soil configuration: the [soil.NAME] and [boundary] tables, polygons, errors."""

import math

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError
from fsi_sph.geometry import fill_polygon, in_polygon
from fsi_sph.simulation import Simulation

BASE = """
[case]
t_end = 0.01
dx = 0.1
[soil.sand]
material = { model = "drucker_prager", rho0 = 2000.0, E = 1e6, nu = 0.3, friction_angle_deg = 30.0 }
blocks = [{ shape = "polygon", vertices = [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 0.0]] }]
"""


def test_soil_table_builds_a_soil_body():
    cfg = load_config(None, text=BASE + '[boundary]\nwalls = [{ side = "bottom", position = 0.0 }]\n')
    assert cfg.modules() == ["drucker_prager_soil:sand", "plane_walls:1"]
    sim = Simulation(cfg)
    body = sim.structures["sand"]
    assert body.body.kind == "soil"
    # psi = 0 (default): the plane-strain match at flow, alpha = sin(phi)/3
    assert body.alpha == pytest.approx(math.sin(math.radians(30)) / 3.0)
    assert "R" not in body.body and "vhat" not in body.body  # options absent -> no fields
    sim.step()
    assert np.isfinite(body.body["x"]).all()


@pytest.mark.parametrize("extra,msg", [
    ('[boundary]\nwalls = [{ side = "bottom", position = 0.0, friction = "coulomb" }]\n',
     "friction_angle_deg is required"),
    ('[boundary]\nwalls = [{ side = "floor", position = 0.0 }]\n', "boundary.walls[0].side"),
    ('[soil.sand.xsph]\nepsilon = 2.0\n', "soil.sand.xsph.epsilon"),
    ('[soil.sand.initial_stress]\nkk = 0.5\n', "unknown key"),
])
def test_soil_config_errors_name_the_key(extra, msg):
    with pytest.raises(ConfigError, match=msg.replace("[", r"\[").replace("]", r"\]")):
        load_config(None, text=BASE + extra)


def test_dilatancy_may_not_exceed_friction():
    with pytest.raises(ConfigError, match="dilatancy_angle_deg"):
        load_config(None, text=BASE.replace("friction_angle_deg = 30.0",
                                            "friction_angle_deg = 30.0, dilatancy_angle_deg = 35.0"))


def test_polygon_fill_area_and_inside():
    pts = fill_polygon([(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (2.0, 0.0)], 0.05)
    area = 1.5
    assert abs(len(pts) * 0.05**2 - area) / area < 0.03
    assert in_polygon(np.array([[0.5, 0.5], [1.9, 0.9]]), [(0, 0), (0, 1), (1, 1), (2, 0)]).tolist() \
        == [True, False]
