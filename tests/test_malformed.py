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
