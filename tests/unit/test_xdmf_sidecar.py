"""The XDMF sidecar gives ParaView 3-vectors (z = 0) (issue 28 §1): checked in the file, and in
a real ParaView (`pvpython`, Debian's python3-paraview) when it is installed."""

import json
import shutil
import subprocess
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from tests.unit.test_cli_long_runs import TANK

SCENE = TANK.replace("dt_max = 0.0005", "dt_max = 0.0005\ninitial_velocity = [0.3, 0.0]") + """
[solid.post]
material = { rho0 = 1100.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.3, 0.0], size = [0.04, 0.1] }]
clamp = [{ origin = [0.3, 0.0], size = [0.04, 0.02] }]
"""

PVSCRIPT = """
import json, sys
from paraview.simple import Glyph, OpenDataFile, servermanager
r = OpenDataFile(sys.argv[1])
r.UpdatePipeline(max(r.TimestepValues))
d = servermanager.Fetch(r)
out = []
it = d.NewIterator()
it.InitTraversal()
while not it.IsDoneWithTraversal():
    b = it.GetCurrentDataObject()
    pd = b.GetPointData()
    for i in range(pd.GetNumberOfArrays()):
        a = pd.GetArray(i)
        out.append([b.GetNumberOfPoints(), a.GetName(), a.GetNumberOfComponents(),
                    [list(a.GetRange(c)) for c in range(a.GetNumberOfComponents())]])
    it.GoToNextItem()
g = Glyph(Input=r, GlyphType="Arrow", OrientationArray=["POINTS", "v"])
g.UpdatePipeline(max(r.TimestepValues))
out.append(["glyph points", servermanager.Fetch(g).GetNumberOfPoints()])
print("RESULT" + json.dumps(out))
"""


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("xdmf")
    Simulation(load_config(None, text=SCENE)).run(out_dir=out, progress=False)
    return out / "run.h5"


def last_snapshot(path):
    with h5py.File(path, "r") as f:
        name = sorted(f["snapshots"])[-1]
        return {b: {k: g[k][()] for k in g} for b, g in f["snapshots"][name].items()}, \
            {b: {k: g[k][()] for k in g} for b, g in f[f"xdmf/snapshots/{name}"].items()}


def test_sidecar_vectors_are_3_vectors_with_z_zero(run_file):
    snap, xyz = last_snapshot(run_file)
    assert set(xyz) == {"fluid", "post"} and set(xyz["post"]) == {"v", "u"}
    for body, fields in xyz.items():
        for k, v in fields.items():
            assert v.shape == (len(snap[body][k]), 3)
            np.testing.assert_array_equal(v[:, :2], snap[body][k].astype(np.float32))
            assert not v[:, 2].any()
    root = ET.parse(run_file.with_suffix(".xmf")).getroot()
    vectors = [a for a in root.iter("Attribute") if a.get("AttributeType") == "Vector"]
    assert vectors and all(a.find("DataItem").get("Dimensions").endswith(" 3") for a in vectors)
    with h5py.File(run_file, "r") as f:  # every path the sidecar names exists, with its shape
        for item in root.iter("DataItem"):
            ref = item.text.split(":", 1)[1]
            assert f[ref].shape == tuple(int(n) for n in item.get("Dimensions").split())


@pytest.mark.skipif(shutil.which("pvpython") is None,
                    reason="pvpython not installed (Debian: apt-get install python3-paraview)")
def test_paraview_reads_3_vectors_and_glyphs_them(run_file, tmp_path):
    script = tmp_path / "read.py"
    script.write_text(PVSCRIPT)
    res = subprocess.run(["pvpython", str(script), str(run_file.with_suffix(".xmf").resolve())],
                         capture_output=True, text=True, timeout=300)
    line = [x for x in res.stdout.splitlines() if x.startswith("RESULT")]
    assert line, res.stdout[-2000:] + res.stderr[-2000:]
    arrays = json.loads(line[0][len("RESULT"):])
    glyphs = arrays.pop()
    snap, _ = last_snapshot(run_file)
    seen = {(n, name): (comps, ranges) for n, name, comps, ranges in arrays}
    for body in ("fluid", "post"):
        n = len(snap[body]["x"])
        comps, ranges = seen[(n, "v")]
        assert comps == 3 and ranges[2] == [0.0, 0.0]
        v = snap[body]["v"]
        assert np.allclose(ranges[0], [v[:, 0].min(), v[:, 0].max()], rtol=1e-6, atol=1e-7)
    assert seen[(len(snap["post"]["x"]), "von_mises")][0] == 1
    assert glyphs[0] == "glyph points" and glyphs[1] > 0


def xdmf_vectors(path):
    with h5py.File(path, "r") as f:
        out = {}
        f["xdmf"].visititems(lambda k, o: out.update({k: o[()]}) if isinstance(
            o, h5py.Dataset) else None)
        return out


def test_a_restarted_run_writes_the_uninterrupted_runs_vectors(tmp_path):
    """A run stopped past a snapshot and restarted writes, for each later snapshot, the
    3-vectors of that snapshot (the restart drops the stopped run's later snapshots and
    their 3-vectors; before, the 3-vectors were left behind, and a later snapshot of the
    same number kept the stopped run's values, or another particle count)."""
    case = tmp_path / "tank.toml"
    case.write_text(SCENE.replace("t_end = 0.004", "t_end = 0.008"))
    assert main(["run", str(case), "--out", str(tmp_path / "whole"), "--no-progress"]) == 0
    assert main(["run", str(case), "--out", str(tmp_path / "cut"), "--no-progress",
                 "--max-steps", "7"]) == 0
    assert main(["run", "--restart", str(tmp_path / "cut" / "run.h5"), "--no-progress"]) == 0
    whole, cut = xdmf_vectors(tmp_path / "whole" / "run.h5"), xdmf_vectors(
        tmp_path / "cut" / "run.h5")
    assert sorted(whole) == sorted(cut)
    assert [k for k in whole if not np.array_equal(whole[k], cut[k])] == []
