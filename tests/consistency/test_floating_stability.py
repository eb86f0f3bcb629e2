"""Metacentric stability of floating rigid bodies: the coupling's torque.

Two rectangles of density ratio s = rho_s / rho_f = 0.5 (draft half the height) float with
their centre on the waterline and are given a small roll, omega0 = 0.3 rad/s. Hydrostatics:
the metacentric height is GM = KB + BM - KG = d/2 + b^2 / (12 d) - h/2 (b width, h height,
d = s h the draft). A wide pontoon (b = 0.198 m, h = 0.06 m): GM = +0.096 m, it rocks back
(amplitude about omega0 / omega_n, omega_n = sqrt(rho g b d GM / I) ~ 14 rad/s without added
inertia: 1.2 deg). A tall box (b = 0.06 m, h = 0.12 m): GM = -0.025 m, it capsizes (growth
rate sqrt(rho g b d |GM| / I) ~ 12 1/s without added inertia) towards lying on its side
(GM = +0.025 m there). Measured 2026-12-01f to 1.2 s (dx 6 mm): pontoon within 0.91 deg;
tall box 1.3 / 3.5 / 9.0 / 23.9 / 58.3 deg at 0.1-0.5 s, then about its side (77-116 deg).
The 12 cm square of the floating-box test (s = 0.5, GM = -0.01 m) is unstable too: it holds
its draft for ~1.5 s from rest, then rolls over to a corner-down position.
"""

import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from tests.consistency.test_floating_box import CASE as BOX_CASE

BLOCK = "blocks = [{ origin = [0.24, 0.18], size = [0.12, 0.12] }]"  # the floating-box test's


def case_text(b, h):
    """The floating-box scene with a b x h box whose centre is on the waterline (y = 0.24)."""
    assert BLOCK in BOX_CASE
    return BOX_CASE.replace(BLOCK, f"blocks = [{{ origin = [{0.3 - b / 2:.4f}, "
                                   f"{0.24 - h / 2:.4f}], size = [{b}, {h}] }}]")


def roll(tmp_path, b, h, t_end, omega0=0.3):
    """Roll angle (deg) of the box over time after a kick ``omega0`` about its centre."""
    p = tmp_path / "box.toml"
    p.write_text(case_text(b, h))
    sim = Simulation(load_config(p))
    body = sim.structures["box"].body
    r = body["x"] - body["x"].mean(axis=0)
    body["v"][:] = omega0 * np.column_stack([-r[:, 1], r[:, 0]])
    ref = np.arctan2(r[0, 1], r[0, 0])
    angles = []
    while sim.t < t_end - 1e-9:
        sim.step()
        rr = body["x"][0] - body["x"].mean(axis=0)
        angles.append(np.degrees(np.arctan2(rr[1], rr[0]) - ref))
    sim.check()
    return np.array(angles)


@pytest.mark.parametrize("b, h, stable", [(0.198, 0.06, True), (0.06, 0.12, False)],
                         ids=["wide_pontoon", "tall_box"])
def test_floating_body_rights_itself_or_capsizes_as_its_metacentre_says(tmp_path, b, h,
                                                                         stable):
    a = roll(tmp_path, b, h, 0.5)
    if stable:
        assert np.abs(a).max() < 2.0
    else:
        assert a[-1] > 30.0  # rolled on in the direction of the kick (58 deg measured)
