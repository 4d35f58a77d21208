"""Long time series drawn as a pixel can show them: per pixel column of a panel, the
lowest and highest sample (:func:`envelope`), drawn as a translucent band between two
edges (:func:`draw`).  A run of 21,834 impacts over 10^4 s has 2 10^5 rows: at 350
pixels, drawn row by row, a curve is a zigzag of hundreds of rows per column that covers
every curve under it; the band is one polygon, and a curve under another shows through
it.  A series with few rows per column is drawn as its plain line.

Also :func:`distinct`, the markers of many points one per cell finer than a pixel, and
:func:`energy_drift`, the total energy's drift in flight, drawn under the energy's
components in ``overview.png``.
"""
from __future__ import annotations

import numpy as np

# more rows than this per pixel column (on average): the band; fewer: the plain line
DENSE = 8.0
BAND_ALPHA = 0.3


def envelope(t: np.ndarray, y: np.ndarray, columns: int, span=None) -> tuple:
    """``(edges, lo, hi)``: ``columns`` equal intervals of time over ``span`` (default the
    rows' own, ``t`` ascending), ``edges`` their ``columns + 1`` bounds, and in each the
    lowest and highest finite sample of ``y`` (NaN in a column without one).  A column
    holds the rows with ``edges[k] <= t < edges[k + 1]``; the last also its right end."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    t0, t1 = (float(t[0]), float(t[-1])) if span is None else map(float, span)
    edges = np.linspace(t0, t1, columns + 1)
    starts = np.searchsorted(t, edges[:-1], side="left")
    ends = np.r_[starts[1:], np.searchsorted(t, t1, side="right")]
    full = ends > starts
    lo = np.full(columns, np.nan)
    hi = np.full(columns, np.nan)
    if full.any():
        # the rows of the non-empty columns are contiguous: one reduceat each; fmin and
        # fmax skip NaN (a column of NaN only stays NaN)
        at = starts[full]
        last = int(ends[full][-1])
        lo[full] = np.fmin.reduceat(y[:last], at)
        hi[full] = np.fmax.reduceat(y[:last], at)
    return edges, lo, hi


def dense(n: int, columns: int) -> bool:
    return n > DENSE * columns


def draw(ax, t, y, colour, columns: int, lw: float = 1.0, zorder: float = 2.0,
         span=None) -> None:
    """``y`` against ``t`` on ``ax``: its plain line when it has few rows per pixel
    column, else its :func:`envelope` as a band (translucent, so that what lies under it
    shows) between its lower and upper edge (full colour: a slow stretch, where they
    meet, is a line)."""
    t = np.asarray(t, dtype=float)
    if not dense(len(t), columns):
        ax.plot(t, y, lw=lw, color=colour, zorder=zorder)
        return
    edges, lo, hi = envelope(t, y, columns, span)
    x = 0.5 * (edges[:-1] + edges[1:])   # each column's extremes at its middle (a pixel)
    ax.fill_between(x, lo, hi, color=colour, alpha=BAND_ALPHA, lw=0, zorder=zorder)
    for edge in (lo, hi):
        ax.plot(x, edge, lw=min(lw, 0.8), color=colour, zorder=zorder + 0.01)


def distinct(points: np.ndarray, cells: int = 1000) -> np.ndarray:
    """The markers worth drawing of ``points`` (rows of x, y): one per occupied cell of a
    grid of ``cells`` across the points' larger span (finer than a panel's pixels, so
    the picture is the same); 21,834 impact points drawn one by one took a second."""
    if len(points) <= cells:
        return points
    lo = points.min(axis=0)
    size = float(np.ptp(points, axis=0).max()) / cells or 1.0
    _, first = np.unique(np.floor((points - lo) / size).astype(np.int64), axis=0,
                         return_index=True)
    return points[np.sort(first)]


def energy_drift(trace, E0: float, t0: float) -> tuple | None:
    """The total energy's drift in flight from the balance's ``trace`` (each flight's
    ``(t at its end, E's change - the drives' work)``, of
    :func:`~derive.runtime.motion.energy_balance`): ``(t, drift)``, the running sum at the
    flights' ends relative to ``|E0|``, from 0 at ``t[0]`` (the first flight's start is
    the run's).  The jumps at events (an impact's loss, a drive's impulsive work) and the
    contact phases are no part of it; its last value is the balance's residual when the run
    has no contact phase.  None without a flight or with ``E0 = 0``."""
    if not trace or not abs(E0) > 0:
        return None
    t_end, share = np.asarray(trace, dtype=float).T
    return np.r_[t0, t_end], np.r_[0.0, np.cumsum(share)] / abs(E0)
