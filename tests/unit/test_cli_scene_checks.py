"""Scene checks before the run (issue 28 §2): each bad scene is exit code 2 from `fsi-sph run`
and `fsi-sph info`, one message of at most 12 lines naming the file, the key and what is
allowed, no traceback, nothing built."""

from pathlib import Path

import numpy as np
import pytest

from fsi_sph import scene_checks
from fsi_sph.__main__ import main
from fsi_sph.config import load_config
from fsi_sph.geometry import in_shapes
from fsi_sph.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
GATE = ROOT / "cases" / "dam_break_elastic_gate.toml"

TANK = """
[case]
t_end = 0.01
dx = 0.02
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [BX, 0.0], size = [0.2, 0.1] }]
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.4, 0.3] }]
"""

POST = """
[solid.post]
material = { rho0 = 1100.0, E = 1.0e6, nu = 0.3 }
blocks = [{ origin = [0.108, 0.008], size = [0.04, 0.06] }]
clamp = [{ origin = [0.108, 0.008], size = [0.04, 0.02] }]
"""

COUPLED = """
[coupling]
structures = ["post"]
"""


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def run_cli(capsys, argv):
    """(exit code, every line printed on stdout and stderr)."""
    rc = main(argv)
    out = capsys.readouterr()
    return rc, (out.out + out.err).strip().splitlines()


def assert_refused(capsys, argv, *words):
    rc, lines = run_cli(capsys, argv)
    text = "\n".join(lines)
    assert rc == 2, text
    assert 1 <= len(lines) <= 12, text
    assert "Traceback" not in text
    for w in words:
        assert w in text, f"{w!r} not in:\n{text}"
    return text


def both_commands(case, *extra):
    return [["run", case, "--no-progress", *extra], ["info", case, *extra]]


@pytest.mark.parametrize("command", [0, 1])
def test_too_fine_dx_is_refused_with_a_dx_that_fits(capsys, command):
    argv = both_commands(str(GATE), "--set", "case.dx=1e-7")[command]
    text = assert_refused(capsys, argv, str(GATE), "case.dx = 1e-07", "particles",
                          "PiB", "this machine has", "would fit", "--force")
    fit = float(text.split("case.dx = ")[2].split(" m")[0])
    cfg = load_config(GATE, [f"case.dx={fit}"])
    assert scene_checks.estimate(cfg, fit).memory <= scene_checks.machine_memory()
    assert scene_checks.estimate(cfg, 0.9 * fit).memory > scene_checks.machine_memory()


def test_memory_estimate_counts_the_particles_the_scene_builds():
    cfg = load_config(GATE, ["case.dx=0.0025"])
    est = scene_checks.estimate(cfg, cfg.case.dx)
    sim = Simulation(cfg)
    assert est.particles == {"gate": sim.structures["gate"].body.n, "fluid": sim.fluid.n,
                             "walls": sim.fluid.walls.body.n}


def test_force_runs_a_scene_past_the_memory_check(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(scene_checks, "machine_memory", lambda: 1.0)
    case = write(tmp_path, TANK.replace("BX", "0.0"))
    argv = ["run", case, "--no-progress", "--max-steps", "1", "--out", str(tmp_path / "o")]
    assert_refused(capsys, argv, "this machine has 0.000977 KiB",
                   "no case.dx fits")
    rc, _ = run_cli(capsys, [*argv, "--force"])
    assert rc == 0


@pytest.mark.parametrize("command", [0, 1])
def test_fluid_block_outside_every_tank(capsys, tmp_path, command):
    case = write(tmp_path, TANK.replace("BX", "2.0"))
    assert_refused(capsys, both_commands(case)[command], case, "fluid.blocks[0]",
                   "x 2..2.2 m", "outside every tank", "walls.tanks[0] x 0..0.4 m")


def test_fluid_above_a_tank_or_a_box_is_allowed(tmp_path):
    above = load_config(None, text=TANK.replace("BX", "0.1").replace("0.0], size = [0.2",
                                                                      "0.5], size = [0.2"))
    scene_checks.check_scene(above, "above")
    shelf = TANK.replace("BX", "2.0") + "boxes = [{ origin = [1.9, -0.1], size = [0.5, 0.1] }]\n"
    scene_checks.check_scene(load_config(None, text=shelf), "shelf")


@pytest.mark.parametrize("command", [0, 1])
def test_fluid_over_an_uncoupled_solid_is_refused(capsys, tmp_path, command):
    case = write(tmp_path, TANK.replace("BX", "0.0") + POST)
    assert_refused(capsys, both_commands(case)[command], case, "fluid.blocks[0] overlaps "
                   "solid.post.blocks[0]", "not coupled", "coupling.structures")


def test_fluid_over_a_coupled_solid_is_carved_around_it(tmp_path, caplog):
    text = (TANK.replace("BX", "0.0").replace("rho0 = 1000.0 }", "rho0 = 1000.0 }\n"
            "pressure_gradient = \"interface_conservative\"") + POST + COUPLED)
    cfg = load_config(None, text=text)
    scene_checks.check_scene(cfg, "coupled")
    with caplog.at_level("INFO"):
        sim = Simulation(cfg)
    x = sim.fluid.body["x"]
    post = cfg.solid["post"].blocks
    assert not in_shapes(x, post).any()
    # the post, offset 0.4 dx in x and y from the fluid's lattice, covers 2 of the 10 columns
    # and 3 of the 5 rows of the block; those 6 fluid particles are 0.57 dx from the post's
    # nearest particle, where the old rule (drop within dx/2 of a structure site) kept them
    assert sim.fluid.n == 50 - 6
    assert "6 particles inside solid.post carved out" in caplog.text


@pytest.mark.parametrize("command", [0, 1])
def test_solid_one_particle_thick(capsys, command):
    argv = both_commands(str(GATE), "--set", "case.dx=0.004")[command]
    assert_refused(capsys, argv, "solid.gate.blocks[0]", "1 particle(s) across",
                   "at least 2", "case.dx <= 0.0025")


@pytest.mark.parametrize("command", [0, 1])
def test_point_probe_far_from_its_body(capsys, tmp_path, command):
    text = GATE.read_text().replace("at = [0.1025, 0.0]", "at = [0.1025, 3.0]")
    case = write(tmp_path, text, "gate.toml")
    assert_refused(capsys, both_commands(case)[command], case, "probes[0] (gate_tip)",
                   "at = [0.1025, 3]", "2.92 m (2916 spacings) from body gate",
                   "within 2 spacings (0.002 m)")


def test_point_probedistance_to_shape_to_a_polygon():
    tri = load_config(None, text="[case]\nt_end = 1.0\ndx = 0.1\n[soil.s]\nmaterial = { "
                      "model = \"drucker_prager\", rho0 = 2000.0, E = 1e7, nu = 0.3, "
                      "friction_angle_deg = 30.0 }\nblocks = [{ shape = \"polygon\", vertices "
                      "= [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] }]\n").soil["s"].blocks[0]
    assert scene_checks.distance_to_shape((0.2, 0.2), tri) == 0.0
    assert np.isclose(scene_checks.distance_to_shape((1.0, 1.0), tri), np.sqrt(0.5))
    assert np.isclose(scene_checks.distance_to_shape((-0.3, 0.5), tri), 0.3)


def test_info_reports_the_scene(capsys):
    rc, lines = run_cli(capsys, ["info", str(GATE), "--set", "case.dx=0.0025"])
    assert rc == 0
    text = "\n".join(lines)
    assert "particles: gate 68, fluid 2240, walls 1298 (total 3606)" in text
    assert "memory estimate: 395 MiB" in text
    assert "first stable time step: 0.00437 s (sub-steps: gate 554)" in text
    # the flow at sqrt(2 g H), H = 0.14 m of water: 1.66 m/s, cfl h / u = 3.65e-4 s
    assert ("steps to t_end = 0.4 s: about 1095 (an estimate: the step of a flow at 1.6 m/s"
            in text)


def test_fluid_over_a_soil_polygon_is_refused_and_beside_it_allowed(tmp_path, capsys):
    soil = ("[soil.bank]\nmaterial = { model = \"drucker_prager\", rho0 = 2000.0, E = 1.0e7, "
            "nu = 0.3, friction_angle_deg = 30.0 }\nblocks = [{ shape = \"polygon\", vertices = "
            "[[0.2, 0.0], [0.4, 0.0], [0.4, VY]] }]\n")
    case = write(tmp_path, TANK.replace("BX", "0.0") + soil.replace("VY", "0.2"))
    # a triangle beside the block (it touches the block's corner at (0.2, 0)) is allowed; one
    # leaning over the block is refused (its overlap sampled over the polygon)
    assert main(["info", case]) == 0
    capsys.readouterr()
    steep = soil.replace("[0.4, 0.0], [0.4, VY]", "[0.4, 0.0], [0.1, 0.2]")
    case = write(tmp_path, TANK.replace("BX", "0.0") + steep, "steep.toml")
    assert_refused(capsys, ["info", case], "fluid.blocks[0] overlaps soil.bank.blocks[0]",
                   "not coupled", "move one of the two")


def test_info_into_a_pipe_its_reader_closed_ends_quietly():
    """``fsi-sph info CASE | head``: the reader has closed the pipe (here before the first
    write, so that the write fails whatever the timing); the command ends with 141
    (128 + SIGPIPE, as a shell reports it) and no traceback."""
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "fsi_sph", "info", str(GATE)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err


def test_info_says_a_full_channel_is_confined(capsys):
    """A through-flow that fills its channel: `info` says it has no free surface and why."""
    case = Path(__file__).resolve().parents[2] / "cases" / "channel_poiseuille.toml"
    rc, lines = run_cli(capsys, ["info", str(case), "--set", "case.dx=0.01"])
    assert rc == 0
    assert any(line.startswith("free surface: none (confined") for line in lines)


CASES = sorted((ROOT / "cases").glob("*.toml"))


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_every_shipped_case_passes_the_checks(case):
    """The checks that `run` and `info` make before building a scene accept every shipped
    case (a circle wall box, cases/turek_hron_cfd2.toml, made `run` stop with an
    AttributeError in the memory estimate)."""
    cfg = load_config(case, [])
    est = scene_checks.check_scene(cfg, str(case), force=True)
    assert sum(est.particles.values()) > 0


def test_memory_estimate_counts_a_circle_and_the_fluid_it_carves():
    """A channel with a round post: the estimate's wall and fluid counts against the built
    scene (the circle is filled by rings, the fluid lattice carved around it)."""
    case = ROOT / "cases" / "turek_hron_cfd2.toml"
    cfg = load_config(case, [])
    est = scene_checks.estimate(cfg, cfg.case.dx)
    sim = Simulation(cfg)
    assert est.particles["walls"] == pytest.approx(sim.fluid.walls.body.n, rel=0.05)
    assert est.particles["fluid"] == pytest.approx(sim.fluid.n, rel=0.05)


def test_distance_to_a_circle():
    circle = load_config(ROOT / "cases" / "turek_hron_cfd2.toml", []).walls.boxes[2]
    assert scene_checks.distance_to_shape([0.2, 0.2], circle) == 0.0
    assert scene_checks.distance_to_shape([0.2, 0.35], circle) == pytest.approx(0.1)
