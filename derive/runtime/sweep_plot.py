"""The picture of a parameter sweep (``derive simulate --sweep``): for one swept field,
the number of impacts and the time of the first resting contact against it; for two, a
map of the number of impacts with refused or failed variants marked."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def sweep_plot(batch, grid: dict, folder: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(grid)
    impacts = batch.column("impacts").astype(float)
    first = batch.column("first_contact_t").astype(float)
    ok = np.array([r.get("status") == "done" for r in batch.rows])
    path = folder / "sweep.png"
    if len(names) == 1:
        x = np.array(grid[names[0]], dtype=float)
        fig, ax = plt.subplots(figsize=(7, 3.6))
        ax.plot(x, impacts, "o-", ms=3, lw=1, color="C0", label="impacts")
        ax.set_xlabel(names[0])
        ax.set_ylabel("impacts", color="C0")
        ax2 = ax.twinx()
        ax2.plot(x, first, "s-", ms=3, lw=1, color="C1", label="first resting contact")
        ax2.set_ylabel("time of first resting contact [s]", color="C1")
        if (~ok).any():
            ax.plot(x[~ok], impacts[~ok], "x", color="red", ms=8, label="not done")
        ax.set_title(f"{len(batch.rows)} variants", fontsize=10)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="upper left", fontsize=8)
        fig.tight_layout()
    else:
        x = np.array(grid[names[0]], dtype=float)
        y = np.array(grid[names[1]], dtype=float)
        Z = impacts.reshape(len(x), len(y)).T
        fig, ax = plt.subplots(figsize=(6.5, 5))
        mesh = ax.pcolormesh(x, y, Z, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label="impacts")
        bad = (~ok).reshape(len(x), len(y)).T
        if bad.any():
            X, Y = np.meshgrid(x, y)
            ax.plot(X[bad], Y[bad], "x", color="red", ms=6, label="not done")
            ax.legend(fontsize=8, loc="upper right")
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
        ax.set_title(f"{len(batch.rows)} variants: impacts", fontsize=10)
        fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
