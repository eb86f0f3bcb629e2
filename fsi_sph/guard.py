"""Blow-up guard: stop a run that has gone bad, say exactly where, keep the last good state.

Checked every ``guard.check_every`` steps (and before every snapshot):

- a position or velocity that is NaN or infinite;
- a particle outside the domain (``guard.domain``, by default the initial bounding box of all
  bodies and fixed walls grown by 3 times its size on every side);
- total kinetic energy above ``guard.energy_factor`` times the energy the scene can release:
  initial kinetic + strain energy + the work gravity can do across the domain height.

A failed check raises :class:`SimulationError` naming time, step, body, particle and quantity.
"""

from __future__ import annotations

import math

import numpy as np

from fsi_sph.errors import SimulationError


def _energy(obj):
    b = obj.body
    ke = 0.5 * float(np.sum(b["m"] * np.einsum("ij,ij->i", b["v"], b["v"])))
    se = obj.strain_energy() if hasattr(obj, "strain_energy") else 0.0
    return ke, se


class Guard:
    """Checks on the physics objects of a simulation (each has ``.body``: x, v, m)."""

    def __init__(self, cfg, bodies: dict, gravity, fixed_points=()):
        self.cfg = cfg
        xs = [o.body["x"] for o in bodies.values() if o.body.n]
        xs += [x for x in fixed_points if len(x)]  # walls bound the scene too
        lo = np.min([x.min(axis=0) for x in xs], axis=0)
        hi = np.max([x.max(axis=0) for x in xs], axis=0)
        if cfg.domain is not None:
            self.lo = np.asarray(cfg.domain.origin, dtype=float)
            self.hi = self.lo + np.asarray(cfg.domain.size, dtype=float)
        else:
            pad = 3.0 * max(float(np.max(hi - lo)), 1e-12)
            self.lo, self.hi = lo - pad, hi + pad
        e0 = sum(sum(_energy(o)) for o in bodies.values())
        mass = sum(float(np.sum(o.body["m"])) for o in bodies.values())
        reach = mass * float(np.hypot(*gravity)) * float(np.max(self.hi - self.lo))
        # 0 for a scene at rest without gravity (a through-flow): its bound is then the
        # inflows' supply alone (check); it was inf, which switched the check off for good
        self.energy_bound = cfg.energy_factor * (e0 + reach)

    def check(self, t, step, bodies: dict):
        """Raise :class:`SimulationError` on the first failed check."""
        where = f"t = {t:.6g} s, step {step}"
        for name, o in bodies.items():
            for q in ("x", "v"):
                arr = o.body[q]
                bad = ~np.isfinite(arr).all(axis=1)
                if bad.any():
                    i = int(np.flatnonzero(bad)[0])
                    raise SimulationError(
                        f"non-finite {q} at {where}, body {name!r}, particle {i} "
                        f"(of {int(bad.sum())} bad): {arr[i].tolist()}")
            x = o.body["x"]
            out = ((x < self.lo) | (x > self.hi)).any(axis=1)
            if out.any():
                i = int(np.flatnonzero(out)[0])
                raise SimulationError(
                    f"particle left the domain at {where}, body {name!r}, particle {i} "
                    f"(of {int(out.sum())}) at x = {x[i].tolist()}; domain "
                    f"{self.lo.tolist()} .. {self.hi.tolist()} (set guard.domain to change it)")
        ke = sum(_energy(o)[0] for o in bodies.values())
        # open boundaries bring energy in: the bound grows by the inflows' supply
        supply = sum(o.energy_supply() for o in bodies.values() if hasattr(o, "energy_supply"))
        bound = self.energy_bound + self.cfg.energy_factor * supply
        if ke > bound > 0.0:  # (nothing can give a scene energy: nothing to compare)
            name, o = max(bodies.items(), key=lambda kv: _energy(kv[1])[0])
            v2 = np.einsum("ij,ij->i", o.body["v"], o.body["v"])
            i = int(np.argmax(v2))
            raise SimulationError(
                f"kinetic energy {ke:.4g} J/m past the bound {bound:.4g} J/m at "
                f"{where}; most in body {name!r}, fastest particle {i} at speed "
                f"{math.sqrt(v2[i]):.4g} m/s (bound = guard.energy_factor x the energy the "
                f"scene can release and its inflows can bring)")
