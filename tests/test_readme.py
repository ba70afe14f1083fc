"""The README's front door works as written: its first sweep runs and plots verbatim, every link of
the README and of the user docs points at a file (and heading) that exists, every make target
it names exists, and user docs name no internal issue numbers or commit hashes."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import BIN, REPO

README = REPO / "README.md"
USER_DOCS = [README, *sorted((REPO / "docs").glob("*.md")), REPO / "python" / "README.md"]


def blocks(text: str) -> list[tuple[str, str]]:
    """The fenced code blocks of a markdown text: (language, body)."""
    return re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.M | re.S)


def test_readme_is_a_front_door():
    lines = README.read_text().splitlines()
    assert len(lines) <= 160, f"README has {len(lines)} lines: details belong in docs/"


def test_first_sweep_runs_and_plots_as_written(tmp_path):
    text = README.read_text()
    section = text[text.index("## A first sweep of your own"):text.index("## Documentation")]
    found = blocks(section)
    langs = [lang for lang, _ in found]
    assert langs == ["json", "sh", "python"], langs
    (_, sweep), (_, commands), (_, plot) = found
    (tmp_path / "my-sweep.json").write_text(sweep)
    for line in commands.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        argv = shlex.split(line)
        assert argv[0] == "target/release/chainsweep", line
        r = subprocess.run([str(BIN), *argv[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, (line, r.stdout, r.stderr)
    with h5py.File(tmp_path / "my-sweep.h5") as f:
        status = f["status"][()]
        assert status.shape == (15, 2) and (status == 1).all()
        lp = f["leading_peak"][()]
        assert np.isfinite(lp).all()
    # The plot, run verbatim through the docs' label check: no dotted path, no file bookkeeping
    # (`probe_units`) in a title or label, nothing past the figure's edges.
    from test_docs import HARNESS

    (tmp_path / "snippet.py").write_text(plot)
    (tmp_path / "harness.py").write_text(HARNESS)
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "harness.py", "snippet.py", str(REPO / "scripts")], cwd=tmp_path,
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert report["figures"] == 1 and report["problems"] == [], report
    # A ratio of two forces is labelled as one, without a unit of force.
    labels = dict(report["labels"])
    assert labels["y label"] == "F15 / F4 [1]" and labels["title"] == "", labels
    assert labels["x label"] == "mass ratio [1]", labels
    assert (tmp_path / "my-sweep.png").stat().st_size > 10_000


def slug(heading: str) -> str:
    """GitHub's anchor of a markdown heading."""
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(REPO)))
def test_links_point_at_files_and_headings_that_exist(doc):
    text = doc.read_text()
    text = re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target) or target.startswith("mailto:"):
            continue
        path, _, anchor = target.partition("#")
        dest = (doc.parent / path).resolve() if path else doc
        assert dest.exists(), f"{doc.name}: link to {target}: no such file"
        assert REPO in dest.parents or dest == REPO, f"{doc.name}: link to {target} leaves the repository"
        if anchor and dest.suffix == ".md":
            headings = re.findall(r"^#+ (.*)$", dest.read_text(), flags=re.M)
            assert anchor in {slug(h) for h in headings}, f"{doc.name}: link to {target}: no such heading"


def test_make_targets_named_in_the_readme_exist():
    makefile = (REPO / "Makefile").read_text()
    targets = set(re.findall(r"^([\w-]+):", makefile, flags=re.M))
    for name in set(re.findall(r"`make ([\w-]+)", README.read_text())):
        assert name in targets, f"README names `make {name}`, which the Makefile lacks"


@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(REPO)))
def test_user_docs_name_no_internal_issues_or_commits(doc):
    text = doc.read_text()
    assert not re.search(r"\bissues? \d+\b|\bissue-\d+\b", text, flags=re.I), f"{doc.name} names an internal issue"
    # A commit hash: 7 to 40 hex digits with at least one letter and one digit, outside numbers.
    for word in re.findall(r"(?<![\w.#-])[0-9a-f]{7,40}(?![\w.-])", text):
        if re.search(r"[a-f]", word) and re.search(r"\d", word):
            pytest.fail(f"{doc.name} names what looks like a commit hash: {word}")
