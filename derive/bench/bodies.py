"""``derive bench bodies``: what several internal bodies cost (issue 32), against the
number of points N = 1..8 and rotors R = 0..4, and against Pinocchio on the same flights.

* **Derivation, emission and compile**: the moments models (``moments``,
  ``moments_rough``) are derived, emitted and compiled once per machine, whatever N and R
  (up to 16 points and 8 rotors: the bodies are data, summed in C by crt_bodies.h); timed
  here from a cold start (a fresh process, an empty compile cache), and every scene of
  the grid checked to load the same library.
* **RHS operations**: the flight right-hand side's operations as emitted: the moments
  RHS is fixed, each point adds its share (point_moments) and 27 additions, each rotor
  its share (rotor_moments) and 6: linear in N and R by construction, printed.
* **The C run**: CPU time per simulated second of a bouncing ball carrying N points and R
  rotors (harmonic laws, small masses: the same motion's steps), and per evaluation of
  the right-hand side; a chart (``bodies-cost.png``).  Targets: no swell (every scene of
  the grid within 1.3x of the least-squares plane a + b N + c R of the per-evaluation
  cost); the scene of 8 points and 4 rotors against the one-point scene run by the
  general model (interleaved, paired samples) is printed without a verdict: the issue asks
  either no new compile (which holds: one library) or, for a model compiled per N and R,
  at most 3x the one-point call, and here the user's own laws (3 formulas a point, one a
  rotor) take most of that time, which no choice of equations removes.
* **Against Pinocchio** (when installed): the same free flights of N points and R rotors
  by a free flyer with prismatic joints per point and a revolute joint per rotor, driven
  along their laws (CRBA and RNEA per evaluation, SciPy's DOP853): time per simulated
  second at rtol 1e-9 and the error of the final attitude and C against Pinocchio's own
  run at 1e-13, which the runtime's run at 1e-13 must match.
"""
from __future__ import annotations

import copy
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .. import layout
from ..commands import Target
from ..scene.bodies import describe
from .timing import (AT_LEAST, CPU, SPREAD_NOTE, PreparedRun, Spread, interleaved, judge,
                     ratios)

POINTS = range(1, 9)
ROTORS = range(0, 5)
SWELL = 1.3                # every scene within this factor of the linear fit
COMPILE_LIMIT = 120.0      # derivation, emission and compile of the moments models (s)
PEER_SPEEDUP = 10.0        # the runtime at least this much faster than Pinocchio + SciPy
AGREE = 1e-9               # the two references' final attitude and C
PEER_CASES = ((1, 0), (4, 2), (8, 4))
G = layout.GENERAL


def scene(n_points: int, n_rotors: int, plane: bool = True, rtol: float = 1e-10) -> dict:
    """The built-in ball carrying ``n_points`` points of 20 g (harmonics of about the
    built-in law's frequencies) and ``n_rotors`` rotors (axes x, y, z, then the
    diagonal; a spin of 20 to 35 rad/s and a harmonic)."""
    from ..scene import builtin_doc
    doc = builtin_doc()
    doc["name"] = f"{n_points} points, {n_rotors} rotors"
    doc["run"].update(duration=2.0, rtol=rtol, atol=rtol * 1e-2)
    doc["point"] = [{"mass": 0.02, "law": [f"0.2*sin({3 + 0.1 * j:g}*t)",
                                           f"0.1*cos({2 + 0.1 * j:g}*t)",
                                           f"0.05*sin({2 + 0.2 * j:g}*t + {j})"]}
                    for j in range(n_points)]
    axes = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.6, 0.0, 0.8])
    doc["rotor"] = [{"axis": axes[k % 4], "inertia": 0.002,
                     "law": f"{20 + 5 * k}*t + 0.5*sin({4 + k}*t)"} for k in range(n_rotors)]
    if not doc["rotor"]:
        doc.pop("rotor")
    if n_points == 1 and not n_rotors:
        doc["point"] = doc["point"][0]
    if not plane:
        doc.pop("plane")
    return doc


# ---- once per machine --------------------------------------------------------------------
_DERIVE = ("from derive.emit.runtime_backend import model, render_model\n"
           "for kind in ('moments', 'moments_rough'):\n"
           "    render_model(model(kind))\n")


def cold_costs(progress) -> dict:
    """Seconds to derive and emit the moments models in a fresh process, and to compile
    each into an empty cache."""
    import os
    import tempfile
    from ..cbuild import build_shared, runtime_flags
    from ..runtime.build import sources
    progress("deriving and emitting the moments models in a fresh process")
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", _DERIVE], check=True)
    out = {"derive_emit_s": time.perf_counter() - start}
    for kind in ("moments", "moments_rough"):
        progress(f"compiling model_{kind}.c into an empty cache")
        keep = tempfile.mkdtemp(prefix="derive-bodies-")
        before = os.environ.get("DERIVE_CACHE")
        os.environ["DERIVE_CACHE"] = keep
        try:
            start = time.perf_counter()
            build_shared(sources(kind), flags=runtime_flags(), name=f"crt_{kind}")
            out[f"compile_{kind}_s"] = time.perf_counter() - start
        finally:
            if before is None:
                os.environ.pop("DERIVE_CACHE")
            else:
                os.environ["DERIVE_CACHE"] = before
    return out


def operations() -> dict:
    """The emitted operations of the flight right-hand side's parts."""
    from .. import models as dm
    from .. import models_moments as mmo
    from ..emit.program import build
    return {"moments_flight_rhs": build(mmo.flight_rhs()).ops,
            "point_moments": build(mmo.point_moments()).ops + layout.MOMENTS.nq,
            "rotor_moments": build(mmo.rotor_moments()).ops + 6,
            "general_flight_rhs": build(dm.flight_rhs("general")).ops}


# ---- the C run ---------------------------------------------------------------------------
def grid_costs(repeats: int, progress) -> dict:
    """Per (N, R): the library, steps, RHS evaluations and the C's CPU time per simulated
    second (a Spread), and per evaluation."""
    out = {}
    for n in POINTS:
        for r in ROTORS:
            progress(f"the C run of {describe(n, r)}")
            run = PreparedRun(scene(n, r))
            if n == 1 and r == 0:
                forced = copy.deepcopy(scene(1, 0))
                forced["run"]["model"] = "moments"
                run = PreparedRun(forced)
            times = Spread.of([min(_cpu(run) for _ in range(3)) for _ in range(repeats)])
            evals = run.raw.stats["rhs_evaluations"]
            out[(n, r)] = {"library": str(run.prep.library.path), "model": run.prep.kind,
                           "steps": run.raw.stats["steps"], "evaluations": evals,
                           "per_second": times.scaled(1.0 / run.prep.scene.duration),
                           "per_evaluation": times.scaled(1.0 / evals),
                           "status": run.raw.status}
    return out


def _cpu(fn) -> float:
    start = CPU()
    fn()
    return CPU() - start


def linear_fit(grid: dict) -> tuple[np.ndarray, float]:
    """The least-squares plane a + b N + c R of the per-evaluation cost's medians, and the
    largest ratio of a scene's cost to it."""
    keys = sorted(grid)
    X = np.array([[1.0, n, r] for n, r in keys])
    y = np.array([grid[k]["per_evaluation"].median for k in keys])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef, float(np.max(y / (X @ coef)))


def breakdown(n_points: int, n_rotors: int, rows: int = 100_000) -> dict:
    """Where an evaluation of the right-hand side goes, ns (CPU, the least of 5 passes
    over ``rows`` times): the law alone (crt_law_rows), the law and the moments' sum
    (crt_eval_u_rows), and the whole right-hand side (crt_eval_rhs_rows)."""
    from ..runtime.build import DP
    run = PreparedRun(scene(n_points, n_rotors))
    s, lib, p = run.session, run.prep.library.lib, run.prep
    s.init(p.options, p.parameters, p.scene.t0, p.start.q0)
    t = np.linspace(p.scene.t0, p.scene.t0 + p.scene.duration, rows)
    u = np.zeros((rows, max(lib.crt_law_width(s.handle), lib.crt_u_width())))
    q = np.ascontiguousarray(np.tile(p.start.q0, (rows, 1)))
    dq = np.zeros_like(q)
    tp, up, qp, dp = (a.ctypes.data_as(DP) for a in (t, u, q, dq))
    calls = {"law": lambda: lib.crt_law_rows(s.handle, rows, tp, up),
             "law and sum": lambda: lib.crt_eval_u_rows(s.handle, rows, tp, up),
             "right-hand side": lambda: lib.crt_eval_rhs_rows(s.handle, rows, tp, qp, dp)}
    return {name: 1e9 * min(_cpu(fn) for _ in range(5)) / rows for name, fn in calls.items()}


def against_one_point(samples: int) -> Spread:
    """Paired samples of the run of 8 points and 4 rotors over the one-point run by the
    general model (the same ball, interleaved rounds)."""
    many, one = PreparedRun(scene(8, 4)), PreparedRun(scene(1, 0))
    got = interleaved({"many": many, "one": one}, samples, block=3)
    return ratios(got["many"], got["one"])


# ---- Pinocchio ---------------------------------------------------------------------------
def _pinocchio_route(sc, rtol: float):
    """A callable running the free flight of ``sc`` by Pinocchio and SciPy: returns the
    final attitude (9) and C (3)."""
    import pinocchio as pin
    from scipy.integrate import solve_ivp
    from ..runtime import bodies as bm
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -sc.g])
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "carrier")
    own = [r.inertia * (0.5 * np.eye(3) + 0.5 * np.outer(r.axis, r.axis)) for r in sc.rotors]
    model.appendBodyToJoint(root, pin.Inertia(sc.M, np.zeros(3),
                                              np.diag(sc.J) - sum(own, np.zeros((3, 3)))),
                            pin.SE3.Identity())
    for j, p in enumerate(sc.points):
        parent = root
        for k, joint in enumerate((pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ())):
            parent = model.addJoint(parent, joint, pin.SE3.Identity(), f"P{j}{'xyz'[k]}")
        model.appendBodyToJoint(parent, pin.Inertia(p.mass, np.zeros(3), np.zeros((3, 3))),
                                pin.SE3.Identity())
    for k, r in enumerate(sc.rotors):
        joint = model.addJoint(root, pin.JointModelRevoluteUnaligned(np.array(r.axis)),
                               pin.SE3.Identity(), f"R{k}")
        model.appendBodyToJoint(joint, pin.Inertia(0.0, np.zeros(3), own[k]), pin.SE3.Identity())
    data = model.createData()

    def joints(t):
        """The joints' positions, rates and accelerations at t: every point's x, y, z and
        every rotor's psi, from the law."""
        b = bm.along(sc, [t])
        return tuple(np.r_[getattr(b, k)[:, 0].ravel(), b.psi[:, 0, d]]
                     for d, k in enumerate(("r", "v", "a")))

    def rhs(t, y):
        R = y[3:12].reshape(3, 3)
        qj, vj, aj = joints(t)
        qp = np.r_[y[:3], pin.Quaternion(R).coeffs(), qj]
        vp = np.r_[y[12:18], vj]
        Mq = pin.crba(model, data, qp)
        Mq = np.triu(Mq) + np.triu(Mq, 1).T
        h = pin.rnea(model, data, qp, vp, np.zeros(model.nv))
        ab = np.linalg.solve(Mq[:6, :6], -(h[:6] + Mq[:6, 6:] @ aj))
        w = y[15:18]
        skew = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        return np.r_[R @ y[12:15], (R @ skew).ravel(), ab]

    from ..runtime.choice import start
    q0 = start(sc, "moments").q0
    A0 = q0[G.A].reshape(3, 3)
    b0 = bm.along(sc, [sc.t0])
    c, cd, _ = bm.offsets(sc, bm.moments(b0))
    w0 = q0[G.omega]
    y0 = np.r_[q0[G.com] - A0 @ c[0], A0.ravel(),
               A0.T @ q0[G.com_velocity] - cd[0] - np.cross(w0, c[0]), w0]
    t1 = sc.t0 + sc.duration
    c1 = bm.offsets(sc, bm.moments(bm.along(sc, [t1])))[0][0]

    def run():
        y = solve_ivp(rhs, (sc.t0, t1), y0, method="DOP853", rtol=rtol,
                      atol=rtol * 1e-3).y[:, -1]
        R = y[3:12].reshape(3, 3)
        return np.r_[R.ravel(), y[:3] + R @ c1]
    return run


def peer(repeats: int, progress) -> list | None:
    """Per (N, R) of PEER_CASES: the runtime's and Pinocchio's time per simulated second at
    rtol 1e-9 and their errors against Pinocchio at 1e-13 (and the runtime at 1e-13's)."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return None
    rows = []
    for n, r in PEER_CASES:
        progress(f"Pinocchio: {describe(n, r)}")
        runs = {}
        for rtol in (1e-9, 1e-13):
            doc = scene(n, r, plane=False, rtol=rtol)
            doc["run"]["method"] = "dop853"
            doc["run"]["model"] = "moments"
            runs[rtol] = PreparedRun(doc)
        sc = runs[1e-9].prep.scene
        pin_fast, pin_ref = _pinocchio_route(sc, 1e-9), _pinocchio_route(sc, 1e-13)
        ref = pin_ref()

        def final(run):
            q = run.raw.q[-1]
            return np.r_[q[G.A], q[G.com]]
        c_time = Spread.of([min(_cpu(runs[1e-9]) for _ in range(3)) for _ in range(repeats)])
        start = CPU()
        got = pin_fast()
        p_time = CPU() - start
        rows.append({"case": (n, r), "c_s": c_time.scaled(1.0 / sc.duration),
                     "pinocchio_s": p_time / sc.duration,
                     "speedup": Spread.of([p_time]).over(c_time),
                     "c_error": float(np.abs(final(runs[1e-9]) - ref).max()),
                     "pinocchio_error": float(np.abs(got - ref).max()),
                     "agree": float(np.abs(final(runs[1e-13]) - ref).max())})
    return rows


# ---- the command -------------------------------------------------------------------------
def run(repeats: int = 5, quick: bool = False, out_dir: str = "bench-out",
        progress=lambda m: None) -> dict:
    out = {"operations": operations(), "grid": grid_costs(repeats, progress)}
    progress("8 points and 4 rotors against one point, interleaved")
    out["against_one_point"] = against_one_point(max(repeats, 5))
    out["breakdown"] = {case: breakdown(*case) for case in ((1, 0), (8, 4))}
    out["cold"] = None if quick else cold_costs(progress)
    out["peer"] = None if quick else peer(repeats, progress)
    out["chart"] = chart(out["grid"], Path(out_dir))
    return out


def chart(grid: dict, folder: Path) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    folder.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(10.0, 4.0))
    FigureCanvasAgg(fig)
    for k, (key, label) in enumerate((("per_second", "C run, ms of CPU per simulated s"),
                                      ("per_evaluation", "per RHS evaluation, us"))):
        ax = fig.add_subplot(1, 2, k + 1)
        scale = 1e3 if key == "per_second" else 1e6
        for r in ROTORS:
            ys = [grid[(n, r)][key] for n in POINTS]
            ax.errorbar(list(POINTS), [y.median * scale for y in ys],
                        yerr=[[scale * (y.median - y.lo) for y in ys],
                              [scale * (y.hi - y.median) for y in ys]],
                        marker="o", ms=3, lw=1, capsize=2, label=f"{r} rotors")
        ax.set_xlabel("points N")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, color="0.9")
        ax.set_ylim(bottom=0)
        if k == 0:
            ax.legend(fontsize=8)
    fig.suptitle("the moments models: the bouncing ball with N points and R rotors")
    fig.tight_layout()
    path = folder / "bodies-cost.png"
    fig.savefig(path, dpi=90)
    return path


def targets(out: dict) -> list[Target]:
    grid = out["grid"]
    libraries = {g["library"] for k, g in grid.items() if g["model"] == "moments"}
    _, worst = linear_fit(grid)
    got = [Target(f"one compiled library for every N = 1..8 and R = 0..4 ({len(libraries)} "
                  "library; the bodies are data: no compile per scene)", len(libraries) == 1),
           Target(f"no swell: every scene's cost per RHS evaluation within {worst:.2f}x of "
                  f"the plane a + b N + c R (target <= {SWELL:g}x)", worst <= SWELL)]
    cold = out["cold"]
    if cold:
        total = sum(cold.values())
        got.append(Target(f"derivation, emission and compile of the moments models, once per "
                          f"machine: {total:.1f} s (target <= {COMPILE_LIMIT:g} s)",
                          total <= COMPILE_LIMIT))
    for row in out["peer"] or ():
        n, r = row["case"]
        what = describe(n, r)
        got.append(judge(f"the runtime against Pinocchio + SciPy, {what}, rtol 1e-9",
                         row["speedup"], AT_LEAST, PEER_SPEEDUP))
        got.append(Target(f"the runtime at 1e-13 agrees with Pinocchio at 1e-13 to "
                          f"{row['agree']:.1e} ({what}; target <= {AGREE:g})",
                          row["agree"] <= AGREE))
    return got


def rhs_ops(ops: dict, n: int, r: int) -> int:
    """The operations of one flight right-hand side with n points and r rotors."""
    return ops["moments_flight_rhs"] + n * ops["point_moments"] + r * ops["rotor_moments"]


def report(out: dict) -> str:
    ops = out["operations"]
    lines = [f"RHS operations (emitted): moments flight RHS {ops['moments_flight_rhs']} "
             f"(fixed), + {ops['point_moments']} per point, + {ops['rotor_moments']} per "
             f"rotor; the general model's one-point RHS {ops['general_flight_rhs']}",
             "  ops(N, R) = " + ", ".join(f"{n},{r}: {rhs_ops(ops, n, r)}" for n, r in
                                          ((1, 0), (4, 2), (8, 4), (16, 8))),
             "", f"{'N':>3}{'R':>3}{'model':>9}{'steps':>7}{'RHS evals':>11}"
             f"{'C ms per sim s':>24}{'us per RHS eval':>24}"]
    for (n, r), g in sorted(out["grid"].items()):
        lines.append(f"{n:>3}{r:>3}{g['model']:>9}{g['steps']:>7}{g['evaluations']:>11}"
                     f"{g['per_second'].scaled(1e3).text('.3f'):>24}"
                     f"{g['per_evaluation'].scaled(1e6).text('.3f'):>24}")
    (n1, o1), (n8, o8) = out["breakdown"].items()
    lines.append(f"per RHS evaluation, ns: the law {o8['law']:.0f}, the moments' sum "
                 f"{o8['law and sum'] - o8['law']:.0f}, the equations "
                 f"{o8['right-hand side'] - o8['law and sum']:.0f} ({n8[0]} points, {n8[1]} "
                 f"rotors: {3 * n8[0] + n8[1]} formulas); the one point's by the general "
                 f"model: the law {o1['law']:.0f}, the equations "
                 f"{o1['right-hand side'] - o1['law']:.0f}")
    coef, _ = linear_fit(out["grid"])
    lines.append(f"per RHS evaluation ~ {1e6 * coef[0]:.3f} + {1e6 * coef[1]:.3f} N + "
                 f"{1e6 * coef[2]:.3f} R us (least squares); chart: {out['chart']}")
    lines.append(f"8 points and 4 rotors against one point by the general model, C CPU time "
                 f"per simulated second: {out['against_one_point'].text('.2f', 'x')} (no verdict: "
                 "one library serves every N and R, and the laws take most of it, above)")
    cold = out["cold"]
    if cold:
        lines.append(f"once per machine, for every N <= 16 and R <= 8: derive and emit "
                     f"{cold['derive_emit_s']:.1f} s, compile moments "
                     f"{cold['compile_moments_s']:.1f} s, moments_rough "
                     f"{cold['compile_moments_rough_s']:.1f} s")
    if out["peer"] is None and cold is not None:
        lines.append("against Pinocchio: not run (pinocchio is not installed: pip install pin)")
    for row in out["peer"] or ():
        n, r = row["case"]
        lines.append(f"free flight, {describe(n, r)}, rtol 1e-9: runtime "
                     f"{1e3 * row['c_s'].median:.3f} ms per sim s (error {row['c_error']:.1e}), "
                     f"Pinocchio + SciPy {1e3 * row['pinocchio_s']:.0f} ms "
                     f"(error {row['pinocchio_error']:.1e}); references agree to "
                     f"{row['agree']:.1e}")
    lines.append(SPREAD_NOTE)
    lines += [f"goal: {t}" for t in targets(out)]
    return "\n".join(lines)


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))
