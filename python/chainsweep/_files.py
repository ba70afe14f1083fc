"""The files installed with the package: the example sweep files and the user guides.

A wheel built with ``make wheel`` carries the repository's ``sweeps/`` (every example sweep file,
the paper's figures and the chains beyond them in ``examples/``) as ``chainsweep/sweeps/`` and the
guides (``docs/*.md``, the sweep file reference ``REFERENCE.md`` among them) as ``chainsweep/docs/``.
"""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).resolve().parent
SWEEPS = _HERE / "sweeps"
DOCS = _HERE / "docs"


def _folder(folder: Path, what: str) -> Path:
    if not folder.is_dir():
        raise FileNotFoundError(
            f"this chainsweep was installed without its {what} ({folder} is missing): "
            "install a wheel built with `make wheel`, or `make python` in a checkout"
        )
    return folder


def examples() -> list[str]:
    """The names of the example sweep files installed with the package, for
    :func:`example_path`: ``"mass-damping"``, ``"fig08"``, …, ``"examples/trimer"``."""
    root = _folder(SWEEPS, "example sweep files")
    return sorted(p.relative_to(root).with_suffix("").as_posix() for p in root.rglob("*.json"))


def example_path(name: str) -> Path:
    """The path of an example sweep file installed with the package, by name: ``"mass-damping"``
    (the repository's ``sweeps/mass-damping.json``), ``"examples/trimer"``
    (``sweeps/examples/trimer.json``); ``.json`` may be given. :func:`examples` lists them.

    >>> import chainsweep
    >>> result = chainsweep.sweep(chainsweep.example_path("mass-damping"), "mass-damping.h5")

    Copy one to start a sweep of your own. Raises :class:`FileNotFoundError` naming the examples when there is none of that name.
    """
    root = _folder(SWEEPS, "example sweep files")
    rel = name[: -len(".json")] if name.endswith(".json") else name
    path = (root / f"{rel}.json").resolve()
    if root not in path.parents or not path.is_file():
        raise FileNotFoundError(f"no example sweep {name!r}; the examples: {', '.join(examples())}")
    return path


def docs_path(name: str | None = None) -> Path:
    """The folder of the user guides installed with the package, or one guide by name:
    ``"PYTHON"`` (the Python interface), ``"SWEEPS"`` (sweeps, resuming, clusters),
    ``"REFERENCE"`` (every field of a sweep file), ``"CLUSTER"``, ``"CHAINS"``, ``"MODEL"``,
    …; ``.md`` may be given. Raises :class:`FileNotFoundError` naming the guides when there is
    none of that name."""
    root = _folder(DOCS, "user guides")
    if name is None:
        return root
    # The sweep reference's name before it moved into docs/ still finds it.
    name = {"README-sweeps": "REFERENCE", "README-sweeps.md": "REFERENCE.md"}.get(name, name)
    file = name if "." in name else f"{name}.md"
    path = (root / file).resolve()
    if root not in path.parents or not path.is_file():
        guides = ", ".join(sorted(p.stem for p in root.glob("*.md")))
        raise FileNotFoundError(f"no guide {name!r}; the guides: {guides}")
    return path
