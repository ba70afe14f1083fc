"""chainsweep from Python: run scenes and sweeps of dissipative granular chains, read the results
as labelled xarray Datasets.

- :func:`run` — one scene (a sweep file's ``base`` as a dict) in this process, as a Dataset;
- :func:`sweep` — a sweep file or dict into an HDF5 file, resumable, with progress;
- :func:`open` — a result file as a Dataset labelled by the grid's axes and the probes;
- :func:`spectrum` — the linear spectrum of a scene or a sweep file's grid point at its static
  state: natural frequencies, mode shapes, damped eigenvalues, a periodic chain's Bloch bands,
  as numpy arrays (no time integration);
- :func:`refined_surface` — a refined surface (a two-field ``refine`` search) interpolated as
  the search estimated its error;
- :func:`example_path`, :func:`examples`, :func:`docs_path` — the example sweep files and the
  user guides installed with the package (``example_path("mass-damping")``,
  ``docs_path("REFERENCE")``: every field of a sweep file).

Installing the package also installs the ``chainsweep`` command (``chainsweep --help``), the
native binary's command line run by the same engine.

Errors: :class:`InputError` (bad input; ``.field`` names the field), :class:`RunError` (a run
failed; ``.reason``), :class:`SweepError` (I/O, a locked output), :class:`DamagedFileError` (a
result file whose values do not match their checksums; ``.damaged``); all are :class:`Error`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._chainsweep import ENGINE_VERSION as __version__
from ._files import docs_path, example_path, examples
from .errors import DamagedFileError, Error, InputError, RunError, SweepError

if TYPE_CHECKING:
    from ._open import open
    from ._plot import plot
    from ._run import run
    from ._spectrum import spectrum
    from ._surface import refined_surface
    from ._sweep import Failure, SweepResult, sweep

# Imported on first use, with numpy, h5py and xarray (a third of a second): the `chainsweep`
# command (chainsweep._cli) needs none of them.
_LAZY = {
    "open": "._open",
    "plot": "._plot",
    "run": "._run",
    "refined_surface": "._surface",
    "spectrum": "._spectrum",
    "sweep": "._sweep",
    "SweepResult": "._sweep",
    "Failure": "._sweep",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

__all__ = [
    "run",
    "sweep",
    "open",
    "plot",
    "refined_surface",
    "spectrum",
    "example_path",
    "examples",
    "docs_path",
    "SweepResult",
    "Failure",
    "Error",
    "InputError",
    "RunError",
    "SweepError",
    "DamagedFileError",
    "__version__",
]
