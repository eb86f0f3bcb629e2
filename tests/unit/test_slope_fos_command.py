"""``fsi-sph fos``: the slope geometry taken from a case, bad input (exit 2, one message, no
traceback), the failure test, and a coarse slope's whole strength reduction."""

import json
import math
from pathlib import Path

import pytest

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.strength_reduction import (
    COLLAPSE,
    SlopeInputError,
    search_bracket,
    slope_geometry,
    soil_body_name,
    verdict,
)

CASES = Path(__file__).resolve().parents[2] / "cases"
SLOPE_1 = (CASES / "slope_1_granular.toml").read_text()


@pytest.mark.parametrize("case,profile,crest,toe,height", [
    ("slope_1_granular", [(0, 1), (1, 1), (2, 0), (4, 0)], (1, 1), (2, 0), 1.0),
    ("slope_2_cohesive", [(0, 10), (5, 10), (15, 0), (35, 0)], (5, 10), (15, 0), 10.0),
    ("slope_3_cohesive_layer", [(0, 15), (10, 15), (20, 5), (45, 5)], (10, 15), (20, 5), 10.0),
])
def test_geometry_from_the_case(case, profile, crest, toe, height):
    """The ground profiles of PHYSICS.md §6 from the body's polygon and the walls (beyond the
    toe along the floor to 2 H, or to the right wall)."""
    cfg = load_config(CASES / f"{case}.toml")
    geo = slope_geometry(cfg, soil_body_name(cfg))
    assert len(geo.profile) == len(profile)
    for got, want in zip(geo.profile, profile, strict=True):
        assert got == pytest.approx(want, abs=1e-9)
    assert geo.crest == pytest.approx(crest) and geo.toe == pytest.approx(toe)
    assert geo.height == pytest.approx(height)
    assert geo.beta_deg == pytest.approx(45.0)
    assert (geo.x_wall, geo.y_floor) == (0.0, 0.0)


def test_verdict_is_scale_free():
    """Scaling displacement and height together does not change a verdict; a slope that
    keeps moving at a steady rate has failed however little it moved, one whose movement
    dies out is stable however much it moved."""
    cases = [((0.0286, 0.0072, 0.0089), "failed"),   # slope 1 creeping at 2.9 % H
             ((0.0028, 7.8e-8, 3.4e-8), "stable"),   # slope 1 at rest
             ((0.05, 0.010, 0.004), "stable"),        # decelerating
             ((1.5 * COLLAPSE, 0.0, 0.0), "failed")]  # moved more than COLLAPSE H
    for (u, g3, g4), want in cases:
        for scale in (1.0, 10.0, 1e3):
            assert verdict(u * scale, g3 * scale, g4 * scale, 1.0 * scale) == want


def _case(tmp_path, text, name="c.toml"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _bad(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.startswith("fsi-sph: error:") and err.count("\n") == 1  # one paragraph
    return err


def test_no_soil_body(capsys):
    err = _bad(capsys, ["fos", str(CASES / "hydrostatic_tank.toml"), "--method", "bishop"])
    assert "no Drucker-Prager soil body" in err


def test_several_soil_bodies_need_body(tmp_path, capsys):
    two = SLOPE_1 + """
[soil.rock]
material = { model = "drucker_prager", rho0 = 2080.0, E = 0.8e6, nu = 0.3, friction_angle_deg = 20.0, cohesion = 0.0 }
blocks = [{ origin = [2.5, 0.0], size = [0.5, 0.2] }]
"""
    err = _bad(capsys, ["fos", _case(tmp_path, two), "--method", "bishop"])
    assert "--body" in err and "sand" in err and "rock" in err
    err = _bad(capsys, ["fos", _case(tmp_path, two), "--body", "gravel"])
    assert "gravel" in err


def test_flat_ground(tmp_path, capsys):
    """A layer between the back wall and a right wall (a free right end would be a cut)."""
    flat = SLOPE_1.replace("[[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 0.0]]",
                           "[[0.0, 0.0], [0.0, 0.5], [2.0, 0.5], [2.0, 0.0]]").replace(
        '{ side = "left", position = 0.0, friction = "free_slip" }',
        '{ side = "left", position = 0.0, friction = "free_slip" },\n'
        '         { side = "right", position = 2.0, friction = "free_slip" }')
    assert flat != SLOPE_1
    err = _bad(capsys, ["fos", _case(tmp_path, flat), "--method", "bishop"])
    assert "flat" in err


def test_free_end_is_a_cut():
    """A block with a free right end is a vertical cut: crest and toe at its corners."""
    cfg = load_config(CASES / "column_collapse.toml")
    geo = slope_geometry(cfg, soil_body_name(cfg))
    assert geo.beta_deg == pytest.approx(90.0)
    assert geo.toe[1] == geo.y_floor and geo.height == pytest.approx(geo.crest[1] - geo.y_floor)


def test_soil_body_name_errors_are_input_errors():
    cfg = load_config(CASES / "slope_1_granular.toml")
    with pytest.raises(SlopeInputError):
        soil_body_name(cfg, "clay")


def test_bishop_method(tmp_path, capsys):
    """``--method bishop``: slope 1's critical circle tends to the infinite slope's
    tan(phi)/tan(beta) from above (circles shallower than 5 % of H excluded)."""
    assert main(["fos", str(CASES / "slope_1_granular.toml"), "--method", "bishop",
                 "--out", str(tmp_path)]) == 0
    r = json.loads((tmp_path / "result.json").read_text())
    f_inf = math.tan(math.radians(20.0))
    assert r["method"] == "bishop" and f_inf < r["fos"] < 1.03 * f_inf


def test_coarse_slope_strength_reduction(tmp_path, capsys):
    """Slope 1 at dx = H/10 through the whole command: a bracket of the stated tolerance,
    one line per trial, the trials' verdicts consistent with the bracket, the outputs, and the
    issue's target, within 10 % of Bishop (0.386 against 0.369 measured at this spacing; the
    finer spacings are in validation/README_soil.md)."""
    assert main(["fos", str(CASES / "slope_1_granular.toml"), "--set", "case.dx=0.1",
                 "--out", str(tmp_path), "--threads", "1"]) == 0
    out = capsys.readouterr().out
    r = json.loads((tmp_path / "result.json").read_text())
    lo, hi = r["bracket"]
    assert hi - lo <= r["settings"]["tol"] * lo
    assert out.count("  F = ") == len(r["trials"]) >= 3
    for t in r["trials"]:
        assert t["verdict"] == ("failed" if t["F"] >= hi else "stable") or lo < t["F"] < hi
    assert any(t["F"] == lo and t["verdict"] == "stable" for t in r["trials"])
    assert any(t["F"] == hi and t["verdict"] == "failed" for t in r["trials"])
    assert abs(r["fos"] - r["fos_bishop"]) < 0.10 * r["fos_bishop"]
    assert (tmp_path / "fos_slip_surface.png").is_file()
    assert (tmp_path / "fos_displacement_vs_F.png").is_file()


def test_coarse_unseen_c_phi_slope(tmp_path, capsys):
    """An unseen c-phi slope (``tests/data/slopes/steep_10m_45deg.toml``: 10 m at 45 deg on a
    4 m layer, c = 20 kPa, phi = 20 deg, E = 100 MPa) at dx = H/10 through the whole
    command, nothing set but the spacing: within the issue's 5 % of Bishop (1.234 against
    1.246, -1.0 %, at this spacing; -2.4 % at H/20; docs/validation/slopes.md)."""
    case = Path(__file__).resolve().parents[1] / "data" / "slopes" / "steep_10m_45deg.toml"
    assert main(["fos", str(case), "--set", "case.dx=1.0", "--out", str(tmp_path),
                 "--threads", "1"]) == 0
    r = json.loads((tmp_path / "result.json").read_text())
    assert r["n_particles"] < 400
    assert abs(r["fos"] - r["fos_bishop"]) < 0.05 * r["fos_bishop"]


def _threshold(f_true):
    """A slope that fails at every F >= f_true; the trials made and their estimates."""
    made = []

    def trial(F, left):
        made.append((F, left))
        return F >= f_true
    return trial, made


@pytest.mark.parametrize("f_true,f_start", [(1.234, 1.25), (0.3, 1.0), (2.9, 1.0),
                                            (0.364, 0.369)])
def test_bracket_search_brackets_the_answer(f_true, f_start):
    """The bracket holds the answer within the tolerance, each F is tried once, and the
    estimate of the trials left is exact once the bisection has begun (0 on the last)."""
    trial, made = _threshold(f_true)
    lo, hi, status = search_bracket(trial, f_start, 0.02)
    assert status == "bracketed" and lo < f_true <= hi and hi - lo <= 0.02 * lo
    assert len({F for F, _ in made}) == len(made)
    assert made[-1][1] == 0
    verdicts = [F >= f_true for F, _ in made]
    k = next(i for i in range(len(made)) if len(set(verdicts[:i + 1])) == 2)  # bracketed
    for i in range(k + 1, len(made)):  # the bisection
        assert made[i][1] == len(made) - 1 - i


def test_bracket_search_reports_bounds_not_numbers():
    """A slope that stands at F_MAX, or fails at F_MIN, gives the bound and its status."""
    from fsi_sph.strength_reduction import F_MAX, F_MIN

    assert search_bracket(_threshold(50.0)[0], 8.0, 0.02) == (F_MAX, None, "stands_past")
    assert search_bracket(_threshold(50.0)[0], 1.0, 0.02) == (F_MAX, None, "stands_past")
    assert search_bracket(_threshold(0.01)[0], 0.017, 0.02) == (None, F_MIN, "fails_below")
    assert search_bracket(_threshold(0.01)[0], 1.0, 0.02) == (None, F_MIN, "fails_below")


def test_tol_out_of_range_is_a_usage_error(capsys):
    """``--tol`` outside (0, 0.5]: exit 2 with what is allowed, before any work."""
    assert main(["fos", str(CASES / "slope_1_granular.toml"), "--tol", "0"]) == 2
    err = capsys.readouterr().err
    assert "--tol" in err and "(0, 0.5]" in err and "Traceback" not in err


def test_a_slope_that_stands_past_the_largest_factor_gives_the_bound(tmp_path, capsys):
    """Slope 1 made strong (c = 200 kPa on a 1 m slope: Bishop far above 5) at dx = H/10
    through the whole command: two trials (F = 4 and 5) stand, the answer is the bound
    'FoS > 5' with status ``stands_past`` and ``fos`` null, exit 0."""
    assert main(["fos", str(CASES / "slope_1_granular.toml"), "--set", "case.dx=0.1",
                 "--set", "soil.sand.material.cohesion=2.0e5", "--out", str(tmp_path),
                 "--threads", "1"]) == 0
    out = capsys.readouterr().out
    r = json.loads((tmp_path / "result.json").read_text())
    assert r["fos_bishop"] > 5.0
    assert r["status"] == "stands_past" and r["fos"] is None and r["bracket"] == [5.0, None]
    assert [t["verdict"] for t in r["trials"]] == ["stable", "stable"]
    assert "> 5" in out and "a bound, not a value" in out
    assert (tmp_path / "fos_displacement_vs_F.png").is_file()
