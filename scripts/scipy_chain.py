"""The paper's chain as a physicist would write it with numpy and scipy, from docs/MODEL.md alone.

This is the "them" of chainsweep's speed claims (the reference run is compared with "a
physicist's scipy script") and an independent check of its physics: it shares no code with the
solver, only the equations of docs/MODEL.md (Hertz contacts with the linear damper while
compressed, gravity, the wall, the static equilibrium as the initial state, the gauge force as the
mean of a cylinder's two contact forces). Its right-hand side is vectorised numpy; the integrator is
`scipy.integrate.solve_ivp`; the leading peak is found on the dense output as the paper's
observable defines it: the maximum of the first excursion, refined by a bounded scalar search.

    from scipy_chain import PaperChain
    chain = PaperChain(cylinders=50, damping_kg_s=6.0)
    result = chain.leading_peaks(duration_s=1e-3, cylinders=(4, 21), method="DOP853", rtol=1e-9)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

G = 9.81


def hertz_sphere_flat(e_sphere, nu_sphere, e_flat, nu_flat, r_sphere):
    """Eq. (4): a sphere against a flat face (a cylinder's end, or the wall)."""
    return 4 * e_flat * e_sphere * np.sqrt(r_sphere) / (3 * (e_sphere * (1 - nu_flat**2) + e_flat * (1 - nu_sphere**2)))


def hertz_sphere_sphere(e1, nu1, r1, e2, nu2, r2):
    """Eq. (5): two spheres (the striker on the first sphere)."""
    r = 1 / (1 / r1 + 1 / r2)
    return 4 * e1 * e2 * np.sqrt(r) / (3 * (e2 * (1 - nu1**2) + e1 * (1 - nu2**2)))


@dataclass
class PeakResult:
    """Leading peaks of the gauge forces, N, and their times, s; the solver's work and wall time."""

    peaks: np.ndarray
    times: np.ndarray
    nfev: int
    wall_s: float


class PaperChain:
    """The sphere–cylinder chain of the paper: striker, sphere, then (cylinder, sphere) × n on a
    wall; defaults are the 0.55 chain (steel spheres of 8 mm and 2.085 g, SS304 cylinders of 3.77 g).
    Particle 0 is the striker, contact j joins particles j and j + 1, the last contact is the wall's.
    """

    def __init__(self, cylinders=50, damping_kg_s=0.0, striker_velocity_m_s=1.3, gravity=True,
                 sphere_mass_kg=2.085e-3, cylinder_mass_kg=3.77e-3, diameter_m=8e-3,
                 e_sphere=200e9, nu_sphere=0.28, e_cylinder=193e9, nu_cylinder=0.29):
        n = 2 * cylinders + 2
        self.n = n
        r = diameter_m / 2
        self.mass = np.full(n, sphere_mass_kg)
        self.mass[2::2] = cylinder_mass_kg  # cylinders: particles 2, 4, …
        flat = hertz_sphere_flat(e_sphere, nu_sphere, e_cylinder, nu_cylinder, r)
        self.a = np.full(n, flat)  # n contacts: n − 1 between particles, then the wall (SS304)
        self.a[0] = hertz_sphere_sphere(e_sphere, nu_sphere, r, e_sphere, nu_sphere, r)
        self.mu = np.full(n, damping_kg_s)
        self.g = G if gravity else 0.0
        # Static equilibrium: contact j carries the weight of the chain particles 1..j; the striker
        # touches particle 1 with no overlap.
        weight = self.g * np.cumsum(self.mass[1:])  # contacts 1 … n−1 (the last: the wall)
        overlap = np.concatenate([[0.0], (weight / self.a[1:]) ** (2 / 3)])
        x = np.empty(n)
        x[-1] = overlap[-1]
        for j in range(n - 2, -1, -1):
            x[j] = x[j + 1] + overlap[j]
        self.x0 = x
        self.v0 = np.zeros(n)
        self.v0[0] = striker_velocity_m_s

    def contact_forces(self, x, v):
        """Net force of every contact (elastic + viscous while compressed), N; shape (n, …)."""
        d = np.concatenate([x[:-1] - x[1:], x[-1:]])
        dv = np.concatenate([v[:-1] - v[1:], v[-1:]])
        a = self.a.reshape((-1,) + (1,) * (np.ndim(x) - 1))
        mu = self.mu.reshape(a.shape)
        dp = np.maximum(d, 0.0)
        return np.where(d > 0, a * dp * np.sqrt(dp) + mu * dv, 0.0)

    def rhs(self, _t, y):
        n = self.n
        x, v = y[:n], y[n:]
        f = self.contact_forces(x, v)
        acc = self.g + (np.concatenate([[0.0], f[:-1]]) - f) / self.mass
        return np.concatenate([v, acc])

    def gauge(self, y, cylinder):
        """Gauge force in cylinder k (particle 2k): the mean of its two contact forces, N."""
        n = self.n
        f = self.contact_forces(y[:n], y[n:])
        return 0.5 * (f[2 * cylinder - 1] + f[2 * cylinder])

    def impact_overlap_m(self):
        """Peak overlap of the striker on a free first sphere (two-body Hertz impact), m: the
        impact's kinetic energy stored as (2/5) A δ^{5/2}."""
        m = 1 / (1 / self.mass[0] + 1 / self.mass[1])
        return (5 * m * self.v0[0] ** 2 / (4 * self.a[0])) ** 0.4

    def impact_force_n(self):
        """Peak force of that impact, N."""
        return self.a[0] * self.impact_overlap_m() ** 1.5

    def leading_peaks(self, duration_s, cylinders, method="DOP853", rtol=1e-9, atol=None,
                      sample_s=2e-7, arrival_fraction=0.01, release_fraction=0.5):
        """Integrates the chain and returns the leading peak of each gauge: the maximum of the first
        excursion (arrival: the signal exceeds its initial value by `arrival_fraction` of the
        two-body impact force; passed: it falls below `release_fraction` of its peak), located on
        samples every `sample_s` and refined on the dense output. `atol` defaults to `rtol` times
        the two-body peak overlap for positions and the striker velocity for velocities."""
        n = self.n
        if atol is None:
            atol = np.concatenate([np.full(n, rtol * self.impact_overlap_m()),
                                   np.full(n, rtol * self.v0[0])])
        y0 = np.concatenate([self.x0, self.v0])
        start = time.perf_counter()
        sol = solve_ivp(self.rhs, (0.0, duration_s), y0, method=method, rtol=rtol, atol=atol,
                        dense_output=True)
        if not sol.success:
            raise RuntimeError(sol.message)
        t = np.arange(0.0, duration_s, sample_s)
        states = sol.sol(t)
        threshold = arrival_fraction * self.impact_force_n()
        peaks, times = [], []
        for k in cylinders:
            s = self.gauge(states, k)
            above = np.nonzero(s - s[0] > threshold)[0]
            if len(above) == 0:
                peaks.append(np.nan)
                times.append(np.nan)
                continue
            # The running maximum from the arrival until the signal falls below the release
            # fraction of it: the first excursion's peak sample.
            i = above[0]
            j = i
            while j < len(s) and s[j] >= release_fraction * s[i]:
                if s[j] > s[i]:
                    i = j
                j += 1
            if j == len(s):
                peaks.append(np.nan)  # the pulse had not passed by the end
                times.append(np.nan)
                continue
            lo, hi = t[max(i - 1, 0)], t[min(i + 1, len(t) - 1)]
            best = minimize_scalar(lambda tt: -self.gauge(sol.sol(tt), k), bounds=(lo, hi),
                                   method="bounded", options={"xatol": 1e-13})
            peaks.append(-best.fun)
            times.append(best.x)
        wall = time.perf_counter() - start
        return PeakResult(np.array(peaks), np.array(times), sol.nfev, wall)
