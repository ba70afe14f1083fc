"""A corpus of malformed sweep files: each is refused before anything runs, with exit code 2, a
message naming the offending field, and no output file created or modified."""

import hashlib
import json
from pathlib import Path

import pytest

from conftest import run

CORPUS = Path(__file__).resolve().parent / "malformed"

# The expectations, shared with crates/runner/tests/malformed_corpus.rs (which checks the same
# files through the library): file stem -> {"field": the exact field the error names ("" where it
# names none), "contains": text the error must contain}.
EXPECTATIONS = CORPUS / "expected.json"
EXPECTED = json.loads(EXPECTATIONS.read_text(encoding="utf-8"))["files"]

FILES = sorted(f for f in CORPUS.glob("*.json") if f != EXPECTATIONS)


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
    field = EXPECTED[path.stem]["field"]
    expected = EXPECTED[path.stem]["contains"]
    r = run("validate", path)
    assert r.returncode == 2, r.stderr
    assert expected in r.stderr, r.stderr
    if field:
        assert f"field `{field}`: " in r.stderr, r.stderr
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


def test_validate_lists_every_error_in_one_pass(tmp_path, binary):
    """Structure (a misspelt field, a wrong type, inside a probe too), each section's values and
    the grid points' ranges: all named at their fields in one run of `validate`, each once."""
    sweep = {
        "base": {
            "chain": {"preset": "chain_055", "cylinders": 10},
            "physics": {"gravity": True, "damping_kg_s": "six", "wall": True, "dampng": 1},
            "striker_velocity_m_s": 1.0,
            "duration_s": 1e-4,
            "integrator": {"method": "dop853", "rtol": 1e-9, "atoll": 1e-9},
        },
        "record": {"probes": [{"kind": "gauge_force", "cylinder": 2, "colour": "red"}]},
        "axes": [
            {"field": "physics.damping_kg_s", "values": [0, 6], "nmae": "mu"},
            {"field": "striker_velocity_m_s", "range": {"start": 1, "stop": 2, "stpe": 1}},
        ],
        "limits": {"max_run_seconds": 0},
        "axis": [],
    }
    path = tmp_path / "many.json"
    path.write_text(json.dumps(sweep))
    r = run("validate", path)
    assert r.returncode == 2, r.stderr
    fields = [
        "axis",
        "axes[0].nmae",
        "axes[1].range.stpe",
        "base.physics.damping_kg_s",
        "base.physics.dampng",
        "base.integrator.atoll",
        "record.probes[0].colour",
        "limits.max_run_seconds",
    ]
    for field in fields:
        assert r.stderr.count(f"field `{field}`: ") == 1, (field, r.stderr)
    assert f"{len(fields)} errors in {path}; nothing was run" in r.stderr
    assert list(tmp_path.iterdir()) == [path]

    # With the structure mended, the values: the limits, and every grid point's distinct error
    # (a base field's once, with the number of points it holds at).
    sweep["base"]["physics"] = {"gravity": True, "damping_kg_s": 0.0, "wall": True, "precompression_force_n": -1}
    sweep["base"]["integrator"] = {"method": "dop853", "rtol": 1e-9}
    sweep["record"]["probes"] = [{"kind": "velocity", "particle": 0}]
    sweep["axes"] = [
        {"field": "physics.damping_kg_s", "values": [0, 6]},
        {"field": "striker_velocity_m_s", "values": [1, -1, 2, -2]},
    ]
    del sweep["axis"]
    path.write_text(json.dumps(sweep))
    r = run("validate", path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("field `limits.max_run_seconds`: ") == 1, r.stderr
    assert r.stderr.count("field `base.physics.precompression_force_n`: ") == 1, r.stderr
    assert "the same at 8 grid points" in r.stderr, r.stderr
    assert "1..=" not in r.stderr

    sweep["base"]["physics"]["precompression_force_n"] = 0
    path.write_text(json.dumps(sweep))
    r = run("validate", path)
    assert r.returncode == 2, r.stderr
    assert "field `record.probes[0].particle`: must be from 1 to 22 (the chain's particles), got 0" in r.stderr
    assert "field `axes[1].values[1]`: " in r.stderr and "field `axes[1].values[3]`: " in r.stderr, r.stderr
