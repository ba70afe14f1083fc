"""Type stubs of the native module (python/src/): see chainsweep.run, chainsweep.sweep and chainsweep.spectrum."""

from collections.abc import Callable
from typing import Any

ENGINE_VERSION: str
SOLVER_VERSION: str
NUMERICS_VERSION: int
GIT_REVISION: str
DEFAULT_CHECKPOINT_INTERVAL_S: float
DEFAULT_PROGRESS_INTERVAL_S: float

def run_scene(scene: Any, record: Any = None, limits: Any = None) -> dict[str, Any] | None: ...
def spectrum(
    scene: str | None = None,
    path: str | None = None,
    index: int = 0,
    modes: bool = True,
    cell_particles: int | None = None,
    dispersion_points: int = 101,
    damped: bool = False,
) -> dict[str, Any]: ...
def run_sweep(
    file: str,
    output: str,
    jobs: int | None = None,
    shard: str | None = None,
    retry_failed: bool = False,
    verify: float | None = None,
    checkpoint_interval: float | None = None,
    progress: Callable[[int, int, int], Any] | None = None,
) -> tuple[int, int]: ...
def check_file(path: str, histories: bool = False) -> dict[str, Any]: ...
def read_unchecked(path: str, name: str) -> tuple[bytes, str, list[int]]: ...
def cli_main(argv: list[str]) -> int: ...
