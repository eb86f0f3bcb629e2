"""Reference curves a case names for its probes (``[[probes]] reference = [...]``), read from
the reference-data folder (``../shared/validation_data`` beside the repository by default)."""

from __future__ import annotations

import json
import logging
import re
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)


def read_curve(path, value_column=1):
    """(t, value) columns of a text table (comma, tab or space separated; lines that are not
    all numbers, such as headers, are skipped)."""
    rows = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        parts = [p for p in re.split(r"[,;\s]+", line.strip()) if p]
        try:
            rows.append([float(p) for p in parts])
        except ValueError:
            continue
    d = np.array([r for r in rows if len(r) > value_column])
    if not len(d):
        raise ValueError(f"{path}: no row with {value_column + 1} numbers")
    return d[:, 0], d[:, value_column]


def probe_references(config_json, data_dir) -> dict:
    """{probe name: [{column, label, t, value}]} of the references the run's case names that
    ``data_dir`` holds (a missing file is logged and left out)."""
    out = {}
    for probe in json.loads(config_json).get("probes", []):
        for ref in probe.get("reference") or []:
            path = Path(data_dir or ".") / ref["file"]
            try:
                t, v = read_curve(path, ref["value_column"])
            except (OSError, ValueError) as e:
                log.warning("probe %s: reference %s not drawn (%s)", probe["name"], path, e)
                continue
            if ref["subtract_first"]:
                v = v - v[0]
            out.setdefault(probe["name"], []).append(
                {"column": ref["column"], "label": ref["label"], "t": t, "value": v})
    return out
