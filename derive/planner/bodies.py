"""Planning through any internal motion (issue 32): a task of ``[[point]]`` and
``[[rotor]]`` whose ``[plan].decide`` names the bodies whose laws the plan makes.

The carrier sees its bodies only through their moments (derive/layout.py's MOMENTS), so
the plan composes the derived CasADi functions, as the runtime does in C: each decided
point's share ``point_moments(m_j, jet_j)``, each decided rotor's ``rotor_moments(a_k, I_k,
(psi_k', psi_k''))`` into (h, h'), the kept bodies' shares from their laws (formulas,
evaluated in CasADi at the time), summed into the 27 moments that ``moments_flight_rhs``,
``moments_gap`` and ``moments_impact`` read.  No new derivation.

The decisions are one uniform cubic B-spline of ``D`` columns (:class:`Channels`): x, y, z
of each decided point (in its order), then psi of each decided rotor; the NLP's ``u`` is
the spline's values, rates and accelerations (D each, :meth:`Channels.jet`), so that the
transcription's law, RK4 intervals and structured derivatives
(:mod:`derive.planner.transcribe`) serve unchanged; what differs is here
(:class:`BodiesTranscription`):

* the state: the goal's, and the time t when a kept body's law moves;
* the limits: each decided point's control points in the region and |OP''| at the knots
  (as for one point); each decided rotor's |psi''| at the knots (``max_rotor_acceleration``:
  psi'' is linear on each piece, so the bound holds everywhere) and the control points of
  psi' (``max_rotor_rate``: psi' lies in their hull, a sufficient condition);
* the ends (``rest_at_ends``): a decided point at rest and back at its start, a decided
  rotor at rest relative to the body (its angle free at the end: a wheel need not come
  back);
* the effort: the integral of each decided body's acceleration over its bound, squared
  (|OP''|^2 / max_acceleration^2, psi''^2 / max_rotor_acceleration^2), so that bodies of
  different units weigh alike;
* the guess: rotors that turn the body about the fixed axis of the wanted rotation (with
  K = 0 and wheels spanning the three axes the eigen-axis turn: psi' = -B^-1 J e theta',
  B = [I_k a_k], exact); with no rotor decided, loops of the first decided point.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .. import layout
from .functions import load
from .transcribe import (GAUSS3, REGION_GROUP, Layout, Transcription, initial_state)

GEN = layout.GENERAL


class CasadiOps:
    """The functions of a law's jet on CasADi symbols (:meth:`Program.output_jets`)."""
    sin, cos, tan, exp, log, sqrt = ca.sin, ca.cos, ca.tan, ca.exp, ca.log, ca.sqrt
    sinh, cosh, tanh = ca.sinh, ca.cosh, ca.tanh
    arcsin, arccos, arctan = ca.asin, ca.acos, ca.atan
    power = staticmethod(lambda x, y: x ** y)


@dataclass(frozen=True)
class Channel:
    """A decided body's columns in the decisions' spline."""
    kind: str            # point | rotor
    index: int           # in scene.points / scene.rotors
    column: int          # its first column
    width: int           # 3 (x, y, z) or 1 (psi)

    @property
    def name(self) -> str:
        return f"{self.kind} {self.index + 1}"

    @property
    def columns(self) -> slice:
        return slice(self.column, self.column + self.width)


class Channels:
    """The decisions of a task (its decided bodies' columns) and the moments of every
    body from them, the kept laws at the time t."""

    def __init__(self, task):
        sc = task.scene
        self.points, self.rotors = sc.points, sc.rotors
        chans, c = [], 0
        for d in task.decided:
            w = 3 if d.kind == "point" else 1
            chans.append(Channel(d.kind, d.index, c, w))
            c += w
        self.channels = tuple(chans)
        self.D = c
        decided = {(d.kind, d.index) for d in task.decided}
        self.kept = tuple((kind, k, body) for kind, bodies in (("point", self.points),
                                                              ("rotor", self.rotors))
                          for k, body in enumerate(bodies) if (kind, k) not in decided)
        # a kept law whose share of the moments changes makes them depend on t (the NLP's
        # state then has t); a rotor at a constant rate (psi = w t: its share reads psi'
        # and psi'' alone) does not, nor does a point held still
        self.moving = tuple(b.name for kind, _, b in self.kept if self._timed(kind, b))
        self.timed = bool(self.moving)

    @staticmethod
    def _timed(kind: str, body) -> bool:
        """Whether a kept body's share of the moments depends on the time (its law read
        in CasADi at a symbolic t: exact, where its summary's samples are not)."""
        if body.summary.max_speed == 0 and body.summary.max_acceleration == 0:
            return False
        t = ca.SX.sym("t")
        jets = body.law.output_jets(CasadiOps, t)
        used = ([jets[c][d] for d in range(3) for c in range(3)] if kind == "point"
                else [jets[0][1], jets[0][2]])
        return any(ca.depends_on(ca.SX(v), t) for v in used)

    @property
    def point_channels(self) -> tuple:
        return tuple(ch for ch in self.channels if ch.kind == "point")

    @property
    def rotor_channels(self) -> tuple:
        return tuple(ch for ch in self.channels if ch.kind == "rotor")

    def jet(self, u, ch: Channel, d: int):
        """The d-th derivative of a channel's columns in u (values D, rates D, accs D)."""
        start = d * self.D + ch.column
        return u[start:start + ch.width]

    def moments(self, u, t=None):
        """The 27 moments (CasADi) from the decisions' u and, for the kept laws, t."""
        pm, rm = load("point_moments"), load("rotor_moments")
        total = ca.MX.zeros(27, 1) if isinstance(u, ca.MX) else ca.SX.zeros(27, 1)
        spin = layout.MOMENTS.spin
        for ch in self.channels:
            if ch.kind == "point":
                jet = ca.vertcat(*(self.jet(u, ch, d) for d in range(3)))
                total += pm(self.points[ch.index].mass, jet)
            else:
                r = self.rotors[ch.index]
                rate = ca.vertcat(self.jet(u, ch, 1), self.jet(u, ch, 2))
                total[spin] += rm(ca.DM(list(r.axis)), r.inertia, rate)
        for kind, k, body in self.kept:
            jets = body.law.output_jets(CasadiOps, t if self.timed else 0.0)
            if kind == "point":
                jet = ca.vertcat(*(jets[c][d] for d in range(3) for c in range(3)))
                total += pm(body.mass, jet)
            else:
                rate = ca.vertcat(jets[0][1], jets[0][2])
                total[spin] += rm(ca.DM(list(body.axis)), body.inertia, rate)
        return total

    def moments_at(self, u, t: float) -> np.ndarray:
        """The moments as numbers (u: the decisions' values, rates and accelerations)."""
        if not hasattr(self, "_numeric"):
            us, ts = ca.SX.sym("u", 3 * self.D), ca.SX.sym("t")
            self._numeric = ca.Function("moments", [us, ts], [self.moments(us, ts)])
        return np.array(self._numeric(np.asarray(u, float), t)).ravel()


class TimedLayout(Layout):
    """A goal's layout with the time t after its entries (the kept laws read it)."""

    def __init__(self, base: Layout, t0: float):
        super().__init__(base.model, base.keep, base.fill)
        self.t0 = t0

    @property
    def nq(self) -> int:
        return len(self.keep) + 1

    @property
    def labels(self) -> tuple:
        return super().labels + ("t",)

    def of_state(self, q_model) -> np.ndarray:
        return np.r_[super().of_state(q_model), self.t0]

    def full(self, q):
        n = len(self.keep)
        return super().full(q[:n] if isinstance(q, np.ndarray) else q[0:n])

    def t_of(self, q):
        return q[len(self.keep)]


def _t_of(lay, q):
    return lay.t_of(q) if isinstance(lay, TimedLayout) else None


class BodiesTranscription(Transcription):
    """The NLP of a task of several bodies (see the module)."""
    bodies = True

    def __init__(self, task, goal, stabilize: bool = False):
        self.channels = Channels(task)
        super().__init__(task, goal, stabilize)

    # ---- the state, the law's shape, the model ---------------------------------------------
    def _layout(self) -> Layout:
        base = self.goal.layout(self.task)
        return TimedLayout(base, self.task.scene.t0) if self.channels.timed else base

    def _law_shape(self):
        self.kind, self.dim = "cartesian", self.channels.D

    def _model(self):
        lay, chans = self.layout, self.channels
        keep = list(lay.keep)
        timed = isinstance(lay, TimedLayout)
        f = load("moments_flight_rhs")

        def rhs(q, u, p):
            dq = f(lay.full(q), chans.moments(u, _t_of(lay, q)), p)[keep]
            return ca.vertcat(dq, 1.0) if timed else dq
        self.f = rhs
        if self.plane:
            gap, impact = load("moments_gap"), load("moments_impact")
            self.gap = lambda q, u, s, p: gap(lay.full(q), chans.moments(u, _t_of(lay, q)),
                                              s, p)

            def jump(q, u, s, p, e):
                q_plus = impact(lay.full(q), chans.moments(u, _t_of(lay, q)), s, p, e)[0][keep]
                return [ca.vertcat(q_plus, lay.t_of(q)) if timed else q_plus]
            self.impact = jump

    # ---- the law's conditions, the limits, the effort --------------------------------------
    def _columns(self, ch):
        return self.C[:, ch.column:ch.column + ch.width]

    def _law_constraints(self, add):
        task, sp, N = self.task, self.spline, self.N
        for ch in self.channels.channels:
            C = self._columns(ch)
            if ch.kind == "point" and not task.rest_at_ends:
                add(f"{ch.name} starts at start", ca.mtimes(ca.DM(sp.weights(0.0, 0)).T, C).T
                    - task.start, 0, 0)
            elif ch.kind == "rotor" and task.rest_at_ends:
                add(f"{ch.name} at rest at the end (rest_at_ends)",
                    ca.vertcat(C[N + 1] - C[N], C[N + 2] - C[N]), 0, 0, "rest_at_ends")
            elif ch.kind == "rotor":
                add(f"{ch.name} starts at psi = 0", ca.mtimes(ca.DM(sp.weights(0.0, 0)).T, C),
                    0, 0)
            # rest_at_ends: a point's first and last three control points, a rotor's
            # first three, are fixed (bounds)

    def _limits(self, add):
        task, sp, T, N = self.task, self.spline, self.T, self.N
        T_ref = task.horizon or self.T_guess_value()
        W2 = ca.DM(np.array([sp.weights(k / N, 2) for k in range(N + 1)]))
        for ch in self.channels.point_channels:
            C = self._columns(ch)
            d = C - ca.repmat(ca.DM(task.region_center).T, sp.n_ctrl, 1)
            add(REGION_GROUP + f" ({ch.name})", ca.sum2(d * d), -np.inf,
                task.region_radius ** 2, "region")
            A = ca.mtimes(W2, C)
            add(f"max_acceleration: |OP''| at the knots ({ch.name})",
                (ca.sum2(A * A) * self.k_acc - T ** 4) / T_ref ** 4, -np.inf, 0.0,
                "max_acceleration")
        a_max, w_max = task.max_rotor_acceleration, task.max_rotor_rate
        D1 = ca.DM(np.diff(np.eye(sp.n_ctrl), axis=0))       # psi's tau-rate control points
        for ch in self.channels.rotor_channels:
            c = self._columns(ch)
            A = ca.mtimes(W2, c)               # tau-accelerations at the knots
            add(f"max_rotor_acceleration: |psi''| at the knots ({ch.name})",
                ca.vertcat(A - a_max * T ** 2, -A - a_max * T ** 2) / (a_max * T_ref ** 2),
                -np.inf, 0.0, "max_rotor_acceleration")
            R = ca.mtimes(D1, c) * N           # psi's tau-rate control points
            add(f"max_rotor_rate: |psi'| (its control points) ({ch.name})",
                ca.vertcat(R - w_max * T, -R - w_max * T) / (w_max * T_ref), -np.inf, 0.0,
                "max_rotor_rate")

    def acceleration_weights(self) -> list:
        """(channel, 1/bound^2) of each decided body."""
        task = self.task
        return [(ch, 1.0 / (task.max_acceleration if ch.kind == "point"
                            else task.max_rotor_acceleration) ** 2)
                for ch in self.channels.channels]

    def _effort(self):
        """The integral of each decided body's (acceleration / its bound)^2, 3-point Gauss
        on each piece; per body in ``effort_parts`` (the integral of |OP''|^2, psi''^2)."""
        parts = {ch.name: [] for ch in self.channels.channels}
        for k in range(self.N):
            for s, wq in GAUSS3:
                u = self.u_at(k, s)
                for ch in self.channels.channels:
                    parts[ch.name].append(wq * ca.sumsqr(self.channels.jet(u, ch, 2)))
        self.effort_parts = {name: (self.T / self.N) * sum(terms)
                             for name, terms in parts.items()}
        self.effort = sum(w * self.effort_parts[ch.name]
                          for ch, w in self.acceleration_weights())

    def effort_part_of(self, name: str, w) -> float:
        """A decided body's integral of |OP''|^2 or psi''^2 at the point w."""
        if not hasattr(self, "_parts_f"):
            self._parts_f = ca.Function("parts", [self.w],
                                        [ca.vertcat(*self.effort_parts.values())])
        values = np.array(self._parts_f(w)).ravel()
        return float(values[list(self.effort_parts).index(name)])

    def max_acceleration_scale(self) -> float:
        return self.task.horizon or self.T_guess_value()

    def fallback_effort(self) -> float:
        """The effort of a start at rest: each decided body at a tenth of its bound over
        the horizon."""
        return 0.01 * len(self.channels.channels) * self.T_guess_value()

    def _bounds(self):
        """As the one point's (the first node, a free T), with the fixed control points of
        rest_at_ends: a point's first and last three at start, a rotor's first three at
        0."""
        task, sp, N, nq = self.task, self.spline, self.N, self.layout.nq
        n = self.w.shape[0]
        lbx, ubx = np.full(n, -np.inf), np.full(n, np.inf)
        if task.rest_at_ends:
            for ch in self.channels.channels:
                fixed = [0, 1, 2] + ([N, N + 1, N + 2] if ch.kind == "point" else [])
                value = task.start if ch.kind == "point" else np.zeros(1)
                for j, c in enumerate(range(ch.column, ch.column + ch.width)):
                    for i in fixed:
                        lbx[c * sp.n_ctrl + i] = ubx[c * sp.n_ctrl + i] = value[j]
        self.goal.bound_first_node(self, lbx[self.n_c:self.n_c + nq],
                                   ubx[self.n_c:self.n_c + nq])
        if self.free_T:
            lbx[-1] = self.goal.shortest(task)
            if task.horizon is not None:
                ubx[-1] = task.horizon
        self.lbx, self.ubx = lbx, ubx

    def limit_values(self, w) -> dict:
        """As the one point's: the largest |OP''| at the knots and distance of a control
        point from the region's centre over the decided points (0 without), and T."""
        ctrl, _, T = self.unpack(w)
        W2 = np.array([self.spline.weights(k / self.N, 2) for k in range(self.N + 1)])
        acc = region = 0.0
        for ch in self.channels.point_channels:
            c = ctrl[:, ch.columns]
            acc = max(acc, float(np.max(np.linalg.norm(W2 @ c, axis=1))) / T ** 2)
            region = max(region, float(np.max(np.linalg.norm(c - self.task.region_center,
                                                             axis=1))))
        return {"max_acceleration": acc, "region": region, "horizon": T}

    # ---- the guess ------------------------------------------------------------------------
    def rest_ctrl(self) -> np.ndarray:
        """Every decided body where it starts, at rest: a point at start, a rotor at 0."""
        row = np.zeros(self.dim)
        for ch in self.channels.point_channels:
            row[ch.columns] = self.task.start
        return np.tile(row, (self.spline.n_ctrl, 1))

    def inertia(self, t: float = 0.0) -> np.ndarray:
        """J of the whole system (about C, body axes) with the decided bodies at rest where
        they start: K at unit omega less K at rest (moments_kinetic_moment)."""
        K = load("moments_kinetic_moment")
        u = np.r_[self.rest_ctrl()[0], np.zeros(2 * self.dim)]
        mom = self.channels.moments_at(u, t)
        q = np.zeros(GEN.nq)
        q[GEN.A] = np.eye(3).ravel()
        base = np.array(K(q, mom, self.p).full()).ravel()
        cols = []
        for i in range(3):
            qi = q.copy()
            qi[GEN.omega.start + i] = 1.0
            cols.append(np.array(K(qi, mom, self.p).full()).ravel() - base)
        return np.array(cols).T

    def attitude_ctrl(self, T: float, A_target, q0) -> np.ndarray:
        """Control points that turn the drifting body towards A_target by T: the rotation
        vector phi wanted at the end (body axes, from where the body drifts with the
        decided bodies at rest) made by the decided rotors about a fixed axis,
        psi = -B^+ J phi s(tau) (B = [I_k a_k]), or, with no rotor decided, by loops of
        the first decided point (:func:`derive.planner.guess.loops`' area rule)."""
        from .guess import fit_ctrl, loops, rotation_vector, smoothstep
        rest = self.rest_ctrl()
        Q = self.rk4_nodes(rest, q0, T)
        phi = rotation_vector(self.layout.A_of(Q[:, -1]).T @ A_target)
        J = self.inertia(self.task.scene.t0)
        task = self.task
        rotors = self.channels.rotor_channels
        dpsi = np.zeros(0)
        if rotors:
            B = np.array([np.asarray(self.channels.rotors[ch.index].axis)
                          * self.channels.rotors[ch.index].inertia for ch in rotors]).T
            dpsi = -np.linalg.pinv(B) @ (J @ phi)
            phi = phi + np.linalg.solve(J, B @ dpsi)      # what the rotors cannot turn
        # the rest by loops of the first decided point, by the rule of one point (the area
        # vector -J phi / (2 mu), J and mu those of one point of the decided points' total
        # mass), the others at rest
        points = self.channels.point_channels
        loop = loops(self, phi, task.rest_at_ends) \
            if points and np.linalg.norm(phi) > 1e-9 else None

        def path(tau):
            s = smoothstep(tau) if task.rest_at_ends else np.asarray(tau)
            out = np.tile(rest[0], (len(s), 1))
            for ch, d in zip(rotors, dpsi):
                out[:, ch.column] = d * s
            if loop is not None:
                out[:, points[0].columns] = loop(tau)
            return out
        return fit_ctrl(self, path)


def initial_nodes(tr: BodiesTranscription) -> np.ndarray:
    """The NLP's state at t0 (the goal's entries, and t)."""
    return tr.layout.of_state(initial_state(tr.task))
