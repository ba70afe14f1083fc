"""chainsweep.sweep: a sweep file (or dict) run into HDF5, resumable, with progress."""

from __future__ import annotations

import os
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

from . import _chainsweep as _native
from . import _layout as L
from ._json import dumps
from ._open import PathLike, _Grid, _read, _value
from ._open import open as _open
from .errors import InputError

try:
    from tqdm.auto import tqdm as _tqdm
except ImportError:  # progress then shows as plain lines
    _tqdm = None

#: A progress callback: ``callback(done, failed, total)``.
ProgressCallback = Callable[[int, int, int], None]

#: Exit codes of the runner (the command line's).
EXIT_OK = 0
EXIT_PARTIAL = 3


@dataclass(frozen=True)
class Failure:
    """A failed grid point: flat index (row-major), axis values, why it failed."""

    index: int
    point: dict[str, Any]
    reason: str


@dataclass(frozen=True)
class SweepResult:
    """What :func:`chainsweep.sweep` did. ``os.fspath(result)`` is the output file."""

    path: Path
    """The output HDF5 file."""
    exit_code: int
    """The command line's exit code: 0 every run succeeded, 3 some failed, did not settle or are
    pending."""
    n_runs: int
    """Grid points of the sweep (of the shard, with ``shard``)."""
    n_ok: int
    n_failed: int
    n_pending: int
    ran: int
    """Runs made by this call (0 when the sweep was finished already)."""
    failures: list[Failure] = field(default_factory=list)
    """Every failed point, with its reason."""
    n_unsettled: int = 0
    """Runs that finished but whose steady state did not settle (``status`` 3): their values
    are stored, but they are not the steady state asked for (lengthen ``settle_periods``)."""
    unsettled: list[int] = field(default_factory=list)
    """Their flat indices."""

    @property
    def complete(self) -> bool:
        """Whether every run of the sweep (or shard) succeeded (and settled)."""
        return self.n_failed == 0 and self.n_pending == 0 and self.n_unsettled == 0

    def open(self, histories: bool = False) -> xr.Dataset:
        """The result as a Dataset (:func:`chainsweep.open`)."""
        return _open(self.path, histories=histories)

    def __fspath__(self) -> str:
        return os.fspath(self.path)



# The most worker threads a sweep takes (the engine's own limit is far above any machine).
_MOST_JOBS = 4096

# Keys whose string values name files relative to the sweep file.
_PATH_KEYS = ("path", "from_fit")


def _paths_from(value: Any, base: Path) -> Any:
    """`value` with every relative file name (a `path` or `from_fit` string) made absolute from
    `base`."""
    if isinstance(value, Mapping):
        return {
            k: str(base / v) if k in _PATH_KEYS and isinstance(v, str) and not os.path.isabs(v)
            else _paths_from(v, base)
            for k, v in value.items()
        }
    if isinstance(value, list):
        return [_paths_from(v, base) for v in value]
    return value

def _duration(secs: float) -> str:
    if not np.isfinite(secs):
        return "?"
    s = int(round(secs))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class _PlainProgress:
    """A line on stderr every `every` seconds and at the end (the command line's plain format)."""

    def __init__(self, every: float = _native.DEFAULT_PROGRESS_INTERVAL_S):
        self.every = every
        self.start = time.monotonic()
        self.last = self.start
        self.first: int | None = None
        self.state = (0, 0, 0)

    def __call__(self, done: int, failed: int, total: int) -> None:
        if self.first is None:  # the state before anything ran
            self.first = done
        self.state = (done, failed, total)
        now = time.monotonic()
        if now - self.last >= self.every:
            self.last = now
            self._line()

    def _line(self) -> None:
        done, failed, total = self.state
        elapsed = time.monotonic() - self.start
        rate = (done - (self.first or 0)) / elapsed if elapsed > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else float("nan")
        print(
            f"chainsweep: {done}/{total} runs done, {failed} failed, {rate:.1f} runs/s, "
            f"elapsed {_duration(elapsed)}, ETA {_duration(eta)}",
            file=sys.stderr,
            flush=True,
        )

    def write(self, line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.first is not None:
            self._line()


class _BarProgress:
    """A tqdm bar (a widget in a notebook, text in a terminal)."""

    def __init__(self, bar_factory: Callable[..., Any]):
        self.factory = bar_factory
        self.bar: Any = None

    def __call__(self, done: int, failed: int, total: int) -> None:
        if self.bar is None:
            self.bar = self.factory(
                total=total, initial=done, unit="run", desc="chainsweep", dynamic_ncols=True
            )
        if self.bar.total != total:
            self.bar.total = total
        self.bar.update(done - self.bar.n)
        self.bar.set_postfix(failed=failed, refresh=False)

    def write(self, line: str) -> None:
        if self.bar is not None:
            self.bar.write(line, file=sys.stderr)
        else:
            print(line, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _interactive() -> bool:
    """Whether a bar can be drawn: a terminal, or a notebook (where tqdm.auto draws a widget).
    Elsewhere (nohup, SLURM, CI logs) plain lines, as the command line prints them."""
    return sys.stderr.isatty() or "ipykernel" in sys.modules


def _display(progress: bool | ProgressCallback | None) -> Any:
    if progress is None or progress is False:
        return None
    if progress is True:
        return _BarProgress(_tqdm) if _tqdm is not None and _interactive() else _PlainProgress()
    if callable(progress):
        return progress
    raise TypeError(f"progress must be True, False or a callable(done, failed, total), got {progress!r}")


def _shard_text(shard: str | tuple[int, int] | None) -> str | None:
    if shard is None or isinstance(shard, str):
        return shard
    try:
        k, n = shard
        return f"{int(k)}/{int(n)}"
    except (TypeError, ValueError):
        raise InputError("shard", f"must be (K, N) or 'K/N' with 1 <= K <= N, got {shard!r}") from None


def _summary(path: Path, exit_code: int, ran: int) -> SweepResult:
    """LAYOUT (root attributes n_runs/n_ok/n_failed/n_pending, status, reason)."""
    with h5py.File(path, "r") as f:
        grid = _Grid(f)
        # LAYOUT: a periodic sweep's branches are its runs (branch_status: 0 pending, 1 ended,
        # 2 failed; branch_end: why).
        periodic = "periodic" in f.attrs
        status = f["branch_status" if periodic else "status"][()].ravel()
        failed = np.flatnonzero(status == L.STATUS_FAILED)
        reason = "branch_end" if periodic else "reason"
        reasons = _read(f[reason])[0].ravel() if failed.size else []
        failures = []
        for i in failed:
            mi = np.unravel_index(int(i), grid.shape)
            point = {
                name: _value(values[mi[grid.dims.index(dim)]])
                for name, (dim, values, _) in grid.coords.items()
                if dim in grid.dims
            }
            failures.append(Failure(int(i), point, str(reasons[i])))
        return SweepResult(
            path=path,
            exit_code=exit_code,
            n_runs=int(f.attrs["n_runs"]),
            n_ok=int(f.attrs["n_ok"]),
            n_failed=int(f.attrs["n_failed"]),
            n_pending=int(f.attrs["n_pending"]),
            ran=ran,
            failures=failures,
            n_unsettled=int(f.attrs.get("n_unsettled", 0)),
            unsettled=[int(i) for i in np.flatnonzero(status == L.STATUS_UNSETTLED)],
        )


def sweep(
    spec: PathLike | Mapping[str, Any],
    output: PathLike,
    jobs: int | None = None,
    verify: float | None = None,
    retry_failed: bool = False,
    progress: bool | ProgressCallback = True,
    *,
    shard: str | tuple[int, int] | None = None,
    ensemble_round: int | None = None,
    checkpoint_interval: float = _native.DEFAULT_CHECKPOINT_INTERVAL_S,
) -> SweepResult:
    """Runs a sweep into an HDF5 file, in this process, exactly as ``chainsweep run`` does.

    ``spec`` is a sweep file's path or its JSON as a dict (base, record, axes, limits; every
    field in ``chainsweep.docs_path("REFERENCE")``; examples installed with the package:
    ``chainsweep.example_path(name)``). ``output`` is the HDF5 file; its work directory
    ``OUTPUT.d/`` holds every finished run, so calling ``sweep`` again with the same arguments
    resumes an interrupted sweep and runs nothing once it is complete; editing the sweep reruns
    exactly the points whose scene changed. ``jobs``: parallel runs (default: ``SLURM_CPUS_PER_TASK``, else every CPU this process may use);
    ``verify``: the fraction of points re-run at a tighter setting (``--verify``);
    ``retry_failed``: run failed points again; ``shard``: ``(K, N)`` or ``"K/N"`` (K from 1), only
    shard K of N (the engine's balanced assignment, as ``chainsweep run --shard K/N``);
    ``ensemble_round``: with ``shard``, the round of an adaptive ensemble that the shard runs
    (``--ensemble-round``; default 0; the merge of every shard's file says whether another is
    due); ``checkpoint_interval``: seconds between refreshes of the output file
    while the sweep runs (0: only at the end).

    ``progress=True`` shows a tqdm bar (a widget in a notebook, a bar in a terminal) when tqdm is
    installed, else — and when stderr is neither, as under nohup or SLURM — a plain line on
    stderr every 10 s; ``False`` shows nothing; a callable is called as
    ``progress(done, failed, total)`` a few times a second. Failed runs are listed at
    the end (with ``progress``) and always in the result.

    Returns a :class:`SweepResult`: ``exit_code`` 0 when every run succeeded, 3 when some failed
    (each recorded in the file with its reason, NaN summaries; the sweep goes on) or are pending
    (a shard); counts, ``ran`` (runs made by this call) and ``failures``. Raises
    :class:`~chainsweep.InputError` for a bad sweep or argument (``.field``: e.g.
    ``axes[0].values[3]``, ``base.duration_s``, ``jobs``; nothing is run, created or modified),
    :class:`~chainsweep.SweepError` for anything else (I/O, the output locked by another
    process). Ctrl-C (or a notebook's interrupt) stops the sweep cleanly — runs in flight finish
    and are stored, the file is written with the rest pending — and raises
    ``KeyboardInterrupt``; the same call resumes.
    """
    display = _display(progress)
    output = Path(output)
    shard_text = _shard_text(shard)
    for name, value in (("jobs", jobs), ("checkpoint_interval", checkpoint_interval), ("verify", verify)):
        if isinstance(value, bool) or (value is not None and not isinstance(value, (int, float, np.number))):
            raise InputError(name, f"must be a number, got {value!r}")
    if jobs is not None and (jobs != int(jobs) or not 1 <= jobs <= _MOST_JOBS):
        raise InputError("jobs", f"must be a whole number from 1 to {_MOST_JOBS}, got {jobs}")
    if ensemble_round is not None and (
        isinstance(ensemble_round, bool) or not isinstance(ensemble_round, (int, np.integer)) or ensemble_round < 0
    ):
        raise InputError("ensemble_round", f"must be a whole number >= 0, got {ensemble_round!r}")
    with tempfile.TemporaryDirectory(prefix="chainsweep-") as tmp:
        if isinstance(spec, Mapping):
            # Written into a temporary folder: the files it names by relative path (a fit's
            # data, a recorded drive, a fit's result) are the working directory's, as run()
            # and a sweep file in the working directory find them.
            file = Path(tmp) / f"{output.stem}.json"
            file.write_text(dumps(_paths_from(dict(spec), Path.cwd())) + "\n")
        else:
            file = Path(spec)
        try:
            code, ran = _native.run_sweep(
                os.fspath(file),
                os.fspath(output),
                jobs=None if jobs is None else int(jobs),
                shard=shard_text,
                ensemble_round=None if ensemble_round is None else int(ensemble_round),
                retry_failed=bool(retry_failed),
                verify=None if verify is None else float(verify),
                checkpoint_interval=float(checkpoint_interval),
                progress=display,
            )
        except KeyboardInterrupt:
            if hasattr(display, "close"):
                display.close()
            print(
                f"chainsweep: interrupted; the runs finished so far are stored in {output} "
                "(call sweep() again to resume)",
                file=sys.stderr,
                flush=True,
            )
            raise
        except BaseException:
            if hasattr(display, "close"):
                display.close()
            raise
    if hasattr(display, "close"):
        display.close()
    result = _summary(output, code, ran)
    if display is not None and hasattr(display, "write") and result.failures:
        display.write(f"chainsweep: {len(result.failures)} failed run(s):")
        for fl in result.failures[:20]:
            where = " ".join(f"{k}={v}" for k, v in fl.point.items())
            display.write(f"  point {fl.index} ({where}): {fl.reason}")
        if len(result.failures) > 20:
            display.write(f"  … and {len(result.failures) - 20} more (result.failures)")
    return result
