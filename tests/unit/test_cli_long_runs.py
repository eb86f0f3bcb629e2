"""Long runs (issue 28 §3): progress with ETA and wall time per simulated second, as a bar on a
terminal and as lines elsewhere; `fsi-sph run` does not overwrite a run without --overwrite."""

import io

import h5py

from fsi_sph import progress
from fsi_sph.__main__ import main
from fsi_sph.progress import Progress, duration

TANK = """
[case]
t_end = 0.004
dx = 0.02
output_every = 0.002
[fluid]
material = { rho0 = 1000.0 }
blocks = [{ origin = [0.0, 0.0], size = [0.2, 0.1] }]
dt_max = 0.0005
[walls]
tanks = [{ origin = [0.0, 0.0], size = [0.4, 0.3] }]
"""


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_duration_text():
    assert [duration(s) for s in (4.4, 187, 7500, float("nan"))] == ["4s", "3m07s", "2h05m", "?"]


def test_lines_every_five_percent_with_eta_when_not_a_terminal():
    clock, out = FakeClock(), io.StringIO()
    p = Progress(1.0, stream=out, clock=clock)
    for k in range(1, 101):  # 100 steps of 0.01 simulated s, 1 s of wall time each
        clock.now = float(k)
        p.update(k / 100)
    p.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 20
    assert lines[9] == ("fsi-sph: t = 0.5 / 1 s (50 %), 50s elapsed, ETA 50s, 1m40s per "
                        "simulated s")


def test_no_line_in_the_first_seconds():
    clock, out = FakeClock(), io.StringIO()
    p = Progress(1.0, stream=out, clock=clock)
    for k in range(1, 101):  # 0.05 s of wall time per step: 2 s reached at 40 %
        clock.now = 0.05 * k
        p.update(k / 100)
    lines = out.getvalue().splitlines()
    assert len(lines) == 13 and "(40 %)" in lines[0]  # 40, 45, ..., 100 %


def test_bar_on_a_terminal_shows_eta_and_time_per_simulated_second(monkeypatch):
    monkeypatch.setattr(progress, "DELAY", 0.0)
    clock, out = FakeClock(), Terminal()
    p = Progress(2.0, stream=out, clock=clock)
    clock.now = 30.0
    p.update(0.5)
    p.close()
    text = out.getvalue()
    assert "0.5/2 s [00:00, ETA" in text and "1m00s per simulated s]" in text


def test_cli_run_prints_progress_lines_into_a_log(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(progress, "DELAY", 0.0)
    case = tmp_path / "tank.toml"
    case.write_text(TANK)
    assert main(["run", str(case), "--out", str(tmp_path / "o")]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if "per simulated s" in x]
    assert len(lines) >= 4 and "(100 %)" in lines[-1] and "ETA 0s" in lines[-1]


def test_run_refuses_to_overwrite_a_run(capsys, tmp_path):
    case = tmp_path / "tank.toml"
    case.write_text(TANK)
    argv = ["run", str(case), "--out", str(tmp_path / "o"), "--no-progress"]
    assert main([*argv, "--max-steps", "2"]) == 0
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert f"{tmp_path / 'o' / 'run.h5'} already holds a run (stopped at max_steps = 2, 2 " \
           "snapshots); --overwrite replaces it, --out DIR writes elsewhere" in err[0]
    with h5py.File(tmp_path / "o" / "run.h5", "r") as f:
        assert f.attrs["status"] == "stopped at max_steps = 2"
    assert main([*argv, "--overwrite"]) == 0
    with h5py.File(tmp_path / "o" / "run.h5", "r") as f:
        assert f.attrs["status"] == "completed"
