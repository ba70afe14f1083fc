"""A corpus of malformed sweep files: each is refused before anything runs, with exit code 2, a
message naming the offending field, and no output file created or modified."""

import hashlib
from pathlib import Path

import pytest

from conftest import run

CORPUS = Path(__file__).resolve().parent / "malformed"

# File -> text the error message must contain (the offending field).
EXPECTED = {
    "axis_unknown_field": "physics.dampingg",
    "axis_values_and_range": "axes[1]",
    "duplicate_axis_field": "axes[2].field",
    "duplicate_description_key": "duplicate key `description`",
    "duplicate_key": "duplicate key `gravity`",
    "empty_axes": "axes",
    "empty_values": "axes[0].values",
    "flat_flat_without_law": "chain.contacts",
    "fractional_cylinders": "chain.cylinders",
    "infinite_velocity": "striker_velocity_m_s",
    "mass_ratio_above_one": "chain.cylinder.mass.heavy_cylinders.mass_ratio",
    "mass_ratio_zero_in_axis": "mass_ratio",
    "missing_base": "base",
    "nan_damping": "damping_kg_s",
    "negative_damping_range": "physics.damping_kg_s",
    "negative_precompression_force": "physics.precompression_force_n",
    "negative_pulse_amplitude_axis": "excitation.half_sine_force.amplitude_n",
    "negative_drift_limit": "limits.energy_drift_max",
    "negative_duration_axis": "duration_s",
    "negative_sphere_mass": "chain.sphere.mass_kg",
    "negative_velocity_axis": "striker_velocity_m_s",
    "poisson_ratio_out_of_range": "wall_material.poisson_ratio",
    "power_law_exponent_below_one": "chain.contacts[0].law.power_law.exponent",
    "probe_beyond_chain": "record.probes[1].cylinder",
    "probe_beyond_shorter_chain_axis": "record.probes[1].cylinder",
    "range_num_zero": "axes[1].range.num",
    "range_unknown_key": "stpe",
    "range_wrong_sign": "axes[1].range.step",
    "range_zero_step": "axes[1].range.step",
    "record_twice": "base.record",
    "reserved_axis_name": "axes[1].name",
    "rtol_out_of_range": "integrator.rtol",
    "taper_axis_vanishing_particle": "chain.taper.ratio",
    "taper_vanishing_particle": "chain.taper.ratio",
    "truncated_json": "field",
    "typographic_quotes": "typographic quote",
    "unit_after_number": "duration_s",
    "unknown_chain_preset": "base.chain.preset",
    "unknown_integrator_method": "integrator.method",
    "unknown_physics_field": "dampng_kg_s",
    "unknown_probe_kind": "record.probes[0]",
    "unknown_top_level_field": "axis",
    "velocity_probe_particle_zero": "record.probes[2].particle",
    "wrong_type_damping": "physics.damping_kg_s",
    "wrong_type_gravity": "physics.gravity",
    "zero_duration": "duration_s",
    "tiny_history_interval": "record.history_interval_s",
    "tiny_summary_interval": "record.summary_interval_s",
    "zero_max_run_seconds": "limits.max_run_seconds",
    "null_max_run_seconds": "limits.max_run_seconds",
    "huge_max_run_seconds": "limits.max_run_seconds",
    "zero_history_interval": "record.history_interval_s",
    "zero_max_steps": "max_steps",
    "zero_pulse_duration": "excitation.half_sine_force.duration_s",
    "zip_unequal_lengths": "axes[1].zip[1].values",
}

FILES = sorted(CORPUS.glob("*.json"))


def test_corpus_is_complete():
    assert len(FILES) >= 25
    assert {f.stem for f in FILES} == set(EXPECTED)


def tree_digest(root):
    """Names and contents of every file under root."""
    h = hashlib.sha256()
    for p in sorted(Path(root).rglob("*")):
        h.update(str(p.relative_to(root)).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_malformed_is_refused(binary, tmp_path, path):
    expected = EXPECTED[path.stem]
    r = run("validate", path)
    assert r.returncode == 2, r.stderr
    assert expected in r.stderr, r.stderr
    assert "field" in r.stderr or "missing field" in r.stderr

    # `run` refuses it too, before creating anything.
    out = tmp_path / "out.h5"
    r = run("run", path, "-o", out, "--quiet")
    assert r.returncode == 2, r.stderr
    assert expected in r.stderr
    assert list(tmp_path.iterdir()) == []

    # An existing output (and its work directory) is left untouched.
    out.write_bytes(b"previous contents")
    (tmp_path / "out.h5.d").mkdir()
    (tmp_path / "out.h5.d" / "keep").write_text("x")
    before = tree_digest(tmp_path)
    r = run("run", path, "-o", out, "--quiet", "--jobs", "2")
    assert r.returncode == 2
    assert tree_digest(tmp_path) == before

    # --dry-run refuses it as well.
    r = run("run", path, "--dry-run")
    assert r.returncode == 2


def test_byte_order_mark_is_accepted(binary, tmp_path):
    """A UTF-8 byte-order mark (as Windows editors write) is not an error: the file validates."""
    sweep = tmp_path / "bom.json"
    sweep.write_bytes(b"\xef\xbb\xbf" + (CORPUS.parent.parent / "sweeps" / "fig08.json").read_bytes())
    r = run("validate", sweep)
    assert r.returncode == 0, r.stderr


def test_truncated_file_says_so(binary, tmp_path):
    """A file that ends inside its JSON is called truncated, naming no unrelated field and adding
    nothing about finite numbers."""
    sweep = tmp_path / "cut.json"
    sweep.write_text('{"base": {"duration_s": 1e-3')
    r = run("validate", sweep)
    assert r.returncode == 2
    assert "truncated" in r.stderr, r.stderr
    assert "finite" not in r.stderr and "field `" not in r.stderr, r.stderr
