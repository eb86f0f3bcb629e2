"""The scaling benchmark's bookkeeping (validation/benchmark_scaling.py): the array breakdown
counts each array once, by the path it is first reached by; the report's table reads the
stored JSON."""

import json

import numpy as np

from validation.benchmark_scaling import array_breakdown
from validation.report import scaling_section


class Part:  # a stand-in for the simulation's objects (module name decides what is walked)
    __module__ = "fsi_sph.fake"

    def __init__(self, **kw):
        self.__dict__.update(kw)


def test_array_breakdown_counts_an_array_once_and_views_as_their_base():
    a = np.zeros(100)  # 800 B
    b = np.zeros((10, 10), dtype=np.int32)  # 400 B
    root = Part(fluid=Part(body=Part(x=a, view=a[:10]), lists=b), other=Part(again=a))
    out = array_breakdown(root)
    assert out == {"fluid.body.x": 800, "fluid.lists": 400}


def test_scaling_section_tabulates_each_size(tmp_path):
    row = {"n_fluid": 1000, "s_per_step": 0.01, "particle_steps_per_s": 1e5,
           "peak_rss_bytes": 2e8, "rss_per_particle_kB": 200.0,
           "phases_s_per_step": {k: 0.001 for k in (
               "neighbours", "free_surface", "shift", "predict", "ppe_assemble", "ppe_setup",
               "ppe_solve", "correct", "other")}}
    path = tmp_path / "bench.json"
    path.write_text(json.dumps({"threads": 2, "machine": "cpu, 2 cores", "date": "2026-12-06",
                                "load_average": [[0.5, 0, 0], [1.0, 0, 0]],
                                "rows": {"1k": row, "4k": row}}))
    lines = scaling_section(path)
    rows = [r for r in lines if r.startswith("| 1k") or r.startswith("| 4k")]
    assert len(rows) == 2
    assert rows[0].split("|")[2].strip() == "1000"
    assert scaling_section(tmp_path / "absent.json") == []
