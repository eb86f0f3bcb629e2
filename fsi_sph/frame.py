"""A shaken scene: the frame (tank, walls and all bodies' coordinates) moves as
``X(t) = A sin(omega t) d`` (``case.shaking``); the bodies are computed in that frame, where
each particle feels the body force ``g - X''(t) = g + A omega^2 sin(omega t) d`` (d' Alembert's
inertial force; the frame does not rotate). A sloshing tank is the standard use. Not in
PHYSICS.md; tested against the analytic motion of a free body (tests/unit/test_frame.py)."""

from __future__ import annotations

import math

import numpy as np


class ShakenFrame:
    """The body force of the frame's motion at time ``t``."""

    def __init__(self, shaking, gravity):
        d = np.asarray(shaking.direction, dtype=np.float64)
        self.direction = d / float(np.hypot(*d))
        self.amplitude = float(shaking.amplitude)
        self.omega = 2.0 * math.pi * float(shaking.frequency)
        self.gravity = np.asarray(gravity, dtype=np.float64)

    def displacement(self, t: float) -> np.ndarray:
        return self.amplitude * math.sin(self.omega * t) * self.direction

    def body_force(self, t: float) -> np.ndarray:
        """``g - X''(t)`` per unit mass (m/s^2)."""
        inertial = self.amplitude * self.omega ** 2 * math.sin(self.omega * t)
        return self.gravity + inertial * self.direction

    def apply(self, t: float, bodies: dict) -> None:
        """Set ``g - X''(t)`` as the body force of every body (``set_gravity``)."""
        g = self.body_force(t)
        for body in bodies.values():
            body.set_gravity(g)

    def peak_body_force(self) -> float:
        """The largest ``|g - X''|`` over a period (bounds for the time step and guard)."""
        return float(np.hypot(*self.gravity)) + self.amplitude * self.omega ** 2


def frame_of(case):
    """The scene's shaken frame, or None when ``case.shaking`` is absent."""
    return ShakenFrame(case.shaking, case.gravity) if case.shaking is not None else None


def peak_gravity(frame, gravity):
    """The body force the guard bounds the energy with: the frame's largest, or gravity."""
    return (frame.peak_body_force(), 0.0) if frame is not None else gravity
