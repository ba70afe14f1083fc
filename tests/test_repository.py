"""The repository is self-contained: no committed file points outside it (the model is documented
in docs/MODEL.md, not in a file beside the checkout)."""

import re
import subprocess

from conftest import REPO

# Spelled in pieces so that this file does not match itself.
OUTSIDE = re.compile("|".join([r"\.\./" + "shared", "shared/" + "MODEL", "/" + "work/"]))


def committed_files():
    out = subprocess.run(
        ["git", "ls-files", "-z"], cwd=REPO, check=True, capture_output=True
    ).stdout
    return [REPO / p for p in out.decode().split("\0") if p]


def test_no_file_refers_to_a_path_outside_the_repository():
    files = committed_files()
    assert any(f.name == "MODEL.md" and f.parent.name == "docs" for f in files)
    hits = []
    for f in files:
        if not f.is_file():
            continue  # deleted in the working tree, not yet committed
        try:
            text = f.read_text()
        except UnicodeDecodeError:
            continue  # binary
        for n, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                hits.append(f"{f.relative_to(REPO)}:{n}: {line.strip()[:100]}")
    assert hits == []


def test_the_checker_finds_a_reference_outside():
    assert OUTSIDE.search("see ../" + "shared/" + "MODEL.md")
    assert OUTSIDE.search("/" + "work/shared/paper")
    assert not OUTSIDE.search("see docs/MODEL.md")
