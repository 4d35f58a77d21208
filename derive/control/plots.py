"""``control.png``: what a closed loop did, where people would rather look than read.

Per-hop feedback: the deviation from the orbit at every impact (log scale) beside the
decay the design predicts, the gait amplitude the controller set for each hop, and the
point's realised law z(t) over the design's gait; pushes marked.  Mirror law: the apex
of every hop against the target, and the realised law.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import layout, shapes


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
        if len(dev) and np.max(dev) > 0:
            k0 = int(np.argmax(dev))                # from the largest: after a push
            k = np.arange(len(t) - k0)
            ax.semilogy(t[k0:], dev[k0] * lam ** k, "--", color="0.5",
                        label=f"predicted decay |lambda|^k = {lam:.3g}^k")
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
