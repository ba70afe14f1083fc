"""The interpolant of a refined surface (a `refine` search over two fields), as the search
estimated its error: bilinear on the cells of its tree."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

# Lattice units per first-scan cell: exact midpoints down to 2^-20 of a scan cell.
_UNIT = 2**20


def refined_surface(ds: Any, x: Any, y: Any) -> np.ndarray:
    """The refined surface of a two-field ``refine`` search at the points ``(x, y)`` (arrays of
    the searched fields' values, broadcast together), interpolated bilinearly on the cells of
    the refinement: the interpolant whose error the search estimated (``refine_error``).

    ``ds`` is the search's Dataset from :func:`chainsweep.open`, taken at one outer point when
    the sweep has outer axes (``ds.sel(striker_velocity_m_s=1.3)``). Starting from the first
    scan's cells, a cell is halved along a field wherever the midpoints of both its edges across
    that field were sampled (into four where its centre was too), and each cell is interpolated
    from its corners. Points outside the searched box are NaN."""
    sweep = json.loads(ds.attrs["sweep"])
    search = sweep.get("search") or {}
    fields = search.get("fields", [])
    if search.get("goal") != "refine" or len(fields) != 2:
        raise ValueError("refined_surface reads a refine search over two fields")
    scan = search.get("scan", 5)
    scan = list(scan) if isinstance(scan, list) else [scan, scan]
    names = [f.get("name") or f["field"].split(".")[-1] for f in fields]
    for n in names:
        if ds[n].ndim != 1:
            raise ValueError(f"take the Dataset at one outer point first: {n} has dimensions {ds[n].dims}")

    def lattice(v: np.ndarray, f: dict, n: int) -> np.ndarray:
        return np.round((v - f["min"]) / (f["max"] - f["min"]) * (n - 1) * _UNIT)

    xs, ys, zs = (np.asarray(ds[v].values, dtype=float) for v in (*names, "objective"))
    keep = np.isfinite(xs) & np.isfinite(ys)
    la = lattice(xs[keep], fields[0], scan[0]).astype(np.int64)
    lb = lattice(ys[keep], fields[1], scan[1]).astype(np.int64)
    samples = dict(zip(zip(la.tolist(), lb.tolist()), zs[keep].tolist()))
    leaves: list[tuple[int, int, int, int]] = []
    stack = [(i * _UNIT, (i + 1) * _UNIT, j * _UNIT, (j + 1) * _UNIT)
             for i in range(scan[0] - 1) for j in range(scan[1] - 1)]
    while stack:
        a0, a1, b0, b1 = stack.pop()
        am, bm = (a0 + a1) // 2, (b0 + b1) // 2
        along_a = a1 - a0 >= 2 and (am, b0) in samples and (am, b1) in samples
        along_b = b1 - b0 >= 2 and (a0, bm) in samples and (a1, bm) in samples
        if along_a and along_b and (am, bm) in samples:
            stack += [(a0, am, b0, bm), (am, a1, b0, bm), (a0, am, bm, b1), (am, a1, bm, b1)]
        elif along_a:
            stack += [(a0, am, b0, b1), (am, a1, b0, b1)]
        elif along_b:
            stack += [(a0, a1, b0, bm), (a0, a1, bm, b1)]
        else:
            leaves.append((a0, a1, b0, b1))
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    pa = lattice(x, fields[0], scan[0])
    pb = lattice(y, fields[1], scan[1])
    out = np.full(x.shape, np.nan)
    # Larger cells first: on an edge shared with smaller cells (whose corners lie on it) the
    # smaller cells' values stand, so that the interpolant passes through every sample.
    leaves.sort(key=lambda c: (c[1] - c[0]) * (c[3] - c[2]), reverse=True)
    for a0, a1, b0, b1 in leaves:
        m = (pa >= a0) & (pa <= a1) & (pb >= b0) & (pb <= b1)
        if not m.any():
            continue
        u, v = (pa[m] - a0) / (a1 - a0), (pb[m] - b0) / (b1 - b0)
        f = [samples.get(k, np.nan) for k in ((a0, b0), (a1, b0), (a0, b1), (a1, b1))]
        out[m] = f[0] * (1 - u) * (1 - v) + f[1] * u * (1 - v) + f[2] * (1 - u) * v + f[3] * u * v
    return out
