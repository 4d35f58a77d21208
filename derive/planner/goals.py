"""The goals a task can have: one object each, holding everything that differs.

* how the goal is planned: the state the NLP carries (``layout``), the end conditions it
  adds to the transcription (``end_constraints``), the bounds of the first node, whether
  T is free, the plane, and the initial guess;
* what is done after the solve (``refine``: a hop's multipliers and, if unstable, the
  orbit with the stability conditions);
* how the written plan runs (``schedule``: the initial state and duration of
  ``scene.toml``, the span of the table, the NLP's estimate) and how its table ends
  (``table_ends``: periodic, rest or free);
* how its achievement is measured on a re-simulation (``measure``: the ``achieved``
  entries of plan.json) and said (``achieved_text``: the line the CLI prints).

The rest of the planner asks :func:`goal_of` instead of comparing goal strings.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..models import STATE_LABELS
from .functions import load, lowest_point
from .guess import hop_guess, land_guess, reorient_guess
from .law import Law
from .resim import ATTITUDE, OMEGA, Trajectory, attitude_of, rotation_angle
from .resim import rows as _rows
from .solve import solve
from .stability import analyse
from .transcribe import ACC, POS, Layout, general_layout, initial_state

LAND_EXTENSION = 0.05        # the table runs this fraction of T past touchdown
HOP_PERIODS = 4              # periods re-simulated for a hop
# the entries of the vertical state that a hop's period repeats (the others follow: Z_C
# from h = 0, n_z from |n| = 1, omega_z from K.n, see Hop.end_constraints)
HOP_PERIODIC = ("Z_C'", "omega_x", "omega_y", "a31", "a32")


@dataclass
class Schedule:
    """How the written scene runs the plan."""
    initial: dict                 # [initial] of scene.toml
    duration: float               # [run].duration
    t_table: float                # the table spans [0, t_table]
    nlp_estimate: dict            # the NLP's own figures, beside the achieved ones
    extra: dict = field(default_factory=dict)    # what measure() needs besides the law


def _initial_from_task(task) -> dict:
    sc = task.scene
    return {"time": 0.0, "com": list(sc.com), "com_velocity": list(sc.com_velocity),
            "omega": list(sc.omega), "matrix": [list(r) for r in np.asarray(sc.A0)]}


class Goal:
    name = ""
    model = "general"
    plane = False                # the plane is in the NLP (gap, touchdown)
    periodic_law = False         # the law is periodic and has no fixed ends (a hop)

    # ---- planning ----------------------------------------------------------------------
    def layout(self, task) -> Layout:
        raise NotImplementedError

    def free_time(self, task) -> bool:
        """T is a decision variable."""
        return task.objective == "time"

    def shortest(self, task) -> float:
        """The lower bound of a free T."""
        return 1e-3

    def v_ref(self, task) -> float:
        """A speed of S at touchdown, to scale v_n."""
        return math.sqrt(2 * task.scene.g * max(task.scene.com[2], 1e-3))

    def end_constraints(self, tr, add) -> None:
        raise NotImplementedError

    def objective_terms(self, tr):
        """What the goal adds to the objective beside the effort (or the time)."""
        return 0

    def bound_first_node(self, tr, lb, ub) -> None:
        """The first node is the task's initial state."""
        lb[:] = ub[:] = tr.layout.of_state(initial_state(tr.task))

    def guess(self, tr) -> np.ndarray:
        raise NotImplementedError

    def refine(self, task, report, progress: bool):
        """(report, stability, attempts) after a successful solve."""
        return report, None, []

    # ---- the written plan ------------------------------------------------------------------
    def table_ends(self, task) -> str:
        return "free"

    def law_rests(self, task) -> bool:
        """The law is at rest at both ends (held there past them)."""
        return task.rest_at_ends

    def schedule(self, task, tr, Q, T) -> Schedule:
        raise NotImplementedError

    def measure(self, task, law: Law, traj: Trajectory, extra: dict) -> dict:
        raise NotImplementedError

    def achieved_text(self, m: dict) -> str:
        raise NotImplementedError


class Reorient(Goal):
    """Turn the body to target_matrix at t = horizon, in free flight."""
    name = "reorient"

    def layout(self, task) -> Layout:
        return general_layout(task, OMEGA + ATTITUDE)

    def shortest(self, task) -> float:
        return 0.05 * task.horizon

    def end_constraints(self, tr, add) -> None:
        add("target_matrix at the end of the horizon", tr.attitude_error(tr.Q[:, tr.N]), 0, 0,
            "target_matrix")

    def guess(self, tr) -> np.ndarray:
        return reorient_guess(tr)

    def table_ends(self, task) -> str:
        if task.rest_at_ends:
            return "periodic" if task.circle is None else "rest"
        return "free"

    def schedule(self, task, tr, Q, T) -> Schedule:
        return Schedule(_initial_from_task(task), T, T, {
            "attitude_error_rad": rotation_angle(task.target, tr.layout.A_of(Q[:, -1]))})

    def measure(self, task, law, traj, extra) -> dict:
        A = attitude_of(traj.q[-1])
        return {"source": traj.source, "status": traj.status, "t_end": float(traj.t[-1]),
                "attitude_error_rad": rotation_angle(task.target, A),
                "omega_end": traj.q[-1, _rows(OMEGA)].tolist(),
                "orthonormality": float(np.max(np.abs(A @ A.T - np.eye(3))))}

    def achieved_text(self, m: dict) -> str:
        return f"attitude error {m['attitude_error_rad']:.2e} rad at t = {m['t_end']:.6g} s"


class Land(Goal):
    """Touch the plane at t = T (free) with target_matrix, or with d = CS x n = 0."""
    name = "land"
    plane = True

    def layout(self, task) -> Layout:
        return general_layout(task, ("Z_C", "Z_C'") + OMEGA + ATTITUDE)

    def free_time(self, task) -> bool:
        return True

    def end_constraints(self, tr, add) -> None:
        qN, uN = tr.touchdown(add)
        tr.touchdown_state = (qN, uN)
        task = tr.task
        if task.at_touchdown == "attitude":
            add("target_matrix at touchdown", tr.attitude_error(qN), 0, 0, "target_matrix")
        else:
            CS, _ = load("lever")(tr.layout.full(qN), uN, tr.s_of(qN), ca.DM(tr.p))
            A = tr.layout.A_of(qN)
            add("d = CS x n = 0 at touchdown (CS vertical)", ca.mtimes(A[0:2, :], CS)
                / task.scene.body_size, 0, 0, "at_touchdown")

    def objective_terms(self, tr):
        """``spin_weight |omega+|^2``: the spin the touchdown impact leaves."""
        if not tr.task.spin_weight:
            return 0
        qN, uN = tr.touchdown_state
        q_plus = tr.impact(qN, uN, tr.s_of(qN), ca.DM(tr.p), tr.task.scene.e)[0]
        omega = [tr.layout.index(c) for c in OMEGA]
        return tr.task.spin_weight * ca.sumsqr(q_plus[omega])

    def guess(self, tr) -> np.ndarray:
        return land_guess(tr)

    def schedule(self, task, tr, Q, T) -> Schedule:
        est = {"touchdown_time": T}
        if task.at_touchdown == "attitude":
            est["attitude_error_rad"] = rotation_angle(task.target, tr.layout.A_of(Q[:, -1]))
        return Schedule(_initial_from_task(task), T * (1 + 0.5 * LAND_EXTENSION),
                        T * (1 + LAND_EXTENSION), est)

    def measure(self, task, law, traj, extra) -> dict:
        out = {"source": traj.source, "status": traj.status}
        if not traj.impacts:
            out["error"] = "no impact in the re-simulation"
            return out
        first = traj.impacts[0]
        qm = first["q_minus"]
        omega = _rows(OMEGA)
        out.update(touchdown_time=first["t"], touchdown_time_error=first["t"] - law.T,
                   v_n_minus=first["v_minus"],
                   spin_after=float(np.linalg.norm(first["q_plus"][omega])))
        if task.at_touchdown == "attitude":
            out["attitude_error_rad"] = rotation_angle(task.target, attitude_of(qm))
        else:
            sc = task.scene
            n = np.asarray(qm)[_rows(("a31", "a32", "a33"))]
            s = np.array(lowest_point(sc.shape, n, sc.center, sc.size).full()).ravel()
            p = [sc.M, sc.m, *sc.J, sc.g]
            _, d = load("lever")(qm, first["u"], s, p)
            out["d_norm"] = float(np.linalg.norm(np.array(d.full()).ravel()))
            out["omega_jump"] = float(np.linalg.norm(first["q_plus"][omega] - qm[omega]))
        return out

    def achieved_text(self, m: dict) -> str:
        if "error" in m:
            return m["error"]
        text = (f"touchdown at t = {m['touchdown_time']:.9g} s (planned "
                f"{m['touchdown_time'] - m['touchdown_time_error']:.9g})")
        spin = f", spin after the impact |omega+| = {m['spin_after']:.3g} rad/s"
        if "attitude_error_rad" in m:
            return text + f", attitude error {m['attitude_error_rad']:.2e} rad" + spin
        return (text + f", |d| = {m['d_norm']:.2e}, |omega+ - omega-| = {m['omega_jump']:.2e}"
                + spin)


class Hop(Goal):
    """A periodic hop: one impact per period, the highest Z_C apex_height."""
    name = "hop"
    model = "vertical"
    plane = True
    periodic_law = True

    def layout(self, task) -> Layout:
        n = len(STATE_LABELS["vertical"])
        return Layout("vertical", tuple(range(n)), np.zeros(n))

    def free_time(self, task) -> bool:
        return True

    def v_ref(self, task) -> float:
        return math.sqrt(2 * task.scene.g * max(task.apex_height, 1e-3))

    def bound_first_node(self, tr, lb, ub) -> None:
        """Only the spin: omega_z of [initial] (K.n is conserved, the rest periodic)."""
        k = tr.layout.index("omega_z")
        lb[k] = ub[k] = tr.task.scene.omega[2]

    def end_constraints(self, tr, add) -> None:
        """One impact per period, at t = 0 = T: post-impact state Q_0 on the plane;
        Q_N is the state just before the next impact, mapped by E1.10-E1.16 back to Q_0.
        Z_C(T) and n_z follow from h = 0 and |n| = 1, omega_z from K.n (conserved in
        flight and at impacts, since d is normal to n): those are not repeated."""
        p = ca.DM(tr.p)
        q0, u0 = tr.Q[:, 0], tr.u_at(0, 0.0)
        n0 = tr.layout.n_of(q0)
        add("hop: S on the plane just after the impact (h = 0)",
            tr.gap(q0, u0, tr.s_of(q0), p)[0], 0, 0)
        add("hop: |n| = 1", ca.sumsqr(n0) - 1, 0, 0)
        qN, uN = tr.touchdown(add)
        e = ca.DM([tr.task.scene.e])
        q_plus = tr.impact(qN, uN, tr.s_of(qN), p, e)[0]
        sel = [tr.layout.index(name) for name in HOP_PERIODIC]
        add("hop: periodic orbit (impact map E1.10-E1.16 back to the start)",
            q_plus[sel] - q0[sel], 0, 0)
        g = tr.task.scene.g
        Z, Zd = tr.layout.index("Z_C"), tr.layout.index("Z_C'")
        add("apex_height: highest Z_C of the hop", q0[Z] + q0[Zd] ** 2 / (2 * g)
            - tr.task.apex_height, 0, 0, "apex_height")
        if tr.stabilize:
            self._stability_conditions(tr, add, q0, u0)

    @staticmethod
    def _stability_conditions(tr, add, q0, u0) -> None:
        """Two conditions that favour a stable orbit (then checked by the multipliers):

        * tilt: C below the centre of the shape at the impact (for a sphere, below the
          centre of curvature of the contact: the impulse then rights the body);
        * vertical: the "table" of reference [5] (the height nu n.OP that the point's
          motion gives S) accelerates at the impact within the stable window of the ball
          on a vibrating table, tr DP = 1 + e^2 + (1 + e)^2 s''/g in
          [-(1 + e^2), 1 + e^2], kept 30 % inside it."""
        sc = tr.task.scene
        nu = sc.m / (sc.m + sc.M)
        n0 = tr.layout.n_of(q0)
        depth = ca.dot(n0, nu * u0[POS] - ca.DM(list(sc.center)))
        add("stability (tilt): C below the shape's centre at the impact", depth, -np.inf,
            -0.1 * nu * tr.task.region_radius, "require_stable")
        e, g = sc.e, sc.g
        trace = 1 + e * e + (1 + e) ** 2 * nu * ca.dot(n0, u0[ACC]) / g
        bound = 0.7 * (1 + e * e)
        add("stability (vertical): impact in the stable window of reference [5]", trace,
            -bound, bound, "require_stable")

    def guess(self, tr) -> np.ndarray:
        return hop_guess(tr)

    def refine(self, task, report, progress: bool):
        """The effort-optimal orbit; if its multipliers say unstable, the orbit with the
        stability conditions, kept if stable (or less unstable).  With require_stable,
        an orbit still unstable makes the task infeasible."""
        law, Q = _hop_law(report)
        first = analyse(report.tr, law, Q)
        attempts = [{"conditions": False, "verdict": first["verdict"],
                     "max_modulus": first["max_modulus"],
                     "effort": report.tr.effort_of(report.result.w)}]
        kept, stability = report, first
        if not first["stable"]:
            second = solve(task, self, progress=progress, w0=report.result.w, stabilize=True,
                           diagnose=False)
            if not second.success:
                attempts.append({"conditions": True, "verdict": second.message})
            else:
                law2, Q2 = _hop_law(second)
                stab2 = analyse(second.tr, law2, Q2)
                attempts.append({"conditions": True, "verdict": stab2["verdict"],
                                 "max_modulus": stab2["max_modulus"],
                                 "effort": second.tr.effort_of(second.result.w)})
                second.rounds = report.rounds + second.rounds
                second.solver_seconds += report.solver_seconds
                second.build_seconds += report.build_seconds
                if stab2["stable"] or stab2["max_modulus"] < first["max_modulus"]:
                    kept, stability = second, stab2
        if task.require_stable and not stability["stable"]:
            kept.success = False
            tried = f"the effort-optimal orbit is {attempts[0]['verdict']}"
            if len(attempts) > 1:
                tried += f"; with the stability conditions: {attempts[1]['verdict']}"
            kept.message = f"infeasible: require_stable: no stable orbit ({tried})"
        return kept, stability, attempts

    def table_ends(self, task) -> str:
        return "periodic"

    def law_rests(self, task) -> bool:
        return False

    def schedule(self, task, tr, Q, T) -> Schedule:
        """scene.toml starts at mid-flight (node N/2) and runs HOP_PERIODS periods."""
        lay = tr.layout
        k = tr.N // 2
        qm = Q[:, k]
        Z, Zd = lay.index("Z_C"), lay.index("Z_C'")
        A = _matrix_from_n(lay.n_of(qm))
        initial = {"time": k * T / tr.N, "com": [0.0, 0.0, qm[Z]],
                   "com_velocity": [0.0, 0.0, qm[Zd]],
                   "omega": [qm[lay.index(w)] for w in OMEGA],
                   "matrix": [list(r) for r in A]}
        est = {"period": T, "apex": float(Q[Z, 0] + Q[Zd, 0] ** 2 / (2 * task.scene.g)),
               "post_impact_state": Q[:, 0].tolist()}
        return Schedule(initial, HOP_PERIODS * T, T, est, {"post_impact": Q[:, 0]})

    def measure(self, task, law, traj, extra) -> dict:
        """Every impact: the post-impact vertical state against the planned one."""
        out = {"source": traj.source, "status": traj.status}
        if not traj.impacts:
            out["error"] = "no impact in the re-simulation"
            return out
        vertical = _rows(STATE_LABELS["vertical"])        # the same labels, general rows
        planned, g, T = extra["post_impact"], task.scene.g, law.T
        Z, Zd = _rows(("Z_C", "Z_C'"))
        rows = []
        for imp in traj.impacts:
            qp = imp["q_plus"]
            apex = qp[Z] + qp[Zd] ** 2 / (2 * g)
            rows.append({"t": imp["t"], "apex": apex,
                         "state_error": float(np.max(np.abs(qp[vertical] - planned))),
                         "phase_error": float((imp["t"] - round(imp["t"] / T) * T))})
        out.update(impacts=len(rows), period=T,
                   apex_error=float(max(abs(r["apex"] - task.apex_height) for r in rows)),
                   first_period_state_error=rows[0]["state_error"],
                   first_period_phase_error=rows[0]["phase_error"],
                   max_state_error=float(max(r["state_error"] for r in rows)),
                   per_impact=[{k: float(v) for k, v in r.items()} for r in rows])
        return out

    def achieved_text(self, m: dict) -> str:
        if "error" in m:
            return m["error"]
        return (f"{m['impacts']} impacts, apex error {m['apex_error']:.2e} m, post-impact "
                f"state error {m['max_state_error']:.2e}, period {m['period']:.9g} s")


def _hop_law(report) -> tuple:
    ctrl, Q, T = report.tr.unpack(report.result.w)
    return Law(report.tr.spline, ctrl, T, "cartesian", (), "periodic"), Q


def _matrix_from_n(n) -> np.ndarray:
    """A rotation whose third row is n (the vertical in body axes)."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r1 = helper - n * (n @ helper)
    r1 /= np.linalg.norm(r1)
    r2 = np.cross(n, r1)
    return np.array([r1, r2, n])


GOALS = {g.name: g for g in (Reorient(), Land(), Hop())}


def goal_of(task) -> Goal:
    """The goal object of a task."""
    return GOALS[task.goal]
