"""Elastic constitutive laws in 2D: F -> first Piola-Kirchhoff stress P.

Plane strain (PHYSICS.md §4, the default) or plane stress; the two differ only in the first
Lame constant the 2D law is given (:func:`lame`).

Tensors are passed as four scalars (row-major ``f00, f01, f10, f11``) so that the
particle loops allocate nothing. ``MODELS`` maps case-file names to the ids the loops use.
"""

import math

from numba import njit

STVK = 0
HOOKE_ALMANSI = 1
NEO_HOOKEAN = 2

#: registry: case-file name -> model id
MODELS = {"stvk": STVK, "hooke_almansi": HOOKE_ALMANSI, "neo_hookean": NEO_HOOKEAN}


def lame(E, nu, plane="strain"):
    """Lame constants of the 2D law.

    Plane strain [F 37-40]: lambda = E nu/((1+nu)(1-2nu)), mu = E/(2(1+nu)).
    Plane stress (sigma_zz = 0): the in-plane law is the plane-strain one with
    lambda* = 2 lambda mu/(lambda + 2 mu) = E nu/(1 - nu^2) (the out-of-plane strain
    eliminated); exact for small strains, and for large strains a 2D hyperelastic law with
    the plane-stress small-strain constants (the out-of-plane stretch is not solved for)."""
    lam, mu = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))
    if plane == "stress":
        lam = 2.0 * lam * mu / (lam + 2.0 * mu)
    elif plane != "strain":
        raise ValueError(f"plane = {plane!r}: allowed 'strain', 'stress'")
    return lam, mu


def wave_speed(E, nu, rho0, plane="strain"):
    """P-wave speed of the 2D law, c_s = sqrt((lambda + 2 mu)/rho0) (PHYSICS §4: K + 4G/3
    in plane strain)."""
    lam, mu = lame(E, nu, plane)
    return math.sqrt((lam + 2.0 * mu) / rho0)


@njit(cache=True)
def _inverse_transpose(f00, f01, f10, f11):
    """F^-T and J = det F."""
    J = f00 * f11 - f01 * f10
    return f11 / J, -f10 / J, -f01 / J, f00 / J, J


@njit(cache=True)
def pk1(model, lam, mu, f00, f01, f10, f11):
    """First Piola-Kirchhoff stress P(F) of model ``model``; returns (p00, p01, p10, p11).

    STVK [F 37-40 in the reference frame]: E = (F^T F - I)/2, S = lam tr(E) I + 2 mu E, P = F S.
    HOOKE_ALMANSI [F 37-40 as printed]: e = F^-T E F^-1, sigma = lam tr(e) I + 2 mu e,
    P = J sigma F^-T.
    NEO_HOOKEAN: P = mu (F - F^-T) + lam ln(J) F^-T.
    """
    if model == NEO_HOOKEAN:
        i00, i01, i10, i11, J = _inverse_transpose(f00, f01, f10, f11)
        lj = lam * math.log(J)
        return (mu * (f00 - i00) + lj * i00, mu * (f01 - i01) + lj * i01,
                mu * (f10 - i10) + lj * i10, mu * (f11 - i11) + lj * i11)
    # Green-Lagrange strain E = (F^T F - I)/2
    e00 = 0.5 * (f00 * f00 + f10 * f10 - 1.0)
    e01 = 0.5 * (f00 * f01 + f10 * f11)
    e11 = 0.5 * (f01 * f01 + f11 * f11 - 1.0)
    if model == HOOKE_ALMANSI:
        i00, i01, i10, i11, J = _inverse_transpose(f00, f01, f10, f11)
        # Almansi e = F^-T E F^-1 = A E A^T with A = F^-T
        t00 = i00 * e00 + i01 * e01
        t01 = i00 * e01 + i01 * e11
        t10 = i10 * e00 + i11 * e01
        t11 = i10 * e01 + i11 * e11
        a00 = t00 * i00 + t01 * i01
        a01 = t00 * i10 + t01 * i11
        a11 = t10 * i10 + t11 * i11
        tr = a00 + a11
        s00 = lam * tr + 2.0 * mu * a00
        s01 = 2.0 * mu * a01
        s11 = lam * tr + 2.0 * mu * a11
        # P = J sigma F^-T
        return (J * (s00 * i00 + s01 * i10), J * (s00 * i01 + s01 * i11),
                J * (s01 * i00 + s11 * i10), J * (s01 * i01 + s11 * i11))
    tr = e00 + e11
    s00 = lam * tr + 2.0 * mu * e00
    s01 = 2.0 * mu * e01
    s11 = lam * tr + 2.0 * mu * e11
    return (f00 * s00 + f01 * s01, f00 * s01 + f01 * s11,
            f10 * s00 + f11 * s01, f10 * s01 + f11 * s11)


@njit(cache=True)
def energy_density(model, lam, mu, f00, f01, f10, f11):
    """Stored energy per reference volume. STVK: lam/2 tr(E)^2 + mu E:E; Neo-Hookean:
    mu/2 (tr C - 2 - 2 ln J) + lam/2 (ln J)^2. The Hooke-Almansi law has no exact potential;
    its STVK energy is used (they agree to second order in the strain)."""
    if model == NEO_HOOKEAN:
        J = f00 * f11 - f01 * f10
        trc = f00 * f00 + f01 * f01 + f10 * f10 + f11 * f11
        lj = math.log(J)
        return 0.5 * mu * (trc - 2.0 - 2.0 * lj) + 0.5 * lam * lj * lj
    e00 = 0.5 * (f00 * f00 + f10 * f10 - 1.0)
    e01 = 0.5 * (f00 * f01 + f10 * f11)
    e11 = 0.5 * (f01 * f01 + f11 * f11 - 1.0)
    tr = e00 + e11
    return 0.5 * lam * tr * tr + mu * (e00 * e00 + 2.0 * e01 * e01 + e11 * e11)
