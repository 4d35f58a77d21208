"""Stability diagrams from a :class:`~derive.stability.sweep.Sweep`: max |rho| as colour,
the unstable regions outlined, as PNG plus the data (CSV per point, JSON for the run)."""
from __future__ import annotations

import csv
import textwrap
from pathlib import Path

import numpy as np

from .. import json_text

from .families import FamilyError, family
from .sweep import Sweep


VERDICTS = ("linearly stable", "critical, Jordan block at 1", "unstable", "no body")


def missing_name(family_name: str) -> str:
    """What a grey point lacks: a body with those moments, or (the bounce family) an
    orbit, below the existence threshold."""
    return "no orbit" if family_name == "bounce" else "no body"


def categories(sw: Sweep) -> np.ndarray:
    """Index into VERDICTS per point."""
    out = np.zeros(sw.max_modulus.shape, dtype=int)
    out[sw.jordan > 0.5] = 1
    out[sw.max_modulus > 1 + sw.tol] = 2
    out[~np.isfinite(sw.max_modulus)] = 3
    return out


def counts(sw: Sweep) -> dict:
    cat = categories(sw)
    keys = ("stable_linear", "critical_jordan", "unstable", "no_body")
    return {"points": int(cat.size), **{k: int(np.sum(cat == i)) for i, k in enumerate(keys)}}


def fixed_values(sw: Sweep) -> dict:
    """Every parameter that is not swept, at its value in the sweep."""
    values = dict(sw.fixed)
    for corner in ((sw.x.lo, sw.y.lo), (sw.x.hi, sw.y.hi), (sw.x.lo, sw.y.hi),
                   (sw.x.hi, sw.y.lo)):
        try:
            values = family(sw.family).values(sw.fixed | {sw.x.name: corner[0],
                                                          sw.y.name: corner[1]})
            break
        except FamilyError:
            continue
    swept = {sw.x.name, sw.y.name}
    if swept & {"a", "Gamma"}:
        swept |= {"a", "Gamma"}               # each follows from the other (bounce)
    return {k: v for k, v in values.items() if k not in swept}


def summary(sw: Sweep) -> dict:
    fam = family(sw.family)
    finite = sw.max_modulus[np.isfinite(sw.max_modulus)]
    return {"family": sw.family, "law": fam.title, "x": str(sw.x), "y": str(sw.y),
            "fixed": fixed_values(sw),
            "unstable_if": f"max |rho| > 1 + {sw.tol:g}", "rtol": sw.rtol,
            "counts": counts(sw),
            "max_modulus": float(finite.max()) if finite.size else None,
            "max_base_drift": float(np.nanmax(sw.drift)) if finite.size else None,
            "executor": sw.executor, "workers": sw.workers, "seconds": sw.seconds,
            "library": sw.library}


def write(sw: Sweep, folder: str | Path, plot: bool = True) -> list[Path]:
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    stem = f"stability-{sw.family.replace('.', '_')}-{sw.x.name}-{sw.y.name}"
    paths = [out / f"{stem}.csv", out / f"{stem}.json"]
    with open(paths[0], "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow([sw.x.name, sw.y.name, "max_modulus", "base_drift", "verdict"])
        cat = categories(sw)
        for j, yv in enumerate(sw.y.values):
            for i, xv in enumerate(sw.x.values):
                w.writerow([repr(float(xv)), repr(float(yv)), repr(float(sw.max_modulus[j, i])),
                            repr(float(sw.drift[j, i])),
                            missing_name(sw.family) if cat[j, i] == 3 else VERDICTS[cat[j, i]]])
    paths[1].write_text(json_text.dumps(summary(sw)), encoding="utf-8")
    if plot:
        paths.append(draw(sw, out / f"{stem}.png"))
    return paths


def _cell_edges(values) -> np.ndarray:
    """The edges of the cells drawn around grid values (pcolormesh's "nearest")."""
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def _outline(mask: np.ndarray, ex: np.ndarray, ey: np.ndarray) -> list:
    """The segments between cells in ``mask`` (rows along y, columns along x) and cells
    outside it or the chart's edge."""
    ny, nx = mask.shape
    segs = []
    for j, i in zip(*np.nonzero(mask)):
        if i == 0 or not mask[j, i - 1]:
            segs.append([(ex[i], ey[j]), (ex[i], ey[j + 1])])
        if i == nx - 1 or not mask[j, i + 1]:
            segs.append([(ex[i + 1], ey[j]), (ex[i + 1], ey[j + 1])])
        if j == 0 or not mask[j - 1, i]:
            segs.append([(ex[i], ey[j]), (ex[i + 1], ey[j])])
        if j == ny - 1 or not mask[j + 1, i]:
            segs.append([(ex[i], ey[j + 1]), (ex[i + 1], ey[j + 1])])
    return segs


def draw(sw: Sweep, path: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from matplotlib.ticker import FormatStrFormatter

    fam = family(sw.family)
    X, Y = np.meshgrid(sw.x.values, sw.y.values)
    Z = np.ma.masked_invalid(sw.max_modulus)
    top = float(Z.max()) if Z.count() else 1.0
    fig, ax = plt.subplots(figsize=(7.0, 5.8), layout="constrained")
    ax.set_facecolor("0.85")                     # masked (no body): grey
    mesh = ax.pcolormesh(X, Y, np.ma.maximum(Z, 1.0), shading="nearest", cmap="magma_r",
                         norm=LogNorm(vmin=1.0, vmax=max(top, 1.0 + 1e-3)))
    bar = fig.colorbar(mesh, ax=ax, label="max |rho| (monodromy over one period)")
    bar.ax.yaxis.set_major_formatter(FormatStrFormatter("%.3g"))
    bar.ax.yaxis.set_minor_formatter(FormatStrFormatter("%.3g"))
    ex, ey = _cell_edges(sw.x.values), _cell_edges(sw.y.values)
    unstable = np.nan_to_num(sw.max_modulus, nan=0.0) > 1 + sw.tol
    if np.any(unstable):
        # the outline of the unstable cells as drawn (a contour through the points would
        # cut across cells, and stay open at the chart's edges)
        from matplotlib.collections import LineCollection
        ax.add_collection(LineCollection(_outline(unstable, ex, ey), colors="tab:cyan",
                                         linewidths=1.4))
    if np.any(sw.jordan > 0.5):
        from matplotlib.patches import Rectangle
        for j, i in zip(*np.nonzero(sw.jordan > 0.5)):
            ax.add_patch(Rectangle((ex[i], ey[j]), ex[i + 1] - ex[i], ey[j + 1] - ey[j],
                                   fill=False, hatch="....", lw=0.0))
    if fam.name == "bounce" and {sw.x.name, sw.y.name} == {"e", "Gamma"}:
        # the closed forms of the ball on a vibrating table: where the n-orbit appears
        # and where it doubles its period (derive/stability/bouncing.py)
        from .bouncing import existence_threshold, period_doubling_threshold
        n = int(fixed_values(sw).get("n", 1))
        es = np.linspace(min(sw.values_of("e")), max(sw.values_of("e")), 200)
        curves = {"existence": [existence_threshold(e, n) for e in es],
                  "period doubling": [period_doubling_threshold(e, n) for e in es]}
        for (label, g), style in zip(curves.items(), ("--", ":")):
            xy = (es, g) if sw.x.name == "e" else (g, es)
            ax.plot(*xy, style, color="tab:blue", lw=1.2, label=f"{label} (closed form)")
        ax.set_xlim(sw.x.lo - 0.5 * (sw.x.hi - sw.x.lo) / max(sw.x.n - 1, 1),
                    sw.x.hi + 0.5 * (sw.x.hi - sw.x.lo) / max(sw.x.n - 1, 1))
        ax.set_ylim(sw.y.lo - 0.5 * (sw.y.hi - sw.y.lo) / max(sw.y.n - 1, 1),
                    sw.y.hi + 0.5 * (sw.y.hi - sw.y.lo) / max(sw.y.n - 1, 1))
    c = counts(sw)
    others = ", ".join(f"{k}={v:g}" for k, v in fixed_values(sw).items())
    what = "" if fam.name == "bounce" else " stationary rotation"
    head = textwrap.fill(f"{fam.name}{what}: {fam.title}", 90)       # the figure's width
    ax.set_title(head + "\n" + textwrap.fill(others, 90), fontsize=9)
    ax.set_xlabel(sw.x.name)
    ax.set_ylabel(sw.y.name)
    # the counts and the closed forms in one legend under the chart, outside the axes
    # (inside, the legend and the counts' box hid the cells at e 0.7-0.9, Gamma 0.5)
    from matplotlib.patches import Patch
    keys = [Patch(facecolor="none", edgecolor="tab:cyan", lw=1.4,
                  label=f"unstable (outlined, max |rho| > 1 + {sw.tol:g}): {c['unstable']}"),
            Patch(facecolor=mesh.cmap(mesh.norm(1.0)), edgecolor="0.6", lw=0.5,
                  label=f"linearly stable: {c['stable_linear']}")]
    if c["critical_jordan"]:
        keys.append(Patch(facecolor="white", edgecolor="0.3", hatch="....", lw=0.0,
                          label="critical with a Jordan block at rho = 1 (dotted): "
                                f"{c['critical_jordan']}"))
    if c["no_body"]:
        keys.append(Patch(facecolor="0.85", edgecolor="0.6", lw=0.5,
                          label=f"{missing_name(fam.name)} (grey): {c['no_body']}"))
    lines, _ = ax.get_legend_handles_labels()
    fig.legend(handles=lines + keys, loc="outside lower center", ncols=2, fontsize=8,
               frameon=False)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
