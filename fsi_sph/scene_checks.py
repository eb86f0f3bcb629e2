"""Checks of a scene before anything is built (``fsi-sph run`` and ``fsi-sph info``).

Every check reads the config alone (shapes, spacing, probes), allocates nothing per particle
and raises a :class:`ConfigError` naming the file, the key and what is allowed:

- the particle count and memory, estimated from the shapes, must fit in the machine's memory
  (``--force`` skips this one check);
- a fluid block must lie in a tank's column or above a wall box (else it falls forever);
- a fluid block may overlap a *coupled* solid (the fluid is carved around it when the scene
  is built, and the count is logged), not an uncoupled solid or a soil (the bodies would pass
  through each other);
- a solid or soil rectangle must be at least two particles across (one row makes the TLSPH
  correction matrix singular);
- a ``point_displacement`` probe must lie within two spacings of its body.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from fsi_sph.errors import ConfigError
from fsi_sph.geometry import in_shapes

#: memory of a scene: a fixed part (Python, numpy, numba and its compiled kernels) plus a
#: part per particle (arrays, neighbour lists, the pressure matrix and its AMG hierarchy);
#: peak resident memory of the default gate scene at dx 2.5 / 1.25 / 1 / 0.7 mm (3.6k to 35k
#: particles with the walls): 200-280 MB, 2.5 kB per particle, 390 MB when numba compiles;
#: 4 kB leaves room for the implicit viscous step's operators and for the run's growth
BASE_BYTES = 400e6
BYTES_PER_PARTICLE = 4e3
#: a probe's point may lie this many spacings from its body's shapes
PROBE_REACH = 2.0


@dataclass
class SceneEstimate:
    """Particles per body (estimated from the shapes, before the scene is built) and the
    memory they need."""

    particles: dict[str, int]
    dx: float

    @property
    def total(self) -> int:
        return sum(self.particles.values())

    @property
    def memory(self) -> float:
        """Bytes."""
        return BASE_BYTES + BYTES_PER_PARTICLE * self.total


def check_scene(cfg, label, force=False) -> SceneEstimate:
    """Run every check on ``cfg`` (read from ``label``); returns the estimate."""
    check_fluid_held(cfg, label)
    check_overlaps(cfg, label)
    check_thickness(cfg, label)
    check_probes(cfg, label)
    est = estimate(cfg, cfg.case.dx)
    if not force:
        check_memory(cfg, est, label)
    return est


# ---------------------------------------------------------------------- shapes
def _kind(shape):
    return getattr(shape, "shape", "rectangle")


def _bounds(shape):
    """(x_min, y_min, x_max, y_max) of a rectangle, polygon or circle."""
    if _kind(shape) == "polygon":
        v = np.asarray(shape.vertices)
        return (*v.min(axis=0), *v.max(axis=0))
    if _kind(shape) == "circle":
        (x, y), r = shape.centre, shape.radius
        return x - r, y - r, x + r, y + r
    (x, y), (w, h) = shape.origin, shape.size
    return x, y, x + w, y + h


def _area(shape):
    if _kind(shape) == "circle":
        return math.pi * shape.radius**2
    if _kind(shape) == "polygon":
        v = np.asarray(shape.vertices)
        return 0.5 * abs(float(np.dot(v[:, 0], np.roll(v[:, 1], -1))
                               - np.dot(v[:, 1], np.roll(v[:, 0], -1))))
    return shape.size[0] * shape.size[1]


def _count(shape, dx):
    """Particles of a shape's lattice fill (exact for a rectangle)."""
    if _kind(shape) != "rectangle":
        return _area(shape) / dx**2
    return round(shape.size[0] / dx) * round(shape.size[1] / dx)


def _overlap(a, b, samples=64):
    """Area (m^2) common to two shapes: exact for rectangles, sampled for polygons and
    circles."""
    ax0, ay0, ax1, ay1 = _bounds(a)
    bx0, by0, bx1, by1 = _bounds(b)
    x0, y0, x1, y1 = max(ax0, bx0), max(ay0, by0), min(ax1, bx1), min(ay1, by1)
    if x1 <= x0 or y1 <= y0:
        return 0.0
    if _kind(a) == _kind(b) == "rectangle":
        return (x1 - x0) * (y1 - y0)
    s = (np.arange(samples) + 0.5) / samples
    gx, gy = np.meshgrid(x0 + s * (x1 - x0), y0 + s * (y1 - y0))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    inside = in_shapes(pts, [a]) & in_shapes(pts, [b])
    return float(np.mean(inside)) * (x1 - x0) * (y1 - y0)


def distance_to_shape(point, shape):
    """Distance (m) from a point to a shape (0 inside)."""
    p = np.asarray(point, dtype=np.float64)
    if in_shapes(p[None, :], [shape])[0]:
        return 0.0
    if _kind(shape) == "circle":
        return max(math.hypot(p[0] - shape.centre[0], p[1] - shape.centre[1]) - shape.radius,
                   0.0)
    if _kind(shape) != "polygon":
        x0, y0, x1, y1 = _bounds(shape)
        return math.hypot(max(x0 - p[0], 0.0, p[0] - x1), max(y0 - p[1], 0.0, p[1] - y1))
    v = np.asarray(shape.vertices, dtype=np.float64)
    e = np.roll(v, -1, axis=0) - v
    t = np.clip(np.einsum("ij,ij->i", p - v, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    return float(np.min(np.hypot(*(v + t[:, None] * e - p).T)))


def _describe(shape):
    x0, y0, x1, y1 = _bounds(shape)
    return f"x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m"


# ---------------------------------------------------------------------- estimate
def _tank_count(tank, layers, dx):
    floor = round((tank.size[0] + 2 * layers * dx) / dx) * layers
    return floor + 2 * layers * round(tank.size[1] / dx)


def estimate(cfg, dx) -> SceneEstimate:
    """Particles per body at spacing ``dx``, from the shapes (nothing allocated)."""
    counts = {}
    for name, sec in {**cfg.solid, **cfg.soil}.items():
        counts[name] = sum(_count(s, dx) for s in sec.blocks)
    if cfg.fluid is not None:
        holes = [s for n in (cfg.coupling.structures if cfg.coupling else ())
                 for s in cfg.solid[n].blocks]
        if cfg.walls is not None:
            holes += list(cfg.walls.boxes)
            counts["walls"] = (sum(_tank_count(t, cfg.walls.layers, dx) for t in cfg.walls.tanks)
                               + sum(_count(s, dx) for s in cfg.walls.boxes))
        cut = sum(_overlap(b, s) for b in cfg.fluid.blocks for s in holes) / dx**2
        counts["fluid"] = max(sum(_count(s, dx) for s in cfg.fluid.blocks) - cut, 0.0)
    return SceneEstimate({k: int(round(v)) for k, v in counts.items()}, dx)


def machine_memory() -> float:
    """Physical memory of the machine (bytes)."""
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def _round_up(x):
    """``x`` rounded up to two significant digits."""
    unit = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / unit - 1e-9) * unit


def fitting_dx(cfg, limit):
    """The smallest spacing (two significant digits) whose scene fits in ``limit`` bytes;
    None when none does."""
    per = (limit - BASE_BYTES) / BYTES_PER_PARTICLE
    if per < 1.0:
        return None
    dx = _round_up(cfg.case.dx * math.sqrt(max(estimate(cfg, cfg.case.dx).total / per, 1.0)))
    for _ in range(100):
        if estimate(cfg, dx).memory <= limit:
            return dx
        dx = _round_up(dx * 1.05)
    return None


def size_text(n_bytes):
    """A memory size in readable units: ``'1.2 GiB'``, ``'5.4 PiB'``."""
    for unit in ("KiB", "MiB", "GiB", "TiB", "PiB"):
        n_bytes /= 1024.0
        if n_bytes < 1024.0 or unit == "PiB":
            return f"{n_bytes:.3g} {unit}"


def check_memory(cfg, est, label, limit=None):
    """Refuse a scene whose memory estimate exceeds ``limit`` (the machine's memory)."""
    limit = machine_memory() if limit is None else limit
    if est.memory <= limit:
        return
    dx = fitting_dx(cfg, limit)
    fix = (f"case.dx = {dx:g} m would fit (--set case.dx=...)" if dx is not None else
           f"no case.dx fits (the program alone needs about {size_text(BASE_BYTES)})")
    raise ConfigError(
        f"{label}: case.dx = {cfg.case.dx:g} m makes about {est.total:.3g} particles, "
        f"which need about {size_text(est.memory)} of memory; this machine has "
        f"{size_text(limit)}.\n  {fix}; --force runs it anyway")


# ---------------------------------------------------------------------- geometry checks
def _held(block, walls):
    """Whether a fluid block lies in a tank's open column or above a wall box."""
    x0, y0, x1, _ = _bounds(block)
    for t in walls.tanks:
        tx0, ty0, tx1, _ = _bounds(t)
        if x0 < tx1 and x1 > tx0 and y0 >= ty0 - 1e-12:
            return True
    for b in walls.boxes:
        bx0, _, bx1, by1 = _bounds(b)
        if x0 < bx1 and x1 > bx0 and y0 >= by1 - 1e-12:
            return True
    return False


def check_fluid_held(cfg, label):
    """A fluid block outside every tank (and above no wall box) falls forever."""
    if cfg.fluid is None or cfg.walls is None or not cfg.walls.tanks:
        return
    if cfg.case.gravity[1] >= 0.0:
        return
    for k, block in enumerate(cfg.fluid.blocks):
        if not _held(block, cfg.walls):
            tanks = "; ".join(f"walls.tanks[{i}] {_describe(t)}"
                              for i, t in enumerate(cfg.walls.tanks))
            raise ConfigError(
                f"{label}: fluid.blocks[{k}] ({_describe(block)}) lies outside every tank "
                f"and above no wall box: it would fall forever.\n  Tanks: {tanks}; move the "
                f"block into one, or add a tank or box under it")


def check_overlaps(cfg, label):
    """Fluid over a coupled solid is carved when built; over anything else, refused."""
    if cfg.fluid is None:
        return
    coupled = {f"solid.{n}" for n in (cfg.coupling.structures if cfg.coupling else ())}
    for k, block in enumerate(cfg.fluid.blocks):
        for name, j, shape in _structure_blocks(cfg):
            area = _overlap(block, shape) if name not in coupled else 0.0
            if area > 0.0:
                fix = ("list it in coupling.structures (the fluid is then carved around it), "
                       "or move" if name.startswith("solid.") else "move")
                raise ConfigError(
                    f"{label}: fluid.blocks[{k}] overlaps {name}.blocks[{j}] ({area:.3g} m^2), "
                    f"and {name} is not coupled to the fluid: they would pass through each "
                    f"other.\n  Allowed: fluid over a coupled solid; {fix} one of the two")


def _structure_blocks(cfg):
    """(``solid.NAME`` or ``soil.NAME``, index, shape) of every solid and soil block."""
    for kind, bodies in (("solid", cfg.solid), ("soil", cfg.soil)):
        for name, sec in bodies.items():
            for j, shape in enumerate(sec.blocks):
                yield f"{kind}.{name}", j, shape


def check_thickness(cfg, label):
    """A solid or soil rectangle one particle across makes a singular correction matrix."""
    dx = cfg.case.dx
    for name, j, s in _structure_blocks(cfg):
        if _kind(s) == "polygon":
            continue
        thin = min(s.size)
        if round(thin / dx) < 2:
            raise ConfigError(
                f"{label}: {name}.blocks[{j}] is {thin:g} m thin, {round(thin / dx)} "
                f"particle(s) across at case.dx = {dx:g} m; allowed: at least 2 (one row has "
                f"no stiffness across it).\n  Use case.dx <= {thin / 2:g} m")


def check_probes(cfg, label):
    """A point_displacement probe farther than PROBE_REACH spacings from its body."""
    dx = cfg.case.dx
    bodies = {**cfg.solid, **cfg.soil}
    for k, p in enumerate(cfg.probes):
        if p.kind != "point_displacement" or p.body not in bodies:
            continue
        d = min(distance_to_shape(p.at, s) for s in bodies[p.body].blocks)
        if d > PROBE_REACH * dx:
            raise ConfigError(
                f"{label}: probes[{k}] ({p.name}) at = [{p.at[0]:g}, {p.at[1]:g}] is {d:.3g} m "
                f"({d / dx:.0f} spacings) from body {p.body}; allowed: within "
                f"{PROBE_REACH:g} spacings ({PROBE_REACH * dx:.3g} m) of its blocks")
