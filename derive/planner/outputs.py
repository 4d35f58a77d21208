"""Writing a plan: law.csv, scene.toml, plan.json, law.c, law.h and PNG plots.

Downstream of the pipeline (:mod:`derive.planner.core`), which it does not import: it
is handed a :class:`~derive.planner.core.Plan` and writes it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import layout

from .resim import OMEGA, attitude_of, rotation_angle, rows


def write_table(path: Path, table: np.ndarray):
    """law.csv: t, x, y, z, x', y', z', x'', y'', z'' (every float by repr)."""
    head = "t,x,y,z,x',y',z',x'',y'',z''"
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(head + "\n")
        for row in table:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def write_plan(plan, out: Path) -> list[Path]:
    """Every output of a plan (only plan.json for a plan that failed)."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    if plan.ok:
        if plan.tables:                      # several bodies: a table per decided body
            from .bodies_plan import write_table as write_body_table
            for name, rows in plan.tables.items():
                write_body_table(out / name, rows)
                written.append(out / name)
        else:
            write_table(out / "law.csv", plan.table)
            written.append(out / "law.csv")
        (out / "scene.toml").write_text(plan.scene_toml, encoding="utf-8")
        written.append(out / "scene.toml")
        for name in sorted(plan.sources):                  # law.c, law.h
            (out / name).write_text(plan.sources[name], encoding="utf-8")
            written.append(out / name)
    (out / "plan.json").write_text(plan.summary.to_json(), encoding="utf-8")
    written.append(out / "plan.json")
    if plan.ok:
        written += plots(plan, out)
    return written


def plots(plan, out: Path) -> list[Path]:
    """law.png (the planned law) and motion.png (the re-simulated motion)."""
    import matplotlib
    matplotlib.use("Agg")
    paths = []
    if plan.tables:
        from .bodies_plan import plot_law
        paths.append(plot_law(plan, out / "law.png"))
    else:
        paths.append(_plot_point_law(plan, out / "law.png"))
    paths += _plot_motion(plan, out)
    return paths


def _plot_point_law(plan, path: Path) -> Path:
    import matplotlib.pyplot as plt
    task = plan.task
    t = plan.table[:, 0]
    u = plan.table[:, 1:].T
    fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for k, name in enumerate("xyz"):
        ax[0].plot(t, u[k], label=name)
    ax[0].set_ylabel("OP, body axes (m)")
    ax[0].legend(loc="best")
    ax[1].plot(t, np.linalg.norm(u[layout.U.a], axis=0), label="|OP''|")
    ax[1].axhline(task.max_acceleration, color="k", ls="--", lw=0.8, label="max_acceleration")
    ax[1].set_ylabel("m/s^2")
    ax[1].set_xlabel("t (s)")
    ax[1].legend(loc="best")
    fig.suptitle(f"planned law ({task.goal})")
    fig.subplots_adjust(left=0.12, right=0.97, top=0.92, bottom=0.09, hspace=0.12)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_motion(plan, out: Path) -> list[Path]:
    import matplotlib.pyplot as plt
    task, paths = plan.task, []
    traj = plan.trajectories.get("scipy")
    if traj is not None:
        fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        for name, k in zip(OMEGA, rows(OMEGA)):
            ax[0].plot(traj.t, traj.q[:, k], label=name)
        ax[0].set_ylabel("rad/s")
        ax[0].legend(loc="best")
        if task.target is not None:
            ang = [rotation_angle(task.target, attitude_of(q)) for q in traj.q]
            ax[1].semilogy(traj.t, np.maximum(ang, 1e-16))
            ax[1].set_ylabel("angle to target_matrix (rad)")
        else:
            ax[1].plot(traj.t, traj.q[:, rows(("Z_C",))[0]], label="Z_C")
            ax[1].set_ylabel("Z_C (m)")
        ax[1].set_xlabel("t (s)")
        fig.suptitle("re-simulated scene.toml (SciPy DOP853)")
        fig.subplots_adjust(left=0.12, right=0.97, top=0.92, bottom=0.09, hspace=0.12)
        fig.savefig(out / "motion.png", dpi=110)
        plt.close(fig)
        paths.append(out / "motion.png")
    return paths
