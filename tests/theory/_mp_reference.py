"""Independent 50-digit mpmath evaluation of the printed jump distribution for power-law y(q).

Written from the formulas of SPEC §1 alone (in the variable u = 1 - q, with mpmath's erfc and
tanh-sinh quadrature), sharing no code with ``jamlab.theory.jumps``.
"""

from __future__ import annotations

import mpmath as mp

mp.mp.dps = 50


def rho(x):
    return mp.exp(-x * x / 4) / mp.sqrt(mp.pi) + x / 2 * mp.erfc(-x / 2)


class PowerLawReference:
    """y(q) = y0 + A((1-q)^-mu - 1) for q < q_max, constant above."""

    def __init__(self, mu, amplitude=1, y0=0, q_max=1):
        self.mu = mp.mpf(mu)
        self.A = mp.mpf(amplitude)
        self.y0 = mp.mpf(y0)
        self.u_min = 1 - mp.mpf(q_max)

    def y_of_u(self, u):
        u = max(u, self.u_min)
        return self.y0 + self.A * (u ** (-self.mu) - 1)

    def dy_of_u(self, u):
        return self.A * self.mu * u ** (-self.mu - 1)

    def Y_of_u(self, u):  # noqa: N802
        # ∫_{1-u}^1 y(q) dq with y frozen at y(q_max) for q > q_max
        um, mu = self.u_min, self.mu

        def prim(v):
            return self.y0 * v + self.A * (v ** (1 - mu) / (1 - mu) - v)

        if um == 0:
            return prim(u)
        ymax = self.y_of_u(um)
        if u <= um:
            return u * ymax
        return prim(u) - prim(um) + um * ymax


def C_and_dC(ref: PowerLawReference, dE, dgamma):  # noqa: N802
    """(C, ∂C/∂ΔE) at ΔE < 0 by mpmath.quad in u with breakpoints at the features."""
    dE = mp.mpf(dE)
    a = abs(mp.mpf(dgamma))
    d2 = a * a

    def x_of(u):
        return (dE + d2 * ref.Y_of_u(u)) / (mp.sqrt(u) * a)

    pts = set()
    u_x = (dE / a) ** 2  # where x ~ -1 when the δγ² Y term is negligible
    # zero of ΔE + δγ² Y(u), if any: bisection in log u
    u_star = None
    if dE + d2 * ref.Y_of_u(mp.mpf(1)) > 0:
        lo, hi = mp.mpf(-2000), mp.mpf(0)
        for _ in range(400):
            mid = (lo + hi) / 2
            if dE + d2 * ref.Y_of_u(mp.exp(mid)) > 0:
                hi = mid
            else:
                lo = mid
        u_star = mp.exp((lo + hi) / 2)
    lower = ref.u_min
    if lower == 0:
        lower = u_x / 10**4
        if u_star is not None:
            lower = min(lower, u_star * mp.mpf(10) ** -6)
        while x_of(lower) > -40:
            lower /= 100
    pts.add(lower)
    pts.add(mp.mpf(1))
    for k in range(-4, 3):
        for c in (1, 3):
            p = u_x * c * mp.mpf(10) ** k
            if lower < p < 1:
                pts.add(p)
    # every third decade: the integrand is a smooth power of u away from the features
    e = mp.floor(mp.log10(lower))
    while 10**e < 1:
        if 10**e > lower:
            pts.add(mp.mpf(10) ** e)
        e += 3
    if u_star is not None and lower < u_star < 1:
        pts.add(u_star)
        for j in (2, 5, 10, 18, 30, 45):
            for sgn in (-1, 1):
                p = u_star * (1 + sgn * mp.mpf(2) ** -j)
                if lower < p < 1:
                    pts.add(p)
    pts = sorted(pts)
    C = mp.quad(lambda u: ref.dy_of_u(u) * mp.sqrt(u) * rho(x_of(u)), pts) * a
    dC = mp.quad(lambda u: ref.dy_of_u(u) * mp.erfc(-x_of(u) / 2), pts) / 2
    # the atom y(0+) = y0 at q = 0, i.e. u = 1
    if ref.y0 > 0:
        C += a * ref.y0 * rho(x_of(mp.mpf(1)))
        dC += ref.y0 * mp.erfc(-x_of(mp.mpf(1)) / 2) / 2
    return C, dC


def pdf_cdf(ref, dE, dgamma):
    C, dC = C_and_dC(ref, dE, dgamma)
    return mp.exp(-C) * dC, -mp.expm1(-C)
