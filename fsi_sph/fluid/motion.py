"""The velocity and position updates of the fluid step: the shift [F 22-33] with its
Taylor correction, the explicit predictor [F 16], the correction [F 18-19] with the
collision model, the kinematic guard and the density relaxation's displacement."""

from __future__ import annotations

import numpy as np

from fsi_sph.fluid import _kernels as K
from fsi_sph.fluid.shifting import Shifting


class Motion:
    """Updates of the particle set ``ps`` (row roles ``rows``, pressure gradient
    ``gradient``, pressure solve ``pressure``, kinematic guard ``guard``); ``free_slip``:
    the shift's Taylor correction takes the walls as free-slip (the Newtonian fluid)."""

    def __init__(self, ps, rows, gradient, pressure, guard, free_slip, boundary=None):
        self.ps = ps
        self.boundary = boundary
        self.rows = rows
        self.gradient = gradient
        self.pressure = pressure
        self.increments = pressure.increments
        self.guard = guard
        self.free_slip = free_slip
        cfg = ps.cfg
        self.shifting = Shifting(cfg.shifting, ps.h) if cfg.shifting is not None else None
        self.shift_lo = np.full((ps.nf, 3), -np.inf)  # the Taylor correction's limiter
        self.shift_hi = np.full((ps.nf, 3), np.inf)

    def resize(self):
        """A new fluid particle count (open boundaries): the limiter's arrays follow."""
        self.shift_lo = np.full((self.ps.nf, 3), -np.inf)
        self.shift_hi = np.full((self.ps.nf, 3), np.inf)

    def shift(self, dt):
        """Particle shifting [F 22-33] with the Taylor correction of u and p [F 33]."""
        ps = self.ps
        if self.shifting is None:
            return
        b = ps.body
        ps.sync()
        self.shifting.vectors(ps.x_all, ps.v_all, ps.vol_all, ps.ff_start, ps.ff_j,
                              ps.nf, ps.h, ps.kernel, dt, b["class"], b["normal"], b["dr"])
        self.guard.shift(b["dr"])
        if self.shifting.cfg.taylor_correction:
            # Newtonian fluid: the velocity's Taylor correction [F 33] takes the walls as
            # free-slip. With their zero (no-slip) velocity in the gradient, a particle that
            # slides along a wall at speed U sees a shear of order U / dx, and every shift
            # away from the wall (the usual direction: the colour gradient pushes particles
            # off a wall they came too close to) added dr U / dx to its speed. A thin sheet
            # on the floor at 2 m/s threw particles at 5-9 m/s that way (measured).
            # (The viscosity laws keep their no-slip walls: viscous.py.)
            free_slip = self.free_slip
            ps.gradients(free_slip=free_slip)
            K.neighbour_bounds(ps.p_all, ps.v_all, ps.ff_start, ps.ff_j, ps.nf,
                               ps.nf if free_slip else -1, self.shift_lo, self.shift_hi)
        self.shifting.apply(b["dr"], ps.grad_p, ps.grad_v, self.shift_lo,
                            self.shift_hi, b["x"], b["p"], b["v"])
        ps.sync()

    def predict(self, dt):
        """Intermediate velocity [F 16] of the explicit Newtonian step (with the Smagorinsky
        viscosity [F 3] if enabled); the incremental projection's lagged pressure
        acceleration taken off."""
        ps = self.ps
        b = ps.body
        ps.sync()
        if ps.cfg.smagorinsky is not None:
            ps.gradients()
            cs_dx2 = (ps.cfg.smagorinsky.cs * ps.dx) ** 2
            K.smagorinsky(ps.grad_v, cs_dx2, ps.nu0, b["nu"])
            ps.nu_all[:ps.nf] = b["nu"]
        ps.v_old[:] = b["v"]
        g = ps.gravity
        if ps.open is not None:
            # a through-flow's walls are no-slip surfaces for the viscous term (Adami et al.
            # 2012); with the walls at rest a channel's first row slipped at 8 % of the
            # centre speed (docs/numerics/fluid.md § Open boundaries). Closed tanks keep
            # their walls at rest in the Morris sum (their results are unchanged).
            ps.v_all[ps.nf:ps.nf + ps.nw] = self.boundary.no_slip_velocity()
        K.predict_velocity(ps.x_all, ps.v_all, ps.vol_all, ps.nu_all, ps.ff_start,
                           ps.ff_j, ps.nf, ps.h, ps.kernel, ps.eta2, g[0], g[1], dt,
                           ps.v_star)
        if ps.open is not None:
            ps.v_all[ps.nf:ps.nf + ps.nw] = ps.v_b
        if self.pressure.incremental_step:  # [Goda 1979]: u* = u^n + dt (visc + g - grad p^n / rho)
            ps.v_star -= dt * self.gradient.lagged_acceleration()

    def correct(self, dt, interface_force=None):
        """``u^{n+1} = u* - dt grad p / rho`` [F 18] with the conservative gradient [F 10];
        ``r^{n+1} = r^n + dt (u^n + u^{n+1}) / 2`` [F 19]; ``a = (u^{n+1} - u^n) / dt``.
        Incremental projection: ``u^{n+1} = u* - dt grad phi / rho`` [Goda 1979], and the
        density relaxation's pressure ``q`` (:meth:`PressureIncrements.solve`) moves the particles
        by ``-dt^2 grad q / rho`` without entering their velocity (as a velocity, the next
        increment would take it back and keep the pressure that does so: ``p`` drifted to
        2-3 times hydrostatic in the collapse at dt 2e-4 s).

        With coupled structures the pressure gradient leaves out the structure particles and
        ``interface_force`` (N/m per fluid particle, the pair force [F 46-47] that the
        structures receive with the opposite sign) is applied instead."""
        ps = self.ps
        b = ps.body
        if self.pressure.incremental_step:
            self.gradient.apply(self.increments.phi_all, ps.grad_p, floor="increment")
        else:
            self.gradient.apply(ps.p_all, ps.grad_p)
        v = b["v"]
        np.multiply(ps.grad_p, -dt / ps.rho, out=v)
        v += ps.v_star
        if interface_force is not None:
            v += (dt / b["m"])[:, None] * interface_force
        if ps.cfg.collision is not None:
            self.collide(v)
        b["a"][:] = (v - ps.v_old) / dt
        self.guard.velocities(dt, v)
        # [F 19] (trapezoid, w_new = 0.5) or FluidSection.position_update = "damped"
        # (r^n + dt u^{n+1} + dt (u^{n+1} - u^n) / 2, w_new = 1.5)
        b["x"] += dt * (ps.w_new * v + (1.0 - ps.w_new) * ps.v_old)
        if self.pressure.incremental_step and ps.cfg.density_relaxation > 0.0:
            self.relaxation_shift(dt)

    def collide(self, v):
        """The particle collision model (``fluid.collision``, :func:`_kernels.collision_dv`)
        on the corrected velocities ``v``: approaching pairs of fluid particles closer than
        the contact distance lose their approach."""
        ps = self.ps
        c = ps.cfg.collision
        dv = np.empty((ps.nf, 2))
        K.collision_dv(ps.x_all, v, ps.body["m"], ps.ff_start, ps.ff_j, ps.nf,
                       self.rows.fluid_of, c.distance * ps.dx, c.restitution, dv)
        v += dv

    def relaxation_shift(self, dt):
        """The incremental projection's density relaxation as a displacement
        ``dr = -dt^2 grad q / rho`` (:meth:`correct`), none into a wall (the shift guard)."""
        ps = self.ps
        dr = self.gradient.apply(self.increments.relax_all, np.empty((ps.nf, 2)), floor=None)
        dr *= -dt * dt / ps.rho
        self.guard.shift(dr)
        ps.body["x"] += dr
