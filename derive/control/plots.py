"""The pictures of a closed loop: the disturbance and what it does (closed against open
loop), the re-planned laws overlaid, the solve time per sample.

Drawn on bare :class:`matplotlib.figure.Figure` objects with the Agg canvas (no pyplot),
like :mod:`derive.runtime.plots`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import layout

G = layout.GENERAL
_TITLE = {"fontsize": 10, "y": 1.0, "pad": 4}


def _figure(w: float, h: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(w, h), dpi=90)
    FigureCanvasAgg(fig)
    return fig


def _angle_to(target, q) -> np.ndarray:
    """The rotation angle (deg) between the target and each row's attitude."""
    A = q[:, G.A].reshape(-1, 3, 3)
    R = np.einsum("ji,njk->nik", np.asarray(target), A)
    s = 0.5 * np.linalg.norm(np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0],
                                       R[:, 1, 0] - R[:, 0, 1]], axis=1), axis=1)
    c = 0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0)
    return np.degrees(np.arctan2(s, c))


def _first_impact(result) -> float | None:
    imp = [e["t"] for e in result.events if e["kind"] == "impact"]
    return imp[0] if imp else None


def disturbance(path: Path, task, closed, open_, dist, goal_time: float) -> Path:
    """The angle to the target and |omega| against time, closed and open loop, the
    pushes marked; the plant's factors and the noise in the title."""
    fig = _figure(8.0, 5.6)
    ax1, ax2 = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    for res, colour, name in ((open_, "0.55", "open loop (the plan played)"),
                              (closed, "tab:blue", "closed loop (re-planned)")):
        if res is None:
            continue
        keep = res.row_kind == 0
        t, q = res.t[keep], res.q[keep]
        ax1.plot(t, _angle_to(task.target, q), color=colour, lw=1.4, label=name)
        ax2.plot(t, np.linalg.norm(q[:, G.omega], axis=1), color=colour, lw=1.4)
        t_imp = _first_impact(res)
        if t_imp is not None:
            ax1.axvline(t_imp, color=colour, ls=":", lw=1)
    for ax in (ax1, ax2):
        for p in (dist.pushes if dist else ()):
            ax.axvline(p[0], color="tab:red", ls="--", lw=1)
        ax.axvline(goal_time, color="k", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
    for p in (dist.pushes if dist else ()):
        ax1.annotate(f"push {np.linalg.norm(p[1:4]):.3g} N s", (p[0], 1.0),
                     xycoords=("data", "axes fraction"), xytext=(3, -10),
                     textcoords="offset points", color="tab:red", fontsize=8)
    ax1.set_ylabel("angle to the target (deg)")
    ax2.set_ylabel("|omega| (rad/s)")
    ax2.set_xlabel("t (s)")
    ax1.legend(fontsize=8, loc="upper left")
    parts = []
    if dist is not None:
        parts.append(f"M x {dist.mass_factor:.3g}, m x {dist.point_mass_factor:.3g}, "
                     f"J x ({', '.join(f'{f:.3g}' for f in dist.inertia_factor)})")
        if any(dist.noise):
            parts.append("noise std: omega {:.3g} rad/s, attitude {:.3g} rad, C {:.3g} m, "
                         "C' {:.3g} m/s".format(*dist.noise))
    ax1.set_title("the disturbance: " + ("; ".join(parts) if parts else "none") +
                  "\n(dotted: touchdown or the plan's end)", **{**_TITLE, "fontsize": 9})
    fig.tight_layout()
    fig.savefig(path)
    return path


def replans(path: Path, laws: list, realised, plan_law) -> Path:
    """x, y, z of P: every law the controller set (from its call on, coloured by the
    call's time), the realised law (black), the offline plan (dashed)."""
    from matplotlib import colormaps
    fig = _figure(8.0, 6.4)
    axes = [fig.add_subplot(3, 1, k + 1) for k in range(3)]
    cmap = colormaps["viridis"]
    t_all = [t for t, _ in laws] or [0.0]
    lo, hi = min(t_all), max(t_all) + 1e-12
    t_end = float(realised.knots[-1])
    tt = np.linspace(float(realised.knots[0]), t_end, 800)
    u_plan = plan_law.u(tt)
    u_real = realised.jets(tt)
    for t_call, seg in laws:
        ts = np.linspace(seg.knots[0], seg.knots[-2], 120)
        u = np.array([seg.at(x) for x in ts])
        colour = cmap((t_call - lo) / (hi - lo))
        for k, ax in enumerate(axes):
            ax.plot(ts, u[:, k], color=colour, lw=0.7, alpha=0.8)
    for k, ax in enumerate(axes):
        ax.plot(tt, u_plan[k], "k--", lw=1.0)
        ax.plot(tt, u_real[3 * k], color="k", lw=1.6)
        ax.set_ylabel("xyz"[k] + " of OP (m)")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title(f"{len(laws)} re-planned laws (colour: the time of the call), the "
                      "realised law (black), the offline plan (dashed)", **_TITLE)
    fig.tight_layout()
    fig.savefig(path)
    return path


def solve_times(path: Path, times: np.ndarray, what: str, target_ms: float = 5.0) -> Path:
    """The solve time of every call that ran the solver, its median and p99."""
    fig = _figure(8.0, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    times = np.asarray(times).reshape(-1, 2)
    ms = times[:, 1] * 1e3
    ax.plot(times[:, 0], ms, "o", ms=3, color="tab:blue")
    if len(ms):
        for value, name, style in ((np.median(ms), "median", "-"),
                                   (np.percentile(ms, 99), "p99", "--")):
            ax.axhline(value, color="tab:blue", ls=style, lw=1)
            ax.annotate(f"{name} {value:.3g} ms", (1.0, value), xycoords=("axes fraction",
                        "data"), xytext=(-4, 3), textcoords="offset points", ha="right",
                        fontsize=8, color="tab:blue")
    ax.axhline(target_ms, color="tab:red", ls=":", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("solve (ms)")
    ax.set_title(f"solve time per sample: {what}", **_TITLE)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path)
    return path
