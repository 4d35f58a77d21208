"""The pictures of a closed loop, where people would rather look than read.

``control.png`` (hop and mirror modes, :func:`chart`): per-hop feedback's deviation from
the orbit at every impact (log scale) beside what the design's linear map (A - B K)
predicts, one hop ahead of each reading and hop after hop from the push on, the gait
amplitude the controller set for each hop, and the point's realised law z(t) over the
design's gait, pushes marked; the mirror law's apex of every hop against the target, and
the realised law.  Re-planning (:func:`disturbance`, :func:`replans`,
:func:`solve_times`): the disturbance and what it does (closed against open loop), the
re-planned laws overlaid, the solve time per sample.

Drawn on bare :class:`matplotlib.figure.Figure` objects with the Agg canvas (no pyplot),
like :mod:`derive.runtime.plots`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import abi, layout, shapes

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
        keep = res.row_kind == abi.ROW_KIND["step"]
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
        ax.axvspan(goal_time, ax.get_xlim()[1], color="0.92", lw=0, zorder=0)
        ax.grid(alpha=0.3)
    ax2.annotate("after the goal:\nnot controlled", (1.0, 1.0), xycoords="axes fraction",
                 xytext=(-3, -4), textcoords="offset points", ha="right", va="top",
                 color="0.35", fontsize=8)
    for p in (dist.pushes if dist else ()):
        ax1.annotate(f"push {np.linalg.norm(p[1:4]):.3g} N s", (p[0], 0.0),
                     xycoords=("data", "axes fraction"), xytext=(3, 4),
                     textcoords="offset points", color="tab:red", fontsize=8)  # (not under
        # the legend, which sits in the upper left)
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
    ax1.set_title("the disturbance: " + (";\n".join(parts) if parts else "none") +
                  "\n(dotted: touchdown or the plan's end)", **{**_TITLE, "fontsize": 9})
    fig.tight_layout()
    fig.savefig(path)
    return path


def replans(path: Path, laws: list, realised, plan_u,
            labels=("x of OP (m)", "y of OP (m)", "z of OP (m)")) -> Path:
    """x, y, z of P (or the columns ``labels`` names: a task of bodies' decided
    bodies): every law the controller set (from its call on, coloured by the call's
    time), the realised law (black), the offline plan (dashed; ``plan_u(t)``, 9 rows)."""
    from matplotlib import colormaps
    fig = _figure(8.0, 6.4)
    axes = [fig.add_subplot(3, 1, k + 1) for k in range(3)]
    cmap = colormaps["viridis"]
    t_all = [t for t, _ in laws] or [0.0]
    lo, hi = min(t_all), max(t_all) + 1e-12
    t_end = float(realised.knots[-1])
    tt = np.linspace(float(realised.knots[0]), t_end, 800)
    u_plan = plan_u(tt)
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
        ax.set_ylabel(labels[k])
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t (s)")
    axes[0].set_title(f"{len(laws)} re-planned laws (colour: the time of the call), the "
                      "realised law (black), the offline plan (dashed)", **_TITLE)
    fig.tight_layout()
    fig.savefig(path)
    return path


def solve_times(path: Path, times: np.ndarray, what: str, target_ms: float) -> Path:
    """The solve time (the thread's CPU time) of every call that ran the solver, its
    median and p99."""
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
    ax.annotate(f"median target {target_ms:g} ms", (0.0, target_ms),
                xycoords=("axes fraction", "data"), xytext=(4, -10), textcoords="offset points",
                fontsize=8, color="tab:red")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter      # plain numbers, not 4x10^0
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(FuncFormatter(
        lambda v, _: f"{v:g}" if f"{v:.0e}"[0] in "25" else ""))
    ax.set_xlabel("t (s)")
    ax.set_ylabel("solve, CPU time (ms)")
    ax.set_title(f"solve time per sample: {what}", **_TITLE)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path)
    return path


def chart(closed, path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    res = closed.result
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 8.0), sharex=True)
    pushes = [e["t"] for e in res.events if e["kind"] == "push"]
    imp = res.impacts[:, 0]
    d = closed.design
    if d is not None:
        hist = closed.controller.history
        t = np.array([h[0] for h in hist])
        orbit = d.orbit
        dev = np.array([np.hypot(orbit.gait.W * h[1][0], h[1][1] / orbit.v) for h in hist])
        ax = axes[0]
        ax.semilogy(t, np.maximum(dev, 1e-17), "o-", ms=3,
                    label="read at each impact (with the noise)")
        lam = float(max(abs(d.closed_loop)))
        closed_map = d.A - d.B @ d.K               # the linear map the design predicts with
        states = [np.asarray(h[1], dtype=float) for h in hist]

        def size(s):
            return np.hypot(orbit.gait.W * s[0], s[1] / orbit.v)
        if len(states) > 1:                        # each hop from the one read before it
            ax.semilogy(t[1:], [max(size(closed_map @ s), 1e-17) for s in states[:-1]], "x",
                        color="0.35", ms=5, label="predicted one hop ahead: (A - B K) s")
        after = [k for k in range(len(t)) if pushes and t[k] > pushes[0]]
        k0 = after[0] if after else (int(np.argmax(dev)) if len(dev) else 0)
        if len(dev) and dev[k0] > 0:              # from the push on, the design's forecast
            s, forecast = states[k0], []
            for _ in range(len(t) - k0):
                forecast.append(max(size(s), 1e-17))
                s = closed_map @ s
            ax.semilogy(t[k0:], forecast, "--", color="0.5",
                        label=f"forecast from t = {t[k0]:.3g} s: (A - B K)^k s, "
                              f"|lambda| = {lam:.3g}")
        if len(dev) and np.max(dev) > 0:
            ax.set_ylim(max(1e-9, 0.3 * float(np.min(dev[dev > 0]))), 3 * float(np.max(dev)))
        ax.set_ylabel("deviation from the orbit\n(phase rad, velocity rel.)")
        ax.set_title(f"per-hop feedback ({d.gain}): open-loop |rho| up to "
                     f"{max(abs(d.open_loop)):.3g}, closed-loop |lambda| up to {lam:.3g}",
                     fontsize=10)
        ax.legend(fontsize=8)
        ax = axes[1]
        amps = [orbit.gait.a + h[2] for h in hist]
        ax.step(t, amps, where="post", label="gait amplitude set after the impact")
        ax.axhline(orbit.gait.a, color="0.5", ls="--", label=f"the orbit's a = {orbit.gait.a:g}")
        ax.set_ylabel("a of the coming hop [m]")
        ax.legend(fontsize=8)
    else:
        ax = axes[0]
        R = -shapes.of(res.scene.shape).lowest((0.0, 0.0, 1.0), res.scene.center,
                                               res.scene.size)[2] if res.scene.size else 0.0
        Z = res.general[:, layout.GENERAL.Z] if res.general is not None else \
            res.model_q[:, layout.of(res.model).Z]
        tops = [(b, Z[(res.t > a) & (res.t < b)].max() - R) for a, b in zip(imp[:-1], imp[1:])]
        if tops:
            ax.plot(*zip(*tops), "o-", ms=3, label="apex of each hop (Z_C - R)")
        ax.axhline(closed.target.get("apex_height", np.nan), color="0.5", ls="--",
                   label="target")
        ax.set_ylabel("apex [m]")
        ax.set_title(f"{closed.mode} law", fontsize=10)
        ax.legend(fontsize=8)
        ax = axes[1]                              # the ball and the table it mirrors
        sc = res.scene
        nu = sc.m / (sc.m + sc.M)
        z = closed.law.jets(np.clip(res.t, closed.law.t_first, None))[layout.JET_R[2]]
        ax.plot(res.t, Z - R, lw=0.8, label="the ball: Z_C - R")
        ax.plot(res.t, nu * z, lw=0.8, label="the table: nu z")
        ax.axhline(0.0, color="0.7", lw=0.5)
        ax.set_ylabel("[m]")
        ax.legend(fontsize=8, loc="upper right")
    ax = axes[2]
    law = closed.law
    ts = np.linspace(law.t_first, law.t_last, 4000)
    ax.plot(ts, law.jets(ts)[layout.JET_R[2]], lw=0.8, label="z(t), the realised law")
    if d is not None:
        ax.plot(ts, d.orbit.gait.jet(ts)[0], lw=0.6, color="0.6", label="the orbit's gait")
    ax.set_ylabel("z [m]")
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=8, loc="upper right")
    for a_ in axes:
        for tp in pushes:
            a_.axvline(tp, color="#d62728", lw=1.0, alpha=0.7)
    if pushes:
        axes[0].text(pushes[0], axes[0].get_ylim()[1], " push", color="#d62728",
                     va="top", fontsize=8)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
