"""The written plan of a task of several bodies (:mod:`derive.planner.bodies`): a table
per decided body (``point1.csv``: t, x, y, z and their rates; ``rotor2.csv``: t, psi,
psi', psi''), the scene with those tables and the kept bodies' laws, what the law does
(:class:`~derive.planner.summary.BodiesLawStats`) and its plots.

Downstream of the pipeline (:mod:`derive.planner.core` calls it); it imports nothing from
there.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from .. import shapes
from .law import Law
from .summary import BodiesLawStats

POINT_HEAD = ("t", "x", "y", "z", "x'", "y'", "z'", "x''", "y''", "z''")
ROTOR_HEAD = ("t", "psi", "psi'", "psi''")


def file_of(ch) -> str:
    """A decided body's table: point1.csv, rotor2.csv."""
    return f"{ch.kind}{ch.index + 1}.csv"


def _columns(channels, ch) -> list:
    """Where a channel's value, rate and acceleration sit in the law's u (D each)."""
    D = channels.D
    return [d * D + c for d in range(3) for c in range(ch.column, ch.column + ch.width)]


def tabulate(law: Law, channels, t_end: float | None = None, per_piece: int = 32):
    """({file: rows}, reproduction error): each decided body's table on a grid containing
    the knots, refined until a cubic spline with the table's ends reproduces every
    body's values to 1e-11 (as :func:`derive.planner.core.tabulate` for one point)."""
    T = law.T
    t_end = T if t_end is None else t_end
    h = T / law.spline.n
    D = channels.D
    bc = ((1, np.zeros(D)), (1, np.zeros(D))) if law.ends == "rest" else "not-a-knot"
    while True:
        t = np.linspace(0.0, T, law.spline.n * per_piece + 1)
        if t_end > T:
            extra = max(2, math.ceil((t_end - T) / (h / per_piece)))
            t = np.r_[t, np.linspace(T, t_end, extra + 1)[1:]]
        u = law.u(t)
        sp = CubicSpline(t, u[:D].T, axis=0, bc_type=bc)
        probe = np.r_[0.5 * (t[1:] + t[:-1]), t[:-1] + 0.25 * np.diff(t)]
        err = float(np.max(np.abs(sp(probe).T - law.u(probe)[:D])))
        if err < 1e-11 or per_piece >= 2048:
            break
        per_piece *= 2
    tables = {file_of(ch): np.column_stack([t, u[_columns(channels, ch)].T])
              for ch in channels.channels}
    return tables, err


def write_table(path, rows: np.ndarray):
    head = POINT_HEAD if rows.shape[1] == len(POINT_HEAD) else ROTOR_HEAD
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(head) + "\n")
        for row in rows:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def scene_document(task, channels, law: Law, initial: dict, duration: float) -> dict:
    """The task's scene with each decided body's law as its table, the kept bodies with
    their laws (formulas the law parser read: only its whitelist's tokens); the task's
    name is not copied."""
    sc = task.scene
    body = {"mass": sc.M, "inertia": list(sc.J), "shape": sc.shape}
    if sc.shape != shapes.NONE:
        body.update(shapes.fields_of(shapes.of(sc.shape), sc.size))
        body["center"] = list(sc.center)
    decided = {(ch.kind, ch.index): ch for ch in channels.channels}
    points = []
    for k, p in enumerate(sc.points):
        ch = decided.get(("point", k))
        points.append({"mass": p.mass, "table": file_of(ch), "ends": law.ends} if ch
                      else {"mass": p.mass, "law": list(p.law_text)})
    rotors = []
    for k, r in enumerate(sc.rotors):
        ch = decided.get(("rotor", k))
        el = {"axis": list(r.axis), "inertia": r.inertia}
        el.update({"table": file_of(ch), "ends": law.ends} if ch else {"law": r.law_text})
        rotors.append(el)
    doc = {"name": f"planned-{task.goal}", "body": body}
    if points:
        doc["point"] = points
    if rotors:
        doc["rotor"] = rotors
    if sc.plane:
        doc["plane"] = {"restitution": sc.e}
    doc["initial"] = initial
    doc["run"] = {"duration": duration, "method": "dop853", "rtol": 1e-12, "atol": 1e-14,
                  "g": sc.g, "outputs": ["pose", "omega", "impacts"]}
    return doc


def law_stats(task, tr, law: Law, tables: dict, repro: float, w) -> BodiesLawStats:
    """What the planned law of every decided body does, on a fine grid."""
    ch_all = tr.channels
    t = np.linspace(0.0, law.T, 64 * tr.N + 1)
    u = law.u(t)
    bodies = []
    for ch in ch_all.channels:
        val, rate, acc = (u[d * ch_all.D + ch.column:d * ch_all.D + ch.column + ch.width]
                          for d in range(3))
        row = {"name": ch.name, "effort": float(tr.effort_part_of(ch.name, w))}
        if ch.kind == "point":
            row.update(max_acceleration=float(np.max(np.linalg.norm(acc, axis=0))),
                       max_distance_from_region_center=float(np.max(np.linalg.norm(
                           val.T - task.region_center, axis=1))))
        else:
            row.update(max_rate=float(np.max(np.abs(rate))),
                       max_acceleration=float(np.max(np.abs(acc))),
                       turn=float(val[0, -1] - val[0, 0]))
        bodies.append(row)
    rows = sum(len(r) for r in tables.values()) // max(1, len(tables))
    return BodiesLawStats(kind="bodies", pieces=tr.N, duration=law.T, ends=law.ends,
                          decided=[ch.name for ch in ch_all.channels], table_rows=rows,
                          table_reproduction_error=repro, bodies=bodies,
                          effort=tr.effort_of(w))


def plot_law(plan, path):
    """law.png: each decided body's values and accelerations against its bound."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    task, tables = plan.task, plan.tables
    fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for name, rows in tables.items():
        label = name.removesuffix(".csv").replace("point", "point ").replace("rotor", "rotor ")
        t = rows[:, 0]
        if rows.shape[1] == len(POINT_HEAD):
            for k, c in enumerate("xyz"):
                ax[0].plot(t, rows[:, 1 + k], label=f"{label}: {c} (m)")
            ax[1].plot(t, np.linalg.norm(rows[:, 7:10], axis=1) / task.max_acceleration,
                       label=f"{label}: |OP''| / max_acceleration")
        else:
            ax[0].plot(t, rows[:, 1], label=f"{label}: psi (rad)")
            ax[1].plot(t, np.abs(rows[:, 3]) / task.max_rotor_acceleration,
                       label=f"{label}: |psi''| / max_rotor_acceleration")
    ax[1].axhline(1.0, color="k", ls="--", lw=0.8)
    ax[0].legend(loc="best", fontsize=8)
    ax[1].legend(loc="best", fontsize=8)
    ax[1].set_xlabel("t (s)")
    fig.suptitle(f"planned laws ({task.goal}: {', '.join(d.name for d in task.decided)})")
    fig.subplots_adjust(left=0.12, right=0.97, top=0.92, bottom=0.09, hspace=0.12)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
