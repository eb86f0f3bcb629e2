"""Case files: every malformed-input kind gives exit code 2 and a short message naming the
file, the key path and what is allowed; never a traceback."""

import json

import pytest
from pydantic import ValidationError

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.errors import ConfigError

GOOD = """
[case]
t_end = 0.1
dx = 0.01

[solid.bar]
material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.05] }]

[[probes]]
name = "tip"
kind = "point_displacement"
body = "bar"
at = [0.2, 0.0]
"""


def _case(tmp_path, text, name="case.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


# (id, case text, substrings the message must contain)
BAD = [
    ("unknown_key", GOOD.replace("dx = 0.01", "dx = 0.01\ndxx = 1"),
     ["case.dxx", "unknown key", "allowed:", "dx", "t_end"]),
    ("unknown_table", GOOD + "\n[fluidd]\nrho0 = 1000.0\n", ["fluidd", "unknown table"]),
    ("unknown_nested_key", GOOD.replace("nu = 0.3", "nu = 0.3, G = 1.0"),
     ["solid.bar.material.G", "unknown key", "allowed:", "rho0"]),
    ("wrong_type", GOOD.replace("dx = 0.01", 'dx = "fine"'), ["case.dx", "number", '"fine"']),
    ("wrong_type_list", GOOD.replace("at = [0.2, 0.0]", "at = 0.2"), ["probes[0].at"]),
    ("nu_too_large", GOOD.replace("nu = 0.3", "nu = 0.5"),
     ["solid.bar.material.nu", "less than 0.5", "0.5"]),
    ("E_not_positive", GOOD.replace("E = 1e6", "E = 0.0"),
     ["solid.bar.material.E", "greater than 0"]),
    ("dx_not_positive", GOOD.replace("dx = 0.01", "dx = -0.01"), ["case.dx", "greater than 0"]),
    ("dx_nan", GOOD.replace("dx = 0.01", "dx = nan"), ["case.dx", "finite"]),
    ("bad_model", GOOD.replace("rho0 = 1000.0,", 'model = "rubber", rho0 = 1000.0,'),
     ["solid.bar.material.model", "stvk", "neo_hookean"]),
    ("missing_case", GOOD.replace("[case]\nt_end = 0.1\ndx = 0.01\n", ""),
     ["case", "required table is missing"]),
    ("missing_key", GOOD.replace("t_end = 0.1\n", ""), ["case.t_end", "required key"]),
    ("missing_material", GOOD.replace("material = { rho0 = 1000.0, E = 1e6, nu = 0.3 }\n", ""),
     ["solid.bar.material", "missing"]),
    ("no_body", "[case]\nt_end = 1.0\ndx = 0.1\n", ["no body"]),
    ("probe_unknown_body", GOOD.replace('body = "bar"', 'body = "gate"'),
     ["probes[0].body", "gate", "bar"]),
    ("probe_needs_at", GOOD.replace("at = [0.2, 0.0]\n", ""), ["probes[0]", "at"]),
    ("syntax_error", GOOD.replace("dx = 0.01", "dx = = 0.01"), ["TOML syntax error", "line"]),
    ("empty", "", ["empty"]),
    ("blank", "  \n# only a comment\n", ["no keys or tables"]),
    ("extends_missing", 'extends = "nowhere.toml"\n' + GOOD, ["nowhere.toml", "not found",
                                                              "extends"]),
]


@pytest.mark.parametrize("text,needles", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_case_exit_code_2(tmp_path, capsys, text, needles):
    p = _case(tmp_path, text)
    assert main(["info", str(p)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert str(p) in err
    for n in needles:
        assert n in err, f"{n!r} not in {err!r}"


def test_extends_cycle(tmp_path, capsys):
    _case(tmp_path, 'extends = "b.toml"\n' + GOOD, "a.toml")
    _case(tmp_path, 'extends = "a.toml"\n', "b.toml")
    assert main(["info", str(tmp_path / "a.toml")]) == 2
    err = capsys.readouterr().err
    assert "cycle" in err and "a.toml" in err and "b.toml" in err


def test_extends_merges_tables(tmp_path):
    _case(tmp_path, "[case]\nt_end = 5.0\ndx = 0.01\ngravity = [0.0, -1.0]\n", "base.toml")
    p = _case(tmp_path, 'extends = "base.toml"\n' + GOOD.replace("t_end = 0.1\n", ""))
    cfg = load_config(p)
    assert cfg.case.t_end == 5.0 and cfg.case.gravity == (0.0, -1.0) and cfg.case.dx == 0.01


@pytest.mark.parametrize("path_kind", ["missing", "directory", "binary"])
def test_unreadable_file(tmp_path, capsys, path_kind):
    p = tmp_path / "c.toml"
    if path_kind == "directory":
        p.mkdir()
    elif path_kind == "binary":
        p.write_bytes(b"\xff\xfe\x00[case]")
    assert main(["info", str(p)]) == 2
    err = capsys.readouterr().err
    assert str(p) in err and "Traceback" not in err


def test_overrides(tmp_path, capsys):
    p = _case(tmp_path, GOOD)
    cfg = load_config(p, ["case.dx=0.02", "solid.bar.material.model=neo_hookean"])
    assert cfg.case.dx == 0.02 and cfg.solid["bar"].material.model == "neo_hookean"
    for bad, needle in [("case.dx", "KEY.PATH=VALUE"), ("case.dx=abc", "case.dx"),
                        ("case.dx.x=1", "not a table"), ("solid.bar.material.nu=0.7", "nu")]:
        assert main(["info", str(p), "--set", bad]) == 2
        err = capsys.readouterr().err
        assert needle in err and "Traceback" not in err


def test_resolved_config_is_json_and_frozen(tmp_path):
    cfg = load_config(_case(tmp_path, GOOD))
    data = json.loads(cfg.to_json())
    assert data["sph"]["kernel"] == "cubic_spline"  # defaults are resolved
    assert data["solid"]["bar"]["hourglass"]["coefficient"] == 10.0
    with pytest.raises(ValidationError):
        cfg.case.dx = 1.0


def test_config_error_type(tmp_path):
    with pytest.raises(ConfigError):
        load_config(_case(tmp_path, GOOD.replace("nu = 0.3", "nu = 0.6")))


def test_bad_cli_options(tmp_path, capsys):
    p = _case(tmp_path, GOOD)
    assert main(["run", str(p), "--max-steps", "-1"]) == 2
    assert main(["run", str(p), "--threads", "999", "--max-steps", "0"]) == 2
    assert main(["validate", "no_such_case"]) == 2
    assert main(["plot", str(tmp_path / "none.h5")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "no_such_case" in err


@pytest.mark.parametrize("override,needle", [
    ("case.dx=0.5", "solid.bar.blocks[0]"),
    ("solid.bar.clamp=[{origin=[5.0,5.0],size=[0.1,0.1]}]", "solid.bar.clamp[0]"),
])
def test_bad_geometry_exit_code_2(tmp_path, capsys, override, needle):
    p = _case(tmp_path, GOOD)
    assert main(["run", str(p), "--set", override, "--max-steps", "0", "--out",
                 str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert needle in err and str(p) in err and "Traceback" not in err
