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


def test_what_the_main_jobs_draw_is_not_tracked():
    """`make figures`, `make examples` and `make accuracy` draw into results/: nothing there that
    they write is tracked (a run would leave the checkout modified: the wall-time plots differ
    from run to run), and git ignores all of it; the docs show docs/figures/."""
    tracked = [f.relative_to(REPO).as_posix() for f in committed_files()]
    drawn = [f for f in tracked if f.startswith("results/") and f.endswith((".png", ".pdf", ".h5"))]
    assert drawn == []
    for name in ("results/fig08.png", "results/fig08.pdf", "results/examples/trimer.pdf",
                 "results/work_precision_fig08.png", "results/fig08.h5"):
        r = subprocess.run(["git", "check-ignore", "-q", name], cwd=REPO)
        assert r.returncode == 0, f"{name} is not ignored"
    figures = [f for f in tracked if f.startswith("docs/figures/")]
    assert "docs/figures/fig08.png" in figures and len(figures) >= 20
    # Every figure the docs link is there.
    for md in (REPO / "docs").glob("*.md"):
        for target in re.findall(r"\]\((figures/[^)]+)\)", md.read_text()):
            assert (REPO / "docs" / target).is_file(), (md.name, target)


# An internal issue number or a commit hash (7 to 12 or 40 hex digits, with a
# letter and a digit; a float's 16-digit bit pattern is neither) means nothing to a reader of the
# code: name what was asked, or a tag (`git tag`), instead.
ISSUE = re.compile(r"\bissues? \d+\b|\bissue-\d+\b", re.I)
HASH = re.compile(r"(?<![\w.#-])(?:[0-9a-f]{7,12}|[0-9a-f]{40})(?![\w.-])")


def residue(text: str) -> list[str]:
    found = [m.group() for m in ISSUE.finditer(text)]
    found += [w for w in HASH.findall(text) if re.search(r"[a-f]", w) and re.search(r"\d", w)]
    return found


def test_code_tests_scripts_and_makefile_name_no_internal_issues_or_commits():
    hits = []
    for f in committed_files():
        rel = f.relative_to(REPO).as_posix()
        code = rel == "Makefile" or rel.startswith((".ci/", "scripts/", "tests/", "crates/", "python/"))
        if not code or not f.is_file() or f.suffix in (".json", ".csv", ".h5", ".lock", ".txt", ".png"):
            continue
        try:
            text = f.read_text()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if f.name == "test_repository.py" and "residue(" in line:
                continue  # this file's own examples
            if residue(line):
                hits.append(f"{rel}:{n}: {line.strip()[:100]}")
    assert hits == []


def test_the_residue_check_finds_issues_and_hashes_not_floats():
    assert residue("# Issue 14 item 4: a damaged record")
    assert residue("BEFORE_REV (default b2d0522)")
    assert residue("built at 1564ed6f2a3b")
    assert not residue('chain_098: mass 6dd27ce51d9316f5 stiffness')
    assert not residue("the tag first-release; 1200 runs; colour #1f77b4")


def test_no_source_file_is_over_a_thousand_lines():
    """A file is read whole: past a thousand lines it holds more than one thing, and is split
    along its seams (tests and data tables included, none is that long today)."""
    long = []
    for path in committed_files():
        if path.suffix in (".rs", ".py") and path.is_file():
            n = path.read_bytes().count(b"\n")
            if n > 1000:
                long.append(f"{path.relative_to(REPO)}: {n} lines")
    assert not long, long
