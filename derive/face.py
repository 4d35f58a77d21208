"""The flat face a body rests on, and the friction over it: the base model's geometry and
its face integrals (derive/base.py derives the dynamics; this module integrates over the
face, by fixed rules designed for C).

**The face.**  A box rests on one of its six faces, a cylinder on one of its two ends.  The
*face frame* is the body frame turned so that its third axis is the upward vertical n (for
these shapes a signed permutation of the body axes: J stays diagonal, the moments are
permuted).  In it the face is the rectangle ``|x - c_x| <= a, |y - c_y| <= b`` or the disc
``|r - c| <= R`` at the height ``-h`` below O (``h``: O's height above the plane while the
face lies on it).  :func:`face_on` finds it from the shape, its size and centre, and n.

**Friction over the face** (Coulomb's law at every point, so sliding and spinning are
coupled: Contensou).  A body point r of the face (from O's vertical, face frame) moves at
``u(r) = v + w e_z x r`` (v: O's horizontal velocity, w: the yaw rate), and friction there
is ``-mu p(r) u/|u|``.  Summed over the face: the force ``F`` and the torque ``T_z`` about
O's vertical (:func:`slip_wrench`), and the power they take, the dissipation ``D(v, w) =
mu int p |u| dA`` (:func:`dissipation`).  D is a norm of the twist (v, w), and the friction
of a slip is minus its gradient: ``(F, T_z) = -grad D``.

**The limit surface**: the set of wrenches ``(F, T_z)`` static friction can supply, ``{W :
W.xi <= D_s(xi) for every twist xi}`` (``D_s`` with the static coefficient).  Its gauge
``gamma(W) = max_xi W.xi / D_s(xi)`` (the dual norm of D_s, :func:`gauge`) is at most 1
inside: a body sticks while the wrench its rest requires has gamma <= 1, and slips from
the twist xi* that attains the maximum when gamma reaches 1.

**Pressure** over the face, for a normal force N with its centre at ``cp``:
``"uniform"`` (``p = N/A``; cp, from the moment balance, only says where the body would
tip) or ``"linear"`` (``p`` affine in position with its centroid at cp: the distribution of
a rigid face on an elastic floor that balances the tipping moment, Sakharov 2015); linear
pressure is positive while cp stays in the face's kern (``|x|/a + |y|/b <= 1/3`` of a
rectangle, ``|r| <= R/4`` of a disc, from the face centroid), beyond which the face begins
to lift at an edge (:func:`kern_margin`).

**Rules.**  Fixed product Gauss rules (:func:`rule`): Gauss–Legendre in x and y over a
rectangle; over a disc, Gauss–Legendre in the radius (with the weight r) times the
trapezoid rule in the angle (exact for trigonometric polynomials).  Pure spin about the
centre of a disc is integrated exactly (|u| = |w| r); elsewhere the integrand has a cone
point at the instant centre ``r0 = e_z x v/w``, which limits a fixed rule to a few digits
(measured in tests/test_face.py against the closed forms of :mod:`derive.base_reference`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special
from scipy.optimize import minimize

from . import abi, shapes

PRESSURES = abi.names(abi.PRESSURES)     # ("uniform", "linear")
FAR = 8.0                  # the instant centre this many sizes away: the product rule
ANGLE_ORDER = 32           # the instant-centre rule's order (Friction.n; crt_face.h's)
FAR_ORDER = 12             # crt_face.h's product rule where r0 is FAR (converged there)
RIM = 0.9                  # r0 between RIM R and R / RIM from a disc's centre: closed form
AXIS_TOL = 1e-9            # n within this of a face normal: the face lies flat


@dataclass(frozen=True)
class Face:
    """A flat face on the plane, in the face frame (see the module's docstring)."""
    kind: str                  # "rectangle" | "disc"
    half: tuple                # (a, b) of a rectangle, (R,) of a disc
    centre: tuple              # (c_x, c_y): the face's centroid from O's vertical
    height: float              # h: O's height above the plane
    frame: np.ndarray          # Q: rows are the face frame's axes in body axes

    @property
    def area(self) -> float:
        if self.kind == "rectangle":
            return 4.0 * self.half[0] * self.half[1]
        return math.pi * self.half[0] ** 2

    @property
    def second_moments(self) -> tuple:
        """int x^2 dA, int y^2 dA about the centroid."""
        if self.kind == "rectangle":
            a, b = self.half
            return (4 * a ** 3 * b / 3, 4 * a * b ** 3 / 3)
        R = self.half[0]
        return (math.pi * R ** 4 / 4,) * 2

    @property
    def size(self) -> float:
        """The length that scales the spin in a twist (v, size w): the face's half-diagonal
        or radius."""
        return math.hypot(*self.half) if self.kind == "rectangle" else self.half[0]

    def edge_margin(self, cp) -> float:
        """How far cp (from O's vertical) is inside the face: 0 on its edge, negative
        outside (the body tips)."""
        x, y = cp[0] - self.centre[0], cp[1] - self.centre[1]
        if self.kind == "rectangle":
            return min(self.half[0] - abs(x), self.half[1] - abs(y))
        return self.half[0] - math.hypot(x, y)

    def kern_margin(self, cp) -> float:
        """Linear pressure stays positive while this is >= 0 (scaled as a length)."""
        x, y = cp[0] - self.centre[0], cp[1] - self.centre[1]
        if self.kind == "rectangle":
            a, b = self.half
            return min(a, b) * (1.0 / 3.0 - abs(x) / a - abs(y) / b)
        return self.half[0] / 4 - math.hypot(x, y)


def vertical_text(n) -> str:
    """The vertical n as messages print it: [0, 1, 0], not a -2.22e-16 of round-off."""
    n = np.asarray(n, dtype=float)
    return "[" + ", ".join(f"{c:.6g}" for c in np.where(np.abs(n) < 1e-12, 0.0, n)) + "]"


def face_on(shape: str, size, center, n) -> Face:
    """The face of a box or the end of a cylinder whose outward normal is ``-n`` (``n``
    the upward vertical in body axes), or ValueError when n is along no face normal."""
    n = np.asarray(n, dtype=float)
    n = n / np.linalg.norm(n)
    k = int(np.argmax(np.abs(n)))
    if abs(abs(n[k]) - 1.0) > AXIS_TOL or (shape == "cylinder" and k != 2):
        raise ValueError(f"the vertical {vertical_text(n)} (body axes) is along no face "
                         f"normal of {shapes.with_article(shape)}")
    sign = 1.0 if n[k] > 0 else -1.0
    third, first, second = [0.0] * 3, [0.0] * 3, [0.0] * 3
    third[k] = sign                              # sign e_k
    first[(k + 1) % 3] = 1.0                     # e_(k+1)
    second[(k + 2) % 3] = sign                   # third x first
    Q = np.array([first, second, third])
    c = Q @ np.asarray(center, dtype=float)
    if shape == "box":
        ext = np.abs(Q) @ np.asarray(size, dtype=float)
        return Face("rectangle", (float(ext[0]), float(ext[1])), (float(c[0]), float(c[1])),
                    float(ext[2] - c[2]), Q)
    if shape == "cylinder":
        R, L = size
        return Face("disc", (float(R),), (float(c[0]), float(c[1])), float(L - c[2]), Q)
    raise ValueError(f"{shapes.with_article(shape)} has no flat face")


# ---- a start whose lowest points are not one point ----------------------------------------
# A body started on the plane (or with S on it at rest) whose vertical is within LINE_TOL
# (the sine of the angle) of a box's edge or face or of a cylinder's side or end touches
# the plane along a line or a face.  Only the base model takes a face (on a rough plane);
# the one-point models do not make a line or a face contact: S jumps between its ends as
# round-off tilts the body, and the run chatters (a cylinder on its side: 99,998 reversals
# in 0.15 ms, max_events).  Measured on that cylinder (R 3 cm, L 7.5 cm, mu 0.25, e 0.5)
# tilted about the horizontal square to its axis: 1e-3 and 1e-6 rad stop with
# surface_jump as it falls flat (at 4.1 ms and 0.129 ms, sqrt(2 tilt / its angular
# acceleration)); 1e-7 ran 0.2 s "done" (the fall missed), 1e-8 max_steps, 3e-9 and less
# chatter to max_events.  So a start nearer than LINE_TOL is refused.
LINE_TOL = 5e-7


def flat_contact(shape: str, n, turn=None) -> str | None:
    """What a body of ``shape`` whose upward vertical is ``n`` (body axes) touches the
    plane with when its lowest points are not one: ``"an edge"`` or ``"a face"`` of a box,
    ``"its side (a line)"`` or ``"an end face"`` of a cylinder; None for one point.
    ``turn``: how far n turns over the run (n x omega times the duration, body axes), a
    component that leaves the tolerance by it is not square (the body rolls off the line
    or the face at once: a single-point contact)."""
    n = np.asarray(n, dtype=float)
    n = n / np.linalg.norm(n)
    d = np.zeros(3) if turn is None else np.asarray(turn, dtype=float)
    if shape == "box":           # body axes square to the vertical, and staying so
        square = int(np.sum((np.abs(n) <= LINE_TOL) & (np.abs(d) <= LINE_TOL)))
        return (None, "an edge", "a face")[min(square, 2)]
    if shape == "cylinder":
        if abs(n[2]) <= LINE_TOL and abs(d[2]) <= LINE_TOL:
            return "its side (a line)"
        if math.hypot(n[0], n[1]) <= LINE_TOL and math.hypot(d[0], d[1]) <= LINE_TOL:
            return "an end face"
    return None


# ---- fixed rules ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Rule:
    """Nodes (K, 2) from O's vertical (face frame) and weights (K,), summing to the area;
    ``offsets``: the nodes from the face's centroid."""
    nodes: np.ndarray
    weights: np.ndarray
    offsets: np.ndarray


def rule(face: Face, n: int = 12) -> Rule:
    """The fixed rule of order n: n x n Gauss–Legendre over a rectangle; over a disc n
    Gauss–Legendre radii (weight r) times 2n + 2 equally spaced angles."""
    x, w = np.polynomial.legendre.leggauss(n)
    if face.kind == "rectangle":
        a, b = face.half
        X, Y = np.meshgrid(a * x, b * x, indexing="ij")
        W = np.outer(a * w, b * w)
        off = np.column_stack([X.ravel(), Y.ravel()])
        weights = W.ravel()
    else:
        R = face.half[0]
        r, wr = R * (x + 1) / 2, R * w / 2
        m = 2 * n + 2
        th = (np.arange(m) + 0.5) * 2 * math.pi / m
        off = np.column_stack([np.outer(r, np.cos(th)).ravel(), np.outer(r, np.sin(th)).ravel()])
        weights = np.outer(wr * r, np.full(m, 2 * math.pi / m)).ravel()
    nodes = off + np.asarray(face.centre)
    return Rule(nodes=nodes, weights=weights, offsets=off)


def pressure(face: Face, rl: Rule, N: float, cp=None, mode: str = "uniform") -> np.ndarray:
    """The pressure at the rule's nodes times their weights (summing to N)."""
    if mode == "uniform" or cp is None:
        return rl.weights * (N / face.area)
    Ix, Iy = face.second_moments
    dx, dy = cp[0] - face.centre[0], cp[1] - face.centre[1]
    p = N / face.area + N * (dx * rl.offsets[:, 0] / Ix + dy * rl.offsets[:, 1] / Iy)
    return rl.weights * p


def slip_wrench(rl: Rule, pw: np.ndarray, mu: float, twist) -> np.ndarray:
    """(F_x, F_y, T_z): the friction on the body over the face for the slip twist
    ``(v_x, v_y, w)`` at O (``pw``: pressure times weight at the nodes)."""
    vx, vy, w = twist
    ux = vx - w * rl.nodes[:, 1]
    uy = vy + w * rl.nodes[:, 0]
    speed = np.hypot(ux, uy)
    k = np.divide(-mu * pw, speed, out=np.zeros_like(speed), where=speed > 0)
    fx, fy = k * ux, k * uy
    return np.array([fx.sum(), fy.sum(), (rl.nodes[:, 0] * fy - rl.nodes[:, 1] * fx).sum()])


def dissipation(rl: Rule, pw: np.ndarray, mu: float, twist) -> float:
    """mu int p |v + w e_z x r| dA: the power friction takes at the twist (a norm)."""
    vx, vy, w = twist
    return float(mu * (pw * np.hypot(vx - w * rl.nodes[:, 1], vy + w * rl.nodes[:, 0])).sum())


# ---- the instant-centre rule ----------------------------------------------------------------
# With w != 0 the slip field is a rotation about the instant centre r0 = e_z x v / w, so the
# unit slip is sign(w) e_z x (r - r0)/|r - r0| and, p affine (p = P0 + k.(r - r0) from r0),
#
#   F = -mu sgn(w) e_z x G,  G = int p (r - r0)/|r - r0| dA
#   T = -mu sgn(w) H,        H = int p r.(r - r0)/|r - r0| dA
#   D = mu |w| E,            E = int p |r - r0| dA.
#
# In polar coordinates about r0 the radial integrals are polynomial and done exactly; what
# is left is one integral along the boundary.  Over a rectangle, edge by edge: the triangle
# (r0, V_i, V_i+1) parametrised r = r0 + t q(s), q(s) = V_i - r0 + s (V_i+1 - V_i), dA =
# t A2 ds dt (A2 = (V_i - r0) x (V_i+1 - r0), signed: the triangles of the edges r0 sees
# from behind subtract); the s-integrals in closed form (asinh and square roots: exact, no
# rule).  Over a disc, in the angle about r0 by a fixed rule of order n: the trapezoid
# rule with 4n angles from r0 - c's direction when r0 is inside (a periodic integrand),
# n-point Gauss–Legendre in phi with sin(theta - theta_c) = (R/delta) sin(phi) when r0 is
# outside (smooth at the two tangents).  Near the rim (RIM R < delta < R / RIM) the chord's
# square root nearly vanishes at one angle (inside: sqrt(R^2 - delta^2 sin^2) at theta =
# +-pi/2, its width sqrt(1 - delta^2/R^2)) and those rules lose their rate (7e-8 off
# adaptive quadrature within 1e-4 R inside, 2e-10 outside); there the sums over the angle
# are complete elliptic integrals, taken in closed form (:func:`_rim_integrals`).
def _polygon_integrals(face: Face, r0, P_c: float, k, n: int = 0) -> tuple:
    """G, H, E over a rectangle, edge by edge in closed form (n is not read).  Along an
    edge, q = tau e + eta nu (e the edge's unit direction, nu its left normal, eta = q.nu
    constant, tau from tau_1 to tau_1 + l, ds = d tau / l); the tau-integrals of 1/|q|,
    tau/|q|, tau^2/|q|, |q|, tau |q| are asinh and powers of |q|."""
    a, b = face.half
    cx, cy = face.centre
    V = np.array([[cx + a, cy - b], [cx + a, cy + b], [cx - a, cy + b], [cx - a, cy - b]])
    r0 = np.asarray(r0, dtype=float)
    P0 = P_c + k @ (r0 - np.asarray(face.centre))
    G, E = np.zeros(2), 0.0
    for i in range(4):
        A, B = V[i] - r0, V[(i + 1) % 4] - r0
        edge = B - A
        ell = math.hypot(*edge)
        e = edge / ell
        nu = np.array([-e[1], e[0]])
        eta = float(A @ nu)
        if eta == 0.0:
            continue                      # r0 on the edge's line: a flat triangle
        h = abs(eta)
        ke, kn = float(k @ e), float(k @ nu)

        def prim(tau):
            L = math.hypot(tau, eta)
            ash = math.asinh(tau / h)
            return (ash, L, (tau * L - eta * eta * ash) / 2,       # 1/|q|, tau/|q|, tau^2/|q|
                    (tau * L + eta * eta * ash) / 2, L ** 3 / 3)     # |q|, tau |q|
        lo, hi = prim(float(A @ e)), prim(float(A @ e) + ell)
        I0, I1, K2, J0, J1 = (y - x for x, y in zip(lo, hi))
        c2 = P0 / 2 + eta * kn / 3
        c3 = P0 / 3 + eta * kn / 4
        # the triangle's A2 = (V_i - r0) x (V_i+1 - r0) = -l eta, times ds = d tau / l
        G += -eta * (e * (c2 * I1 + ke / 3 * K2) + nu * eta * (c2 * I0 + ke / 3 * I1))
        E += -eta * (c3 * J0 + ke / 4 * J1)
    return G, float(r0 @ G) + E, E


def _elliptic_moments(kp2: float) -> dict:
    """The integrals over [0, pi/2] of cos^i sin^j Delta^p, Delta = sqrt(1 - k^2 sin^2),
    that a disc's moments about r0 near its rim take, from the complete elliptic integrals
    E(k) and K(k) (SciPy's, parameter m = k^2): each reduced to E and (1 - k^2) K by the
    recurrence (2m + 1) k^2 U_m+1 = 2m (1 + k^2) U_m - (2m - 1) U_m-1 of U_m = int
    sin^2m / Delta (U_0 = K, U_1 = (K - E)/k^2, from d/dtheta (sin^(2m-1) cos Delta)).  kp2
    = 1 - k^2, taken from a difference of the lengths (exact near the rim), where (1 - k^2)
    K -> 0 while K diverges; the keys: c2_3 is int cos^2 Delta^3, c4_m1 int cos^4 / Delta."""
    k2 = 1.0 - kp2
    E = float(special.ellipe(k2))
    L = 0.0 if kp2 == 0.0 else kp2 * float(special.ellipkm1(kp2))     # (1 - k^2) K(k)
    return {"c2_1": ((1 + k2) * E - L) / (3 * k2),
            "3": (2 * (kp2 + 1) * E - L) / 3,
            "c2_3": ((8 - 3 * kp2 - 2 * kp2 ** 2) * E + (kp2 - 4) * L) / (15 * k2),
            "c4_1": ((3 * kp2 ** 2 - 13 * kp2 + 8) * E + 2 * (3 * kp2 - 2) * L) / (15 * k2 ** 2),
            "s2_3": ((2 + 3 * kp2 - 8 * kp2 ** 2) * E + (4 * kp2 - 1) * L) / (15 * k2),
            "s2c2_1": (2 * (kp2 ** 2 - kp2 + 1) * E - (kp2 + 1) * L) / (15 * k2 ** 2),
            "c4_m1": (-2 * (2 * kp2 - 1) * E + (3 * kp2 - 1) * L) / (3 * k2 ** 2),
            "s2c4_m1": ((2 - 7 * kp2 - 3 * kp2 ** 2) * E + (9 * kp2 - 1) * L) / (15 * k2 ** 3)}


def _rim_integrals(R: float, delta: float, e_d, r0, P0: float, k) -> tuple:
    """G, H, E about r0 within RIM of a disc's rim (RIM R < delta < R / RIM), in closed
    form.  By the disc's symmetry about the line through c and r0 (e_d = (r0 - c)/delta,
    e_p = e_z x e_d): G = P0 A e_d + (Mdd e_d e_d^T + Mpp e_p e_p^T) k, E = P0 E0 + Bd e_d.k,
    with A = int e.e_d hi^2/2, Mdd, Mpp = int (e.e_d)^2, (e.e_p)^2 hi^3/3, E0 = int hi^3/3,
    Bd = int e.e_d hi^4/4 over the angle (lo = 0).  Inside, at the angle theta from e_d the
    four rays +-theta, pi -+ theta reach hi = R Delta -+ delta cos(theta) (k = delta/R);
    their sums leave even powers of cos and sin times R Delta.  Outside (k = R/delta), the
    rays at alpha from -e_d with sin(alpha) = k sin(phi) cross the disc over the chord
    delta cos(alpha) -+ R cos(phi), cos(alpha) = Delta(phi), d alpha = k cos(phi)/Delta
    d phi."""
    if delta < R:
        J = _elliptic_moments((R - delta) * (R + delta) / (R * R))
        A = -4 * delta * R * J["c2_1"]
        E0 = 4 * R ** 3 * J["3"] / 3 + 4 * delta ** 2 * R * J["c2_1"]
        Mdd = 4 * R ** 3 * J["c2_3"] / 3 + 4 * delta ** 2 * R * J["c4_1"]
        Mpp = 4 * R ** 3 * J["s2_3"] / 3 + 4 * delta ** 2 * R * J["s2c2_1"]
        Bd = -4 * delta * R ** 3 * J["c2_3"] - 4 * delta ** 3 * R * J["c4_1"]
    else:
        q = R / delta
        J = _elliptic_moments((delta - R) * (delta + R) / (delta * delta))
        A = -4 * R * R * J["c2_1"]
        E0 = 4 * q * R * (R * R * J["c4_m1"] + 3 * delta ** 2 * J["c2_1"]) / 3
        Mdd = 4 * q * R * (R * R * J["c4_1"] + 3 * delta ** 2 * J["c2_3"]) / 3
        Mpp = 4 * q ** 3 * R * (R * R * J["s2c4_m1"] + 3 * delta ** 2 * J["s2c2_1"]) / 3
        Bd = -4 * R * R * (R * R * J["c4_1"] + delta ** 2 * J["c2_3"])
    e_p = np.array([-e_d[1], e_d[0]])
    G = P0 * A * e_d + Mdd * (k @ e_d) * e_d + Mpp * (k @ e_p) * e_p
    E = P0 * E0 + Bd * (k @ e_d)
    return G, float(r0 @ G) + E, E


def _disc_integrals(face: Face, r0, P_c: float, k, n: int) -> tuple:
    R = face.half[0]
    c = np.asarray(face.centre)
    r0 = np.asarray(r0, dtype=float)
    d = r0 - c
    delta = math.hypot(*d)
    P0 = P_c + k @ d
    if RIM * R < delta < R / RIM:
        return _rim_integrals(R, delta, d / delta, r0, P0, k)
    if delta < R:
        m = 4 * n                         # from r0 - c's direction (crt_face.h's quarters)
        th = math.atan2(d[1], d[0]) + np.arange(m) * 2 * math.pi / m
        wt = np.full(m, 2 * math.pi / m)
        e = np.column_stack([np.cos(th), np.sin(th)])
        de = e @ d
        lo = np.zeros(m)
        hi = -de + np.sqrt(R * R - delta * delta + de * de)
    else:
        x, w = np.polynomial.legendre.leggauss(n)
        phi, wphi = x * math.pi / 2, w * math.pi / 2
        th_c = math.atan2(-d[1], -d[0])
        sn = (R / delta) * np.sin(phi)
        th = th_c + np.arcsin(sn)
        wt = wphi * (R / delta) * np.cos(phi) / np.sqrt(1 - sn * sn)
        e = np.column_stack([np.cos(th), np.sin(th)])
        de = e @ d
        root = R * np.cos(phi)
        lo, hi = -de - root, -de + root
    ke = e @ k

    def moment(j):                       # int_lo^hi rho^j (P0 + rho k.e) d rho, per angle
        return (P0 * (hi ** (j + 1) - lo ** (j + 1)) / (j + 1)
                + ke * (hi ** (j + 2) - lo ** (j + 2)) / (j + 2))
    m1, m2 = moment(1), moment(2)
    G = (wt[:, None] * e * m1[:, None]).sum(axis=0)
    H = (wt * ((e @ r0) * m1 + m2)).sum()
    E = (wt * m2).sum()
    return G, H, E


def pressure_slope(face: Face, N: float, cp=None, mode: str = "uniform") -> tuple:
    """``(P_c, k)``: the pressure at the face's centroid and its gradient (N/A and 0 for
    uniform pressure; linear: the affine p with its centroid at cp)."""
    if mode == "uniform" or cp is None:
        return N / face.area, np.zeros(2)
    Ix, Iy = face.second_moments
    return N / face.area, N * np.array([(cp[0] - face.centre[0]) / Ix,
                                        (cp[1] - face.centre[1]) / Iy])


def centre_wrench(face: Face, N: float, cp, mode: str, mu: float, twist,
                  n: int = ANGLE_ORDER) -> tuple[np.ndarray, float]:
    """``((F_x, F_y, T_z), D)`` by the instant-centre rule of order n (see above)."""
    vx, vy, w = (float(c) for c in twist)
    P_c, k = pressure_slope(face, N, cp, mode)
    speed = math.hypot(vx, vy)
    if abs(w) * face.size <= 1e-12 * speed:           # a translation
        if speed == 0.0:
            return np.zeros(3), 0.0
        centroid = np.asarray(face.centre) + (np.zeros(2) if mode == "uniform" or cp is None
                                              else np.asarray(cp) - face.centre)
        ux, uy = vx / speed, vy / speed
        F = -mu * N * np.array([ux, uy])
        return (np.array([F[0], F[1], centroid[0] * F[1] - centroid[1] * F[0]]),
                mu * N * speed)
    r0 = np.array([-vy / w, vx / w])
    if math.hypot(*(r0 - np.asarray(face.centre))) > FAR * face.size:
        # far from the face the slip field is analytic over it (a product rule converges
        # fast), and the triangles about r0 would cancel (their areas grow as |r0|)
        rl = rule(face, n)
        pw = pressure(face, rl, N, cp, mode)
        return slip_wrench(rl, pw, mu, twist), dissipation(rl, pw, mu, twist)
    integrals = _polygon_integrals if face.kind == "rectangle" else _disc_integrals
    G, H, E = integrals(face, r0, P_c, k, n)
    sg = 1.0 if w > 0 else -1.0
    return np.array([mu * sg * G[1], -mu * sg * G[0], -mu * sg * H]), mu * abs(w) * E


def gauge(friction, wrench, size: float, start=None) -> tuple[float, np.ndarray]:
    """``(gamma, xi*)``: the gauge of the limit surface at ``wrench = (F_x, F_y, T_z)``,
    ``max W.xi / D(xi)``, and the unit twist that attains it, in the scaled components
    ``(v_x, v_y, size w)``.  ``friction(twist) -> (slip wrench, D)`` (for instance
    :func:`centre_wrench` with the static coefficient).  Found as ``1 / min D`` over the
    plane ``W.xi = 1``, a convex problem in two coordinates (D is a norm, its gradient the
    slip wrench's opposite), from ``start`` or from the wrench's own direction."""
    scale = np.array([1.0, 1.0, 1.0 / size])            # scaled twist -> twist
    W = np.asarray(wrench, dtype=float) * scale          # W.twist = W_scaled.xi
    norm = np.linalg.norm(W)
    if norm == 0.0:
        return 0.0, np.array([1.0, 0.0, 0.0])
    e0 = W / norm
    helper = np.eye(3)[int(np.argmin(np.abs(e0)))]
    e1 = np.cross(e0, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e0, e1)
    basis = np.vstack([e1, e2])

    def D(c):
        _, d = friction((e0 / norm + c @ basis) * scale)
        return d

    def grad(c):
        f, _ = friction((e0 / norm + c @ basis) * scale)
        return basis @ (-f * scale)

    c0 = np.zeros(2)
    if start is not None:
        s = np.asarray(start, dtype=float)
        if s @ e0 > 0:
            c0 = basis @ (s / (s @ e0) / norm)
    res = minimize(D, c0, jac=grad, method="BFGS", options={"gtol": 1e-14, "maxiter": 400})
    xi = e0 / norm + res.x @ basis
    return 1.0 / float(res.fun), xi / np.linalg.norm(xi)


@dataclass(frozen=True)
class Friction:
    """The friction of one face under one pressure: ``self(twist) -> ((F_x, F_y, T_z),
    D)`` by the instant-centre rule, or by the product rule with ``product`` set."""
    face: Face
    N: float
    cp: tuple | None = None
    mode: str = "uniform"
    mu: float = 1.0
    n: int = ANGLE_ORDER
    product: bool = False

    def __call__(self, twist):
        if self.product:
            rl = rule(self.face, self.n)
            pw = pressure(self.face, rl, self.N, self.cp, self.mode)
            return slip_wrench(rl, pw, self.mu, twist), dissipation(rl, pw, self.mu, twist)
        return centre_wrench(self.face, self.N, self.cp, self.mode, self.mu, twist, self.n)
