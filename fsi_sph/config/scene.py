"""The scene's common tables: ``[case]``, ``[sph]``, ``[guard]`` and the block shapes that
fill bodies with particles."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from fsi_sph.config.base import NonNegative, Positive, StrictModel, Vec2


class Shape(StrictModel):
    """An axis-aligned rectangle ``origin + [0, size]`` (m)."""

    shape: Literal["rectangle"] = Field("rectangle", description="primitive kind")
    origin: Vec2 = Field(description="lower-left corner (m)")
    size: tuple[Positive, Positive] = Field(description="width and height (m), > 0")


class Polygon(StrictModel):
    """A simple polygon given by its vertices (m), in order; closed automatically."""

    shape: Literal["polygon"] = Field(description="primitive kind")
    vertices: Annotated[list[Vec2], Field(min_length=3)] = Field(
        description="corner points [x, y] (m), at least 3, in order around the polygon")


class Circle(StrictModel):
    """A disk of radius ``radius`` about ``centre`` (m), filled with concentric rings of
    particles (fsi_sph/geometry.py ``fill_circle``), so that its surface is round."""

    shape: Literal["circle"] = Field(description="primitive kind")
    centre: Vec2 = Field(description="centre [x, y] (m)")
    radius: Positive = Field(description="radius (m)")


SoilShape = Annotated[Shape | Polygon, Field(union_mode="left_to_right")]
BodyShape = Annotated[Shape | Polygon | Circle, Field(union_mode="left_to_right")]
#: a rectangle or a polygon: the shapes that fill a fluid, solid or soil body (wall boxes take
#: circles too, BodyShape)
BlockShape = SoilShape


class Shaking(StrictModel):
    """The scene's frame (tank, walls and everything in it) moved as
    ``X(t) = amplitude sin(2 pi frequency t) direction``; the bodies are computed in that
    frame, where the body force is ``g - X''(t)`` (fsi_sph/frame.py)."""

    amplitude: Positive = Field(description="displacement amplitude of the frame (m)")
    frequency: Positive = Field(description="frequency (Hz)")
    direction: Vec2 = Field((1.0, 0.0), description="direction of the motion (normalised)")

    @model_validator(mode="after")
    def _direction(self):
        if not math.hypot(*self.direction) > 0.0:
            raise ValueError(f"direction = {list(self.direction)}: must not be zero")
        return self


class CaseSection(StrictModel):
    """Run control: duration, resolution, output cadence, gravity."""

    name: str = Field("case", description="case name, used for output folders")
    t_end: Positive = Field(description="simulated time (s)")
    dx: Positive = Field(description="initial particle spacing for all bodies (m)")
    output_every: Positive = Field(0.01, description="snapshot interval (s)")
    probe_every: NonNegative = Field(0.0, description="probe sampling interval (s); 0 = every step")
    gravity: Vec2 = Field((0.0, -9.81), description="body force per unit mass (m/s^2)")
    shaking: Shaking | None = Field(None, description="absent: the frame is at rest")


class SphSection(StrictModel):
    """Shared SPH numerics."""

    kernel: Literal["cubic_spline", "wendland_c2"] = Field(
        "cubic_spline", description="smoothing kernel [F 5]; support 2h for both")
    h_over_dx: Annotated[float, Field(ge=1.0, le=2.0)] = Field(
        1.2, description="smoothing length over particle spacing")


class GuardSection(StrictModel):
    """Blow-up guard: checks that stop a run gone bad (see fsi_sph/guard.py)."""

    check_every: Annotated[int, Field(ge=1)] = Field(
        10, description="check every N steps (and before every snapshot)")
    domain: Shape | None = Field(
        None, description="particles must stay inside; default: the initial bounding box of "
        "the bodies and walls grown by 3 times its size on every side")
    energy_factor: Annotated[float, Field(gt=1.0)] = Field(
        10.0, description="stop when the kinetic energy exceeds this times the initial "
        "kinetic + strain energy plus the work gravity can do across the domain")
