"""Pictures of a run (issue 28 §1): every body in its natural field on the whole domain, one
colour bar per field, `--field` overriding; `--movie` with one frame per snapshot (MP4, GIF
without an encoder); probe plots with the reference curves the case names."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from PIL import Image

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.movie import write_movie
from fsi_sph.plot_scene import MARGIN, SceneFigure, open_run
from fsi_sph.plotting import probe_figure
from fsi_sph.references import probe_references

ROOT = Path(__file__).resolve().parents[2]
DX = 0.01
CONFIG = {"case": {"name": "synthetic", "dx": DX},
          "solid": {"gate": {"material": {"model": "neo_hookean"}},
                    "box": {"material": {"model": "rigid"}}},
          "soil": {"sand": {}},
          "probes": [{"name": "tip", "reference": [
              {"file": "ref/tip.csv", "column": "ux", "label": "experiment", "value_column": 1,
               "subtract_first": True}]}]}


def lattice(x0, y0, nx, ny):
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    return np.column_stack([x0 + (ix.ravel() + 0.5) * DX, y0 + (iy.ravel() + 0.5) * DX])


def synthetic_run(path, n_snapshots=3):
    """A run file with a fluid, walls, an elastic gate, a rigid box and a soil; the fluid
    rises by 0.3 m per snapshot."""
    bodies = {"fluid": lattice(0.0, 0.0, 20, 10), "walls": lattice(-0.03, -0.03, 106, 3),
              "gate": lattice(0.2, 0.0, 2, 8), "box": lattice(0.4, 0.0, 4, 4),
              "sand": lattice(0.6, 0.0, 40, 5)}
    with h5py.File(path, "w") as f:
        f.attrs["config"] = json.dumps(CONFIG)
        for k in range(n_snapshots):
            g = f.create_group(f"snapshots/{k:06d}")
            g.attrs["t"] = 0.01 * k
            for name, x in bodies.items():
                gb = g.create_group(name)
                gb["x"] = x + ([0.0, 0.3 * k] if name == "fluid" else 0.0)
                gb["p"] = np.linspace(0.0, 1000.0 * (k + 1), len(x))
                if name in ("fluid", "gate", "box", "sand"):
                    gb["v"] = np.ones((len(x), 2))
                if name in ("gate", "box"):
                    gb["von_mises"] = np.full(len(x), 5.0e3 * k)
                if name == "sand":
                    gb["eps_p"] = np.linspace(0.0, 0.1, len(x))
        ds = f.create_dataset("probes/tip", data=np.column_stack(
            [np.linspace(0, 0.02, 5), np.linspace(0, 1e-3, 5), np.zeros(5)]))
        ds.attrs["columns"] = json.dumps(["t", "ux", "uy"])
    return path


@pytest.fixture
def run_file(tmp_path):
    return synthetic_run(tmp_path / "run.h5")


def scene(run_file, field=None):
    f, groups = open_run(run_file)
    return f, SceneFigure(f, groups, field)


def test_each_body_in_its_natural_field_with_one_bar_per_field(run_file):
    f, s = scene(run_file)
    with f:
        assert {b: st[0] for b, st in s.style.items()} == {
            "fluid": "p", "gate": "von_mises", "sand": "eps_p", "walls": None, "box": None}
        assert s.style["walls"][2] != s.style["box"][2]  # walls and rigid bodies: two greys
        s.draw(f["snapshots/000002"], "t")
        bars = [ax.get_xlabel() for ax in s.fig.axes if ax is not s.ax]
        assert bars == ["fluid pressure p (Pa)", "von Mises stress (Pa)",
                        "accumulated plastic strain"]
        assert s.limits["von_mises"] == (0.0, 1.0e4)  # one scale over every snapshot
        s.close()


def test_whole_domain_at_equal_aspect_without_wasted_space(run_file):
    f, s = scene(run_file)
    with f:
        (x0, x1), (y0, y1) = s.ax.get_xlim(), s.ax.get_ylim()
        # particle centres, padded by a spacing: the walls from -0.025 to 1.025 m, the fluid's
        # top at 0.095 + 0.6 m in the last snapshot
        assert x0 == pytest.approx(-0.025 - DX) and x1 == pytest.approx(1.025 + DX)
        assert y0 == pytest.approx(-0.025 - DX) and y1 == pytest.approx(0.695 + DX)
        w, h = s.fig.get_size_inches()
        box = s.ax.get_position()
        assert box.width * w == pytest.approx((box.height * h) * (x1 - x0) / (y1 - y0), rel=1e-9)
        assert w - box.width * w == pytest.approx(MARGIN["left"] + MARGIN["right"], abs=0.02)
        s.close()


def test_field_overrides_the_natural_fields(run_file):
    f, s = scene(run_file, field="v")
    with f:
        assert [b for b, st in s.style.items() if st[0] == "v"] == ["box", "fluid", "gate",
                                                                      "sand"]
        assert s.style["walls"][0] is None
        assert len(s.fig.axes) == 2  # the axes and one bar
        s.close()


def test_cli_plot_writes_pictures_and_refuses_an_unknown_field(run_file, tmp_path, capsys):
    assert main(["plot", str(run_file), "--out", str(tmp_path / "p"), "--data",
                 str(tmp_path)]) == 0
    names = sorted(p.name for p in (tmp_path / "p").iterdir())
    assert names == ["probe_tip.png", "snapshot_0000.png", "snapshot_0001.png",
                     "snapshot_0002.png"]
    # 8 in of axes for 1.07 m: 5.53 in for 0.74 m, + 0.4 title, 1.22 x label and bars
    assert Image.open(tmp_path / "p" / "snapshot_0000.png").size == (900, 716)
    assert main(["plot", str(run_file), "--field", "nope"]) == 2
    err = capsys.readouterr().err
    assert "--field nope: not in this run; available: eps_p, p, v, von_mises, x" in err


def test_movie_has_one_frame_per_snapshot(run_file, tmp_path):
    import imageio_ffmpeg

    assert main(["plot", str(run_file), "--movie", "--out", str(tmp_path / "m")]) == 0
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "m" / "movie.mp4"))
    assert frames == 3


def test_gif_without_an_encoder(run_file, tmp_path):
    path = write_movie(run_file, tmp_path, encoder=None, progress=False)
    assert path.name == "movie.gif" and Image.open(path).n_frames == 3


def test_probe_plot_overlays_the_named_reference(run_file, tmp_path):
    (tmp_path / "ref").mkdir()
    (tmp_path / "ref" / "tip.csv").write_text("t_s,disp_m\n0.0,0.5\n0.01,0.75\n0.02,1.5\n")
    with h5py.File(run_file, "r") as f:
        refs = probe_references(f.attrs["config"], tmp_path)
        fig = probe_figure("tip", f["probes/tip"], refs["tip"])
    ux, uy = fig.axes
    lines = {ln.get_label(): ln.get_ydata() for ln in ux.get_lines()}
    assert np.array_equal(lines["experiment"], [0.0, 0.25, 1.0])  # first value subtracted
    assert [ln.get_label() for ln in uy.get_lines()] == ["this run"]


def test_gate_and_obstacle_cases_name_their_references():
    data = ROOT.parent / "shared" / "validation_data"
    if not data.is_dir():
        pytest.skip(f"{data}: no reference data")
    for case, n in (("dam_break_elastic_gate.toml", 2), ("dam_break_elastic_obstacle.toml", 2)):
        refs = probe_references(load_config(ROOT / "cases" / case).to_json(), data)
        (curves,) = refs.values()
        assert len(curves) == n and all(len(c["t"]) > 5 for c in curves)
