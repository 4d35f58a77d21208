"""Bardin and Panev's periodic modes (Rus. J. Nonlin. Dyn. 14(4):519-542, 2018), found by
the base model's runs and mapped over their parameter plane (``derive chart modes``).

A point moves at a constant rate w on a vertical circle of radius r about the centre of
mass of a body of mass M sliding, without turning, on a rough plane (coefficient mu, rest
and slip alike).  Along the plane (M + m) u' = F + m r w^2 cos(w t) and the normal force
is N = (M + m) g - m r w^2 sin(w t), so in the time w t the motion depends on two numbers
alone: mu and beta = m r w^2/((M + m) g), the internal force's amplitude over the
weight (beta < 1, or N reaches 0).  A periodic mode always exists, and u reaches 0
twice a period in it: at each stop the body either rests (a stick) or turns back at
once (a reversal).  Its type is what the stops are: two reversals, a rest and a
reversal, or two rests.

:func:`mode_type` reads the type from a run's events once the transient is over (the
stops of the last period against those of the one before it); :func:`chart` runs the
scene derive/scene/examples/bardin-panev.toml over a grid of (mu, beta), beta set by
the body's mass ``M = m r w^2/(beta g) - m`` (the point and its law fixed, so every
variant is one compiled law), and colours each cell by the type found.
"""
from __future__ import annotations

import csv
import math
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

EXAMPLE = Path(__file__).parents[1] / "scene" / "examples" / "bardin-panev.toml"
# the three types of the paper, in the order they appear as mu grows
TYPES = ("two reversals", "a rest and a reversal", "two rests")
NOT_SETTLED = "not settled"
AT_REST = "at rest"       # the rest holds throughout: beta <= mu/sqrt(1 + mu^2)
ODD = "no rest, odd reversals (a stop missed)"      # not a periodic motion
SETTLED = 1e-6            # the last period's stops repeat the previous ones' to this x T
_STOPS = ("stick", "reversal")


def mode_type(events, t_end: float, period: float, t0: float = 0.0,
              settled: float = SETTLED) -> str:
    """The periodic mode's type from a run's events (dicts with ``t`` and ``kind``): the
    stops (``stick``: a rest begins; ``reversal``: the slip turns back) of the period
    ending at the run's last stop against those of the period before it.  Where they
    differ (in kind, or in time by more than ``settled`` x period), the run has not
    reached its mode: NOT_SETTLED.  No stop in either period and a rest last (or never a
    slip): AT_REST, the body held throughout.  An odd number of reversals a period and
    no rest is no periodic motion (u returns to its sign): ODD, an event the run did not
    write.  Another
    type is named by its counts."""
    if t_end - t0 < 2 * period * (1 - 1e-12):
        raise ValueError("a mode's type needs two whole periods of the run")
    at = [(e["t"], e["kind"]) for e in events if e["kind"] in _STOPS]
    if not at or at[-1][0] <= t_end - period:   # no stop in the last period
        moves = [e["kind"] for e in events if e["kind"] in ("slip", *_STOPS)]
        return AT_REST if not moves or moves[-1] == "stick" else "sliding without a stop"
    # the period that ends at the last stop, and the one before it (a margin of 1e-3 T
    # keeps the last stop's repetition one period earlier in the earlier window)
    end, h = at[-1][0], 1e-3 * period
    last = [(t - end, k) for t, k in at if end - period + h < t <= end]
    before = [(t - end + period, k) for t, k in at
              if end - 2 * period + h < t <= end - period + h / 2]
    if [k for _, k in last] != [k for _, k in before] or any(
            abs(a - b) > settled * period for (a, _), (b, _) in zip(last, before)):
        return NOT_SETTLED
    rests = sum(k == "stick" for _, k in last)
    reversals = len(last) - rests
    if not rests and reversals % 2:     # never resting, u turns back an even number of times
        return ODD
    by_counts = {(0, 2): TYPES[0], (1, 1): TYPES[1], (2, 0): TYPES[2]}
    return by_counts.get((rests, reversals),
                         f"{rests} rest{'s' * (rests != 1)} and {reversals} "
                         f"reversal{'s' * (reversals != 1)}")


def stops(events) -> list:
    """The times u reaches 0 (rests and reversals), in order."""
    return [e["t"] for e in events if e["kind"] in _STOPS]


# ---- the scene and its parameters -------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    """The example's point: mass m on a circle of radius r at the rate w; gravity g."""
    m: float
    r: float
    w: float
    g: float

    @property
    def period(self) -> float:
        return 2 * math.pi / self.w

    def body_mass(self, beta: float) -> float:
        """M giving beta = m r w^2/((M + m) g)."""
        return self.m * self.r * self.w ** 2 / (beta * self.g) - self.m

    def beta(self, M: float) -> float:
        return self.m * self.r * self.w ** 2 / ((M + self.m) * self.g)


def example() -> tuple[dict, Setting]:
    """The example scene's dict and its point's setting: r = x(0) and w = 2 pi/T from its
    law x = r cos(w t) (T the law's period)."""
    from ..scene import parse_scene
    from ..scene.law.period import common_period
    doc = tomllib.loads(EXAMPLE.read_text(encoding="utf-8"))
    scene = parse_scene(doc, str(EXAMPLE))
    x, _, _ = scene.points[0].law.sympy()
    t = sorted(x.free_symbols, key=str)[0]
    T = float(common_period([x]))
    return doc, Setting(scene.points[0].mass, float(x.subs(t, 0)), 2 * math.pi / T,
                        scene.g)


# ---- the map ----------------------------------------------------------------------------
@dataclass
class ModeMap:
    mus: list
    betas: list
    types: list                 # one per cell, beta outer, mu inner
    statuses: list
    last_stops: list            # the stops of the last period, in its phase (/T)
    setting: Setting
    periods: int
    seconds: float
    workers: int


def run(cells, periods: int = 40, workers: int | None = None,
        progress: bool = False) -> tuple[list, list, list, Setting, object]:
    """Run the example at each (mu, beta) of ``cells`` for ``periods`` periods of the point,
    from rest: (the types, the statuses, the Results, the setting, the Batch)."""
    from .batch import simulate_many
    if periods < 2:
        raise ValueError("periods: must be >= 2 (a type compares the last two)")
    doc, setting = example()
    T = setting.period
    doc["run"]["duration"] = periods * T
    doc["run"]["output_dt"] = T                    # the events are what is read
    over = [{"plane.friction": float(mu), "body.mass": setting.body_mass(beta)}
            for mu, beta in cells]
    batch = simulate_many(doc, over, workers=workers, keep="result", progress=progress)
    types = [mode_type(res.events, float(res.t[-1]), T, res.scene.t0)
             if res.status == "done" else res.status for res in batch.results]
    return types, [res.status for res in batch.results], batch.results, setting, batch


def chart(mus, betas, periods: int = 40, workers: int | None = None,
          progress: bool = False) -> ModeMap:
    """Run the example over the grid (beta the outer loop, mu the inner) and classify
    every cell."""
    start = time.perf_counter()
    cells = [(mu, beta) for beta in betas for mu in mus]
    types, statuses, results, setting, batch = run(cells, periods, workers, progress)
    T = setting.period
    last = []
    for res in results:
        lo = res.scene.t0 + (periods - 1) * T
        last.append([((e["t"] - lo) / T, e["kind"]) for e in res.events
                     if e["kind"] in _STOPS and e["t"] > lo])
    return ModeMap(list(mus), list(betas), types, statuses, last, setting, periods,
                   time.perf_counter() - start, batch.workers)


def counts(mm: ModeMap) -> dict:
    out = {}
    for t in mm.types:
        out[t] = out.get(t, 0) + 1
    return out


COLOURS = {TYPES[0]: "#3182bd", TYPES[1]: "#fd8d3c", TYPES[2]: "#31a354",
           AT_REST: "#636363", NOT_SETTLED: "#d9d9d9", ODD: "#e7298a"}


def rest_limit(mu):
    """The largest beta at which the rest holds at every phase: |beta cos wt| <= mu (1 -
    beta sin wt) for all t, i.e. beta sqrt(1 + mu^2) <= mu."""
    mu = np.asarray(mu, dtype=float)
    return mu / np.sqrt(1 + mu * mu)


def write(mm: ModeMap, folder) -> list[Path]:
    """modes.png (each cell coloured by its type), modes.csv (a row per cell: mu, beta,
    the body's mass, the status, the type, the last period's stops), modes.json."""
    from .. import json_text
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    s = mm.setting
    with open(folder / "modes.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["mu", "beta", "body_mass", "status", "type", "stops_last_period"])
        k = 0
        for beta in mm.betas:
            for mu in mm.mus:
                stops_text = " ".join(f"{kind}@{phase:.6f}" for phase, kind in mm.last_stops[k])
                w.writerow([repr(float(mu)), repr(float(beta)), repr(s.body_mass(beta)),
                            mm.statuses[k], mm.types[k], stops_text])
                k += 1
    (folder / "modes.json").write_text(json_text.dumps({
        "scene": "derive/scene/examples/bardin-panev.toml",
        "point": {"m": s.m, "r": s.r, "w": s.w, "g": s.g}, "periods": mm.periods,
        "mu": mm.mus, "beta": mm.betas, "counts": counts(mm), "seconds": mm.seconds,
        "workers": mm.workers}), encoding="utf-8")
    return [folder / "modes.csv", folder / "modes.json", _draw(mm, folder / "modes.png")]


def _draw(mm: ModeMap, path: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch
    known = (*TYPES, AT_REST, NOT_SETTLED, ODD)
    found = list(dict.fromkeys([*[t for t in known if t in mm.types],
                                *sorted(set(mm.types) - set(known))]))
    extra = ["#756bb1", "#a6761d", "#e6ab02", "#1b9e77", "#666666"]
    colours = [COLOURS.get(t) or extra[k % len(extra)] for k, t in enumerate(found)]
    index = np.array([found.index(t) for t in mm.types]).reshape(len(mm.betas), len(mm.mus))
    mus, betas = np.asarray(mm.mus, float), np.asarray(mm.betas, float)
    fig, ax = plt.subplots(figsize=(9.5, 5))
    ax.pcolormesh(_edges(mus), _edges(betas), index, cmap=ListedColormap(colours),
                  vmin=-0.5, vmax=len(found) - 0.5, shading="flat")
    fine = np.linspace(_edges(mus)[0], _edges(mus)[-1], 200)
    ax.plot(fine, rest_limit(fine), "w--", lw=1.2)
    ax.set_ylim(_edges(betas)[0], _edges(betas)[-1])
    ax.set_xlabel("mu (friction, rest and slip alike)")
    ax.set_ylabel("beta = m r w^2 / ((M + m) g)")
    s = mm.setting
    ax.set_title(f"Bardin-Panev modes: {len(mm.types)} cells, {mm.periods} periods each "
                 f"(m = {s.m:g}, r = {s.r:g}, w = {s.w:g}; M from beta)", fontsize=9)
    from matplotlib.lines import Line2D
    ax.legend([*(Patch(color=c) for c in colours), Line2D([], [], color="k", ls="--")],
              [*found, "beta = mu/sqrt(1 + mu^2):\nat rest below (closed form)"],
              fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _edges(v: np.ndarray) -> np.ndarray:
    """Cell edges around the values (half-way between neighbours)."""
    if len(v) == 1:
        return np.array([v[0] - 0.05, v[0] + 0.05])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
