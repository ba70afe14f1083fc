"""chainsweep.spectrum: the linear spectrum of a scene or of a sweep file's grid point at its
static state, as numpy arrays: the fixed-free closed form, mass-orthonormal mode shapes solving
K v = ω² M v, the diatomic Bloch dispersion, damped eigenvalues, errors naming the field."""

from __future__ import annotations

import json

import numpy as np
import pytest

import chainsweep
from conftest import REPO

EXAMPLE = REPO / "sweeps" / "examples" / "dimer-bands.json"


def monodisperse_scene(n, f0, gravity=False, damping=0.0):
    """n steel spheres on the wall under f0, every pair and the wall under one Hertz law."""
    law = {"power_law": {"coefficient": 8.0e9, "exponent": 1.5}}
    return {
        "chain": {
            "particles": {
                "ball": {
                    "sphere": {
                        "diameter_m": 0.008,
                        "mass_kg": 0.002085,
                        "material": {"youngs_modulus_pa": 2e11, "poisson_ratio": 0.28},
                    }
                }
            },
            "sequence": [{"repeat": n, "of": ["ball"]}],
            "contacts": [
                {"between": ["ball", "ball"], "law": law},
                {"between": ["ball", "wall"], "law": law},
            ],
        },
        "physics": {
            "gravity": gravity,
            "damping_kg_s": damping,
            "wall": True,
            "precompression_force_n": f0,
        },
        "excitation": {"impulse": {"velocity_m_s": 0.1}},
        "duration_s": 1e-3,
    }


def test_python_frequencies_and_modes():
    n, f0, m = 60, 5.0, 0.002085
    s = chainsweep.spectrum(monodisperse_scene(n, f0))
    k = 1.5 * 8.0e9 ** (2 / 3) * f0 ** (1 / 3)
    j = np.arange(1, n + 1)
    exact = 2 * np.sqrt(k / m) * np.sin((2 * j - 1) * np.pi / (2 * (2 * n + 1)))
    np.testing.assert_allclose(s["angular_frequency_rad_s"], exact, rtol=1e-10)
    np.testing.assert_allclose(s["frequency_hz"], exact / (2 * np.pi), rtol=1e-10)
    assert (s["particle"] == j).all()
    # Mass-orthonormal modes solving K v = ω² M v, K from the returned contact stiffnesses.
    v, mass, kc = s["modes"], s["mass_kg"], s["stiffness_n_per_m"]
    np.testing.assert_allclose(v @ np.diag(mass) @ v.T, np.eye(n), atol=1e-10)
    stiff = np.diag(kc + np.concatenate([[0.0], kc[:-1]])) - np.diag(kc[:-1], 1) - np.diag(kc[:-1], -1)
    residual = stiff @ v.T - (mass[:, None] * v.T) * s["angular_frequency_rad_s"] ** 2
    assert np.abs(residual).max() < 1e-10 * np.abs(stiff).max() * np.abs(v).max()


def test_python_dispersion_of_the_dimer():
    sweep = json.loads(EXAMPLE.read_text())
    s = chainsweep.spectrum(EXAMPLE, 7, modes=False, dispersion_points=51)
    # Grid point 7: force 10 N (index 2), small mass 0.0005 kg (index 1).
    f0, m2 = sweep["axes"][0]["values"][2], sweep["axes"][1]["values"][1]
    m1 = sweep["base"]["chain"]["particles"]["large"]["sphere"]["mass_kg"]
    k = 1.5 * 8.0e9 ** (2 / 3) * f0 ** (1 / 3)
    q = s["wavenumber"]
    assert "modes" not in s and q.shape == (51,) and s["dispersion_hz"].shape == (51, 2)
    a = 1 / m1 + 1 / m2
    root = np.sqrt(a**2 - 4 * np.sin(q / 2) ** 2 / (m1 * m2))
    exact = np.sqrt(np.clip(np.stack([k * (a - root), k * (a + root)], axis=1), 0, None)) / (2 * np.pi)
    np.testing.assert_allclose(s["dispersion_hz"], exact, rtol=1e-8, atol=1e-6 * exact.max())
    np.testing.assert_allclose(s["gap_lower_hz"], [np.sqrt(2 * k / m1) / (2 * np.pi)], rtol=1e-8)
    np.testing.assert_allclose(s["gap_upper_hz"], [np.sqrt(2 * k / m2) / (2 * np.pi)], rtol=1e-8)


def test_python_damped_eigenvalues():
    # Linear viscous damping under gravity: not proportional, the companion matrix.
    s = chainsweep.spectrum(monodisperse_scene(30, 2.0, gravity=True, damping=2.0), damped=True, modes=False)
    lam = s["damped_eigenvalues"]
    assert s["damped_method"] == "companion" and lam.shape == (60,)
    assert (lam.real < 0).all()
    n = len(s["mass_kg"])
    c = s["damping_kg_s"]
    trace = ((c + np.concatenate([[0.0], c[:-1]])) / s["mass_kg"]).sum()
    np.testing.assert_allclose(lam.real.sum(), -trace, rtol=1e-10)
    # Without damping: ±iω.
    s = chainsweep.spectrum(monodisperse_scene(30, 2.0), damped=True, modes=False)
    assert s["damped_method"] == "undamped"
    np.testing.assert_allclose(np.sort(s["damped_eigenvalues"].imag[n:]), s["angular_frequency_rad_s"])


def test_python_errors_name_the_field():
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.spectrum(monodisperse_scene(10, 0.0))
    assert e.value.field == "physics.precompression_force_n"
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.spectrum(monodisperse_scene(10, 1.0, gravity=True), cell_particles=1)
    assert e.value.field == "cell_particles" and "not periodic" in str(e.value)
    with pytest.raises(chainsweep.InputError) as e:
        chainsweep.spectrum(monodisperse_scene(250, 1.0, gravity=True, damping=1.0), damped=True, modes=False)
    assert e.value.field == "damped"
