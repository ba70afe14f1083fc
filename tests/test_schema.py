"""The sweep file's JSON Schema: `chainsweep schema` prints it, the published copy is that output,
every sweep file of the repository follows it, and every file of the malformed corpus that is
malformed in structure breaks it (the rest are well formed and break only physical ranges, which
`chainsweep validate` checks)."""

import json
from pathlib import Path

import jsonschema
import pytest

from conftest import REPO, base_sweep, run, write_sweep

PUBLISHED = REPO / "docs" / "chainsweep-sweep.schema.json"
CORPUS = REPO / "tests" / "malformed"
EXPECTED = json.loads((CORPUS / "expected.json").read_text(encoding="utf-8"))["files"]


@pytest.fixture(scope="module")
def schema(binary):
    r = run("schema")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


@pytest.fixture(scope="module")
def validator(schema):
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_published_schema_is_the_commands_output(schema):
    assert json.loads(PUBLISHED.read_text(encoding="utf-8")) == schema, (
        "docs/chainsweep-sweep.schema.json is stale: regenerate it with "
        "`chainsweep schema > docs/chainsweep-sweep.schema.json`"
    )


def repository_sweep_files():
    """Every sweep file of the repository: sweeps/ and its folders (examples, stress cases)."""
    files = sorted((REPO / "sweeps").rglob("*.json"))
    assert len(files) >= 40
    return files


@pytest.mark.parametrize("path", repository_sweep_files(), ids=lambda p: str(p.relative_to(REPO / "sweeps")))
def test_every_sweep_file_follows_the_schema(validator, path):
    errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(json.loads(path.read_text()))]
    assert errors == []


def test_test_sweeps_follow_the_schema(validator):
    assert list(validator.iter_errors(base_sweep())) == []
    assert list(validator.iter_errors(base_sweep(history=True))) == []


@pytest.mark.parametrize("stem", sorted(EXPECTED), ids=str)
def test_structurally_malformed_files_break_the_schema(validator, stem):
    text = (CORPUS / f"{stem}.json").read_text(encoding="utf-8")
    try:
        document = json.loads(text)
    except json.JSONDecodeError:
        return  # not JSON: refused by every reader
    errors = list(validator.iter_errors(document))
    if EXPECTED[stem].get("schema", False):
        assert errors, f"{stem} is malformed in structure but follows the schema"
    else:
        assert errors == [], f"{stem} is well formed in structure: {[e.message for e in errors]}"


def test_a_misspelt_field_is_found_where_it_is(validator):
    s = base_sweep()
    s["base"]["physics"]["dampng_kg_s"] = 1.0
    s["record"]["probes"][0]["kind"] = "gauge_forse"
    s["axes"][1]["range"] = {"start": 0, "stop": 1, "num": 0}
    paths = sorted(tuple(e.absolute_path) for e in validator.iter_errors(s))
    assert ("base", "physics") in paths
    assert ("record",) in paths or ("record", "probes", 0) in paths
    assert ("axes", 1) in paths


def test_a_sweep_file_may_name_the_schema(tmp_path, binary):
    """`$schema` is accepted and changes nothing: the same runs (a resume finds them done)."""
    plain = write_sweep(tmp_path / "plain.json", base_sweep())
    out = tmp_path / "out.h5"
    r = run("run", plain, "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    named = base_sweep()
    named = {"$schema": "../docs/chainsweep-sweep.schema.json", **named}
    named_path = write_sweep(tmp_path / "named.json", named)
    r = run("validate", named_path)
    assert r.returncode == 0, r.stderr
    r = run("run", named_path, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "nothing to do" in r.stderr, r.stderr
    r = run("status", out)
    assert r.returncode == 0 and "6 done" in r.stdout, r.stdout


def test_schema_describes_fields_for_editors(schema):
    """Doc comments become descriptions: an editor shows what a field means and its unit."""
    text = json.dumps(schema)
    assert "Viscous damping coefficient" in text
    assert "$defs" in schema and "BaseScene" in schema["$defs"]
