"""Two-parameter sweeps of a family's multipliers, on local cores or a Dask cluster.

A sweep is split into rows (one task per value of the y parameter); every task evaluates
its points with the precompiled variational runtime (built once per machine, loaded by
each worker), so a point's result is the same arithmetic whichever process or machine
ran it: serial, local processes and Dask give identical
arrays (the tests compare them bit for bit).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .. import parallel
from ..progress import Bar
from ..scene.overrides import decimal_grid
from .families import FamilyError, family, member
from .floquet import UNIT_TOL

MAX_POINTS = 250_000


@dataclass(frozen=True)
class Axis:
    name: str
    lo: float
    hi: float
    n: int

    @cached_property
    def values(self) -> np.ndarray:
        """The decimal grid lo:hi:n as typed (0.1:0.9:17 has 0.3, not linspace's
        0.30000000000000004), shared with ``derive simulate --sweep``; computed once
        (3 ms for 2000 values), read only."""
        values = np.array(decimal_grid(self.lo, self.hi, self.n))
        values.flags.writeable = False
        return values

    def __str__(self) -> str:
        return f"{self.name}={self.lo:g}:{self.hi:g}:{self.n}"


def parse_axis(text: str, family_name: str, where: str) -> Axis:
    """``name=lo:hi:n`` (n points from lo to hi inclusive)."""
    fam = family(family_name)
    name, sep, rng = text.partition("=")
    name = name.strip()
    if not sep:
        raise FamilyError(where, f"must be name=lo:hi:n, e.g. a=0:0.5:41 (got {text!r})")
    if name not in fam.parameters:
        raise FamilyError(where, f"{name!r} is not a parameter of family {fam.name} "
                                 f"(parameters: {', '.join(fam.parameters)})")
    parts = rng.split(":")
    if len(parts) != 3:
        raise FamilyError(where, f"range must be lo:hi:n (got {rng!r})")
    try:
        lo, hi = float(parts[0]), float(parts[1])
        n = int(parts[2])
    except ValueError:
        raise FamilyError(where, f"lo and hi must be numbers and n an integer "
                                 f"(got {rng!r})") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or not hi > lo:
        raise FamilyError(where, f"needs finite lo < hi (got {lo:g}, {hi:g})")
    if not 2 <= n <= 2000:
        raise FamilyError(where, f"n must be in [2, 2000] (got {n})")
    rule = fam.axis_rule(name, lo, hi) if hasattr(fam, "axis_rule") else None
    if rule:
        raise FamilyError(where, rule)
    return Axis(name, lo, hi, n)


def parse_settings(texts, where: str = "--set") -> dict:
    """Every ``name=value`` of a repeated ``--set``, a name set twice refused (as
    ``derive simulate`` refuses a field set twice)."""
    out: dict = {}
    for text in texts or []:
        name, value = parse_setting(text, where)
        if name in out:
            raise FamilyError(where, f"{name!r} is set twice ({out[name]:g}, then "
                                     f"{value:g}): give it once")
        out[name] = value
    return out


def parse_setting(text: str, where: str = "--set") -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep:
        raise FamilyError(where, f"must be name=value (got {text!r})")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise FamilyError(where, f"value of {name.strip()!r} must be a number "
                                 f"(got {value!r})") from None


@dataclass
class Sweep:
    family: str
    x: Axis
    y: Axis
    fixed: dict
    rtol: float
    max_modulus: np.ndarray          # (ny, nx); NaN where no body has the parameters
    jordan: np.ndarray               # (ny, nx) 1 where critical with a Jordan block at 1
    drift: np.ndarray                # (ny, nx) |q(T) - q(0)| of the base rotation
    executor: str = "serial"
    workers: int = 1
    seconds: float = 0.0
    library: str = ""
    tol: float = 0.0
    meta: dict = field(default_factory=dict)

    def values_of(self, name: str) -> np.ndarray:
        return self.x.values if self.x.name == name else self.y.values


def _row(task: tuple) -> np.ndarray:
    """One row of the grid (runs in a worker): an (nx, 3) array (NaN where no body or no
    orbit has the parameters)."""
    name, rtol, j, points = task
    fam = family(name)
    mb = member(name, rtol)
    out = np.full((len(points), 3), np.nan)
    for i, given in enumerate(points):
        try:
            values = fam.values(given)
        except FamilyError:
            continue
        out[i] = mb.point(values)
    return out


def tasks(name: str, x: Axis, y: Axis, fixed: dict, rtol: float):
    """One task per row: the parameters each point gives (the rest are defaults)."""
    return [(name, rtol, j,
             [{**fixed, x.name: float(xv), y.name: float(yv)} for xv in x.values])
            for j, yv in enumerate(y.values)]


def run(name: str, x: Axis, y: Axis, fixed: dict | None = None, rtol: float = 1e-12,
        workers: int | None = None, scheduler: str | None = None,
        progress: bool = True) -> Sweep:
    """Sweep ``x`` against ``y`` with the other parameters at ``fixed`` or their
    defaults.  ``workers``: local processes (default: every core; 1 runs in this
    process); ``scheduler``: a Dask scheduler address (tcp://host:port) instead."""
    fixed = dict(fixed or {})
    if x.name == y.name:
        raise FamilyError("--y", f"sweeps {y.name!r} like --x; choose another parameter")
    for ax in (x, y):
        if ax.name in fixed:
            raise FamilyError("--set", f"{ax.name!r} is swept; it cannot also be fixed")
    if hasattr(family(name), "one_view"):
        family(name).one_view({x.name, y.name, *fixed}, "--x/--y/--set")
    if x.n * y.n > MAX_POINTS:
        raise FamilyError("--x/--y", f"{x.n * y.n} points exceed {MAX_POINTS}")
    family(name).values(fixed)                          # check the fixed values early
    start = time.perf_counter()
    from ..runtime.build import library
    lib = str(library("variational").path)           # built once per machine, here
    work = tasks(name, x, y, fixed, rtol)
    grid = np.full((y.n, x.n, 3), np.nan)
    bar = Bar(f"sweeping {name}", progress, delay=0.5)
    done = 0

    def collect(j, rows):
        nonlocal done
        done += 1
        bar.update(done / len(work), f"{done}/{len(work)} rows")

    try:
        rows, executor, n_workers = parallel.run(_row, work, workers, scheduler, collect)
    except parallel.ExecutorError as exc:
        raise FamilyError(exc.where, exc.rule) from None
    for j, r in enumerate(rows):
        grid[j] = r
    bar.close()
    return Sweep(name, x, y, fixed, rtol, grid[..., 0], grid[..., 1], grid[..., 2],
                 executor=executor, workers=n_workers, seconds=time.perf_counter() - start,
                 library=lib, tol=UNIT_TOL)
