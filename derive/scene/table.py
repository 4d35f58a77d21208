"""Point laws given as samples ``(t, x, y, z)``: a C^2 cubic spline through them.

Robot trajectories come from planners as samples.  A table is read from a CSV file (a
header row naming at least ``t, x, y, z``; other columns are ignored) or given inline,
and interpolated per coordinate by a cubic spline (SciPy's ``CubicSpline``: the
coefficients are computed once here; the C runtime and NumPy evaluate the same
piecewise polynomials):

* ``periodic``: the law repeats with period ``t_last - t_first`` (the last row must
  equal the first); the run may be longer than the table;
* ``rest``: P at rest at both ends (clamped spline, zero end velocity);
* ``free``: not-a-knot spline.

For ``rest`` and ``free`` the run must stay inside ``[t_first, t_last]``.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

import numpy as np

from .law import LawError, LawSummary, summarise

ENDS = ("periodic", "rest", "free")
MAX_ROWS = 100_000          # as inline samples: validation stays under a second
MAX_BYTES = 64 * 1024 * 1024


@dataclass(eq=False)
class TableLaw:
    knots: np.ndarray          # (n,)
    coef: np.ndarray           # (n - 1, 3, 4): c0 s^3 + c1 s^2 + c2 s + c3, s = t - t_i
    ends: str
    source: str                # what the table came from, for messages and summaries

    kind = "table"

    @property
    def t_first(self) -> float:
        return float(self.knots[0])

    @property
    def t_last(self) -> float:
        return float(self.knots[-1])

    @property
    def periodic(self) -> bool:
        return self.ends == "periodic"

    def is_zero(self, k: int) -> bool:
        return not np.any(self.coef[:, k, :])

    def is_constant(self, k: int) -> bool:
        return not np.any(self.coef[:, k, :3])

    def constant(self, k: int) -> float:
        return float(self.coef[0, k, 3]) if self.is_constant(k) else math.nan

    def jets(self, ts) -> np.ndarray:
        """(9, N): x, x', x'', y, y', y'', z, z', z'' at the times ``ts``."""
        ts = np.asarray(ts, dtype=float).reshape(-1)
        t0, t1 = self.t_first, self.t_last
        tt = t0 + np.mod(ts - t0, t1 - t0) if self.periodic else np.clip(ts, t0, t1)
        i = np.clip(np.searchsorted(self.knots, tt, side="right") - 1, 0, len(self.knots) - 2)
        s = tt - self.knots[i]
        c = self.coef[i]                                     # (N, 3, 4)
        c0, c1, c2, c3 = c[..., 0], c[..., 1], c[..., 2], c[..., 3]
        s = s[:, None]
        x = ((c0 * s + c1) * s + c2) * s + c3
        dx = (3.0 * c0 * s + 2.0 * c1) * s + c2
        ddx = 6.0 * c0 * s + 2.0 * c1
        return np.stack([x, dx, ddx], axis=2).reshape(len(ts), 9).T.copy()

    def point(self, t: float) -> np.ndarray:
        """u = (x, y, z, x', y', z', x'', y'', z'') at one time."""
        return self.jets([t])[:, 0].reshape(3, 3).T.reshape(-1)

    def arrays(self) -> dict:
        return {"knots": np.ascontiguousarray(self.knots, dtype=float),
                "coef": np.ascontiguousarray(self.coef.reshape(-1), dtype=float)}

    def sympy(self) -> tuple:
        raise LawError("is a table: the symbolic tools need a formula law")

    @property
    def text(self) -> tuple:
        return (f"table {self.source}",) * 3

    def check_run(self, t0: float, t1: float) -> None:
        if self.periodic:
            return
        slack = 1e-12 * max(1.0, abs(self.t_last))
        if t0 < self.t_first - slack or t1 > self.t_last + slack:
            raise LawError(f"covers t in [{self.t_first:.6g}, {self.t_last:.6g}] but the run "
                           f"spans [{t0:.6g}, {t1:.6g}] (use ends = \"periodic\" to repeat it)")

    def summary(self, t0: float, t1: float) -> LawSummary:
        mids = 0.5 * (self.knots[1:] + self.knots[:-1])
        ts = np.sort(np.concatenate([self.knots, mids]))
        if not self.periodic:
            ts = ts[(ts >= t0) & (ts <= t1)]
            ts = np.concatenate([[t0], ts, [t1]])
        return summarise(self.jets(ts))


def read_rows(text: str, where: str, names: tuple = ("t", "x", "y", "z")) -> np.ndarray:
    """(n, len(names)) samples of the columns ``names`` (t, x, y, z; a rotor's t, psi)
    from CSV text with a header row."""
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except StopIteration:
        raise LawError(f"{where} is empty") from None
    except csv.Error as exc:
        raise LawError(f"{where}: not a readable CSV table ({str(exc)[:80]})") from None
    header = [h.strip() for h in header]
    cols = []
    for name in names:
        if name not in header:
            raise LawError(f"{where}: the header row has no column {name!r} "
                           f"(found {', '.join(repr(h[:20]) for h in header[:10])})")
        cols.append(header.index(name))
    rows = []
    try:
        for line, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(rows) >= MAX_ROWS:
                raise LawError(f"{where} has more than {MAX_ROWS} rows")
            try:
                values = [float(row[c]) for c in cols]
            except (IndexError, ValueError):
                raise LawError(f"{where}, line {line}: {', '.join(names)} must be "
                               "numbers") from None
            rows.append(values)
    except csv.Error as exc:             # a field beyond the csv module's limit, ...
        raise LawError(f"{where}: not a readable CSV table ({str(exc)[:80]})") from None
    return np.array(rows, dtype=float).reshape(-1, len(names))


def build(samples, ends: str, source: str) -> TableLaw:
    """The spline through ``samples`` ((n, 4): t, x, y, z) with the given ends."""
    from scipy.interpolate import CubicSpline
    data = np.asarray(samples, dtype=float)
    if data.ndim != 2 or data.shape[1] != 4:
        raise LawError("samples must be rows of four numbers: t, x, y, z")
    if not np.all(np.isfinite(data)):
        bad = int(np.argwhere(~np.isfinite(data))[0][0])
        raise LawError(f"row {bad + 1} of the samples is not finite")
    if len(data) < 4:
        raise LawError(f"needs at least 4 samples (got {len(data)})")
    t = data[:, 0]
    dt = np.diff(t)
    if not np.all(dt > 0):
        bad = int(np.argmax(~(dt > 0)))
        raise LawError(f"times must increase strictly (row {bad + 2}: t = {t[bad + 1]:.6g} "
                       f"after {t[bad]:.6g})")
    if np.min(dt) < 1e-12 * max(1.0, float(np.max(np.abs(t)))):
        raise LawError("two samples are closer in time than 1e-12 of the table's span")
    xyz = data[:, 1:].copy()
    if ends == "periodic":
        scale = max(1.0, float(np.max(np.abs(xyz))))
        gap = float(np.max(np.abs(xyz[-1] - xyz[0])))
        if gap > 1e-9 * scale:
            raise LawError(f"ends = \"periodic\" needs the last row to equal the first "
                           f"(they differ by {gap:.3g})")
        xyz[-1] = xyz[0]
        bc = "periodic"
    elif ends == "rest":
        bc = "clamped"
    elif ends == "free":
        bc = "not-a-knot"
    else:
        raise LawError(f"ends must be one of {', '.join(ENDS)} (got {ends!r})")
    spline = CubicSpline(t, xyz, bc_type=bc, axis=0)
    coef = np.ascontiguousarray(np.transpose(spline.c, (1, 2, 0)))   # (n-1, 3, 4)
    if not np.all(np.isfinite(coef)):
        raise LawError("the spline through the samples is not finite")
    return TableLaw(knots=t.copy(), coef=coef, ends=ends, source=source)
