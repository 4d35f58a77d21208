"""``derive simulate SCENE -o DIR``: trajectory.csv, impacts.csv, summary.json, plots."""
from __future__ import annotations

import json
import os
import platform
from pathlib import Path

import numpy as np

from .driver import Result


def _segments(result: Result):
    """Index ranges between events (rows 'before_event' end one, 'after_event' start
    the next)."""
    kinds = result.row_kind
    start = 0
    for i, k in enumerate(kinds):
        if k == 1:
            yield start, i + 1
        elif k == 2:
            start = i
    yield start, len(kinds)


def invariant_drift(result: Result) -> dict:
    """Relative drift of |K| within each flight phase (E1.9), and of A's orthonormality."""
    out = {}
    K = result.momentum["K_norm"]
    worst = 0.0
    for a, b in _segments(result):
        if b - a > 1 and K[a] > 0:
            worst = max(worst, float(np.max(np.abs(K[a:b] - K[a])) / K[a]))
    out["K_norm_relative_drift_between_events"] = worst
    if result.general is not None:
        A = result.general[:, 9:18].reshape(-1, 3, 3)
        err = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        out["orthonormality_error_max"] = float(err.max())
    return out


def _finite(x: float):
    return float(x) if np.isfinite(x) else None


def summary(result: Result) -> dict:
    s = result.scene
    return {
        "scene": s.name,
        "status": result.status,
        "model": result.model,
        "why": result.why,
        "method": s.method, "rtol": s.rtol, "atol": s.atol,
        "t0": s.t0, "t_end": float(result.t[-1]) if len(result.t) else s.t0,
        "duration": s.duration,
        "counts": {**result.stats, "rows": int(len(result.t)),
                   "events": len(result.events)},
        "contact": {"min_height_of_S": _finite(result.min_height),
                    "t_min_height": _finite(result.summary["t_min_height"]),
                    "min_normal_force_in_contact": _finite(result.min_normal)},
        "invariants": invariant_drift(result),
        "timings_s": result.timings,
        "machine": {"processor": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count()},
    }


def write_csv(path: Path, header: list, rows: np.ndarray) -> None:
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(header) + "\n")
        for row in rows:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def trajectory_table(result: Result) -> tuple[list, np.ndarray]:
    header = ["t", *result.state_names]
    cols = [result.t[:, None], result.q]
    for name, value in result.extras.items():
        if name == "omega" and "omega_x" not in result.state_names:
            header += ["omega_x", "omega_y", "omega_z"]
            cols.append(value)
        elif name == "height":
            header.append("h")
            cols.append(value[:, None])
        elif name == "momentum":
            header += ["K_x", "K_y", "K_z", "K_norm"]
            cols += [value["K_body"], value["K_norm"][:, None]]
    return header, np.hstack(cols)


def plots(result: Result, out: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    written = []
    title = f"{result.scene.name}: {result.model} model, {result.scene.method}"
    t = result.t

    def save(fig, name):
        path = out / name
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    height = result.height
    if height is not None:
        fig, ax = plt.subplots(figsize=(8, 3.5))
        ax.plot(t, height, lw=1)
        for imp in result.impacts:
            ax.axvline(imp[0], color="0.8", lw=0.6, zorder=0)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("height of S [m]")
        ax.set_title(f"{title}: height of the lowest point")
        save(fig, "height.png")
    omega = result.omega
    if omega is not None:
        fig, ax = plt.subplots(figsize=(8, 3.5))
        for k, c in enumerate("xyz"):
            ax.plot(t, omega[:, k], lw=1, label=f"omega_{c}")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("angular velocity [rad/s]")
        ax.legend(loc="best")
        ax.set_title(f"{title}: angular velocity (body axes)")
        save(fig, "omega.png")
        K = result.momentum["K_norm"]
        fig, ax = plt.subplots(figsize=(8, 3.5))
        for a, b in _segments(result):
            if b - a > 1 and K[a] > 0:
                ax.semilogy(t[a:b], np.abs(K[a:b] - K[a]) / K[a] + 1e-17, lw=1, color="C0")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("| |K| - |K|(phase start) | / |K|")
        ax.set_title(f"{title}: drift of |K| between impacts (E1.9)")
        save(fig, "K_drift.png")
    if len(result.impacts):
        fig, ax = plt.subplots(figsize=(8, 3.5))
        ax.stem(result.impacts[:, 0], result.impacts[:, 1])
        ax.set_xlabel("t [s]")
        ax.set_ylabel("impulse I [N s]")
        ax.set_title(f"{title}: impulses ({len(result.impacts)} impacts)")
        save(fig, "impulses.png")
    return written


def write_all(result: Result, out_dir, plot: bool = True) -> list[Path]:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    header, rows = trajectory_table(result)
    write_csv(out / "trajectory.csv", header, rows)
    written.append(out / "trajectory.csv")
    write_csv(out / "impacts.csv", ["t", "I", "v_n_minus", "v_n_plus"], result.impacts)
    written.append(out / "impacts.csv")
    info = summary(result)
    if plot:
        written += plots(result, out)
    (out / "summary.json").write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
    written.append(out / "summary.json")
    return written
