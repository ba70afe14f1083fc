"""Copies into the Python package (python/) the files its wheel carries from elsewhere, so that
each keeps one source in the repository (run by `make wheel` and `make python`; the copies are
git-ignored):

- python/chainsweep/sweeps/: the example sweep files, sweeps/ as it is (``chainsweep.example_path``);
- python/chainsweep/docs/: the user guides, docs/*.md
  (``chainsweep.docs_path``);
- python/chainsweep/example_scripts/: the example scripts, examples/*.py
  (``python -m chainsweep.example_scripts.fig08``);
- python/licenses/: the notices of the C libraries linked into the extension, HDF5's
  (COPYING, COPYING_LBNL_HDF5) and zlib's, taken from the sources Cargo builds them from
  (``cargo metadata``: hdf5-metno-src and libz-sys), so that they follow the versions built; the
  licence of the font the report's PDF and PNG figures are drawn with (DejaVu Sans); and
  rust-crates/THIRD-PARTY-LICENSES.txt, the licence of every Rust crate compiled into it.

The project's own licences (LICENSE-MIT, LICENSE-APACHE) reach the wheel through the links
python/LICENSE-MIT and python/LICENSE-APACHE to the repository's root.

Usage: python scripts/package_files.py [--cargo CARGO]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "python" / "chainsweep"

# (crate, file inside the crate's source, name under python/licenses/)
NOTICES = [
    ("hdf5-metno-src", "ext/hdf5/COPYING", "HDF5/COPYING"),
    ("hdf5-metno-src", "ext/hdf5/COPYING_LBNL_HDF5", "HDF5/COPYING_LBNL_HDF5"),
    ("libz-sys", "src/zlib/LICENSE", "zlib/LICENSE"),
    # The font carried in the binary for the report's PDF and PNG figures: its own licence
    # (Bitstream Vera's, with the public-domain changes), beside the crate's.
    ("dejavu", "assets/dejavu-fonts-ttf-2.37/LICENSE", "DejaVu/LICENSE"),
]


def replace_tree(dest: Path, files: dict[Path, Path]) -> None:
    """Makes `dest` hold exactly `files` (relative name → source), rewriting only what changed,
    so that a rebuild sees the same files as the same."""
    dest.mkdir(parents=True, exist_ok=True)
    for rel, src in files.items():
        out = dest / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        data = src.read_bytes()
        if not out.is_file() or out.read_bytes() != data:
            out.write_bytes(data)
    for old in sorted(dest.rglob("*"), reverse=True):
        rel = old.relative_to(dest)
        if old.is_file() and rel not in files:
            old.unlink()
        elif old.is_dir() and not any(old.iterdir()):
            old.rmdir()


def metadata(cargo: str) -> dict:
    """`cargo metadata` of the workspace, resolved for the wheel's platform."""
    out = subprocess.run(
        [cargo, "metadata", "--format-version", "1", "--filter-platform", "x86_64-unknown-linux-gnu"],
        cwd=REPO,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return json.loads(out)


def crate_dirs(meta: dict) -> dict[str, Path]:
    """The source folder of every package of the workspace's dependency graph, by name."""
    return {p["name"]: Path(p["manifest_path"]).parent for p in meta["packages"]}


# The licence files a crate ships, by the names crates give them.
LICENSE_NAMES = ("LICENSE", "LICENCE", "COPYING", "NOTICE", "UNLICENSE", "COPYRIGHT")


def third_party_notices(meta: dict) -> str:
    """Every crate compiled into the extension (the normal dependencies of the Python package,
    transitively; build scripts and procedural macros run at build time only and are left out):
    its name, version, licence expression and licence files, one after another."""
    packages = {p["id"]: p for p in meta["packages"]}
    nodes = {n["id"]: n for n in meta["resolve"]["nodes"]}
    root = next(p["id"] for p in meta["packages"] if p["name"] == "chainsweep-python")
    seen, todo = set(), [root]
    while todo:
        pid = todo.pop()
        if pid in seen:
            continue
        seen.add(pid)
        for dep in nodes[pid]["deps"]:
            kinds = {k["kind"] for k in dep["dep_kinds"]}
            target_proc_macro = any("proc-macro" in t["kind"] for t in packages[dep["pkg"]]["targets"])
            if None in kinds and not target_proc_macro:
                todo.append(dep["pkg"])
    parts = [
        "Third-party software compiled into chainsweep's extension module (Rust crates), with\n"
        "their licences. HDF5's and zlib's notices are beside this file.\n"
    ]
    for pid in sorted(seen, key=lambda i: (packages[i]["name"], packages[i]["version"])):
        p = packages[pid]
        if p["source"] is None:
            continue  # the workspace's own crates: LICENSE-MIT, LICENSE-APACHE
        folder = Path(p["manifest_path"]).parent
        files = sorted(
            f for f in folder.iterdir()
            if f.is_file() and f.name.upper().startswith(LICENSE_NAMES)
        )
        parts.append("=" * 78)
        parts.append(f"{p['name']} {p['version']} ({p.get('license') or p.get('license_file') or 'see below'})")
        if p.get("repository"):
            parts.append(p["repository"])
        for f in files:
            parts.append("-" * 78)
            parts.append(f.name)
            parts.append(f.read_text(encoding="utf-8", errors="replace").rstrip())
        if not files:
            parts.append("(the crate ships no licence file; its licence is the expression above)")
    return "\n".join(parts) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cargo", default="cargo")
    args = ap.parse_args()

    sweeps = REPO / "sweeps"
    # (A fit's data files beside its sweep file: the examples read them by relative path.)
    replace_tree(
        PACKAGE / "sweeps",
        {p.relative_to(sweeps): p for p in sweeps.rglob("*") if p.suffix in (".json", ".csv")},
    )
    docs = {Path(p.name): p for p in sorted((REPO / "docs").iterdir()) if p.suffix in (".md", ".json")}
    replace_tree(PACKAGE / "docs", docs)
    # The example scripts, runnable from the package (`python -m chainsweep.example_scripts.fig08`);
    # they find their sweeps with chainsweep.example_path.
    scripts = {Path(p.name): p for p in sorted((REPO / "examples").glob("*.py"))}
    init = REPO / "target" / "example_scripts__init__.py"
    init.parent.mkdir(parents=True, exist_ok=True)
    init.write_text('"""The example scripts of the repository\'s examples/, installed with the package."""\n')
    replace_tree(PACKAGE / "example_scripts", {Path("__init__.py"): init, **scripts})

    meta = metadata(args.cargo)
    dirs = crate_dirs(meta)
    notices = {}
    for crate, inside, name in NOTICES:
        if crate not in dirs:
            print(f"package_files: crate {crate} is not in the build (cargo metadata)", file=sys.stderr)
            return 1
        src = dirs[crate] / inside
        if not src.is_file():
            print(f"package_files: {src} is missing", file=sys.stderr)
            return 1
        notices[Path(name)] = src
    third_party = REPO / "target" / "THIRD-PARTY-LICENSES.txt"
    third_party.parent.mkdir(parents=True, exist_ok=True)
    third_party.write_text(third_party_notices(meta), encoding="utf-8")
    notices[Path("rust-crates/THIRD-PARTY-LICENSES.txt")] = third_party
    replace_tree(REPO / "python" / "licenses", notices)
    return 0


if __name__ == "__main__":
    sys.exit(main())
