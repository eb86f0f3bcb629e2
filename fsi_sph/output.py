"""One HDF5 file per run (h5py), with an XDMF sidecar for ParaView.

Layout::

    /                       attrs: version, versions (JSON), git_sha, config (JSON), case_file,
                                   status ("running" | "completed" | "failed: ..."), created
    /bodies/<body>/static/<field>          reference fields, written once
    /snapshots/<k:06d>      attrs: t, step
    /snapshots/<k>/<body>/<field>          snapshot fields
    /probes/<name>          (n, 1 + ncol) float64, resizable; attrs columns
    /timing                 attrs: per-phase wall time (s), steps, particle_steps, loop_time_s
    /steps                  per-step records (t, dt, n_sub; with a fluid also ppe_iterations,
                            ppe_residual, ppe_assemble_s, ppe_setup_s, ppe_solve_s, ppe_rebuilt)
                            as a resizable table; attrs columns
    /restart                attrs: the clock (t, step, next_out, ...); /restart/<body>/<field>:
                            every array of every body at the latest snapshot (``--restart``)

A snapshot written after a failure from the last state that passed the guard has the attr
``last_good = 1``.

The file is opened, written and closed at every snapshot: between writes it is always a
complete, readable HDF5 file, and a run that fails records why in ``status`` and keeps every
snapshot written before the failure.
"""

from __future__ import annotations

import datetime
import json
import logging
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from fsi_sph.errors import UsageError

log = logging.getLogger(__name__)


def versions() -> dict:
    """Versions of Python and of the libraries the results depend on."""
    import numba
    import pyamg
    import scipy

    from fsi_sph.version import __version__

    return {"fsi_sph": __version__, "python": sys.version.split()[0], "numpy": np.__version__,
            "numba": numba.__version__, "scipy": scipy.__version__, "pyamg": pyamg.__version__,
            "h5py": h5py.__version__}


def git_sha() -> str:
    """The commit of the source tree, or "unknown" outside a git checkout."""
    try:
        here = Path(__file__).resolve().parent
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here,
                             capture_output=True, text=True, timeout=5)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _append_rows(group, name, rows, columns):
    rows = np.asarray(rows, dtype=np.float64)
    if name not in group:
        ds = group.create_dataset(name, shape=(0, rows.shape[1]), maxshape=(None, rows.shape[1]),
                                  dtype=np.float64, chunks=(1024, rows.shape[1]))
        ds.attrs["columns"] = json.dumps(list(columns))
    ds = group[name]
    n0 = ds.shape[0]
    ds.resize(n0 + len(rows), axis=0)
    ds[n0:] = rows


class RunWriter:
    """Writes a run to ``path`` (``.h5``) and its XDMF sidecar (``.xmf``)."""

    def __init__(self, path, config_json: str, case_file: str | None, static: dict,
                 step_columns=("t", "dt", "n_sub")):
        self.path = Path(path)
        self.step_columns = tuple(step_columns)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.xmf_path = self.path.with_suffix(".xmf")
        self.snapshots: list[tuple[str, float, dict]] = []  # (group, t, {body: {field: shape}})
        self.last_snapshot_t = -np.inf
        with h5py.File(self.path, "w") as f:
            f.attrs["version"] = versions()["fsi_sph"]
            f.attrs["versions"] = json.dumps(versions())
            f.attrs["git_sha"] = git_sha()
            f.attrs["config"] = config_json
            f.attrs["case_file"] = case_file or ""
            f.attrs["created"] = datetime.datetime.now().isoformat(timespec="seconds")
            f.attrs["status"] = "running"
            for body, fields in static.items():
                g = f.create_group(f"bodies/{body}/static")
                for k, v in fields.items():
                    g.create_dataset(k, data=v)
            f.create_group("snapshots")
            f.create_group("probes")
            f.create_group("timing")

    @classmethod
    def reopen(cls, path, t):
        """Continue writing an existing run file from time ``t`` (restart): snapshots, probe
        rows and step rows after ``t`` are dropped."""
        self = cls.__new__(cls)
        self.path = Path(path)
        self.xmf_path = self.path.with_suffix(".xmf")
        self.snapshots = []
        self.last_snapshot_t = -np.inf
        eps = 1e-12 * max(abs(t), 1.0)
        with h5py.File(self.path, "a") as f:
            self.step_columns = (tuple(json.loads(f["steps"].attrs["columns"])) if "steps" in f
                                 else ("t", "dt", "n_sub"))
            for name in sorted(f["snapshots"]):
                g = f["snapshots"][name]
                if g.attrs["t"] > t + eps:
                    del f["snapshots"][name]
                    if f"xdmf/snapshots/{name}" in f:  # (its 3-vectors: _write_xyz)
                        del f[f"xdmf/snapshots/{name}"]
                    continue
                _write_xyz(f, f"snapshots/{name}")  # a file written before they existed
                shapes = {b: {k: g[b][k].shape for k in g[b]} for b in g}
                self.snapshots.append((f"snapshots/{name}", float(g.attrs["t"]), shapes))
                self.last_snapshot_t = float(g.attrs["t"])
            tables = [f["probes"][k] for k in f["probes"]] + ([f["steps"]] if "steps" in f else [])
            for ds in tables:
                keep = int(np.searchsorted(ds[:, 0], t + eps, side="right"))
                ds.resize(keep, axis=0)
            f.attrs["status"] = "running"
        return self

    def write(self, t, step, bodies: dict, probes: dict, step_rows, timing: dict,
              status="running", restart=None, last_good=False):
        """Append a snapshot (``bodies``: {body: {field: array}}), the probe rows sampled
        since the last write, per-step rows and the timers, and replace the restart state
        (``restart = (clock, {body: {field: array}})``); then close the file."""
        with h5py.File(self.path, "a") as f:
            shapes = {}
            if bodies is not None:
                name = f"snapshots/{len(self.snapshots):06d}"
                while name in f:  # after a reopen the numbering goes on
                    name = f"snapshots/{int(name.rsplit('/', 1)[1]) + 1:06d}"
                g = f.create_group(name)
                g.attrs["t"] = t
                g.attrs["step"] = step
                if last_good:
                    g.attrs["last_good"] = 1
                self.last_snapshot_t = t
                for body, fields in bodies.items():
                    gb = g.create_group(body)
                    shapes[body] = {}
                    for k, v in fields.items():
                        gb.create_dataset(k, data=v)
                        shapes[body][k] = v.shape
                _write_xyz(f, name)
                self.snapshots.append((name, t, shapes))
            for pname, (columns, rows) in probes.items():
                if rows:
                    _append_rows(f["probes"], pname, rows, ("t", *columns))
            if len(step_rows):
                _append_rows(f, "steps", step_rows, self.step_columns)
            for k, v in timing.items():
                f["timing"].attrs[k] = v
            if restart is not None:
                _write_restart(f, *restart)
            f.attrs["status"] = status
        if bodies is not None:
            self._write_xdmf()

    def finish(self, status, timing: dict):
        with h5py.File(self.path, "a") as f:
            for k, v in timing.items():
                f["timing"].attrs[k] = v
            f.attrs["status"] = status

    def _write_xdmf(self):
        """Temporal collection of per-body point clouds; ParaView opens it with the Xdmf3 reader."""
        h5 = self.path.name
        parts = ['<?xml version="1.0" ?>', '<Xdmf Version="3.0">', "<Domain>",
                 '<Grid Name="run" GridType="Collection" CollectionType="Temporal">']
        for name, t, shapes in self.snapshots:
            parts.append(f'<Grid Name="{name}" GridType="Collection" CollectionType="Spatial">')
            parts.append(f'<Time Value="{t:.9g}"/>')
            for body, fields in shapes.items():
                n = fields["x"][0]
                parts.append(f'<Grid Name="{body}" GridType="Uniform">')
                parts.append(f'<Topology TopologyType="Polyvertex" NumberOfElements="{n}"/>')
                parts.append('<Geometry GeometryType="XY">')
                parts.append(f'<DataItem Dimensions="{n} 2" Format="HDF" NumberType="Float" '
                             f'Precision="8">{h5}:/{name}/{body}/x</DataItem></Geometry>')
                for field, shape in fields.items():
                    if len(shape) <= 2 and field != "x":  # x: the geometry; tensors: .h5 only
                        parts.append(_xdmf_attribute(field, shape, h5, name, body))
                parts.append("</Grid>")
            parts.append("</Grid>")
        parts += ["</Grid>", "</Domain>", "</Xdmf>", ""]
        tmp = self.xmf_path.with_suffix(".xmf.tmp")
        tmp.write_text("\n".join(parts))
        tmp.replace(self.xmf_path)


def _write_xyz(f, name):
    """The 2-vectors of snapshot ``name`` (but the positions) as 3-vectors ``(x, y, 0)`` in
    float32 under ``xdmf/<name>``, for the sidecar: ParaView's glyph and stream filters
    expect 3 components, and its Xdmf3 reader does not evaluate XDMF functions (tried:
    JOIN of two hyperslabs) nor, here, HDF5 virtual datasets."""
    for body, g in f[name].items():
        for k, ds in g.items():
            path = f"xdmf/{name}/{body}/{k}"
            if k == "x" or ds.ndim != 2 or ds.shape[1] != 2 or path in f:
                continue
            xyz = np.zeros((ds.shape[0], 3), dtype=np.float32)
            xyz[:, :2] = ds[()]
            f.create_dataset(path, data=xyz)


def _xdmf_attribute(field, shape, h5, name, body):
    """An XDMF attribute: a scalar of the snapshot, or its 2-vector as the sidecar's
    3-vector copy (:func:`_write_xyz`)."""
    n = shape[0]
    if len(shape) == 1:
        kind, dims, ref, size = "Scalar", f"{n}", f"{name}/{body}/{field}", 8
    else:
        kind, dims, ref, size = "Vector", f"{n} 3", f"xdmf/{name}/{body}/{field}", 4
    return (f'<Attribute Name="{field}" AttributeType="{kind}" Center="Node"><DataItem '
            f'Dimensions="{dims}" Format="HDF" NumberType="Float" Precision="{size}">'
            f'{h5}:/{ref}</DataItem></Attribute>')


def _write_restart(f, clock, state):
    if "restart" in f:
        del f["restart"]
    g = f.create_group("restart")
    for k, v in clock.items():
        g.attrs[k] = v
    for body, arrays in state.items():
        gb = g.create_group(body)
        for k, v in arrays.items():
            gb.create_dataset(k, data=v)


def read_restart(path):
    """(clock, {body: {field: array}}) of the latest restart state in a run file.

    Raises ``ValueError`` with a plain message when the file has none."""
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise ValueError(f"{path}: not a readable HDF5 run file ({e})") from None
    with f:
        if "restart" not in f:
            raise ValueError(f"{path}: has no restart state (written at every snapshot since "
                             "fsi_sph 0.1; the run wrote no snapshot)")
        g = f["restart"]
        clock = {k: g.attrs[k].item() for k in g.attrs}
        state = {b: {k: g[b][k][()] for k in g[b]} for b in g}
    return clock, state


def read_config(path) -> str:
    """The resolved config (JSON text) stored in a run file."""
    with h5py.File(path, "r") as f:
        return f.attrs["config"]


def read_probe(path, name):
    """(t, {column: values}) of a probe in a run file."""
    with h5py.File(path, "r") as f:
        ds = f["probes"][name]
        cols = json.loads(ds.attrs["columns"])
        data = ds[()]
    return data[:, 0], {c: data[:, k] for k, c in enumerate(cols) if k > 0}


def read_steps(path):
    """{column: values} of a run file's per-step table (``/steps``; empty without one)."""
    with h5py.File(path, "r") as f:
        if "steps" not in f:
            return {}
        cols = json.loads(f["steps"].attrs["columns"])
        data = f["steps"][()]
    return {c: data[:, k] for k, c in enumerate(cols)}


def refuse_overwrite(path):
    """Raise :class:`UsageError` when ``path`` already holds a run (its status and time in
    the message), so that a second run does not replace what a user computed."""
    path = Path(path)
    if not path.exists():
        return
    try:
        with h5py.File(path, "r") as f:
            status = f.attrs.get("status", "unknown")
            n = len(f["snapshots"]) if "snapshots" in f else 0
    except OSError:
        status, n = "not readable", 0
    raise UsageError(f"{path} already holds a run ({status}, {n} snapshots); --overwrite "
                     f"replaces it, --out DIR writes elsewhere")
