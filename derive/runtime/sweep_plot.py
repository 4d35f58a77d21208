"""The picture of a parameter sweep (``derive simulate --sweep``): for one swept field, a
column of the study against it (the number of impacts by default, with the time of the
first resting contact; ``--plot distance`` the distance C travelled, ...); for two, a map
of that column with refused or failed variants marked.

The map has one cell per variant, centred on a tick that says its value: the axes are
categorical (the values in the order swept, equally spaced whatever their spacing), so
two values are two cells, not a continuous axis from half a step below the first."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

MOST_TICKS = 12                   # every value is a tick up to this many values
# the columns a sweep may draw (the study's numbers), and how each is labelled
PLOTTABLE = {"impacts": "impacts", "contacts": "contact phases", "lift_offs": "lift-offs",
             "slips": "slip events (stick to slip)", "sticks": "stick events (slip to stick)",
             "reversals": "reversals of the slip",
             "steps": "steps", "rhs_evaluations": "RHS evaluations",
             "min_height": "lowest height of S [m]", "first_contact_t":
             "time of first resting contact [s]", "X_C_end": "X_C at the end [m]",
             "Y_C_end": "Y_C at the end [m]", "Z_C_end": "Z_C at the end [m]",
             "distance": "horizontal distance C travelled [m]", "mean_speed":
             "C's mean horizontal speed (distance / duration) [m/s]", "mean_velocity_X":
             "C's mean velocity along X [m/s]", "mean_velocity_Y":
             "C's mean velocity along Y [m/s]", "t_end": "t at the end [s]",
             "run_ms": "run time [ms]"}
_COUNTS = ("impacts", "contacts", "lift_offs", "slips", "sticks", "reversals", "steps",
           "rhs_evaluations")
_SIGNED = ("X_C_end", "Y_C_end", "mean_velocity_X", "mean_velocity_Y")   # about 0: RdBu


def value_text(v: float) -> str:
    """A swept value as written: the shortest form that reads back as the same float."""
    text = f"{v:.15g}"
    return text if float(text) == v else repr(float(v))


def axis_name(name: str, values) -> str:
    """An axis's label: the field, or for a formula swept by one of its numbers
    (:class:`derive.scene.overrides.Formulas`) that number's name in it."""
    symbol = getattr(values, "symbol", None)
    return name if symbol is None else f"{symbol} in {name}"


def category_ticks(n: int) -> list[int]:
    """The indices of n values to mark: all of them up to MOST_TICKS, else every k-th
    from the first (about ten)."""
    step = 1 if n <= MOST_TICKS else math.ceil(n / 10)
    return list(range(0, n, step))


def signed_norm(Z):
    """The colour scale of a column of both signs: each sign to its own extreme, 0 white
    (a crawl forward of mm/s beside a slide back of cm/s is white on one symmetric
    scale)."""
    from matplotlib.colors import TwoSlopeNorm
    return TwoSlopeNorm(vmin=float(Z.min()), vcenter=0.0, vmax=float(Z.max()))


def sweep_plot(batch, grid: dict, folder: Path, column: str = "impacts") -> Path:
    """sweep.png: ``column`` (a key of :data:`PLOTTABLE`) against the swept values."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator
    names = [axis_name(name, values) for name, values in grid.items()]
    grid = {n: list(getattr(v, "numbers", v)) for n, v in zip(names, grid.values())}
    label = PLOTTABLE[column]
    impacts = batch.column(column).astype(float).filled(np.nan)
    first = batch.column("first_contact_t").filled(np.nan)
    ok = batch.column("status") == "done"
    path = folder / "sweep.png"
    if len(names) == 1:
        x = np.array(grid[names[0]], dtype=float)
        fig, ax = plt.subplots(figsize=(7, 4.0), layout="constrained")
        ax.plot(x, impacts, "o-", ms=3, lw=1, color="C0", label=label)
        ax.set_xlabel(names[0])
        ax.set_ylabel(label, color="C0")
        if column in _COUNTS:
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        if len(x) <= MOST_TICKS:
            ax.set_xticks(x, [value_text(v) for v in x])
        handles = []
        if column == "impacts":               # and when the impacts end in resting contact
            ax2 = ax.twinx()
            ax2.plot(x, first, "s-", ms=3, lw=1, color="C1", label="first resting contact")
            ax2.set_ylabel("time of first resting contact [s]", color="C1")
            if not np.isfinite(first).any():
                ax2.set_yticks([])
                ax2.text(0.98, 0.5, "no resting contact", transform=ax2.transAxes,
                         ha="right", va="center", color="C1", fontsize=8)
            handles = ax2.get_legend_handles_labels()
        if (~ok).any():
            ax.plot(x[~ok], impacts[~ok], "x", color="red", ms=8, label="not done")
        ax.set_title(f"{len(batch.rows)} variants", fontsize=10)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = handles or ([], [])
        # under the axes, never over a point (upper left had sat on the first ones)
        fig.legend(h1 + h2, l1 + l2, loc="outside lower center", ncols=3, fontsize=8,
                   frameon=False)
    else:
        xs, ys = list(grid[names[0]]), list(grid[names[1]])
        nx, ny = len(xs), len(ys)
        Z = np.ma.masked_invalid(impacts.reshape(nx, ny).T)
        fig, ax = plt.subplots(figsize=(6.5, 5), layout="constrained")
        signed = column in _SIGNED and Z.count() and Z.min() < 0 < Z.max()
        norm = signed_norm(Z) if signed else None
        mesh = ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, Z,
                             shading="flat", cmap="RdBu_r" if signed else "viridis",
                             norm=norm)
        bar = fig.colorbar(mesh, ax=ax, label=label + (" (each sign to its own extreme)"
                                                       if signed else ""))
        if signed:
            bar.set_ticks(np.r_[np.linspace(norm.vmin, 0.0, 5)[:-1], 0.0,
                                np.linspace(0.0, norm.vmax, 5)[1:]])
        for axis, values in ((ax.xaxis, xs), (ax.yaxis, ys)):
            ticks = category_ticks(len(values))
            axis.set_ticks(ticks, [value_text(values[k]) for k in ticks])
        if nx * ny <= 64:                # few cells: the count written in each
            missing = np.ma.getmaskarray(Z)
            lo, hi = mesh.norm.vmin, mesh.norm.vmax
            big = float(np.abs(Z).max())        # round-off of a variant at rest: 0
            for i in range(nx):
                for j in range(ny):
                    if not missing[j, i]:
                        dark = (abs(float(norm(Z[j, i])) - 0.5) > 0.3 if signed else
                                hi > lo and (Z[j, i] - lo) / (hi - lo) < 0.6)
                        text = (f"{int(Z[j, i])}" if column in _COUNTS else
                                f"{Z[j, i]:.3g}" if abs(Z[j, i]) > 1e-9 * big else "0")
                        ax.text(i, j, text, ha="center", va="center",
                                fontsize=8, color="white" if dark else "black")
        bad = (~ok).reshape(nx, ny).T
        if bad.any():
            X, Y = np.meshgrid(np.arange(nx), np.arange(ny))
            ax.plot(X[bad], Y[bad], "x", color="red", ms=6, label="not done")
            fig.legend(fontsize=8, loc="outside lower center", frameon=False)   # off the cells
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
        ax.set_title(f"{len(batch.rows)} variants: {label}", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
