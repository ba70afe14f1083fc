"""chainsweep from Python: run scenes and sweeps of dissipative granular chains, read the results
as labelled xarray Datasets.

- :func:`run` — one scene (a sweep file's ``base`` as a dict) in this process, as a Dataset;
- :func:`sweep` — a sweep file or dict into an HDF5 file, resumable, with progress;
- :func:`open` — a result file as a Dataset labelled by the grid's axes and the probes;
- :func:`refined_surface` — a refined surface (a two-field ``refine`` search) interpolated as
  the search estimated its error;
- :func:`example_path`, :func:`examples`, :func:`docs_path` — the example sweep files and the
  user guides installed with the package (``example_path("mass-damping")``,
  ``docs_path("README-sweeps")``: every field of a sweep file).

Installing the package also installs the ``chainsweep`` command (``chainsweep --help``), the
native binary's command line run by the same engine.

Errors: :class:`InputError` (bad input; ``.field`` names the field), :class:`RunError` (a run
failed; ``.reason``), :class:`SweepError` (I/O, a locked output), :class:`DamagedFileError` (a
result file whose values do not match their checksums; ``.damaged``); all are :class:`Error`.
"""

from __future__ import annotations

from ._chainsweep import ENGINE_VERSION as __version__
from ._files import docs_path, example_path, examples
from ._open import open
from ._run import run
from ._surface import refined_surface
from ._sweep import Failure, SweepResult, sweep
from .errors import DamagedFileError, Error, InputError, RunError, SweepError

__all__ = [
    "run",
    "sweep",
    "open",
    "refined_surface",
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
