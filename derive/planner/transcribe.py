"""Direct multiple shooting over the derived CasADi functions.

Scaled time ``tau = t / T`` on ``[0, 1]`` is cut into ``N`` intervals, one per piece of
the law's B-spline (:mod:`derive.planner.law`), so the law is a single cubic on each
interval.  Each interval is integrated by ``substeps`` RK4 steps of the derived flight
right-hand side (``general_flight_rhs`` for reorient and land, ``vertical_flight_rhs``
for hop, loaded from ``generated/casadi``), built once as an SX function and mapped over
the intervals.  Decision variables: the law's control points, the state at every node,
and ``T`` when it is free (land, hop, objective = time).

The RK4 of the NLP is coarse on purpose (a small, fast NLP); the plan is then made
exact by *defect correction*: the continuity constraints read
``q_{k+1} = RK4(q_k) + delta_k`` with ``delta_k = flow(q_k) - RK4(q_k)`` measured by an
accurate integration (SciPy DOP853, rtol 1e-13) at the previous solution, and the NLP is
re-solved, warm-started, until ``delta`` stops changing.  The fixed point satisfies the
constraints with the exact flow.

Constraints come in named groups (``Group``), which the progress line and the
infeasibility report use.  What differs between goals (the layout, the end conditions,
the bounds of the first node, the guess) is asked of the goal object
(:mod:`derive.planner.goals`), which the caller passes in.  The task's three limits
(``max_acceleration``, ``region``, ``horizon``) are not built into the NLP: they are a
parameter and bounds of each run (:class:`Limits`), so that one IPOPT instance solves
the task, lifts a limit to diagnose an infeasible task, or moves a bound step by step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from .. import models as dm
from .functions import load, lowest_point
from .law import BASIS, Spline, circle_u

GAUSS3 = ((0.5 - math.sqrt(15) / 10, 5 / 18), (0.5, 8 / 18), (0.5 + math.sqrt(15) / 10, 5 / 18))
HOP_PERIODIC = ("Z_C'", "omega_x", "omega_y", "a31", "a32")     # see Transcription._hop
CONTINUITY = "continuity of the motion (multiple shooting)"
GAP_GROUP = "flight: S above the plane before touchdown (h >= 0)"
REGION_GROUP = "region: P in the ball (control points)"
# OP and OP'' in the law's u = (OP, OP', OP'')
POS = slice(dm.U_LABELS.index("x"), dm.U_LABELS.index("z") + 1)
ACC = slice(dm.U_LABELS.index("x''"), dm.U_LABELS.index("z''") + 1)


@dataclass
class Group:
    name: str          # what the constraint is, in the task's words
    start: int         # rows [start, stop) of g
    stop: int
    limit: str = ""    # the task key it comes from, for the infeasibility report


@dataclass
class Layout:
    """The NLP's state: the entries ``keep`` of a derived model's state (the others do
    not influence them and are held at ``fill``)."""
    model: str                  # general | vertical
    keep: tuple                 # indices into the model's state
    fill: np.ndarray            # the model's state for the entries not kept

    @property
    def nq(self) -> int:
        return len(self.keep)

    @property
    def labels(self) -> tuple:
        return tuple(dm.STATE_LABELS[self.model][i] for i in self.keep)

    def index(self, label: str) -> int:
        return self.labels.index(label)

    def of_state(self, q_model) -> np.ndarray:
        """The NLP's state from the model's (numbers)."""
        return np.asarray(q_model, dtype=float)[list(self.keep)]

    def full(self, q):
        """The model's state from the NLP's (CasADi or NumPy)."""
        where = {i: k for k, i in enumerate(self.keep)}
        if isinstance(q, np.ndarray):
            out = np.array(self.fill, dtype=float)
            out[list(self.keep)] = q
            return out
        return ca.vertcat(*[q[where[i]] if i in where else float(self.fill[i])
                            for i in range(len(self.fill))])

    def n_of(self, q):
        return q[[self.index(lb) for lb in ("a31", "a32", "a33")]]

    def A_of(self, q):
        """Row-major a_ij as a 3x3 matrix (general layout only)."""
        idx = [self.index(f"a{i}{j}") for i in (1, 2, 3) for j in (1, 2, 3)]
        if isinstance(q, np.ndarray):
            return q[idx].reshape(3, 3)
        return ca.reshape(q[idx], 3, 3).T


def general_layout(task, labels: tuple) -> Layout:
    """The ``general`` model's state reduced to ``labels``, the others held at the
    task's initial values."""
    every = dm.STATE_LABELS["general"]
    return Layout("general", tuple(every.index(lb) for lb in labels), initial_state(task))


LIMITS = ("max_acceleration", "region", "horizon")


@dataclass(frozen=True)
class Limits:
    """The values of the task's limits in one run; ``inf`` lifts a limit."""
    max_acceleration: float
    region: float                    # the region's (or circle's) radius
    horizon: float = math.inf        # the upper bound of a free T

    @classmethod
    def of(cls, task) -> "Limits":
        """The task's; a task that decides no point has no acceleration bound nor region
        (inf: the rows of neither exist)."""
        return cls(math.inf if task.max_acceleration is None else task.max_acceleration,
                   math.inf if task.region_radius is None else task.region_radius,
                   math.inf if task.horizon is None else task.horizon)

    def value(self, name: str) -> float:
        return getattr(self, name)

    def replace(self, **values) -> "Limits":
        return replace(self, **values)

    def lifted(self, *names) -> "Limits":
        return replace(self, **{n: math.inf for n in names})


def vee_skew(R):
    """(R - R^T)/2 as a vector: sin(angle) * axis for a rotation R."""
    return 0.5 * ca.vertcat(R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1])


class Transcription:
    """The NLP of one task: variables, constraints by group, objective, bounds."""

    bodies = False       # the moments models (derive.planner.bodies): several bodies

    def __init__(self, task, goal, stabilize: bool = False):
        self.task, self.goal, self.stabilize = task, goal, stabilize
        sc = task.scene
        self.p = [sc.M, sc.m, *sc.J, sc.g]
        self.layout = self._layout()
        self._law_shape()
        self.N = task.intervals
        self.m = task.substeps
        self.spline = Spline(self.N, periodic=goal.periodic_law)
        self.plane = goal.plane
        self._model()
        self._build_law_function()
        self._build_interval()
        self._build_nlp()

    # ---- what a transcription of several bodies changes (derive.planner.bodies) ----------
    def _layout(self) -> Layout:
        return self.goal.layout(self.task)

    def _law_shape(self):
        """The law's shape: OP itself (3 columns) or an angle on a circle (1)."""
        self.kind = "circle" if self.task.circle is not None else "cartesian"
        self.dim = 1 if self.kind == "circle" else 3

    def _model(self):
        """The derived functions of the model, on the NLP's state: f, and with the plane
        the gap and the impact map."""
        lay = self.layout
        f = load(f"{lay.model}_flight_rhs")
        self.f = lambda q, u, p: f(lay.full(q), u, p)[list(lay.keep)]
        if self.plane:
            gap = load(f"{lay.model}_gap")
            impact = load(f"{lay.model}_impact")
            self.gap = lambda q, u, s, p: gap(lay.full(q), u, s, p)
            self.impact = lambda q, u, s, p, e: [
                impact(lay.full(q), u, s, p, e)[0][list(lay.keep)]]

    # ---- the law on one piece ----------------------------------------------------------
    def _build_law_function(self):
        """``U(cl, s, T) -> u`` (9): the law on a piece with local control points ``cl``
        (4 x dim, column-major) at local parameter ``s``."""
        cl = ca.SX.sym("cl", 4 * self.dim)
        s = ca.SX.sym("s")
        T = ca.SX.sym("T")
        C = ca.reshape(cl, 4, self.dim)
        N = self.N
        rows = []
        for d in range(3):
            powers = [ca.SX(0)] * 4
            for j in range(d, 4):
                fact = math.factorial(j) / math.factorial(j - d)
                powers[j] = fact * s ** (j - d)
            b = [sum(BASIS[k, j] * powers[j] for j in range(4)) for k in range(4)]
            val = ca.vertcat(*[sum(b[k] * C[k, c] for k in range(4)) for c in range(self.dim)])
            rows.append(val * (N / T) ** d)
        if self.kind == "cartesian":
            u = ca.vertcat(*rows)
        else:
            cx, cy, R, _ = self.task.circle
            u = circle_u(rows[0], rows[1], rows[2], cx, cy, R, ca)
        self.U = ca.Function("U", [cl, s, T], [u], ["cl", "s", "T"], ["u"])

    def s_of(self, q):
        sc = self.task.scene
        return lowest_point(sc.shape, self.layout.n_of(q), sc.center, sc.size)

    # ---- one interval ----------------------------------------------------------------
    def _build_interval(self):
        nq, m, N = self.layout.nq, self.m, self.N
        q0 = ca.SX.sym("q", nq)
        cl = ca.SX.sym("cl", 4 * self.dim)
        T = ca.SX.sym("T")
        delta = ca.SX.sym("delta", nq)
        p = ca.DM(self.p)
        h = (T / N) / m              # the RK4 step in t
        q = q0
        gaps = []
        for j in range(m):
            s0, s1 = j / m, (j + 1) / m
            sm = 0.5 * (s0 + s1)
            u0, um, u1 = (self.U(cl, s, T) for s in (s0, sm, s1))
            k1 = self.f(q, u0, p)
            k2 = self.f(q + 0.5 * h * k1, um, p)
            k3 = self.f(q + 0.5 * h * k2, um, p)
            k4 = self.f(q + h * k3, u1, p)
            q = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if self.plane:
                gaps.append(self.gap(q, u1, self.s_of(q), p)[0])
        outs = [q + delta]
        names = ["q_end"]
        if self.plane:
            outs.append(ca.vertcat(*gaps))
            names.append("h")
        self.F = ca.Function("interval", [q0, cl, T, delta], outs,
                             ["q", "cl", "T", "delta"], names)
        self.FN = self.F.map(N)
        # the accurate flow's right-hand side on a piece, in s: dq/ds = (T/N) f
        s = ca.SX.sym("s")
        self.G = ca.Function("G", [s, q0, cl, T], [(T / N) * self.f(q0, self.U(cl, s, T), p)])

    # ---- the NLP ---------------------------------------------------------------------
    def _build_nlp(self):
        task, N, nq, dim = self.task, self.N, self.layout.nq, self.dim
        sp = self.spline
        C = ca.MX.sym("C", sp.n_ctrl, dim)
        Q = ca.MX.sym("Q", nq, N + 1)
        parts = [ca.vec(C), ca.vec(Q)]
        self.free_T = self.goal.free_time(task)
        if self.free_T:
            Tv = ca.MX.sym("T")
            parts.append(Tv)
            T = Tv
        else:
            T = task.horizon
        self.w = ca.vertcat(*parts)
        self.n_c, self.n_q = sp.n_ctrl * dim, nq * (N + 1)
        self.C, self.Q, self.T = C, Q, T
        self.delta = ca.MX.sym("delta", nq, N)      # a parameter: the defect correction
        self.k_acc = ca.MX.sym("k_acc")             # a parameter: 1/max_acceleration^2
        self.params = ca.vertcat(ca.vec(self.delta), self.k_acc)
        self.n_p = self.params.shape[0]
        cls = [ca.vec(C[sp.indices(k), :]) for k in range(N)]
        self.CL = ca.horzcat(*cls)
        out = self.FN.call([Q[:, :N], self.CL, T, self.delta])
        self.q_end = out[0]
        self.h_sub = out[1] if self.plane else None

        g, self.groups, lbg, ubg = [], [], [], []
        self.group_exprs = []

        def add(name, expr, lb, ub, limit=""):
            expr = ca.vec(expr)
            n = expr.shape[0]
            start = sum(e.shape[0] for e in g)
            g.append(expr)
            self.group_exprs.append(expr)
            lbg.extend(np.broadcast_to(lb, n).tolist())
            ubg.extend(np.broadcast_to(ub, n).tolist())
            self.groups.append(Group(name, start, start + n, limit))

        add(CONTINUITY, Q[:, 1:] - self.q_end, 0, 0)
        self._law_constraints(add)
        self._limits(add)
        self.goal.end_constraints(self, add)
        self.g = ca.vertcat(*g)
        self.lbg, self.ubg = np.array(lbg), np.array(ubg)
        self._effort()
        self.set_effort_scale(self.max_acceleration_scale())
        self._bounds()

    def _z_index(self, k: int) -> list:
        """Where z_k = (q_k, the control points of piece k, T if free) sits in w."""
        nq, sp, dim = self.layout.nq, self.spline, self.dim
        idx = list(self.n_c + k * nq + np.arange(nq))
        idx += [c * sp.n_ctrl + i for c in range(dim) for i in sp.indices(k)]
        if self.free_T:
            idx.append(self.w.shape[0] - 1)
        return idx

    def _interval_symbols(self):
        nq, dim = self.layout.nq, self.dim
        q, cl, T, delta = (ca.SX.sym("q", nq), ca.SX.sym("cl", 4 * dim), ca.SX.sym("T"),
                           ca.SX.sym("delta", nq))
        z = ca.vertcat(q, cl, T) if self.free_T else ca.vertcat(q, cl)
        return q, cl, T, delta, z

    def _x_parts(self, x):
        sp, dim, nq, N = self.spline, self.dim, self.layout.nq, self.N
        ctrl = ca.reshape(x[:self.n_c], sp.n_ctrl, dim)
        Qx = ca.reshape(x[self.n_c:self.n_c + self.n_q], nq, N + 1)
        Tx = x[x.shape[0] - 1] if self.free_T else self.task.horizon
        CLx = ca.horzcat(*[ca.vec(ctrl[sp.indices(k), :]) for k in range(N)])
        return Qx, CLx, Tx

    def _rest(self):
        """The groups other than continuity and the in-flight gap: (groups, SX w, J, g)."""
        rest = [gr for gr in self.groups if gr.name not in (CONTINUITY, GAP_GROUP)]
        g_rest = ca.vertcat(*[self.group_exprs[self.groups.index(gr)] for gr in rest])
        f_rest = ca.Function("rest", [self.w, self.k_acc], [self.J, g_rest]).expand()
        ws, ks = ca.SX.sym("w", self.w.shape[0]), ca.SX.sym("k_acc")
        J_s, g_s = f_rest(ws, ks)
        return rest, (ws, ks), J_s, g_s

    def jacobian_function(self) -> ca.Function:
        """``(x, p) -> (g, dg/dx)`` from its structure, like :meth:`hessian_function`:
        the Jacobian of one RK4 interval in z_k, built once and mapped."""
        nq, N, m = self.layout.nq, self.N, self.m
        nw = self.w.shape[0]
        q, cl, T, delta, z = self._interval_symbols()
        out = self.F.call([q, cl, T, delta])
        outs = [ca.jacobian(out[0], z)] + ([ca.jacobian(out[1], z)] if self.plane else [])
        JF = ca.Function("JF", [q, cl, T, delta], outs).map(N)
        nz = z.shape[0]
        x = ca.MX.sym("x", nw)
        p = ca.MX.sym("p", self.n_p)
        Qx, CLx, Tx = self._x_parts(x)
        delta, k_acc = ca.reshape(p[:nq * N], nq, N), p[nq * N]
        J_int = JF.call([Qx[:, :N], CLx, Tx, delta])
        E = [ca.DM(ca.Sparsity.triplet(nz, nw, list(range(nz)), self._z_index(k)), 1.0)
             for k in range(N)]
        rest, (ws, ks), _, g_s = self._rest()
        Jrest = ca.Function("Jrest", [ws, ks], [ca.jacobian(g_s, ws)])(x, k_acc)
        blocks, r = [], 0
        for gr in self.groups:
            if gr.name == CONTINUITY:
                for k in range(N):
                    nxt = ca.DM(ca.Sparsity.triplet(nq, nw, list(range(nq)), list(
                        self.n_c + (k + 1) * nq + np.arange(nq))), 1.0)
                    blocks.append(nxt - ca.mtimes(J_int[0][:, k * nz:(k + 1) * nz], E[k]))
            elif gr.name == GAP_GROUP:
                for k in range(N):
                    Jh = ca.mtimes(J_int[1][:, k * nz:(k + 1) * nz], E[k])
                    blocks.append(Jh if k < N - 1 else Jh[:m - 1, :])
            else:
                n = gr.stop - gr.start
                blocks.append(Jrest[r:r + n, :])
                r += n
        g = ca.Function("g", [self.w, self.params], [self.g])(x, p)
        return ca.Function("jac_g", [x, p], [g, ca.vertcat(*blocks)], ["x", "p"],
                           ["g", "jac_g_x"])

    def hessian_function(self) -> ca.Function:
        """The Hessian of the Lagrangian, ``(x, p, lam_f, lam_g) -> triu(H)``, built from
        its structure: the RK4 intervals contribute one small block each, the Hessian of
        ``lam^T F`` in (q_k, the piece's control points, T), differentiated once for all
        intervals and mapped; the rest (objective, end conditions, limits) is small and
        differentiated directly.  IPOPT gets the same matrix as from differentiating the
        whole NLP, at a fraction of the cost of building it."""
        nq, N, m = self.layout.nq, self.N, self.m
        nw = self.w.shape[0]
        q, cl, T, delta, z = self._interval_symbols()
        lq, lh = ca.SX.sym("lq", nq), ca.SX.sym("lh", m if self.plane else 0)
        out = self.F.call([q, cl, T, delta])
        phi = -ca.dot(lq, out[0]) + (ca.dot(lh, out[1]) if self.plane else 0)
        HF = ca.Function("HF", [q, cl, T, delta, lq, lh], [ca.hessian(phi, z)[0]]).map(N)
        nz = z.shape[0]
        x = ca.MX.sym("x", nw)
        p = ca.MX.sym("p", self.n_p)
        delta, k_acc = ca.reshape(p[:nq * N], nq, N), p[nq * N]
        lam_f = ca.MX.sym("lam_f")
        lam_g = ca.MX.sym("lam_g", self.g.shape[0])
        cont = next(gr for gr in self.groups if gr.name == CONTINUITY)
        LQ = ca.reshape(lam_g[cont.start:cont.stop], nq, N)
        if self.plane:
            gap = next(gr for gr in self.groups if gr.name == GAP_GROUP)
            LH = ca.reshape(ca.vertcat(lam_g[gap.start:gap.stop], 0), m, N)
        else:
            LH = ca.MX(0, N)
        Qx, CLx, Tx = self._x_parts(x)
        blocks = HF(Qx[:, :N], CLx, Tx, delta, LQ, LH)
        H = ca.MX(nw, nw)
        for k in range(N):
            E = ca.DM(ca.Sparsity.triplet(nz, nw, list(range(nz)), self._z_index(k)), 1.0)
            H += ca.mtimes([E.T, blocks[:, k * nz:(k + 1) * nz], E])
        rest, (ws, ks), J_s, g_s = self._rest()
        lam_rest = ca.vertcat(*[lam_g[gr.start:gr.stop] for gr in rest])
        ls, lf = ca.SX.sym("l", g_s.shape[0]), ca.SX.sym("lf")
        H_rest = ca.Function("Hrest", [ws, ks, lf, ls],
                             [ca.hessian(lf * J_s + ca.dot(ls, g_s), ws)[0]])
        H += H_rest(x, k_acc, lam_f, lam_rest)
        return ca.Function("hess_lag", [x, p, lam_f, lam_g], [ca.triu(H)],
                           ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])

    def effort_of(self, w) -> float:
        """The effort (integral of |OP''|^2) of a point w."""
        if not hasattr(self, "_effort_f"):
            self._effort_f = ca.Function("effort", [self.w], [self.effort])
        return float(self._effort_f(w))

    def limit_values(self, w) -> dict:
        """What the point w asks of each limit, in the NLP's own terms: the largest
        |OP''| where it is bounded (at the knots, where it is largest; on a circle at the
        RK4 points), the largest distance of a control point from the region's centre
        (what the region bounds; on a circle its radius) and T."""
        ctrl, _, T = self.unpack(w)
        task = self.task
        if self.kind == "cartesian":
            W2 = np.array([self.spline.weights(k / self.N, 2) for k in range(self.N + 1)])
            acc = float(np.max(np.linalg.norm(W2 @ ctrl, axis=1))) / T ** 2
            region = float(np.max(np.linalg.norm(ctrl - task.region_center, axis=1)))
        else:
            acc = max(float(np.linalg.norm(np.array(self.U(self.local_ctrl(ctrl, k), j / self.m,
                                                           T).full()).ravel()[ACC]))
                      for k in range(self.N) for j in range(self.m + 1))
            region = task.region_radius
        return {"max_acceleration": acc, "region": region, "horizon": T}

    def u_at(self, k: int, s: float):
        return self.U(self.CL[:, k], s, self.T)

    def _law_constraints(self, add):
        task, sp, C = self.task, self.spline, self.C
        N = self.N
        if self.kind == "cartesian":
            if self.goal.periodic_law:
                if task.rest_at_ends:
                    add("P at rest at the impact (rest_at_ends)",
                        ca.vertcat(ca.mtimes(ca.DM(sp.weights(0.0, 1)).T, C),
                                   ca.mtimes(ca.DM(sp.weights(0.0, 2)).T, C)), 0, 0,
                        "rest_at_ends")
            elif not task.rest_at_ends:
                add("P starts at start", ca.mtimes(ca.DM(sp.weights(0.0, 0)).T, C).T
                    - task.start, 0, 0)
            # rest_at_ends (reorient, land): fixed control points (bounds)
        else:
            if task.rest_at_ends:
                add("P at rest at the end (rest_at_ends)",
                    ca.vertcat(C[N + 1] - C[N], C[N + 2] - C[N]), 0, 0, "rest_at_ends")
            else:
                add("P starts at start_angle", ca.mtimes(ca.DM(sp.weights(0.0, 0)).T, C)
                    - task.circle[3], 0, 0)

    def _limits(self, add):
        """The task's limits, their values set per run (:meth:`bounds`, :meth:`parameters`):
        the region's radius^2 is the upper bound of its rows, 1/max_acceleration^2 the
        parameter ``k_acc`` (0 lifts it), the horizon the upper bound of a free T."""
        task, sp, C, T = self.task, self.spline, self.C, self.T
        if self.kind == "cartesian":
            d = C - ca.repmat(ca.DM(task.region_center).T, sp.n_ctrl, 1)
            add(REGION_GROUP, ca.sum2(d * d), -np.inf, task.region_radius ** 2, "region")
            W2 = np.array([sp.weights(k / self.N, 2) for k in range(self.N + 1)])
            A = ca.mtimes(ca.DM(W2), C)          # tau-accelerations at the knots
            # |A|^2 <= amax^2 T^4, without the A-T coupling of |A|^2 / T^4 (whose
            # curvature slows IPOPT down when T is free); scaled by T_ref^4
            T_ref = task.horizon or self.T_guess_value()
            add("max_acceleration: |OP''| at the knots", (ca.sum2(A * A) * self.k_acc
                - T ** 4) / T_ref ** 4, -np.inf, 0.0, "max_acceleration")
        else:
            vals = []
            for k in range(self.N):
                for j in range(self.m + 1):
                    u = self.u_at(k, j / self.m)
                    vals.append(ca.sumsqr(u[ACC]))
            add("max_acceleration: |OP''| at the RK4 points", ca.vertcat(*vals) * self.k_acc,
                -np.inf, 1.0, "max_acceleration")

    def bounds(self, limits: Limits):
        """(lbx, ubx, lbg, ubg) of a run with these limits."""
        ubg, ubx = self.ubg.copy(), self.ubx.copy()
        for gr in self.groups:
            if gr.limit == "region":
                ubg[gr.start:gr.stop] = limits.region ** 2
        if self.free_T:
            ubx[-1] = limits.horizon
        return self.lbx, ubx, self.lbg, ubg

    def parameters(self, delta, limits: Limits) -> np.ndarray:
        """The NLP's parameter: the defect correction and 1/max_acceleration^2."""
        return np.r_[np.asarray(delta, dtype=float).ravel(order="F"),
                     1.0 / limits.max_acceleration ** 2]

    def attitude_error(self, q):
        """sin(angle) * axis of target_matrix^T A at the state q."""
        A = self.layout.A_of(q)
        return vee_skew(ca.mtimes(ca.DM(self.task.target).T, A))

    def touchdown(self, add):
        """The gap closes at t = T, S approaching, and stays open before; returns the
        state and the law at t = T."""
        p = ca.DM(self.p)
        qN = self.Q[:, self.N]
        uN = self.u_at(self.N - 1, 1.0)
        h, vn = self.gap(qN, uN, self.s_of(qN), p)
        add("touchdown: S reaches the plane at t = T (h = 0)", h, 0, 0)
        add("touchdown: S approaches the plane (v_n < 0)", vn / self.goal.v_ref(self.task),
            -np.inf, -0.05)
        hs = ca.vec(self.h_sub)         # after every RK4 step; the last one is t = T
        add(GAP_GROUP, hs[:-1], 0, np.inf, "plane")
        return qN, uN

    def _effort(self):
        """The integral of |OP''|^2 by 3-point Gauss on each piece."""
        terms = []
        for k in range(self.N):
            for s, wq in GAUSS3:
                u = self.u_at(k, s)
                terms.append(wq * ca.sumsqr(u[ACC]))
        self.effort = (self.T / self.N) * sum(terms)

    def max_acceleration_scale(self) -> float:
        """The effort of max_acceleration held over the horizon: the scale of the
        objective until :meth:`set_effort_scale` is given the guess's effort."""
        return self.task.max_acceleration ** 2 * (self.task.horizon or self.T_guess_value())

    def set_effort_scale(self, scale: float):
        """The objective, with the effort divided by ``scale``: the effort of the initial
        guess, so that the objective starts near 1 whatever max_acceleration is (a bound
        of 1e6 had made the objective 1e-12 of the constraints, and IPOPT stopped at the
        first feasible point)."""
        task = self.task
        self.effort_scale = float(scale)
        if task.objective == "time":
            T_ref = task.horizon or self.T_guess_value()
            self.J = self.T / T_ref + 1e-6 * self.effort / self.effort_scale
        else:
            self.J = self.effort / self.effort_scale
        self.J = self.J + self.goal.objective_terms(self)

    def T_guess_value(self) -> float:
        return getattr(self, "_T_guess", None) or (self.task.horizon or 1.0)

    def _bounds(self):
        task, sp, dim, N, nq = self.task, self.spline, self.dim, self.N, self.layout.nq
        n = self.w.shape[0]
        lbx, ubx = np.full(n, -np.inf), np.full(n, np.inf)
        Cl = np.full((sp.n_ctrl, dim), -np.inf)
        Cu = np.full((sp.n_ctrl, dim), np.inf)
        if not self.goal.periodic_law and task.rest_at_ends:
            fixed = [0, 1, 2] + ([N, N + 1, N + 2] if self.kind == "cartesian" else [])
            value = task.start if self.kind == "cartesian" else np.array([task.circle[3]])
            for i in fixed:
                Cl[i], Cu[i] = value, value
        lbx[:self.n_c] = Cl.ravel(order="F")
        ubx[:self.n_c] = Cu.ravel(order="F")
        self.goal.bound_first_node(self, lbx[self.n_c:self.n_c + nq],
                                   ubx[self.n_c:self.n_c + nq])
        if self.free_T:
            lbx[-1] = self.goal.shortest(task)
            if task.horizon is not None:
                ubx[-1] = task.horizon
        self.lbx, self.ubx = lbx, ubx

    # ---- packing ---------------------------------------------------------------------
    def pack(self, ctrl, Q, T=None) -> np.ndarray:
        parts = [np.asarray(ctrl, float).reshape(self.spline.n_ctrl, self.dim).ravel(order="F"),
                 np.asarray(Q, float).reshape(self.layout.nq, self.N + 1).ravel(order="F")]
        if self.free_T:
            parts.append([T])
        return np.concatenate(parts)

    def unpack(self, w):
        w = np.asarray(w, float).ravel()
        ctrl = w[:self.n_c].reshape(self.spline.n_ctrl, self.dim, order="F")
        Q = w[self.n_c:self.n_c + self.n_q].reshape(self.layout.nq, self.N + 1, order="F")
        T = float(w[-1]) if self.free_T else float(self.task.horizon)
        return ctrl, Q, T

    def local_ctrl(self, ctrl, k):
        return np.asarray(ctrl)[self.spline.indices(k)].ravel(order="F")

    def gap_value(self, q, cl, s, T):
        """(h, v_n) at state q with the law piece cl at local s (numbers)."""
        u = self.U(cl, s, T)
        h, vn = self.gap(ca.DM(q), u, self.s_of(ca.DM(q)), ca.DM(self.p))
        return float(h), float(vn)

    def rk4_nodes(self, ctrl, q0, T):
        """March the NLP's own integrator from q0 (a consistent initial guess)."""
        Q = [np.asarray(q0, float)]
        zero = np.zeros(self.layout.nq)
        for k in range(self.N):
            out = self.F.call([Q[-1], self.local_ctrl(ctrl, k), T, zero])
            Q.append(np.array(out[0].full()).ravel())
        return np.array(Q).T


def initial_state(task) -> np.ndarray:
    """The general-layout state at t = 0 from the scene's initial conditions."""
    sc = task.scene
    return np.r_[sc.com, sc.com_velocity, sc.omega, np.asarray(sc.A0).ravel()]


@dataclass
class NLPResult:
    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    extra: dict = field(default_factory=dict)
