"""chainsweep.spectrum: the linear spectrum of a chain at its static state, as numpy arrays."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from . import _chainsweep as _native
from ._json import dumps


def _floats(raw: bytes) -> np.ndarray:
    return np.frombuffer(raw, dtype="<f8").astype(np.float64)


def spectrum(
    source: Mapping[str, Any] | str | os.PathLike,
    index: int = 0,
    *,
    modes: bool = True,
    cell_particles: int | None = None,
    dispersion_points: int = 101,
    damped: bool = False,
) -> dict[str, Any]:
    """The chain of a scene (``source``: a sweep file's ``base`` as a dict) or of grid point
    ``index`` of a sweep file (``source``: its path), linearised about its static state
    (precompression and/or gravity on the wall); nothing is integrated in time.

    Each contact's stiffness is its law's ``dF/dδ`` at its static overlap and its damping
    ``dF/dδ̇`` there; the striker (a projectile) is left out. Returns a dict of numpy arrays:

    - ``particle``: the particle numbers (1-based, as in the sweep file) of the rows;
    - ``mass_kg``, ``stiffness_n_per_m``, ``damping_kg_s``: the rows' masses and the contacts'
      linear coefficients (contact ``i`` below row ``i``; the last, the wall's);
    - ``angular_frequency_rad_s``, ``frequency_hz``: the ``N`` natural frequencies, increasing;
    - ``modes`` (when ``modes``): shape ``(N, N)``, ``modes[j]`` the shape of mode ``j``,
      orthonormal in the mass inner product (``modes @ diag(mass) @ modes.T = I``);
    - with a unit cell (``cell_particles``, default the scene's ``record.spectrum.cell_particles``):
      ``wavenumber`` (``dispersion_points`` values over ``[0, π]``, per cell),
      ``dispersion_hz`` (shape ``(points, cell_particles)``, the bands at each wavenumber),
      ``band_lower_hz``, ``band_upper_hz`` (each band's edges) and ``gap_lower_hz``,
      ``gap_upper_hz`` (the gaps between bands, lowest first);
    - with ``damped``: ``damped_eigenvalues`` (complex, ``2N``, 1/s: a mode ``exp(λt)``) and
      ``damped_method`` (``"undamped"``, ``"proportional"`` for damping proportional to the
      stiffness, solved mode by mode, or ``"companion"``: the dense companion matrix, at most 200
      particles).

    Raises :class:`chainsweep.InputError` naming the field: a chain without a wall or without a
    statically compressed contact (``physics.wall``, ``physics.precompression_force_n``), a cell
    the chain does not repeat (``cell_particles``), non-proportional damping beyond 200 particles
    (``damped``).
    """
    if isinstance(source, Mapping):
        raw = _native.spectrum(
            scene=dumps(dict(source)),
            index=index,
            modes=modes,
            cell_particles=cell_particles,
            dispersion_points=dispersion_points,
            damped=damped,
        )
    else:
        raw = _native.spectrum(
            path=os.fspath(source),
            index=index,
            modes=modes,
            cell_particles=cell_particles,
            dispersion_points=dispersion_points,
            damped=damped,
        )
    omega = _floats(raw["angular_frequency_rad_s"])
    n = len(omega)
    hz = 1.0 / (2.0 * np.pi)
    out: dict[str, Any] = {
        "particle": np.arange(raw["first_particle"], raw["first_particle"] + n, dtype=np.int64),
        "mass_kg": _floats(raw["mass_kg"]),
        "stiffness_n_per_m": _floats(raw["stiffness_n_per_m"]),
        "damping_kg_s": _floats(raw["damping_kg_s"]),
        "angular_frequency_rad_s": omega,
        "frequency_hz": omega * hz,
    }
    if raw["modes"] is not None:
        out["modes"] = _floats(raw["modes"]).reshape(n, n)
    p = raw["cell_particles"]
    if p is not None:
        lower = _floats(raw["band_lower_rad_s"]) * hz
        upper = _floats(raw["band_upper_rad_s"]) * hz
        out["cell_particles"] = int(p)
        out["wavenumber"] = _floats(raw["wavenumber"])
        out["dispersion_hz"] = _floats(raw["dispersion_rad_s"]).reshape(-1, p) * hz
        out["band_lower_hz"] = lower
        out["band_upper_hz"] = upper
        gap = lower[1:] > upper[:-1] * (1 + 1e-12)
        out["gap_lower_hz"] = upper[:-1][gap]
        out["gap_upper_hz"] = lower[1:][gap]
    if raw["damped_method"] is not None:
        out["damped_eigenvalues"] = _floats(raw["damped_re"]) + 1j * _floats(raw["damped_im"])
        out["damped_method"] = raw["damped_method"]
    return out
