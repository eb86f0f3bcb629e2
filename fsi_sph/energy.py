"""The mechanical energy of a whole scene: kinetic, gravitational potential and stored
elastic (strain and hourglass-penalty) energy of every moving body, J per metre of depth.

In a closed scene (fixed walls, constant gravity, no inflow) gravity does no net work and
every dissipative term (viscosity, plasticity, artificial viscosity, collisions) only takes
energy away, so the total may never rise above its initial value by more than the scheme's
error: the scene zoo's bound (validation/scene_zoo.py).

The potential energy is measured from a datum, ``-m g . (x - x_datum)``; :class:`SceneEnergy`
takes the lowest initial particle along gravity as the datum, so the initial total is the
energy the scene can release, and a drift in per cent of it does not depend on where the
origin of the coordinates lies. Definitions, not in PHYSICS.md; tested against a hand sum and
the free fall of an elastic block (tests/unit/test_energy.py).
"""

from __future__ import annotations

import numpy as np


def body_energy(obj, gravity, datum) -> dict:
    """Kinetic, potential (from ``datum``, a point) and stored elastic energy of one body."""
    b = obj.body
    g = np.asarray(gravity, dtype=np.float64)
    kinetic = 0.5 * float(np.sum(b["m"] * np.einsum("ij,ij->i", b["v"], b["v"])))
    potential = -float(np.sum(b["m"] * ((b["x"] - np.asarray(datum)) @ g)))
    stored = 0.0
    if hasattr(obj, "strain_energy"):
        stored += obj.strain_energy()
    if hasattr(obj, "hourglass_energy"):
        stored += obj.hourglass_energy()
    return {"kinetic": kinetic, "potential": potential, "stored": stored}


class SceneEnergy:
    """The energy of a simulation's bodies over a run, from the datum at its start.

    ``sample(sim)`` returns the totals ``kinetic, potential, stored, total``;
    ``drift_pct(sim)`` the rise of the total above its initial value in per cent of that
    initial value (negative: energy dissipated)."""

    def __init__(self, sim):
        self.gravity = np.asarray(sim.cfg.case.gravity, dtype=np.float64)
        bodies = sim.bodies()
        x = np.concatenate([o.body["x"] for o in bodies.values()])
        g_norm = float(np.hypot(*self.gravity))
        down = self.gravity / g_norm if g_norm > 0.0 else np.array([0.0, -1.0])
        self.datum = x[int(np.argmax(x @ down))].copy()   # the lowest particle
        self.initial = self.sample(sim)["total"]

    def sample(self, sim) -> dict:
        out = {"kinetic": 0.0, "potential": 0.0, "stored": 0.0}
        for obj in sim.bodies().values():
            for k, v in body_energy(obj, self.gravity, self.datum).items():
                out[k] += v
        out["total"] = out["kinetic"] + out["potential"] + out["stored"]
        return out

    def drift_pct(self, sim) -> float:
        total = self.sample(sim)["total"]
        return 100.0 * (total - self.initial) / max(abs(self.initial), 1e-300)
