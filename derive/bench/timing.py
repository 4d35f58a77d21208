"""Timings with their spread, and targets judged on them: the one helper of every bench
for "compare two timings".

A timing on a shared machine is a distribution, not a number: a quantity is sampled
several times (each sample the least of a block of calls, so that a sample is the call's
cost at a quiet moment, and the samples' spread how quiet the machine was) and kept as
a :class:`Spread`, its median and interquartile range.  The clock is the calling
thread's CPU time (:data:`CPU`): the time other processes take from the thread is not
charged to it, which a wall clock charges to long calls (a SciPy run of 200 ms is never
without it, a C run of 50 us often is) and not to short ones; only what is about
parallelism (two workers against one) reads the wall clock (:data:`WALL`), and a
subprocess is charged its CPU time (:func:`children_cpu`).  Two timings compare through the
ratio of their spreads; paired samples (two routes timed in the same rounds, one after
the other, so that a burst of load hits both) give the spread of their ratios directly.

A target says its margin (``at most 1.3x``, ``at least 1000x``) and is judged by
:func:`judge`: met (PASS) when the median meets it, a tie (TIE, counted as met) when
the median misses it by less than the spread (the interquartile range reaches the
margin), missed (FAIL) only when the whole interquartile range is on the wrong side.
"""
from __future__ import annotations

import resource
import time
from dataclasses import dataclass

import numpy as np

from ..commands import Target


@dataclass(frozen=True)
class Spread:
    """A measured quantity: the median of its samples and their interquartile range."""
    median: float
    lo: float
    hi: float
    n: int = 1

    @classmethod
    def of(cls, samples) -> "Spread":
        x = np.asarray(samples, dtype=float)
        x = x[np.isfinite(x)]
        if not len(x):
            return cls(np.nan, np.nan, np.nan, 0)
        lo, mid, hi = np.percentile(x, [25, 50, 75])
        return cls(float(mid), float(lo), float(hi), len(x))

    def scaled(self, k: float) -> "Spread":
        """k times the quantity (k > 0)."""
        return Spread(self.median * k, self.lo * k, self.hi * k, self.n)

    def over(self, other: "Spread") -> "Spread":
        """The ratio of two quantities sampled apart: the ratio of the medians, between
        the least and the greatest ratio of their quartiles."""
        return Spread(self.median / other.median, self.lo / other.hi, self.hi / other.lo,
                      min(self.n, other.n))

    def inverse(self) -> "Spread":
        return Spread(1.0 / self.median, 1.0 / self.hi, 1.0 / self.lo, self.n)

    def text(self, fmt: str = ".3g", unit: str = "") -> str:
        """``1.04x (1.01-1.07)``: the median and the interquartile range."""
        return (f"{self.median:{fmt}}{unit} ({self.lo:{fmt}}-{self.hi:{fmt}})"
                if self.n > 1 else f"{self.median:{fmt}}{unit}")


def blend(a: Spread, b: Spread, w: float) -> Spread:
    """Between two spreads in log-log (a work-precision curve read between two runs): the
    median and each quartile interpolated alike, ``w`` = 0 at ``a``, 1 at ``b``."""
    def mix(x, y):
        return float(np.exp((1 - w) * np.log(x) + w * np.log(y)))
    return Spread(mix(a.median, b.median), mix(a.lo, b.lo), mix(a.hi, b.hi), min(a.n, b.n))


CPU = time.thread_time          # the calling thread's CPU time
WALL = time.perf_counter


def children_cpu() -> float:
    """The CPU time (user and system) of this process's finished child processes: the
    clock of a subprocess run."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def least_of(fn, block: int, clock=CPU) -> float:
    """The least time of ``block`` calls of ``fn``."""
    best = np.inf
    for _ in range(block):
        start = clock()
        fn()
        best = min(best, clock() - start)
    return best


def sampled(fn, samples: int, block: int = 1, clock=CPU) -> Spread:
    """``fn`` timed after a warm-up: ``samples`` samples, each the least of ``block``
    calls."""
    fn()
    return Spread.of([least_of(fn, block, clock) for _ in range(samples)])


def interleaved(fns: dict, samples: int, block: int = 1, wall: tuple = ()) -> dict:
    """Several routes sampled in rounds, one sample of each per round (a burst of load
    hits them alike): name -> the list of samples (pair them for the spread of a
    ratio: :func:`ratios`).  The routes named in ``wall`` are timed by the wall clock
    (parallel work), the others by the CPU clock."""
    for fn in fns.values():
        fn()
    out: dict = {name: [] for name in fns}
    for _ in range(samples):
        for name, fn in fns.items():
            out[name].append(least_of(fn, block, WALL if name in wall else CPU))
    return out


class PreparedRun:
    """One scene ready to run in C (prepared, its session built and its law set once): a
    call is one run of the C alone, what the benches time; ``raw`` is the first run's."""

    def __init__(self, doc: dict):
        from ..runtime.driver import prepare
        from ..runtime.session import Session
        self.prep = prepare(doc)
        self.session = Session(self.prep.library)
        self.session.set_law(self.prep.scene.runtime_law)
        self.raw = self()

    def __call__(self):
        p = self.prep
        return self.session.run(p.scene.t0, p.scene.duration, p.start.q0, p.options,
                                p.parameters)


def ratios(a: list, b: list) -> Spread:
    """The spread of the ratio of paired samples a_k / b_k."""
    return Spread.of(np.asarray(a, dtype=float) / np.asarray(b, dtype=float))


@dataclass(frozen=True)
class Judged(Target):
    """A target with its margin judged on a spread: ``tie`` when the median misses the
    margin within the interquartile range (counted as met, marked TIE)."""
    tie: bool = False

    @property
    def mark(self) -> str:
        return "TIE" if self.tie else super().mark


AT_MOST, AT_LEAST = "<=", ">="


def verdict(x: Spread, way: str, margin: float) -> str:
    """PASS when the median meets ``x way margin``, TIE when only the interquartile range
    reaches it, else FAIL."""
    if not np.isfinite(x.median):
        return "FAIL"
    if way == AT_MOST:
        return "PASS" if x.median <= margin else "TIE" if x.lo <= margin else "FAIL"
    return "PASS" if x.median >= margin else "TIE" if x.hi >= margin else "FAIL"


def judge(what: str, x: Spread, way: str, margin: float, fmt: str = ".3g",
          unit: str = "x") -> Judged:
    """``what: 1.04x (1.01-1.07; target <= 1.3x)``, judged."""
    v = verdict(x, way, margin)
    spread = f" ({x.lo:{fmt}}-{x.hi:{fmt}}; " if x.n > 1 else " ("
    return Judged(f"{what}: {x.median:{fmt}}{unit}{spread}target {way} {margin:g}{unit})",
                  v != "FAIL", v == "TIE")


SPREAD_NOTE = ("timings: CPU time of the calling thread (wall time for two workers against "
               "one), the median of repeated samples and their interquartile range; a target "
               "missed by the median within that range is a tie (TIE, met), not a failure")
