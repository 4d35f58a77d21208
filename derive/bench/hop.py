"""``derive bench hop``: per-hop feedback on the reference-[5] hop, measured.

* **Region of attraction**: from a grid of deviations of the impact's phase and C's
  upward velocity off the orbit, the hop runs open loop (the gait held), with the per-hop
  LQR (the C controller, crt_hop.c) and with the mirror law (below).  Two orbits: one
  stable open loop (a = 0.07, Gamma = 1.28) and one past period doubling (a = 0.1,
  Gamma = 1.83, |rho| = 2.016).  Chart: ``hop-region.png`` in the output folder.
* **Convergence against the prediction**: the per-hop decay of the closed loop in the
  linear range against the largest |eigenvalue| of A - B K.
* **Cost**: a closed-loop run with the C controller against the same run with the
  Python controller (the same law to the bit).

A start converges when the last three of ``HOPS`` hops rise to the orbit's apex within
1 % (the mirror law steers the apex, not the phase).  Targets: past period doubling the
open loop brings back no start off the orbit, and the per-hop feedback every start in
its linear range (+-0.05 rad, +-2.5 %); the measured rate within 25 % of the predicted
one.  The regions are reported (a stronger gain converges faster and saturates sooner:
the stable orbit's region with the default weights is smaller than the open loop's).
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from .. import abi
from ..commands import Target, all_pass

HOPS = 30
MIRROR_PERIOD = 0.002
CASES = (("stable open loop", 0.07), ("past period doubling", 0.1))


def _run(hm, design, controller, dphi: float, dv: float, hops: int = HOPS,
         period: float = 0.0):
    """A run started off the orbit (phase by dphi radians of the gait, C's velocity by dv
    of the orbit's): the scaled deviations at its impacts and the apex of each hop (the
    highest Z_C above its rest height).  None when the start is not a state."""
    from ..control import hop as H
    from ..runtime.driver import prepare, run_prepared
    from ..runtime.loop import Loop
    orbit = design.orbit
    g = orbit.gait
    T = g.period
    x = orbit.x + np.r_[dphi / g.W, dv * orbit.v, 0, 0, 0, 0, 0]
    q0 = H._state(hm, x)
    scene = dataclasses.replace(hm.scene, t0=float(x[0]), duration=(hops + 0.5) * T,
                                com=(0.0, 0.0, q0[0]), com_velocity=(0.0, 0.0, q0[1]))
    res = run_prepared(prepare(scene), loop=Loop(controller, period=period))
    rows = np.flatnonzero(res.row_kind == abi.ROW_KIND["after_event"])
    dt = (res.t[rows] - orbit.t + 0.5 * T) % T - 0.5 * T
    dvr = (res.model_q[rows, 1] - orbit.v) / orbit.v
    imp, Z, R = res.impacts[:, 0], res.model_q[:, 0], hm.scene.size[0]
    tops = np.array([Z[(res.t > a) & (res.t < b)].max() - R for a, b in zip(imp[:-1], imp[1:])])
    return np.hypot(g.W * dt, dvr), tops


def _converged(tops, apex: float, hops: int = HOPS) -> bool:
    """The last three hops rise to the orbit's apex within 1 % (a run that came to rest,
    or hopped less than a third of the hops asked, did not converge)."""
    return len(tops) >= hops // 3 and bool(np.all(np.abs(tops[-3:] - apex) < 0.01 * apex))


def run(out_dir: str = "bench-out", grid: int = 15, progress=lambda msg: None) -> dict:
    from ..control import hop as H
    from ..scene import parse_scene
    from ..stability import bouncing
    out = {"grid": grid, "hops": HOPS, "cases": []}
    phis = np.linspace(-0.6, 0.6, grid)
    vs = np.linspace(-0.3, 0.3, grid)
    for label, a in CASES:
        progress(f"{label}: design")
        sc = parse_scene(bouncing.bouncing_scene(a=a))
        hm = H.HopMap(sc)
        d = H.design(hm, hm.gait)
        apex = H.orbit_apex(hm, d.orbit)
        controllers = {
            "open loop": lambda: H.OpenLoopGait(hm.gait),
            "per-hop LQR": lambda: H.c_controller(d),
            "mirror law": lambda: H.MirrorLaw(hm.scene, apex=apex, period=MIRROR_PERIOD),
        }
        region = {}
        for name, make in controllers.items():
            progress(f"{label}: {name} over a {grid} x {grid} grid")
            ok = np.zeros((grid, grid), dtype=bool)
            period = MIRROR_PERIOD if name == "mirror law" else 0.0
            for i, dv in enumerate(vs):
                for j, dphi in enumerate(phis):
                    _, tops = _run(hm, d, make(), dphi, dv, period=period)
                    ok[i, j] = _converged(tops, apex)
            region[name] = ok
        # every start of a small grid in the linear range: +-0.05 rad, +-2.5 %
        near = [_converged(_run(hm, d, H.c_controller(d), p, v)[1], apex)
                for p in np.linspace(-0.05, 0.05, 3) for v in np.linspace(-0.025, 0.025, 3)]
        # the rate in the linear range against the prediction
        dev, _ = _run(hm, d, H.c_controller(d), 0.0, 2e-3, hops=14)
        rate = float((dev[9] / dev[3]) ** (1 / 6))
        # the cost of a run, C controller against Python
        costs = {}
        for name, make in (("C", lambda: H.c_controller(d)),
                           ("Python", lambda: H.HopController(d))):
            best = math.inf
            for _ in range(3):
                start = time.perf_counter()
                _run(hm, d, make(), 0.01, 0.005)
                best = min(best, time.perf_counter() - start)
            costs[name] = best
        out["cases"].append({
            "label": label, "a": a, "open_loop_multipliers": [abs(r) for r in d.open_loop],
            "predicted_rate": float(max(abs(d.closed_loop))), "measured_rate": rate,
            "region": {k: v.tolist() for k, v in region.items()},
            "fraction": {k: float(v.mean()) for k, v in region.items()},
            "linear_range_converges": bool(all(near)),
            "costs_s": costs})
    out["chart"] = str(_chart(out, phis, vs, Path(out_dir)))
    return out


def _chart(out: dict, phis, vs, folder: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    folder.mkdir(parents=True, exist_ok=True)
    cases = out["cases"]
    names = list(cases[0]["region"])
    fig, axes = plt.subplots(len(cases), len(names), figsize=(3.2 * len(names),
                                                               3.0 * len(cases)),
                             squeeze=False, sharex=True, sharey=True)
    for r, case in enumerate(cases):
        for c, name in enumerate(names):
            ax = axes[r][c]
            ok = np.array(case["region"][name])
            ax.pcolormesh(phis, vs, ok, cmap="Greens", vmin=0, vmax=1.4, shading="nearest")
            ax.plot(0, 0, "k+", ms=8)
            ax.set_title(f"{name}\n{case['label']}: {100 * ok.mean():.0f} %", fontsize=9)
            if r == len(cases) - 1:
                ax.set_xlabel("phase deviation (rad of the gait)")
            if c == 0:
                ax.set_ylabel("velocity deviation (relative)")
    fig.suptitle(f"Starts that converge within {out['hops']} hops (green)", fontsize=10)
    fig.tight_layout()
    path = folder / "hop-region.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _targets(out: dict) -> list:
    targets = []
    for case in out["cases"]:
        lam, got = case["predicted_rate"], case["measured_rate"]
        targets.append(Target(f"{case['label']}: per-hop decay {got:.4f} against the "
                              f"predicted |lambda| {lam:.4f} (within 25 %)",
                              abs(got - lam) <= 0.25 * lam))
    past = out["cases"][-1]
    reg = np.array(past["region"]["open loop"])
    g = len(reg) // 2
    off_orbit = np.delete(reg.ravel(), g * len(reg) + g)      # all but the orbit itself
    targets.append(Target(f"past period doubling: the open loop brings back no start off "
                          f"the orbit ({int(off_orbit.sum())} of {off_orbit.size})",
                          not off_orbit.any()))
    for case in out["cases"]:
        targets.append(Target(f"{case['label']}: the per-hop feedback brings back every "
                              f"start within +-0.05 rad and +-2.5 % of the orbit",
                              case["linear_range_converges"]))
    return targets


def report(out: dict) -> str:
    lines = [f"per-hop feedback on the reference-[5] hop ({out['grid']} x {out['grid']} "
             f"starts, {out['hops']} hops each)"]
    for case in out["cases"]:
        rho = ", ".join(f"{r:.4g}" for r in case["open_loop_multipliers"])
        lines.append(f"  {case['label']} (a = {case['a']}): open-loop |rho| {rho}; "
                     + ", ".join(f"{k} {100 * v:.0f} %" for k, v in case["fraction"].items())
                     + f"; a run {1e3 * case['costs_s']['C']:.2f} ms with the C controller, "
                       f"{1e3 * case['costs_s']['Python']:.2f} ms through Python")
    lines += [str(t) for t in _targets(out)]
    lines.append(f"chart: {out['chart']}")
    return "\n".join(lines)


def passed(out: dict) -> bool:
    return all_pass(_targets(out))
