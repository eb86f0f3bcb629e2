"""One picture of a run's snapshot: every body in its natural field on the whole domain.

By default the fluid is coloured by its pressure, elastic solids by the von Mises stress, soils
by the accumulated plastic strain; walls are grey (rigid bodies dark grey). Each field has its
colour bar and one colour scale over every snapshot drawn. ``field`` colours every body that
has that field by it (one bar) and the others grey. The axes hold the whole domain (every
particle of every snapshot drawn but a few splashed ones) at equal aspect, and the figure is
sized to it.
:class:`SceneFigure` draws snapshot after snapshot on one figure (PNGs and movie frames).
"""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from fsi_sph.errors import UsageError  # noqa: E402

#: body kind -> (field, colour bar label, colour map, part of the map used)
NATURAL = {
    "fluid": ("p", "fluid pressure p (Pa)", "Blues", (0.3, 1.0)),
    "elastic": ("von_mises", "von Mises stress (Pa)", "inferno", (0.0, 0.85)),
    "soil": ("eps_p", "accumulated plastic strain", "YlOrBr", (0.2, 1.0)),
}
GREY = {"walls": "0.62", "rigid": "0.3"}
WIDTH = 9.0  # in: figure width (less for a tall domain)
MAX_AXES_HEIGHT = 6.0  # in
DPI = 100
SPLASH = 0.001  # fraction of a body's particles that may lie outside the picture
MARGIN = {"left": 0.75, "right": 0.25, "top": 0.4, "bottom": 0.55, "bars": 0.55, "gap": 0.12}


def body_kinds(config_json) -> dict:
    """{body name: 'fluid' | 'walls' | 'elastic' | 'rigid' | 'soil'} from a run's config."""
    cfg = json.loads(config_json)
    kinds = {"fluid": "fluid", "walls": "walls"}
    for name, sec in (cfg.get("solid") or {}).items():
        kinds[name] = "rigid" if sec["material"]["model"] == "rigid" else "elastic"
    kinds.update({name: "soil" for name in (cfg.get("soil") or {})})
    return kinds


def _truncated(name, part):
    return ListedColormap(plt.get_cmap(name)(np.linspace(*part, 256)))


def _scalar(values):
    """A per-particle scalar from a field: vectors -> magnitude, tensors -> Frobenius norm."""
    v = np.asarray(values)
    if v.ndim == 1:
        return v
    return np.sqrt(np.sum(v.reshape(len(v), -1) ** 2, axis=1))


class SceneFigure:
    """A figure for the snapshots ``groups`` (h5py groups) of a run file ``f``."""

    def __init__(self, f, groups, field=None):
        self.groups = groups
        self.kinds = body_kinds(f.attrs["config"])
        self.dx = json.loads(f.attrs["config"])["case"]["dx"]
        self.field = field
        bodies = list(groups[0])
        self.style = {b: self._style(b, groups[0][b]) for b in bodies}
        if field is not None and not any(s[0] for s in self.style.values()):
            have = sorted({k for g in groups[0].values() for k in g})
            raise UsageError(f"--field {field}: not in this run; available: {', '.join(have)}")
        self.limits = self._limits()
        self._layout()
        self.artists = {}

    def _style(self, body, group):
        """(field or None, colour bar label, colour map or grey) of one body."""
        kind = self.kinds.get(body, "elastic")
        if self.field is not None:
            if self.field in group:
                return self.field, self.field, plt.get_cmap("viridis")
            return None, None, GREY.get(kind, "0.75")
        if kind in NATURAL and NATURAL[kind][0] in group:
            name, label, cmap, part = NATURAL[kind]
            return name, label, _truncated(cmap, part)
        return None, None, GREY.get(kind, "0.75")

    def _limits(self):
        """{field: (lo, hi)} over every snapshot drawn (0.5 and 99.5 percentiles)."""
        lo, hi = {}, {}
        for g in self.groups:
            for body, (name, _, _) in self.style.items():
                if name is None or body not in g:
                    continue
                s = _scalar(g[body][name][()])
                a, b = np.percentile(s, [0.5, 99.5]) if len(s) else (0.0, 0.0)
                lo[name], hi[name] = min(lo.get(name, a), a), max(hi.get(name, b), b)
        return {k: (lo[k], hi[k] if hi[k] > lo[k] else lo[k] + 1.0) for k in lo}

    def _extent(self):
        """The first snapshot's bounding box grown to hold the later snapshots' particles,
        but for the farthest 0.1 % of each body's (a few splashed particles do not leave the
        picture empty), padded by a spacing."""
        lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
        for k, g in enumerate(self.groups):
            for body in g.values():
                x = body["x"][()]
                if len(x):
                    q = [0.0, 1.0] if k == 0 else [SPLASH, 1.0 - SPLASH]
                    a, b = np.quantile(x, q, axis=0, method="nearest")
                    lo, hi = np.minimum(lo, a), np.maximum(hi, b)
        return lo - self.dx, hi + self.dx

    def _layout(self):
        """Figure and axes sized to the domain's aspect; a row of colour bars below."""
        lo, hi = self._extent()
        span = np.maximum(hi - lo, 1e-12)
        m = MARGIN
        aw = WIDTH - m["left"] - m["right"]
        ah = aw * span[1] / span[0]
        if ah > MAX_AXES_HEIGHT:
            ah = MAX_AXES_HEIGHT
            aw = ah * span[0] / span[1]
        bars = [k for k in dict.fromkeys(s[0] for s in self.style.values()) if k is not None]
        below = m["bottom"] + (m["bars"] + m["gap"] if bars else 0.0)
        w = _even(aw + m["left"] + m["right"])
        h = _even(ah + m["top"] + below)
        self.fig = plt.figure(figsize=(w, h), dpi=DPI)
        self.ax = self.fig.add_axes((m["left"] / w, below / h, aw / w, ah / h))
        self.ax.set_xlim(lo[0], hi[0])
        self.ax.set_ylim(lo[1], hi[1])
        self.ax.set_aspect("equal")
        self.ax.set_xlabel("x (m)")
        self.ax.set_ylabel("y (m)")
        # a particle's square, in pt^2, 15 % wider than the spacing: no hairline gaps
        self.marker = (1.15 * self.dx * aw * 72.0 / span[0]) ** 2
        self.bar_axes = {}
        bw = (aw - 0.6 * (len(bars) - 1)) / max(len(bars), 1)
        for k, name in enumerate(bars):
            x0 = m["left"] + k * (bw + 0.6)
            self.bar_axes[name] = self.fig.add_axes((x0 / w, m["bars"] / h, bw / w, 0.12 / h))
        self.title = self.ax.set_title("")

    def draw(self, group, title):
        """Draw one snapshot (an h5py group) with ``title``."""
        for z, body in enumerate(sorted(group, key=lambda b: _order(self.kinds.get(b)))):
            name, label, color = self.style.get(body, (None, None, "0.75"))
            x = group[body]["x"][()]
            art = self.artists.get(body)
            if art is None:
                art = self._first(body, x, name, label, color, z)
            art.set_offsets(x)
            if name is not None:
                art.set_array(_scalar(group[body][name][()]))
        self.title.set_text(title)

    def _first(self, body, x, name, label, color, z):
        kw = {"s": self.marker, "marker": "s", "linewidths": 0, "zorder": z}
        if name is None:
            art = self.ax.scatter(x[:, 0], x[:, 1], c=color, **kw)
        else:
            lo, hi = self.limits[name]
            art = self.ax.scatter(x[:, 0], x[:, 1], c=np.zeros(len(x)), cmap=color, vmin=lo,
                                  vmax=hi, **kw)
            cax = self.bar_axes.pop(name, None)
            if cax is not None:  # the first body with this field draws its bar
                self.fig.colorbar(art, cax=cax, orientation="horizontal", label=label,
                                  extend="both")
        self.artists[body] = art
        return art

    def close(self):
        plt.close(self.fig)


def _order(kind):
    """Walls under the fluid under the structures."""
    return {"walls": 0, "fluid": 1}.get(kind, 2)


def _even(inches):
    """A size whose pixel count at DPI is even (video encoders need it)."""
    return 2.0 * np.ceil(inches * DPI / 2.0) / DPI


def open_run(path):
    """An fsi_sph run file opened for reading and its snapshot groups, in time order; bad
    input is a :class:`UsageError`."""
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise UsageError(f"{path}: not a readable HDF5 run file ({e})") from None
    if "snapshots" not in f or "config" not in f.attrs:
        f.close()
        raise UsageError(f"{path}: not an fsi_sph run file (no /snapshots)")
    groups = [f["snapshots"][k] for k in sorted(f["snapshots"])]
    if not groups:
        f.close()
        raise UsageError(f"{path}: the run has no snapshot")
    return f, groups


def time_stamp(group, name):
    return f"{name}   t = {group.attrs['t']:.3f} s"
