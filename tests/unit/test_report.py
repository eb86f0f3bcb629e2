"""The validation report: a table and an error-vs-wall-time plot per case, marks, failures."""

from fsi_sph.__main__ import main
from validation.common import make_record
from validation.report import load_results, write_report


def _result():
    recs = [make_record(lab, dx, {"n_particles": n, "steps": 10 * n, "wall_time_s": t,
                                  "particle_steps_per_s": 1e6},
                        {"period_pct": e, "amplitude_pct": -e / 2},
                        {"note": 1.5, "history_t_s": [0.0, 0.1], "table": {"a": 1}})
            for lab, dx, n, t, e in [("coarse", 0.004, 300, 2.0, 4.0),
                                     ("fine", 0.002, 1200, 16.0, 1.0)]]
    return {"case": "demo", "reference": "analytic", "records": recs,
            "marks": {"source paper": {"period_pct": 2.36}},
            "machine": {"platform": "test-os", "cpus": 2, "numba_threads": 2, "git_sha": "abc",
                        "versions": {"numpy": "1"}}}


def test_write_report(tmp_path):
    path = write_report({"demo": _result()}, tmp_path / "REPORT.md", tmp_path / "fig",
                        failures={"broken": "RuntimeError: no data"})
    text = path.read_text()
    assert "## demo" in text and "| coarse | 0.004 | 300 | 3000 | 2.0 |" in text
    assert "+4.000" in text and "-0.500" in text
    # the published model beside our ladder, in the table (its own row) and on the plot
    assert "| *source paper* |" in text and "*+2.360*" in text
    # single values in the text; histories and tables stay in result.json
    assert "note = 1.5" in text and "history_t_s" not in text and "table = " not in text
    assert "![demo](fig/demo.png)" in text and (tmp_path / "fig" / "demo.png").stat().st_size
    assert "test-os" in text and "numpy 1" in text
    assert "## broken" in text and "no data" in text


def test_load_results(tmp_path):
    import json

    (tmp_path / "demo").mkdir()
    (tmp_path / "demo" / "result.json").write_text(json.dumps(_result()))
    assert list(load_results(tmp_path)) == ["demo"]


def test_validate_usage(capsys):
    assert main(["validate"]) == 2
    assert main(["validate", "oscillating_plate", "--all"]) == 2
    assert "available" in capsys.readouterr().err


def test_report_only_rewrites_from_stored_results(tmp_path, monkeypatch):
    import json

    import validation.report as report

    (tmp_path / "demo").mkdir()
    res = _result()
    res["machine"]["load_average_1min"] = 3.5
    (tmp_path / "demo" / "result.json").write_text(json.dumps(res))
    written = {}
    real = report.write_report

    def to_tmp(results, **kw):
        written["path"] = real(results, path=tmp_path / "REPORT.md", fig_dir=tmp_path / "f", **kw)
        return written["path"]

    monkeypatch.setattr(report, "write_report", to_tmp)
    assert main(["validate", "--report", "--out", str(tmp_path)]) == 0
    text = written["path"].read_text()
    assert "## demo" in text and "load average 3.5" in text
    assert "No stored result yet" in text  # every other validation is listed as missing
    assert main(["validate", "--report", "--out", str(tmp_path / "empty")]) == 2


def test_load_results_takes_a_folder_s_record_file(tmp_path):
    import json

    (tmp_path / "soil").mkdir()
    (tmp_path / "soil" / "slope.json").write_text(json.dumps(_result()))
    (tmp_path / "soil" / "other.json").write_text(json.dumps({"not": "a record"}))
    (tmp_path / "empty").mkdir()
    assert list(load_results(tmp_path)) == ["soil"]


def test_plot_skips_errors_a_record_lacks(tmp_path):
    from fsi_sph.plotting import error_vs_time

    recs = _result()["records"]
    recs[1]["errors"] = {"other_pct": 2.0}
    assert error_vs_time(recs, ["period_pct", "other_pct"], "t", tmp_path / "p.png").exists()


def test_dam_break_disagreement_floor():
    """Two data sets 10 % apart at one time: no curve is within 100 * 1/21 % of both there."""
    import numpy as np

    from validation.dam_break import disagreement_floor

    T = np.array([0.5, 1.0, 1.5])
    data = {"koshizuka": (T, np.array([1.1, 2.2, 3.0])),
            "martin_moyce": (T, np.array([1.0, 2.0, 3.0]))}
    assert abs(disagreement_floor(data) - 100 * 0.1 / 2.1) < 1e-9
