"""Over a run ``[t0, t1]`` a law must have no singular point: interval arithmetic over
boxes of t, bisected where a box cannot be cleared, proves that no denominator vanishes,
that ``log``, ``sqrt`` and non-integer powers see positive arguments, ``asin``/``acos``
arguments inside (-1, 1) and ``tan`` no pole (:func:`find_singularity`).  These are
exactly the conditions under which x, x' and x'' exist and are continuous, so a law that
passes is C^2 on the whole run, not only on a grid of samples.  And what a run needs to
know about a point's law: :class:`LawSummary`."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import layout
from .ops import HALF_PI, OPS, iv_sine
from .program import Program

# ---- the whole run: interval arithmetic --------------------------------------------------
MAX_BOXES = 512
# a harmonic node's enclosure over a box of t: the sine's of its argument's box
_SINE = {"hsin": iv_sine(0.0), "hcos": iv_sine(HALF_PI)}


@dataclass(frozen=True)
class Singularity:
    coordinate: int
    t: float
    what: str


def shortest_in(lo: float, hi: float) -> float:
    """The number of fewest significant digits in [lo, hi] (0 when the box holds it): a
    singular point is reported as 0 or 1.5, not as the middle of the last box,
    4.54747351e-12 or 1.50000000000023."""
    lo, hi = float(lo), float(hi)
    if lo <= 0.0 <= hi:
        return 0.0
    mid = 0.5 * (lo + hi)
    for digits in range(1, 18):
        x = float(f"{mid:.{digits}g}")
        if lo <= x <= hi:
            return x
    return mid


def _entire(p: Program) -> bool:
    """Every node is an entire function of t (nothing to prove)."""
    return all(OPS[name].entire or (name == "powi" and p.consts[p.b[k]] > 0)
               for k, name in enumerate(p.ops))


def find_singularity(p: Program, t0: float, t1: float) -> Singularity | None:
    """The earliest point of [t0, t1] near which the law may not be twice continuously
    differentiable, or None when interval arithmetic proves it is everywhere.  A box is
    bisected while some node may be singular in it; a box narrower than 1e-12 of the run
    (or 1e-300) that still may be singular is reported."""
    if _entire(p):
        return None
    ops = p.ops
    width_min = max(1e-12 * (t1 - t0), 1e-12 * max(abs(t0), abs(t1)), 1e-300)
    edges = np.linspace(t0, t1, 65)
    lo_t, hi_t = edges[:-1], edges[1:]
    with np.errstate(all="ignore"):
        for _ in range(200):
            n = lo_t.size
            box: list = [None] * len(ops)
            bad = np.zeros(n, dtype=bool)
            first_bad = np.full(n, -1)
            for k, name in enumerate(ops):
                op = OPS[name]
                a, b = p.a[k], p.b[k]
                if op.shape == "const":
                    box[k] = (np.full(n, p.consts[a]),) * 2
                    continue
                if op.shape == "t":
                    box[k] = (lo_t, hi_t)
                    continue
                if op.shape == "harmonic":      # A sin(w t + p) (cos: p + pi/2) on the box
                    A, w, ph = p.consts[a:a + 3]
                    arg = (w * lo_t + ph, w * hi_t + ph) if w >= 0 else \
                        (w * hi_t + ph, w * lo_t + ph)
                    s_lo, s_hi, _ = _SINE[name](arg, None, 0.0)
                    box[k] = (A * s_lo, A * s_hi) if A >= 0 else (A * s_hi, A * s_lo)
                    continue
                lo, hi, flag = op.interval(box[a], box[b] if op.reads_b else None,
                                           p.consts[b] if op.shape == "power" else 0.0)
                box[k] = (lo, hi)
                new = flag & ~bad
                first_bad[new] = k
                bad |= flag
            if not bad.any():
                return None
            idx = np.flatnonzero(bad)
            narrow = idx[(hi_t[idx] - lo_t[idx]) <= width_min]
            if narrow.size:
                j = narrow[0]
                node = int(first_bad[j])
                return Singularity(p.coordinate_of(node), shortest_in(lo_t[j], hi_t[j]),
                                   OPS[ops[node]].singular or "a singular point")
            idx = idx[:MAX_BOXES]
            mid = 0.5 * (lo_t[idx] + hi_t[idx])
            lo_t = np.concatenate([lo_t[idx], mid])
            hi_t = np.concatenate([mid, hi_t[idx]])
            order = np.argsort(lo_t, kind="stable")
            lo_t, hi_t = lo_t[order], hi_t[order]
    return Singularity(0, float(lo_t[0]), "a point that could not be cleared")


# ---- what a run needs to know about its law ----------------------------------------------
@dataclass(frozen=True)
class LawSummary:
    """Facts about a law over a run, from its samples and the interval proof (a rotor's:
    the same of its angle psi, a vector of one coordinate)."""
    max_radius: float           # max |OP|
    max_speed: float            # max |OP'|
    max_acceleration: float     # max |OP''|
    amplitude: float            # max |OP - mean OP|
    time_scale: float           # sqrt(amplitude / max |OP''|) (inf for a still point)


SAMPLES = 4097


def summarise(jets: np.ndarray) -> LawSummary:
    """The summary of a law's jets: a point's (9, N) x, x', x'', y, ...; a rotor's (3,
    N) psi, psi', psi''."""
    if len(jets) == 9:
        r, v, a = (jets[list(rows)] for rows in (layout.JET_R, layout.JET_V, layout.JET_A))
    else:
        r, v, a = jets[0::3], jets[1::3], jets[2::3]
    with np.errstate(over="ignore", invalid="ignore"):     # huge laws: inf, then refused
        rn = np.sqrt((r * r).sum(0))
        amp = float(np.sqrt(((r - r.mean(axis=1, keepdims=True)) ** 2).sum(0)).max())
        acc = float(np.sqrt((a * a).sum(0)).max())
        speed = float(np.sqrt((v * v).sum(0)).max())
    scale = math.sqrt(amp / acc) if acc > 0 and amp > 0 and math.isfinite(acc) else math.inf
    return LawSummary(float(rn.max()), speed, acc, amp, scale)
