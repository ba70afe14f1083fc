"""Scenes and sweeps as the JSON the runner reads: numpy scalars and arrays allowed, NaN and
infinities refused with the path of the field that holds them."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .errors import InputError


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON")


def _non_finite(value: Any, path: str) -> str | None:
    """The path of the first NaN or infinity in `value`, if any."""
    if isinstance(value, (float, np.floating)):
        return None if math.isfinite(value) else path
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, Mapping):
        for k, v in value.items():
            found = _non_finite(v, f"{path}.{k}" if path else str(k))
            if found is not None:
                return found
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            found = _non_finite(v, f"{path}[{i}]")
            if found is not None:
                return found
    return None


def dumps(value: Any, field: str = "", indent: int | None = 2) -> str:
    """JSON text of `value`; `field` is its path, used to name a field that cannot be JSON.
    `indent=None`: compact (for the engine, which keeps no text of it)."""
    try:
        return json.dumps(value, default=_plain, allow_nan=False, indent=indent)
    except ValueError:
        # A NaN or an infinity somewhere (json names no path): found and named.
        bad = _non_finite(value, field)
        if bad is not None:
            raise InputError(bad, "must be a finite number (NaN and infinities are not JSON)") from None
        raise
    except TypeError as e:
        raise InputError(field, f"cannot be written as JSON: {e}") from None
