"""Copies into the Python package (python/) the files its wheel carries from elsewhere, so that
each keeps one source in the repository (run by `make wheel` and `make python`; the copies are
git-ignored):

- python/chainsweep/sweeps/: the example sweep files, sweeps/ as it is (``chainsweep.example_path``);
- python/chainsweep/docs/: the user guides, docs/*.md and crates/runner/README-sweeps.md
  (``chainsweep.docs_path``);
- python/licenses/: the notices of the C libraries linked into the extension, HDF5's
  (COPYING, COPYING_LBNL_HDF5) and zlib's, taken from the sources Cargo builds them from
  (``cargo metadata``: hdf5-metno-src and libz-sys), so that they follow the versions built.

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


def crate_dirs(cargo: str) -> dict[str, Path]:
    """The source folder of every package of the workspace's dependency graph, by name."""
    out = subprocess.run(
        [cargo, "metadata", "--format-version", "1"],
        cwd=REPO,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return {p["name"]: Path(p["manifest_path"]).parent for p in json.loads(out)["packages"]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cargo", default="cargo")
    args = ap.parse_args()

    sweeps = REPO / "sweeps"
    replace_tree(PACKAGE / "sweeps", {p.relative_to(sweeps): p for p in sweeps.rglob("*.json")})
    docs = {Path(p.name): p for p in sorted((REPO / "docs").iterdir()) if p.suffix in (".md", ".json")}
    docs[Path("README-sweeps.md")] = REPO / "crates" / "runner" / "README-sweeps.md"
    replace_tree(PACKAGE / "docs", docs)

    dirs = crate_dirs(args.cargo)
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
    replace_tree(REPO / "python" / "licenses", notices)
    return 0


if __name__ == "__main__":
    sys.exit(main())
