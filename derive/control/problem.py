"""The re-planning problem of a task (``[control] mode = "replan"``, goals reorient and
land): its description as CasADi functions, apart from its rendering to C
(:mod:`derive.control.render`) and its solvers (:mod:`derive.control.solvers`), as
acados keeps the problem, the rendering and the solver object apart.

The problem at a call at time t (the law's value x0 and rate v0 at t, the measured state
q read into the planner's layout: omega and A, and for land Z_C, Z_C'):

* the law from t on is a uniform cubic B-spline of ``intervals`` pieces over [t, t + T]
  (control points C, N + 3 of them; :mod:`derive.control.spline`), at rest at its end
  (x' = x'' = 0: P holds still from t + T on); it starts at x0 with rate v0 (x and x'
  continue, x'' may jump: the impact map reads x');
* the motion from q over each piece by ``substeps`` RK4 steps of the derived flight
  right-hand side (``general_flight_rhs``, an SX function called from MX: single
  shooting, the states are functions of C and T);
* reorient: T = t_end - t (the plan's end, fixed) and the target attitude at t + T;
  land: T free, the gap closes at t + T approaching (h = 0, v_n < 0), and the target
  attitude there (or d = CS x n = 0, ``at_touchdown = "d_zero"``);
* P in the task's region (its control points, a sufficient condition: the B-spline lies
  in their convex hull) and |OP''| <= max_acceleration at the knots (OP'' is linear on
  each piece), each component within max_acceleration / sqrt(3): a box inside the ball,
  linear in the control points, so that a QP step respects it exactly;
* the objective is the task's effort, the integral of |OP''|^2 dt (exact for a cubic),
  scaled by max_acceleration^2 T.

``qp_data(w, p)`` gives the QP of a Gauss-Newton SQP step at w: the Gauss-Newton Hessian
of the effort's residuals plus a Levenberg-Marquardt term, the gradient, the
constraints' Jacobian (the end conditions' by reverse mode through the pieces) and the
bounds on the step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import layout
from ..planner.law import BASIS

G = layout.GENERAL
LM_RELATIVE = 1e-4     # the Levenberg-Marquardt term: this times the largest of H's diagonal
T_MIN = 1e-3           # land: the horizon is at least this (s)
V_N_MAX = -0.05        # land: v_n / v_ref at touchdown at most this (S approaches)
FREEZE_PERIODS = 1.5   # no re-plan when less than this many periods remain
MAX_QP_ITER = 450      # see max_qp_iter
QP_BUDGET = 450        # the QPs' iterations of one sample in all
SOFT_ITERATIONS = 3    # Gauss-Newton steps at most while a step leaves the ends unmet
# the end conditions are soft (exact L1 penalties: a slack per finite side, each costing
# SOFT_L1 s + SOFT_L2 s^2 / 2 in the objective's units), so that every QP has a solution
# however far a disturbance puts them; the actuator's limits (the region, the
# acceleration bound) and the law's own conditions (its start, at rest at its end) hard
SOFT_L1, SOFT_L2 = 1.0, 1.0
SOFT_POWER = 3.0       # the penalties at a horizon T: times (T_start / T)^SOFT_POWER
# a trust region on each QP step, so that the linearised region stays exact: a control
# point's coordinate moves at most STEP_FRACTION times the region's radius (and T by
# T_STEP_FRACTION of itself), and the region's linearised rows keep a margin of
# 3 STEP_FRACTION^2 (|dc|^2 / r^2, the convex constraint's most the step can add): the
# control points stay in the ball, and P with them (the convex hull)
STEP_FRACTION, T_STEP_FRACTION = 0.15, 0.25
ATTITUDE_EPS = 1e-3    # keeps the attitude's residual finite at 180 deg
DATA_NAME = "ctl_qp_data"   # qp_data's name: the C symbol of controller_data.c
PIECE_OPTIONS = {"max_num_dir": 1}   # the pieces' reverse derivative one direction at
#                                       a time: a third less C, as fast


def freeze(period: float) -> float:
    """No re-plan when less horizon than this remains."""
    return FREEZE_PERIODS * period


def max_qp_iter(problem: "Problem") -> int:
    """The first QP's iteration limit in a sample (:data:`QP_BUDGET` bounds them all):
    the QPs of undisturbed samples take about 40 iterations; after a push, a QP whose
    end conditions are out of the step's reach can take several hundred (the law's
    acceleration at its bound at most knots: one iteration per row that binds, and
    those it drops); past the limit the sample keeps the law in use."""
    return MAX_QP_ITER


@dataclass
class Problem:
    """The re-planning problem of a task: sizes, bounds and the CasADi functions.

    ``w = (vec(C) column-major, T)``; ``p = (x0, v0, T_s, q)``: the law's value and rate
    at the call, the horizon the constraints are scaled by, the measured state in the
    planner's layout (``keep``: the general layout's omega and A, with Z_C, Z_C' first for
    land)."""
    task: object
    N: int
    substeps: int = 2
    functions: dict = field(default_factory=dict)

    def __post_init__(self):
        import casadi as ca
        from ..planner.functions import load, lowest_point
        task, N, m = self.task, self.N, self.substeps
        sc = task.scene
        self.goal = task.goal
        if self.goal not in ("reorient", "land"):
            raise ValueError("replan: the goal must be reorient or land")
        if task.circle is not None:
            raise ValueError("replan: P on a circle is not re-planned (give a region)")
        self.land = self.goal == "land"
        # a task of several bodies: what the three columns drive (derive.control.columns);
        # None: the paper's one point, its x, y, z
        self.columns = None
        if task.bodies:
            from .columns import Columns
            if self.land and task.at_touchdown != "attitude":
                raise ValueError("replan: a task of bodies lands with at_touchdown = "
                                 "\"attitude\"")
            self.columns = Columns(task)
        cols = self.columns
        omega, A = list(range(G.omega.start, G.omega.stop)), list(range(G.A.start, G.A.stop))
        self.keep = ([G.Z, G.Zd] if self.land else []) + omega + A
        self.nq = len(self.keep)
        self.nc = N + 3
        self.nw = 3 * self.nc + 1
        self.np = 7 + self.nq
        self.p_model = [sc.M, sc.m, *sc.J, sc.g]
        P = ca.DM(self.p_model)
        keep = self.keep
        if cols is None:
            rhs, gap = load("general_flight_rhs"), load("general_gap")
        else:       # the bodies through their moments, from the columns' u
            f_m, gap_m = load("moments_flight_rhs"), load("moments_gap")

            def rhs(q, u, p):
                return f_m(q, cols.moments(u), p)

            def gap(q, u, s, p):
                return gap_m(q, cols.moments(u), s, p)

        def full(q):
            where = {i: k for k, i in enumerate(keep)}
            return ca.vertcat(*[q[where[i]] if i in where else 0.0 for i in range(G.nq)])

        def n_of(q):
            return q[[keep.index(i) for i in range(G.n.start, G.n.stop)]]

        def s_of(q):
            return lowest_point(sc.shape, n_of(q), sc.center, sc.size)

        # the law on a piece, from its four control points (column-major 4 x 3)
        B = BASIS
        cl, s, h = ca.SX.sym("cl", 12), ca.SX.sym("s"), ca.SX.sym("h")
        C4 = ca.reshape(cl, 4, 3)
        rows = []
        for d in range(3):
            pw = [ca.SX(0)] * 4
            for j in range(d, 4):
                pw[j] = math.factorial(j) / math.factorial(j - d) * s ** (j - d)
            b = [sum(B[k, j] * pw[j] for j in range(4)) for k in range(4)]
            rows.append(ca.vertcat(*[sum(b[k] * C4[k, c] for k in range(4))
                                     for c in range(3)]) / h ** d)
        U = ca.Function("U", [cl, s, h], [ca.vertcat(*rows)])
        # one piece of the motion: `substeps` RK4 steps (an SX function, called from MX)
        q0, T = ca.SX.sym("q", self.nq), ca.SX.sym("T")
        hh = T / N / m
        q = q0

        def f(q, u):
            return rhs(full(q), u, P)[keep]
        for j in range(m):
            s0, s1 = j / m, (j + 1) / m
            u0, um, u1 = (U(cl, x, T / N) for x in (s0, 0.5 * (s0 + s1), s1))
            k1 = f(q, u0)
            k2 = f(q + 0.5 * hh * k1, um)
            k3 = f(q + 0.5 * hh * k2, um)
            k4 = f(q + hh * k3, u1)
            q = q + hh / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        piece = ca.Function("piece", [q0, cl, T], [q], ["q", "cl", "T"], ["q_end"],
                            PIECE_OPTIONS)

        # ---- the algebraic part (SX: compact code): the effort's residuals and the rows
        # on the control points alone, with their derivatives
        ws, ps = ca.SX.sym("w", self.nw), ca.SX.sym("p", self.np)
        Cs, Ts = ca.reshape(ws[:3 * self.nc], self.nc, 3), ws[self.nw - 1]
        x0, v0, T_s = ps[0:3], ps[3:6], ps[6]
        g, lbg, ubg, names = [], [], [], []

        def add(name, e, lb, ub):
            e = ca.vec(e)
            g.append(e)
            lbg.extend([lb] * e.shape[0])
            ubg.extend([ub] * e.shape[0])
            names.extend([name] * e.shape[0])
        acc = Cs[0:N + 1, :] - 2 * Cs[1:N + 2, :] + Cs[2:N + 3, :]      # h^2 x'' at knots
        if cols is None:
            self._point_rows(add, Cs, Ts, x0, v0, acc)
        else:
            self._bodies_rows(add, Cs, Ts, x0, v0)
        g_alg = ca.vertcat(*g)
        # the effort: on each piece x'' is linear, so the integral of |x''|^2 over it is
        # h (|a0|^2 + a0.a1 + |a1|^2)/3 = h (3/4 |a0 + a1|^2 + 1/4 |a0 - a1|^2)/3
        a_t = acc / (Ts / N) ** 2
        res = []
        for k in range(N):
            a0, a1 = a_t[k, :].T, a_t[k + 1, :].T
            res.append(ca.sqrt(Ts / N / 3) * ca.vertcat(math.sqrt(3) / 2 * (a0 + a1),
                                                        0.5 * (a0 - a1)))
        if cols is None:
            r = ca.vertcat(*res) / ca.sqrt(task.max_acceleration ** 2 * T_s)
        else:           # each column's acceleration over its own bound; none: nothing
            scale = ca.DM([1.0 / cols.bound(c) if c in cols.real else 0.0
                           for c in range(3)] * 2)
            r = ca.vertcat(*[e * scale for e in res]) / ca.sqrt(T_s)
        Jr = ca.jacobian(r, ws)
        H = 2 * ca.mtimes(Jr.T, Jr)
        H = H + LM_RELATIVE * ca.mmax(ca.diag(H)) * ca.DM.eye(self.nw)
        alg = ca.Function("alg", [ws, ps], [ca.sumsqr(r), g_alg, H, 2 * ca.mtimes(Jr.T, r),
                                            ca.jacobian(g_alg, ws)])

        # ---- the end conditions (MX), from the state at the end and w
        Cm, Tm = ca.MX.sym("C", self.nc, 3), ca.MX.sym("T")
        w = ca.vertcat(ca.vec(Cm), Tm)
        p = ca.MX.sym("p", self.np)
        qe = ca.MX.sym("q_end", self.nq)
        g = []
        A_end = ca.reshape(qe[[keep.index(i) for i in A]], 3, 3).T
        if self.land:
            uN = U(ca.vec(Cm[N - 1:N + 3, :]), 1.0, Tm / N)
            hN, vnN = gap(full(qe), uN, s_of(qe), P)
            self.v_ref = math.sqrt(2 * sc.g * max(sc.com[2], 1e-3))
            add("touchdown: h = 0", hN, 0.0, 0.0)
            add("touchdown: v_n < 0", vnN / self.v_ref, -np.inf, V_N_MAX)
        if self.goal == "reorient" or task.at_touchdown == "attitude":
            # 2 tan(angle/2) axis of target^T A (the angle to the target, to first order):
            # zero at the target alone, and a step reduces it from any angle short of
            # 180 deg; sin(angle) axis, the planner's, vanishes at 180 deg too, and a
            # disturbed landing more than 90 deg off had been steered there (upside down)
            R = ca.mtimes(ca.DM(task.target).T, A_end)
            cos = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
            add("target attitude", ca.vertcat(R[2, 1] - R[1, 2], R[0, 2] - R[2, 0],
                                              R[1, 0] - R[0, 1]) / (1.0 + cos + ATTITUDE_EPS),
                0.0, 0.0)

        else:
            CS, _ = load("lever")(full(qe), uN, s_of(qe), P)
            add("d = CS x n = 0", ca.mtimes(A_end[0:2, :], CS) / sc.size[0], 0.0, 0.0)

        ends = ca.Function("ends", [qe, w], [ca.vertcat(*g)])
        # land with [plan].spin_weight: the spin the touchdown impact leaves, weighed beside
        # the effort as the planner weighs it (a residual of the least squares: its
        # Gauss-Newton term joins H, through the motion to the end)
        self.spin_weight = float(task.spin_weight) if self.land else 0.0
        if self.spin_weight:
            q_plus = load("general_impact")(full(qe), uN, s_of(qe), P, sc.e)[0]
            spin = ca.Function("spin", [qe, w], [math.sqrt(self.spin_weight)
                                                 * q_plus[omega]])
        self.lbg, self.ubg, self.g_names = np.array(lbg), np.array(ubg), names
        self.ng = len(lbg)
        # the soft rows: the end conditions; their slacks (a finite side each)
        n_alg = g_alg.shape[0]
        self.z1 = np.r_[np.zeros(n_alg), np.full(self.ng - n_alg, SOFT_L1)]
        self.z2 = np.r_[np.zeros(n_alg), np.full(self.ng - n_alg, SOFT_L2)]
        self.slack_sides = [(i, sd) for i in range(n_alg, self.ng)
                            for sd, b in ((1.0, self.lbg[i]), (-1.0, self.ubg[i]))
                            if math.isfinite(b)]
        self.ns = len(self.slack_sides)
        E = np.zeros((self.ng - n_alg, self.ns))
        for j, (i, sd) in enumerate(self.slack_sides):
            E[i - n_alg, j] = sd
        # single shooting (the controller): the motion through the N pieces from p's q;
        # the end conditions' Jacobian by reverse mode through them
        qk = p[7:]
        for k in range(N):
            qk = piece(qk, ca.vec(Cm[k:k + 4, :]), Tm)
        g_end = ends(qk, w)
        f_w, g_a, H_w, grad_w, JA_w = alg(w, p)
        f_effort = f_w                  # the effort alone (the multiple shooting adds its spin)
        if self.spin_weight:
            r_spin = spin(qk, w)
            J_spin = ca.jacobian(r_spin, w)
            f_w = f_w + ca.sumsqr(r_spin)
            H_w = H_w + 2 * ca.mtimes(J_spin.T, J_spin)
            grad_w = grad_w + 2 * ca.mtimes(J_spin.T, r_spin)
        Gx = ca.vertcat(g_a, g_end)
        A_w = ca.vertcat(JA_w, ca.jacobian(g_end, w))
        self.functions["qp_data"] = ca.Function(
            DATA_NAME, [w, p], [ca.densify(H_w), grad_w, ca.densify(A_w),
                                ca.DM(self.lbg) - Gx, ca.DM(self.ubg) - Gx],
            ["w", "p"], ["H", "g", "A", "lba", "uba"])
        self.functions["nlp"] = {"x": w, "p": p, "f": f_w, "g": Gx}
        self.functions["end_state"] = ca.Function("end_state", [w, p], [qk])
        # multiple shooting (the offline solution at the start, by IPOPT: the Hessian of
        # one piece, mapped, instead of one through the chain): x = (w, Q), the states at
        # the knots as variables, continuity as constraints
        Q = ca.MX.sym("Q", self.nq, N + 1)
        CL = ca.horzcat(*[ca.vec(Cm[k:k + 4, :]) for k in range(N)])
        q_next = piece.map(N)(Q[:, :N], CL, Tm)
        f_ms = f_effort + ca.sumsqr(spin(Q[:, N], w)) if self.spin_weight else f_effort
        self.functions["nlp_ms"] = {
            "x": ca.vertcat(w, ca.vec(Q)), "p": p, "f": f_ms,
            "g": ca.vertcat(g_a, ends(Q[:, N], w), ca.vec(Q[:, 1:] - q_next),
                            Q[:, 0] - p[7:])}
        # the same with the end conditions soft, as the QP has them: x = (w, Q, slacks)
        S = ca.MX.sym("s", self.ns)
        scale = ca.MX.sym("scale")          # the penalties' factor at this horizon
        z1s = ca.DM([self.z1[i] for i, _ in self.slack_sides])
        z2s = ca.DM([self.z2[i] for i, _ in self.slack_sides])
        self.functions["nlp_ms_soft"] = {
            "x": ca.vertcat(w, ca.vec(Q), S), "p": ca.vertcat(p, scale),
            "f": f_ms + scale * (ca.dot(z1s, S) + 0.5 * ca.dot(z2s, S * S)),
            "g": ca.vertcat(g_a, ends(Q[:, N], w) + ca.mtimes(ca.DM(E), S),
                            ca.vec(Q[:, 1:] - q_next), Q[:, 0] - p[7:])}
        self.functions["piece"] = piece
        # bounds on w: a point's control points in the region's box (a rotor's free, a
        # column that drives nothing at 0); T
        lbx, ubx = np.full(self.nw, -np.inf), np.full(self.nw, np.inf)
        region_step = (STEP_FRACTION * task.region_radius
                       if cols is None or cols.points else 0.0)
        self.step = np.full(3, region_step)    # a control point's move per QP, by column
        for c in range(3):
            kind = "point" if cols is None else cols.columns[c].kind
            at = slice(c * self.nc, (c + 1) * self.nc)
            if kind == "point":
                lbx[at] = task.region_center[c] - task.region_radius
                ubx[at] = task.region_center[c] + task.region_radius
            elif kind == "none":
                lbx[at] = ubx[at] = 0.0
            if cols is not None:
                self.step[c] = cols.step(c, region_step, STEP_FRACTION)
        lbx[-1] = T_MIN
        self.lbx, self.ubx = lbx, ubx
        # the region's rows: C0's; C1, ... follow (None: no point decided)
        self.region_row = names.index("region") if "region" in names else None
        self.region_margin = 3.0 * STEP_FRACTION ** 2

    @property
    def qp_data(self):
        return self.functions["qp_data"]

    def bounds(self, T_fixed: float | None):
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        if T_fixed is not None:
            lbx[-1] = ubx[-1] = T_fixed
        return lbx, ubx

    def step_bounds(self, w: np.ndarray, T_fixed: float | None):
        """The bounds of the QP's step at w: the bounds of w and the trust region."""
        lbx, ubx = self.bounds(T_fixed)
        lo, hi = lbx - w, ubx - w
        step = np.repeat(self.step, self.nc)
        lo[:-1] = np.maximum(lo[:-1], -step)
        hi[:-1] = np.minimum(hi[:-1], step)
        lo[-1] = max(lo[-1], -T_STEP_FRACTION * w[-1])
        hi[-1] = min(hi[-1], T_STEP_FRACTION * w[-1])
        return lo, hi

    def region_rows(self, uba: np.ndarray) -> np.ndarray:
        """The linearised region's upper bounds less the margin (in place); the three
        control points the start holds to P's place and rate (C0, C1, C2) no further
        out than they are (P may already be out by what the last step's linearisation
        missed)."""
        r = self.region_row
        if r is None:
            return uba
        uba[r:r + self.nc] -= self.region_margin
        uba[r:r + 3] = np.maximum(uba[r:r + 3], 0.0)
        return uba

    @staticmethod
    def penalty_scale(T: float, T_ref: float) -> float:
        """The soft rows' penalties at a horizon T are the start's (at T_ref) times this:
        the end conditions' multipliers grow as the horizon shrinks (on the land
        example from 0.04 at 0.6 s to 1 at 0.11 s and 14 at 0.09 s), and a penalty
        below them would trade the goal for effort."""
        return (T_ref / T) ** SOFT_POWER

    def penalties(self, T: float, T_ref: float):
        """The rows' L1 and quadratic penalties at a horizon T (the start's: T_ref)."""
        scale = self.penalty_scale(T, T_ref)
        return self.z1 * scale, self.z2 * scale

    def _point_rows(self, add, Cs, Ts, x0, v0, acc):
        """The law's rows of one point: its start, at rest at its end, in the region,
        its acceleration bounded (acc: h^2 x'' at the knots)."""
        import casadi as ca
        task, N = self.task, self.N
        add("start: x", (Cs[0, :] + 4 * Cs[1, :] + Cs[2, :]).T / 6 - x0, 0.0, 0.0)
        add("start: x'", (Cs[2, :] - Cs[0, :]).T / 2 - Ts / N * v0, 0.0, 0.0)
        add("end: at rest", ca.vertcat(Cs[N + 1, :] - Cs[N, :], Cs[N + 2, :] - Cs[N, :]),
            0.0, 0.0)
        center = ca.DM(task.region_center).T
        dC = Cs - ca.repmat(center, self.nc, 1)
        add("region", ca.sum2(dC * dC) / task.region_radius ** 2, -np.inf, 1.0)
        # |OP''| <= max_acceleration through each component within max_acceleration/sqrt(3)
        # (a box inside the ball): linear in C, so a QP step cannot leave it however
        # short the horizon (x'' = (c_k - 2 c_k+1 + c_k+2)/h^2 magnifies a step by 1/h^2,
        # and the ball's linearisation bounds nothing where x'' is small)
        lim = 1.0 / math.sqrt(3.0)
        add("max_acceleration", ca.vec(acc / (Ts / N) ** 2) / task.max_acceleration, -lim,
            lim)

    def _bodies_rows(self, add, Cs, Ts, x0, v0):
        """The law's rows of the decided bodies (the columns that drive one): each
        starts at its value and rate, at rest at its end (a rotor at rest relative to
        the body, its angle free); a point as one point's; a rotor's |psi''| at the knots
        (linear on each piece: the bound holds everywhere) and psi' at its control
        points (psi' lies in their hull) within their bounds.  A column that drives
        nothing has no row (its control points are bounds at 0)."""
        import casadi as ca
        task, N, cols = self.task, self.N, self.columns
        real = cols.real
        add("start: x", (Cs[0, real] + 4 * Cs[1, real] + Cs[2, real]).T / 6 - x0[real],
            0.0, 0.0)
        add("start: x'", (Cs[2, real] - Cs[0, real]).T / 2 - Ts / N * v0[real], 0.0, 0.0)
        add("end: at rest", ca.vertcat(Cs[N + 1, real] - Cs[N, real],
                                       Cs[N + 2, real] - Cs[N, real]), 0.0, 0.0)
        if cols.points:
            pts = cols.points
            dC = Cs[:, pts] - ca.repmat(ca.DM(task.region_center).T, self.nc, 1)
            add("region", ca.sum2(dC * dC) / task.region_radius ** 2, -np.inf, 1.0)
            acc = Cs[0:N + 1, pts] - 2 * Cs[1:N + 2, pts] + Cs[2:N + 3, pts]
            lim = 1.0 / math.sqrt(3.0)
            add("max_acceleration", ca.vec(acc / (Ts / N) ** 2) / task.max_acceleration,
                -lim, lim)
        if cols.rotors:
            rot = cols.rotors
            acc = Cs[0:N + 1, rot] - 2 * Cs[1:N + 2, rot] + Cs[2:N + 3, rot]
            add("max_rotor_acceleration", ca.vec(acc / (Ts / N) ** 2)
                / task.max_rotor_acceleration, -1.0, 1.0)
            rate = Cs[1:self.nc, rot] - Cs[0:self.nc - 1, rot]          # h psi' points
            add("max_rotor_rate", ca.vec(rate / (Ts / N)) / task.max_rotor_rate, -1.0, 1.0)

    @property
    def column_labels(self) -> tuple:
        """What the law's three columns are (plots)."""
        if self.columns is None:
            return ("x of OP (m)", "y of OP (m)", "z of OP (m)")
        return tuple(f"{n.replace('_', ' ')} (rad)" if n.endswith("psi") else
                     f"{n.replace('_', ' ')} (m)" if n != "none" else "(none)"
                     for n in self.columns.names)

    def law_u(self, law, t) -> np.ndarray:
        """(9, len(t)): a planned law's u as the controller's columns (x, y, z and two
        derivatives; on a task of bodies the decided bodies' columns, zeros for none)."""
        if self.columns is None:
            return np.asarray(law.u(np.atleast_1d(np.asarray(t, float))))[:9]
        return self.columns.u9(law, t)

    def params(self, u: np.ndarray, T_s: float, q_model: np.ndarray) -> np.ndarray:
        """p from the law at the call (u: x, y, z, x', ...), the horizon and the measured
        state in the general layout."""
        return np.r_[u[0:3], u[3:6], T_s, np.asarray(q_model)[self.keep]]
