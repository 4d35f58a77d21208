"""The contact reaction of a run's rows, recomputed apart from the runtime.

The judge of the rough plane (:func:`derive.verify.judges.judge_rough`) holds the
friction cone, the couples' bounds and the sign of N against the reaction computed here,
not against the runtime's own (``Session.rough_rows`` and ``wrench_rows`` evaluate the
runtime's C).  Written from Newton's and Euler's laws for the bodies, without reading
derive/friction.py, derive/friction_models.py, derive/contact.py, derive/moments.py or
the runtime's C; the scene's numbers, each body's own law (``Point.law.jets``,
``Rotor.law.jets``, evaluated in Python) and the surface's support map
(:mod:`derive.shapes`, the shape's definition) are its only inputs.

The bodies, body axes of the carrier for the dynamics (n = A^T e_Z the vertical):

* the carrier, mass M, principal central inertia diag(J) about its centre O (its rotors'
  masses in M, and their inertia as if locked in J: the scene's [body]);
* point j (the paper's one point, or each [[point]]), mass m_j, at r_j = OP_j(t) in body
  axes with r_j', r_j'' prescribed: the carrier exerts F_j on it, it exerts -F_j on the
  carrier at P_j;
* rotor k ([[rotor]]), turning by psi_k(t) relative to the carrier about the unit axis
  a_k fixed in it, axial moment I_k: the carrier and its rotors have the angular
  momentum J w + h_r about O, h_r = sum_k I_k psi_k' a_k (a rotor's transverse moments
  and its locked axial one are in J), whose rate relative to the body is h_r' = sum_k
  I_k psi_k'' a_k;
* the plane acts on the carrier at its material point at S (s = OS in body axes, the
  lowest point of the surface) with the force R and the couple T (fixed axes).

The laws (a_O the absolute acceleration of O, w' the angular acceleration)::

    carrier, Newton   M a_O + sum_j F_j - A^T R                   = -M g n
    point j, Newton   m_j (a_O + w' x r_j) - F_j
                          = -m_j g n - m_j (w x (w x r_j) + 2 w x r_j' + r_j'')
    carrier, Euler    J w' + sum_j r_j x F_j - s x A^T R - A^T T
                          = -w x (J w + h_r) - h_r'                  (about O)

and the row's mode constraints, on the acceleration of the material point at S
``a_S = a_O + w' x s + w x (w x s) + w x s'`` (s' the motion of S over the surface as the
body turns: d(n . s)/dt involves it) and on A w' (the rate of Omega = A w):

* always: e_Z . A a_S = 0 (S stays on the plane);
* sticking: e_X . A a_S = e_Y . A a_S = 0 and R_X, R_Y unknown; sliding along the unit
  horizontal sigma: R = N (e_Z - mu_f sigma);
* spin friction held: (A w')_Z = 0 and T_Z unknown; turning with Omega_Z: T_Z = -mu_s N
  sign(Omega_Z); rolling resistance held: (A w')_X = (A w')_Y = 0 and T_X, T_Y unknown;
  turning: (T_X, T_Y) = -mu_r N (Omega_X, Omega_Y)/|(Omega_X, Omega_Y)|.

One dense solve per row (numpy.linalg.solve on the stacked system, every row at once):
12 + 3 N_points unknowns (a_O, w', each F_j, and the reaction's six).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import abi, shapes

E_Z = np.array([0.0, 0.0, 1.0])
FLIGHT, SMOOTH, SLIDING, STICKING = (abi.index(abi.MODES, name)
                                     for name in ("flight", "smooth", "sliding", "sticking"))
SPIN, ROLL = (dict(abi.COUPLE_BITS)[name] for name in ("spin", "roll"))


@dataclass(frozen=True)
class Bodies:
    """The numbers of a scene the bodies' laws read: the carrier's, each point's mass
    ``masses`` (N,), each rotor's unit ``axes`` (R, 3) and axial moment ``inertias``
    (R,), the plane's."""
    M: float
    masses: np.ndarray
    J: np.ndarray
    g: float
    shape: str
    size: tuple
    center: np.ndarray
    mu_f: float
    mu_s: float
    mu_r: float
    axes: np.ndarray
    inertias: np.ndarray

    @classmethod
    def of(cls, scene) -> "Bodies":
        rotors = scene.rotors
        return cls(float(scene.M), np.array([float(p.mass) for p in scene.points]),
                   np.asarray(scene.J, dtype=float), float(scene.g), scene.shape,
                   tuple(scene.size), np.asarray(scene.center, dtype=float),
                   float(scene.friction), float(scene.spin_friction),
                   float(scene.rolling_resistance),
                   np.array([r.axis for r in rotors], dtype=float).reshape(-1, 3),
                   np.array([float(r.inertia) for r in rotors]))

    @property
    def m(self) -> float:
        """The points' total mass."""
        return float(np.sum(self.masses))

    @property
    def weight(self) -> float:
        """(M + m) g, or (M + m) where g < 1: the judge's force scale."""
        return (self.M + self.m) * max(self.g, 1.0)


def _cross(a, b):
    return np.cross(a, b)


def _skew(v):
    """(n, 3) -> (n, 3, 3): skew(v) @ x = v x x."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


@dataclass
class Jets:
    """The bodies' laws on rows: ``points`` (n, N, 9) each point's r, r', r'' (body
    axes); ``rotors`` (n, R, 3) each rotor's psi, psi', psi''."""
    points: np.ndarray
    rotors: np.ndarray


def _jets(u, n_rotors: int) -> Jets:
    """``u`` as :class:`Jets`: itself, or one point's rows (n, 9) or the points' (n, N,
    9) with no rotor."""
    if isinstance(u, Jets):
        return u
    u = np.asarray(u, dtype=float)
    pts = u[:, None, :] if u.ndim == 2 else u
    return Jets(pts, np.zeros((len(pts), n_rotors, 3)))


@dataclass
class Kinematics:
    """Rows of a run in the bodies' terms (body axes unless said)."""
    A: np.ndarray       # (n, 3, 3): fixed = A body
    w: np.ndarray       # angular velocity
    n: np.ndarray       # the vertical
    r: np.ndarray       # (n, N, 3): each OP_j and its rates
    rd: np.ndarray
    rdd: np.ndarray
    h_r: np.ndarray     # the rotors' axial angular momentum sum I psi' a, and its rate
    h_rd: np.ndarray
    s: np.ndarray       # OS and its rate as the body turns
    sd: np.ndarray
    v_S: np.ndarray     # the velocity of the material point at S, fixed axes
    Omega: np.ndarray   # A w, fixed axes


def kinematics(b: Bodies, q, u) -> Kinematics:
    """``q`` (n, 18): X_C, V_C (fixed), omega (body), A (row-major, a_ij = cos(fixed i,
    body j)); ``u``: :class:`Jets`, or (n, 9) one point's r, r', r'' (body axes)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    jets = _jets(u, len(b.inertias))
    A = q[:, 9:18].reshape(-1, 3, 3)
    w, V_C = q[:, 6:9], q[:, 3:6]
    pts = jets.points
    r, rd, rdd = pts[..., 0:3], pts[..., 3:6], pts[..., 6:9]
    spin = b.inertias * b.axes.T[:, None, :]                 # (3, 1, R): I_k a_k
    h_r = np.sum(spin * jets.rotors[None, :, :, 1], axis=2).T
    h_rd = np.sum(spin * jets.rotors[None, :, :, 2], axis=2).T
    n = A[:, 2, :]
    shape = shapes.of(b.shape)
    s = shape.lowest_rows(n, b.center, b.size)
    nd = _cross(n, w)                        # e_Z fixed: n' = n x w in body axes
    sd = _surface_rate(shape, b, n, nd)
    # V_C = V_O + (s_m' + w x s_m)/(M + m), s_m = sum m_j r_j (C's definition)
    first = np.einsum("j,njk->nk", b.masses, rd + _cross(w[:, None, :], r))
    v_O = np.einsum("nji,nj->ni", A, V_C) - first / (b.M + b.m)
    v_S = np.einsum("nij,nj->ni", A, v_O + _cross(w, s))
    return Kinematics(A, w, n, r, rd, rdd, h_r.reshape(-1, 3), h_rd.reshape(-1, 3), s, sd,
                      v_S, np.einsum("nij,nj->ni", A, w))


def _surface_rate(shape, b: Bodies, n, nd):
    """d(OS)/dt = (dS/dn) n', by a fourth-order central difference of the support map
    along n' (|n'| scaled out: the step is 1e-3 of the direction's length)."""
    speed = np.linalg.norm(nd, axis=1)
    e = nd / np.where(speed > 0.0, speed, 1.0)[:, None]
    h = 1e-3

    def at(k):
        return shape.lowest_rows(n + k * h * e, b.center, b.size)
    d = (-at(2) + 8.0 * at(1) - 8.0 * at(-1) + at(-2)) / (12.0 * h)
    return d * speed[:, None]


@dataclass
class Reaction:
    """The contact's reaction on rows (fixed axes): the force R at S and the couple T;
    ``a_S`` the acceleration of the material point at S and ``Omega_rate`` = A w' under
    it (the constraints' residuals)."""
    R: np.ndarray
    T: np.ndarray
    a_S: np.ndarray
    Omega_rate: np.ndarray

    @property
    def N(self) -> np.ndarray:
        return self.R[:, 2]


def solve(b: Bodies, k: Kinematics, sticking, sigma=None, spin_held=None, roll_held=None,
          spin_sign=None, roll_dir=None) -> Reaction:
    """The reaction on every row under its mode: ``sticking`` (n,) bool; where not
    sticking, sliding along ``sigma`` (n, 2) (fixed X, Y; unit); ``spin_held`` /
    ``roll_held`` (n,) bool for the couples' channels (None: the channel is off, its
    couple 0), turning along ``spin_sign`` (n,) / ``roll_dir`` (n, 2) where not held."""
    nrow = len(k.A)
    sticking = np.asarray(sticking, dtype=bool).reshape(nrow)
    sig = np.zeros((nrow, 2)) if sigma is None else np.asarray(sigma, dtype=float)
    spin_on, roll_on = spin_held is not None and b.mu_s > 0, roll_held is not None \
        and b.mu_r > 0
    sh = np.asarray(spin_held, dtype=bool) if spin_on else np.zeros(nrow, dtype=bool)
    rh = np.asarray(roll_held, dtype=bool) if roll_on else np.zeros(nrow, dtype=bool)
    ss = np.zeros(nrow) if spin_sign is None else np.asarray(spin_sign, dtype=float)
    rd = np.zeros((nrow, 2)) if roll_dir is None else np.asarray(roll_dir, dtype=float)
    # the reaction's unknowns z = (N, R_X, R_Y, T_Z, T_X, T_Y): R = Br z, T = Bt z; an
    # unknown a row does not have is pinned to 0 by an identity row
    Br = np.zeros((nrow, 3, 6))
    Bt = np.zeros((nrow, 3, 6))
    Br[:, 2, 0] = 1.0
    Br[:, 0, 0] = np.where(sticking, 0.0, -b.mu_f * sig[:, 0])
    Br[:, 1, 0] = np.where(sticking, 0.0, -b.mu_f * sig[:, 1])
    Br[:, 0, 1] = Br[:, 1, 2] = 1.0
    if spin_on:
        Bt[:, 2, 0] = np.where(sh, 0.0, -b.mu_s * ss)
    if roll_on:
        Bt[:, 0, 0] = np.where(rh, 0.0, -b.mu_r * rd[:, 0])
        Bt[:, 1, 0] = np.where(rh, 0.0, -b.mu_r * rd[:, 1])
    Bt[:, 2, 3] = Bt[:, 0, 4] = Bt[:, 1, 5] = 1.0
    AT = np.transpose(k.A, (0, 2, 1))
    M, g = b.M, b.g
    npt = k.r.shape[1]
    iz = 6 + 3 * npt                    # x = (a_O, w', F_1 .. F_N, z)
    size = iz + 6
    I3 = np.broadcast_to(np.eye(3), (nrow, 3, 3))
    K = np.zeros((nrow, size, size))
    rhs = np.zeros((nrow, size))
    rho = AT @ Br                       # A^T R per unknown
    # carrier: Newton (rows 0:3) and Euler about O (rows 3:6)
    K[:, 0:3, 0:3] = M * I3
    K[:, 0:3, iz:] = -rho
    rhs[:, 0:3] = -M * g * k.n
    K[:, 3:6, 3:6] = np.broadcast_to(np.diag(b.J), (nrow, 3, 3))
    K[:, 3:6, iz:] = -_skew(k.s) @ rho - AT @ Bt
    rhs[:, 3:6] = -_cross(k.w, k.w * b.J + k.h_r) - k.h_rd
    for j, mj in enumerate(b.masses):   # point j: its own Newton, its own force
        F = slice(6 + 3 * j, 9 + 3 * j)
        rj, rdj, rddj = k.r[:, j], k.rd[:, j], k.rdd[:, j]
        K[:, 0:3, F] = I3
        K[:, 3:6, F] = _skew(rj)
        K[:, F, 0:3] = mj * I3
        K[:, F, 3:6] = -mj * _skew(rj)
        K[:, F, F] = -I3
        rhs[:, F] = -mj * g * k.n - mj * (_cross(k.w, _cross(k.w, rj))
                                          + 2.0 * _cross(k.w, rdj) + rddj)
    # a_S = a_O - s x w' + c
    c = _cross(k.w, _cross(k.w, k.s)) + _cross(k.w, k.sd)
    Sa = np.zeros((nrow, 3, 6))
    Sa[:, :, 0:3] = I3
    Sa[:, :, 3:6] = -_skew(k.s)
    ASa = k.A @ Sa                      # fixed axes
    Ac = np.einsum("nij,nj->ni", k.A, c)
    Aw = np.zeros((nrow, 3, 6))
    Aw[:, :, 3:6] = k.A
    # row iz: on the plane; +1, +2: the slip held or R_X, R_Y = 0; +3: the spin held or
    # T_Z = 0 (where turning the column of N carries it); +4, +5: the rolling
    K[:, iz, :6] = ASa[:, 2]
    rhs[:, iz] = -Ac[:, 2]
    for row, axis in ((iz + 1, 0), (iz + 2, 1)):
        K[:, row, :6] = np.where(sticking[:, None], ASa[:, axis], 0.0)
        rhs[:, row] = np.where(sticking, -Ac[:, axis], 0.0)
        K[:, row, iz + 1 + axis] = np.where(sticking, 0.0, 1.0)
    K[:, iz + 3, :6] = np.where(sh[:, None], Aw[:, 2], 0.0)
    K[:, iz + 3, iz + 3] = np.where(sh, 0.0, 1.0)
    for row, axis in ((iz + 4, 0), (iz + 5, 1)):
        K[:, row, :6] = np.where(rh[:, None], Aw[:, axis], 0.0)
        K[:, row, iz + 4 + axis] = np.where(rh, 0.0, 1.0)
    x = np.linalg.solve(K, rhs[:, :, None])[:, :, 0]
    z = x[:, iz:]
    R = np.einsum("nij,nj->ni", Br, z)
    T = np.einsum("nij,nj->ni", Bt, z)
    a_S = np.einsum("nij,nj->ni", ASa, x[:, :6]) + Ac
    return Reaction(R, T, a_S, np.einsum("nij,nj->ni", k.A, x[:, 3:6]))


def law_rows(scene, t) -> Jets:
    """Each body's r, r', r'' (points) and psi, psi', psi'' (rotors) at the times t, from
    its own law evaluated in Python (the paper's one point: the scene's law)."""
    t = np.asarray(t, dtype=float).reshape(-1)
    pts = np.zeros((len(t), len(scene.points), 9))
    for j, p in enumerate(scene.points):
        x = np.asarray(p.law.jets(t))                       # x, x', x'', y, ...
        pts[:, j] = np.stack([x[0], x[3], x[6], x[1], x[4], x[7], x[2], x[5], x[8]], axis=1)
    rot = np.zeros((len(t), len(scene.rotors), 3))
    for k, r in enumerate(scene.rotors):
        rot[:, k] = np.asarray(r.law.jets(t))[0:3].T       # psi is a table's x
    return Jets(pts, rot)


# ---- which mode holds on each row ------------------------------------------------------
_COLLIDE_FOLLOWERS = ("contact", "graze")


@dataclass
class RowModes:
    """What the runtime says holds on each row, pair by pair: ``mode`` (abi.MODES),
    ``couples`` (abi.COUPLE_BITS held), and for the rows around an event its kind
    (``event``: '' elsewhere) and whether the row is the one ``before`` it or ``after``."""
    mode: np.ndarray
    couples: np.ndarray
    event: list
    side: np.ndarray     # 0 a step's row, 1 before an event, 2 after
    cascade: np.ndarray  # the rows of an instant with several events: each holds what
    #                      its own event decided, the next event what it did not


def row_modes(result) -> RowModes:
    """Each pair of rows around an event takes the modes the runtime reported for that
    event alone (a stick that a slip follows at the same instant has its own pair, whose
    after row is sticking), where reading the modes by time would give every row of the
    instant the last event's.  A run's rows and events are in time order; an impact
    shares its pair with the entry into contact (or the graze) that follows it."""
    events = result.events
    kinds = result.row_kind
    t = result.t
    nrow = len(t)
    scale = 1e-9 * max(abs(result.scene.duration), 1.0)
    mode = np.zeros(nrow, dtype=int)
    couples = np.zeros(nrow, dtype=int)
    event = [""] * nrow
    side = np.asarray(kinds, dtype=int).copy()
    cur_mode, cur_couples, k = FLIGHT, 0, 0

    def apply(ev):
        nonlocal cur_mode, cur_couples
        if "mode" in ev:
            cur_mode = abi.index(abi.MODES, ev["mode"])
        elif ev["kind"] == "contact":
            cur_mode = SMOOTH
        elif ev["kind"] == "lift_off":
            cur_mode = FLIGHT
        cur_couples = ev.get("couples", 0) if cur_mode != FLIGHT else 0

    pending: list = []
    for j in range(nrow):
        if kinds[j] == 1:
            while k < len(events) and events[k]["t"] < t[j] - scale:
                apply(events[k])                 # events without rows of their own
                k += 1
            pending = []
            if k < len(events) and abs(events[k]["t"] - t[j]) <= scale:
                pending.append(events[k])
                k += 1
                if pending[0]["kind"] == "impact":
                    while (k < len(events) and events[k]["kind"] in _COLLIDE_FOLLOWERS
                           and abs(events[k]["t"] - t[j]) <= scale):
                        pending.append(events[k])
                        k += 1
            event[j] = pending[0]["kind"] if pending else ""
        elif kinds[j] == 2:
            for ev in pending:
                apply(ev)
            event[j] = pending[0]["kind"] if pending else ""
            pending = []
        mode[j], couples[j] = cur_mode, cur_couples
    # an instant with several pairs of rows (a stick and the slip that follows it, a
    # spin's stop and the slip its held couple causes, ...)
    cascade = np.zeros(nrow, dtype=bool)
    pairs = np.flatnonzero(side == 1)
    for a, b in zip(pairs[:-1], pairs[1:]):
        if abs(t[b] - t[a]) <= scale:
            cascade[a:b + 2] = True
    return RowModes(mode, couples, event, side, cascade)


# ---- the reaction of a run's contact rows ----------------------------------------------
@dataclass
class RowReactions:
    """The independent reaction on the rows ``rows`` of a run: ``reaction`` where each
    row's mode is known (``known``: sticking; sliding with its slip resolved; each turning
    couple with its angular velocity resolved); ``sticking_reaction`` the reaction of the
    sticking equations on every one of these rows (with the row's couples), what a stick
    decision and a slip's onset read; ``modes`` the rows' :class:`RowModes`;
    ``couples_known``: each turning couple's direction resolved (what the sticking
    reaction needs)."""
    rows: np.ndarray
    reaction: Reaction
    known: np.ndarray
    couples_known: np.ndarray
    sticking_reaction: Reaction
    modes: RowModes
    kin: Kinematics
    min_sliding_N: np.ndarray     # sliding rows: the largest N over the directions


def contact_reactions(result, resolution: float) -> RowReactions:
    """The reaction on every contact row of a rough run (the rows whose mode is sliding
    or sticking).  ``resolution``: the fraction of the velocities' scale below which a
    slip or a couple's angular velocity does not say its direction (the runtime then
    follows a reference these rows do not record)."""
    from ..runtime.choice import length_scale
    s = result.scene
    b = Bodies.of(s)
    modes = row_modes(result)
    rows = np.flatnonzero((modes.mode == SLIDING) | (modes.mode == STICKING))
    k = kinematics(b, result.model_q[rows], law_rows(s, result.t[rows]))
    v_scale = float(np.max(np.abs(result.model_q[:, 3:6]))) + 1.0
    w_scale = v_scale / max(length_scale(s), 1e-300)
    sticking = modes.mode[rows] == STICKING
    slip = np.hypot(k.v_S[:, 0], k.v_S[:, 1])
    couples_known = np.ones(len(rows), dtype=bool)
    sigma = k.v_S[:, :2] / np.where(slip > 0.0, slip, 1.0)[:, None]
    held = modes.couples[rows]
    spin_held = roll_held = None
    spin_sign = np.sign(k.Omega[:, 2])
    roll_rate = np.hypot(k.Omega[:, 0], k.Omega[:, 1])
    roll_dir = k.Omega[:, :2] / np.where(roll_rate > 0.0, roll_rate, 1.0)[:, None]
    if b.mu_s > 0.0:
        spin_held = (held & SPIN) != 0
        couples_known &= spin_held | (np.abs(k.Omega[:, 2]) > resolution * w_scale)
    if b.mu_r > 0.0:
        roll_held = (held & ROLL) != 0
        couples_known &= roll_held | (roll_rate > resolution * w_scale)
    known = (sticking | (slip > resolution * v_scale)) & couples_known
    reaction = solve(b, k, sticking, sigma, spin_held, roll_held, spin_sign, roll_dir)
    stick = solve(b, k, np.ones(len(rows), dtype=bool), None, spin_held, roll_held,
                  spin_sign, roll_dir)
    # a sliding row whose slip does not say its direction: the most N any direction gives
    best = np.full(len(rows), np.inf)
    loose = np.flatnonzero(~sticking & ~known)
    if len(loose) and b.mu_s == 0.0 and b.mu_r == 0.0:
        sub = Kinematics(*(getattr(k, f)[loose] for f in Kinematics.__dataclass_fields__))
        best[loose] = -np.inf
        for th in np.linspace(0.0, 2.0 * math.pi, 36, endpoint=False):
            d = np.broadcast_to([math.cos(th), math.sin(th)], (len(loose), 2))
            got = solve(b, sub, np.zeros(len(loose), dtype=bool), d)
            best[loose] = np.maximum(best[loose], got.N)
    return RowReactions(rows, reaction, known, couples_known, stick, modes, k, best)
