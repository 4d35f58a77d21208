"""What the outputs show besides the states: the positions of O, P and S, the kinetic
energy of the carrier and of the point, and the energy balance of a run.  A scene that is
not one point (several points, rotors, or none) has the same quantities per body, and
each drive's work: :mod:`derive.runtime.bodies` gives them (below, "the point" is then
each point, and the rotors' drives join the points').

Positions (fixed axes).  ``O_aO = O_aC - A m/(m+M) OP`` (E1.8a), ``O_aP = O_aO + A OP``.

Kinetic energy.  From its definition for the two bodies, with ``V = A^T V_C`` (body axes),
``u = V_r + omega x OP`` (the absolute rate of OP, body axes), ``nu = m/(m+M)`` and
the paper's reduced mass ``mu = mM/(m+M)`` (``Scene.reduced_mass``):
``V_O = V - nu u`` and ``V_P = V + (1 - nu) u``, so

    T_carrier = 1/2 M |V_O|^2 + 1/2 (omega, J_O omega)      (J_O = diag(J_x, J_y, J_z))
    T_point   = 1/2 m |V_P|^2
    T = T_carrier + T_point = 1/2 (m+M) |V_C|^2 + 1/2 (omega, J_O omega) + 1/2 mu |u|^2

(the cross terms cancel: ``-M nu + m (1 - nu) = 0``; ``M nu^2 + m (1 - nu)^2 = mu``).  The
potential energy is ``(m+M) g Z_C``.  Without the attitude (model ``vertical``) only the
total ``T`` is known: ``A^T V_C`` needs the heading.

Energy balance.  The point is driven along its law by internal forces, which do work:
the force of the carrier on P is ``F = m (a_P + g e_Z)`` and the pair does the work
``F . (A V_r)`` per unit time (P moves relative to the body point under it).  In flight
``a_C = -g e_Z`` and ``a_P = a_C + (1 - nu) A (V_r' + 2 omega x V_r + omega' x OP +
omega x (omega x OP))``, so the drive's power is

    P_drive = mu (V_r' + 2 omega x V_r + omega' x OP + omega x (omega x OP), V_r)

with ``omega'`` from E1.7 solved here with NumPy (``J omega' = -omega x K - mu (V_r x
(omega x OP) + OP x (omega x V_r)) - mu OP x V_r'``).  At an impact the energy jumps by
``I (v_n- + v_n+)/2`` (the impulse at S, whose normal velocity is v_n) plus the drive's
impulsive work ``m (V_P+ - V_P-, A V_r)``; with the point at rest in the body the latter
vanishes and ``e = 1`` conserves the energy.  In persistent contact the reaction does no
work (S does not move normally) and the drive's power gains the term ``m N/(m+M) (n,
V_r)``, with ``omega'`` and N from the runtime's contact equations; for the models
without omega in their state (translational, planar) the change over a contact phase is
reported as it is, not split.

On a rough plane (the ``rough`` model) the reaction R at S has a tangential part.  An
impact changes the energy by the work of its normal impulse ``E_n = int v_Z dp`` and of
its tangential impulse ``E_t = int (v_t, dP_t) <= 0`` (Darboux-Keller, the runtime's
numbers) plus the drive's impulsive work; in contact the drive's power has
``m/(m+M) (A^T R, V_r)`` for the normal term, and friction does the work ``(R, v_S)``
(``-mu_f N |v_t|`` while sliding, 0 while sticking), with R, omega' and v_S from the
runtime's contact equations (``Session.rough_rows``).  ``work_of_friction``, the sum over
impacts and contact, is never positive.  Below ``v_freeze`` (``Session.slip_band``) the
runtime's friction keeps the direction the slip had at the start of the step, and the
rows there are evaluated along it, each such step integrated apart
(:func:`frozen_sliding`); along the slip a dying 2-D slip had left 1.3e-7 J in the
README's ``two.toml``.  The other events' jumps (``at_other_events``: a push, a stick's
impulse at S that removes what is left of the slip) carry the drives' impulsive work,
``drive_work_at_other_events``; the rest is the impulses' own work.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import abi, layout
from . import bodies as bm
from . import choice
from .driver import options, simulate
from .events import event_rows, phases

G = layout.GENERAL


@dataclass
class Motion:
    """Arrays along the rows of a :class:`~derive.runtime.driver.Result`."""
    t: np.ndarray
    omega: np.ndarray                 # (N, 3) body axes
    r: np.ndarray | None              # OP, body axes (None: not one point, see bodies)
    v_r: np.ndarray | None            # V_r, body axes
    a_r: np.ndarray | None            # V_r', body axes
    A: np.ndarray | None              # (N, 3, 3) a_ij, or None without the attitude
    r_C: np.ndarray | None            # (N, 3) fixed axes (None: not known)
    v_C: np.ndarray | None
    r_O: np.ndarray | None
    r_P: np.ndarray | None
    T_carrier: np.ndarray | None      # None without the attitude
    T_point: np.ndarray | None
    T: np.ndarray | None              # total kinetic energy (None: V_C not known)
    U: np.ndarray | None              # potential energy (m+M) g Z_C
    h: np.ndarray | None              # height of S
    # every body: the bodies' motion (None for one point, whose r, v_r, a_r are above),
    # each point's position (n_points, N, 3) fixed axes, each point's kinetic energy
    # (n_points, N) and each rotor's spin beyond its locked share (n_rotors, N)
    bodies: bm.Bodies | None = None
    r_points: np.ndarray | None = None
    T_points: np.ndarray | None = None
    T_rotors: np.ndarray | None = None

    @property
    def E(self) -> np.ndarray | None:
        return None if self.T is None or self.U is None else self.T + self.U


def drive_names(scene) -> tuple:
    """The drives whose work the balance splits: each point's, then each rotor's."""
    return tuple(body.name for body in (*scene.points, *scene.rotors))


def _centre(result):
    """(r_C, v_C) in fixed axes along the rows, or (None, None)."""
    s = result.scene
    if result.general is not None:
        return result.general[:, G.com], result.general[:, G.com_velocity]
    dt = result.t - s.t0
    if result.model == "vertical":
        n = len(dt)
        Z, VZ = result.model_q[:, layout.VERTICAL.Z], result.model_q[:, layout.VERTICAL.Zd]
    elif not s.contact_possible:            # free flight: C moves on its parabola (E1.2)
        n = len(dt)
        Z = s.com[2] + s.com_velocity[2] * dt - 0.5 * s.g * dt ** 2
        VZ = s.com_velocity[2] - s.g * dt
    else:
        return None, None
    X = s.com[0] + s.com_velocity[0] * dt
    Y = s.com[1] + s.com_velocity[1] * dt
    V = np.column_stack([np.full(n, s.com_velocity[0]), np.full(n, s.com_velocity[1]), VZ])
    return np.column_stack([X, Y, Z]), V


PICTURE_SAMPLES = 1500


def for_pictures(result):
    """The run to draw: the same run sampled on a uniform grid of about
    ``PICTURE_SAMPLES`` rows from the dense output when its own rows are coarser (the
    ends of adaptive steps can be a tenth of a second apart: a parabola would be drawn
    as a polygon).  The steps, events and numbers are the run's own: only where they
    are read differs; it costs one more run of the C (milliseconds)."""
    s = result.scene
    fine = s.duration / PICTURE_SAMPLES
    if (0 < s.output_dt <= fine) or len(result.t) >= PICTURE_SAMPLES \
            or result.status != "done":
        return result
    again = rerun(result, fine)
    return again if again is not None and _same_run(result, again) else result


def rerun(result, output_dt: float):
    """The run of ``result`` again with rows every ``output_dt`` (None when it cannot be
    repeated here: a closed loop's controller is not re-run).  A pushed run repeats with
    its pushes (``Result.rerun``); a plain run is :func:`~derive.runtime.driver.simulate`
    of its scene.  A pushed run redrawn by the plain run had been drawn unpushed."""
    if result.rerun is not None:
        return result.rerun(output_dt)
    s = result.scene
    if result.loop is not None or s.disturbance is not None or s.control is not None:
        return None
    return simulate(replace(result.scene, output_dt=output_dt))


def motion(result) -> Motion:
    s = result.scene
    if not s.one_point:
        return _bodies_motion(result)
    t = result.t
    jets = s.law.jets(t)
    r, v_r, a_r = (jets[list(rows)].T for rows in (layout.JET_R, layout.JET_V, layout.JET_A))
    omega = np.asarray(result.omega, dtype=float)
    A = result.general[:, G.A].reshape(-1, 3, 3) if result.general is not None else None
    r_C, v_C = _centre(result)
    nu, J0 = s.nu, np.asarray(s.J, dtype=float)
    u = v_r + np.cross(omega, r)
    rot = 0.5 * np.einsum("ij,j,ij->i", omega, J0, omega)
    r_O = r_P = T_c = T_p = T = U = None
    if v_C is not None:
        T = 0.5 * (s.m + s.M) * np.einsum("ij,ij->i", v_C, v_C) + rot \
            + 0.5 * s.reduced_mass * np.einsum("ij,ij->i", u, u)
        U = (s.m + s.M) * s.g * r_C[:, 2]
    if A is not None and r_C is not None:
        Ar = np.einsum("nij,nj->ni", A, r)
        r_O = r_C - nu * Ar
        r_P = r_O + Ar
        V = np.einsum("nji,nj->ni", A, v_C)          # A^T V_C
        V_O, V_P = V - nu * u, V + (1.0 - nu) * u
        T_c = 0.5 * s.M * np.einsum("ij,ij->i", V_O, V_O) + rot
        T_p = 0.5 * s.m * np.einsum("ij,ij->i", V_P, V_P)
    h = result.height if s.size else None
    return Motion(t=t, omega=omega, r=r, v_r=v_r, a_r=a_r, A=A, r_C=r_C, v_C=v_C, r_O=r_O,
                  r_P=r_P, T_carrier=T_c, T_point=T_p, T=T, U=U, h=h,
                  r_points=None if r_P is None else r_P[None],
                  T_points=None if T_p is None else T_p[None],
                  T_rotors=None if T_p is None else np.zeros((0, len(t))))


def _bodies_motion(result) -> Motion:
    """:func:`motion` of a scene that is not one point (a moments model: the general
    state), per body (:mod:`derive.runtime.bodies`)."""
    s, t = result.scene, result.t
    b = bm.along(s, t)
    omega = np.asarray(result.omega, dtype=float)
    A = result.general[:, G.A].reshape(-1, 3, 3)
    r_C, v_C = _centre(result)
    T_c, T_p, T_r = bm.energies(s, b, omega, A, v_C)
    r_O, r_P = bm.positions(s, b, r_C, A)
    return Motion(t=t, omega=omega, r=None, v_r=None, a_r=None, A=A, r_C=r_C, v_C=v_C,
                  r_O=r_O, r_P=None, T_carrier=T_c, T_point=None,
                  T=T_c + T_p.sum(axis=0) + T_r.sum(axis=0),
                  U=(s.m + s.M) * s.g * r_C[:, 2], h=result.height if s.size else None,
                  bodies=b, r_points=r_P, T_points=T_p, T_rotors=T_r)


def point_velocity_body(scene, mo: Motion) -> np.ndarray | None:
    """V_P in body axes (needs the attitude)."""
    if mo.A is None:
        return None
    V = np.einsum("nji,nj->ni", mo.A, mo.v_C)
    return V + (1.0 - scene.nu) * (mo.v_r + np.cross(mo.omega, mo.r))


def omega_rate_in_flight(scene, mo: Motion) -> np.ndarray:
    """omega' along the rows from E1.7 (flight), solved with NumPy: independent of the C."""
    r, v, acc, w = mo.r, mo.v_r, mo.a_r, mo.omega
    mu = scene.reduced_mass
    J0 = np.asarray(scene.J, dtype=float)
    rr = np.einsum("ij,ij->i", r, r)
    J = np.zeros((len(r), 3, 3))
    J[:, [0, 1, 2], [0, 1, 2]] = J0
    J += mu * (rr[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])
    K = np.einsum("nij,nj->ni", J, w) + mu * np.cross(r, v)
    rhs = -np.cross(w, K) - mu * (np.cross(v, np.cross(w, r)) + np.cross(r, np.cross(w, v))) \
        - mu * np.cross(r, acc)
    return np.linalg.solve(J, rhs[:, :, None])[:, :, 0]


def drive_power_in_flight(scene, mo: Motion) -> np.ndarray:
    """The power of the internal forces that drive P along its law (valid in flight)."""
    r, v, acc, w = mo.r, mo.v_r, mo.a_r, mo.omega
    wd = omega_rate_in_flight(scene, mo)
    rel = acc + 2.0 * np.cross(w, v) + np.cross(wd, r) + np.cross(w, np.cross(w, r))
    return scene.reduced_mass * np.einsum("ij,ij->i", rel, v)


_OMEGA_RATE = {"general": (G.omega, G.n), "rough": (G.omega, G.n),
               "vertical": (layout.VERTICAL.omega, layout.VERTICAL.n),
               "moments": (G.omega, G.n), "moments_rough": (G.omega, G.n)}


def drive_powers_in_flight(scene, mo: Motion) -> np.ndarray:
    """Each drive's power in flight, (drives, rows) (:func:`drive_names`)."""
    if mo.bodies is None:
        return drive_power_in_flight(scene, mo)[None]
    wd = bm.omega_rate_in_flight(scene, mo.bodies, mo.omega)
    return bm.drive_powers(scene, mo.bodies, mo.omega, wd)


def drive_powers_in_contact(result, mo: Motion, a: int, b: int) -> np.ndarray | None:
    """Each drive's power on rows [a, b) of a smooth contact phase (as
    :func:`drive_power_in_contact`), (drives, rows); None for models without omega."""
    if mo.bodies is None or result.model not in _OMEGA_RATE:
        p = drive_power_in_contact(result, mo, a, b)
        return None if p is None else p[None]
    q = result.model_q[a:b]
    dq, N, _ = result.session.contact_rows(result.t[a:b], q)
    return bm.drive_powers(result.scene, mo.bodies.rows(a, b), mo.omega[a:b], dq[:, G.omega],
                           N[:, None] * q[:, G.n])


def drive_power_in_contact(result, mo: Motion, a: int, b: int) -> np.ndarray | None:
    """The drive's power on rows [a, b) of a contact phase: as in flight, with omega' and
    the reaction N from the runtime's contact equations (``Session.contact``); the force
    of the carrier on P gains ``m N/(m+M) n``.  None for models without omega in the
    state."""
    if result.model not in _OMEGA_RATE:
        return None
    s = result.scene
    w_at, n_at = _OMEGA_RATE[result.model]
    q = result.model_q[a:b]
    dq, N, _ = result.session.contact_rows(result.t[a:b], q)
    wd = dq[:, w_at]
    r, v, w = mo.r[a:b], mo.v_r[a:b], mo.omega[a:b]
    rel = mo.a_r[a:b] + 2.0 * np.cross(w, v) + np.cross(wd, r) + np.cross(w, np.cross(w, r))
    F = s.reduced_mass * rel + (s.m / (s.m + s.M)) * N[:, None] * q[:, n_at]
    return np.einsum("ij,ij->i", F, v)


def sliding_directions(result, a: int, b: int) -> np.ndarray:
    """The friction's direction (its opposite) on rows [a, b) of one contact phase: the
    slip's where it is resolved, else the nearest resolved one of the phase (below
    sqrt(rtol) of the speeds the runtime slides along the slip's last direction as it
    stops, and along its first as it starts: crt_friction.h, v_freeze; a slip located at
    its stop can have passed 0 by the event's tolerance and point backwards); zero rows
    where there is none (the runtime's own reference then: see crt_eval_rough_rows)."""
    scale = float(np.max(np.abs(result.model_q[a:b, G.com_velocity]))) + 1.0
    return resolved_directions(result.slip[a:b], scale, result.scene.rtol)


def resolved_directions(v: np.ndarray, scale: float, rtol: float) -> np.ndarray:
    """Rows of v (n x k) made unit where |v| > 10 sqrt(rtol) scale, elsewhere the
    nearest such row's (see :func:`sliding_directions`); zero rows where there is none."""
    speed = np.hypot(v[:, 0], v[:, 1]) if v.shape[1] == 2 else np.abs(v[:, 0])
    good = speed > 10.0 * np.sqrt(rtol) * scale
    out = np.zeros(v.shape)
    if not good.any():
        return out
    idx, rows = np.flatnonzero(good), np.arange(len(v))
    nearest = idx[np.clip(np.searchsorted(idx, rows), 0, len(idx) - 1)]
    before = idx[np.clip(np.searchsorted(idx, rows) - 1, 0, len(idx) - 1)]
    pick = np.where(np.abs(before - rows) < np.abs(nearest - rows), before, nearest)
    out[:] = v[pick] / speed[pick][:, None]
    return out


def rough_contact_power(result, mo: Motion, a: int, b: int, directions=None) -> tuple[
        np.ndarray, np.ndarray]:
    """The rough model on rows [a, b) of a contact phase: each drive's power (as in
    :func:`drive_power_in_contact`, the force of the carrier on P gaining m/(m+M) A^T R;
    (drives, rows)) and the power of friction (R, v_S), with omega', R and v_S from the
    runtime's sliding or sticking equations in each row's mode, sliding along
    ``directions`` (rows of 2; None: :func:`sliding_directions`)."""
    s = result.scene
    if directions is None:
        directions = sliding_directions(result, a, b)
    q = result.model_q[a:b]
    A = q[:, G.A].reshape(-1, 3, 3)
    if result.couples_on:        # the couple's power (T, Omega) joins the friction's
        Om = np.einsum("nij,nj->ni", A, q[:, G.omega])
        scale = (float(np.max(np.abs(q[:, G.com_velocity]))) + 1.0) / choice.length_scale(s)
        cdir = np.c_[resolved_directions(Om[:, 2:], scale, s.rtol),
                     resolved_directions(Om[:, :2], scale, s.rtol)]
        dq, w, u = result.session.wrench_rows(result.t[a:b], q, result.modes[a:b],
                                              directions,
                                              result.couples[a:b], cdir)
        R, v_S = w[:, :3], u[:, :3]
        friction = np.einsum("ij,ij->i", w, u)
    else:
        dq, R, v_S = result.session.rough_rows(result.t[a:b], q, result.modes[a:b],
                                               directions)
        friction = np.einsum("ij,ij->i", R, v_S)
    wd = dq[:, G.omega]
    if mo.bodies is not None:
        return bm.drive_powers(s, mo.bodies.rows(a, b), mo.omega[a:b], wd,
                               np.einsum("nij,ni->nj", A, R)), friction
    r, v, w = mo.r[a:b], mo.v_r[a:b], mo.omega[a:b]
    rel = mo.a_r[a:b] + 2.0 * np.cross(w, v) + np.cross(wd, r) + np.cross(w, np.cross(w, r))
    F = s.reduced_mass * rel + (s.m / (s.m + s.M)) * np.einsum("nij,ni->nj", A, R)
    return np.einsum("ij,ij->i", F, v)[None], friction


def integrate(t: np.ndarray, f: np.ndarray, points: int = 6) -> float:
    """The integral of samples ``f(t)`` (non-decreasing ``t``, any spacing): each interval by
    the polynomial through the ``points`` nearest samples (order ``points``; the rows of
    an adaptive run are far apart, so the order matters); two samples: the trapezoid."""
    if len(t) > 1 and not np.all(t[1:] > t[:-1]):     # rows of one instant (an event at
        keep = np.concatenate([[True], t[1:] > t[:-1]])  # the start): no interval
        t, f = t[keep], f[keep]
    n = len(t)
    if n < 2:
        return 0.0
    k = min(points, n)
    i = np.arange(n - 1)
    first = np.clip(i - (k // 2 - 1), 0, n - k)
    nodes = first[:, None] + np.arange(k)[None, :]
    h = t[i + 1] - t[i]
    tau = (t[nodes] - t[i][:, None]) / h[:, None]          # (n-1, k), the interval is [0, 1]
    V = tau[:, :, None] ** np.arange(k)[None, None, :]       # rows: samples, cols: powers
    moments = np.broadcast_to(1.0 / np.arange(1, k + 1), (n - 1, k))
    weights = np.linalg.solve(np.transpose(V, (0, 2, 1)), moments[:, :, None])[:, :, 0]
    return float(np.sum(h * np.einsum("ij,ij->i", weights, f[nodes])))


QUADRATURE_POINTS = 6      # the order of integrate's rule
ROWS_PER_SCALE = 64        # balance rows per time scale of the motion (law and spin)
MAX_BALANCE_ROWS = 200_000
MAX_PHASE_RUNS = 2000      # short phases resampled one by one, at most
TURNED = 1e-6              # a held direction this far from the slip's: frozen_sliding
_ROUGH_CONTACT = (abi.MODE["sliding"], abi.MODE["sticking"])   # the rough model's contact


def _same_run(a, b) -> bool:
    """Two runs of one scene with the same status and events (only their rows differ)."""
    if a.status != b.status or len(a.event_rows) != len(b.event_rows):
        return False
    if not len(a.event_rows):
        return True
    scale = max(abs(a.scene.t0) + a.scene.duration, 1.0)
    return bool(np.max(np.abs(a.event_rows[:, 0] - b.event_rows[:, 0])) <= 1e-12 * scale)


def _knots(scene):
    """A table law's knots (run time for the first period), or None."""
    knots = getattr(scene.runtime_law, "knots", None)
    return None if knots is None or len(knots) < 3 else np.asarray(knots, dtype=float)


def _on_grid(scene, knots) -> bool:
    """Equally spaced knots, one of them at t0 (mod the period): a grid from t0 with a
    whole number of rows per interval has rows on every knot."""
    gaps = np.diff(knots)
    h = float(gaps.min())
    offset = (scene.t0 - knots[0]) / h
    return bool(gaps.max() - h <= 1e-9 * h and abs(offset - round(offset)) <= 1e-9)


def _integrate_pieces(scene, t: np.ndarray, f: np.ndarray) -> float:
    """:func:`integrate`, stopped at every row on a knot of a table law (the power has
    a kink there, which a polynomial across it would smooth)."""
    knots = _knots(scene)
    if knots is None or len(t) < 3:
        return integrate(t, f)
    if getattr(scene.runtime_law, "periodic", False):
        period = knots[-1] - knots[0]
        first = int(np.floor((t[0] - knots[0]) / period))
        last = int(np.ceil((t[-1] - knots[0]) / period))
        times = (knots[:-1][None, :] + period * np.arange(first, last + 1)[:, None]).ravel()
    else:
        times = knots
    k = np.clip(np.searchsorted(times, t), 1, len(times) - 1)
    gap = np.minimum(np.abs(t - times[k - 1]), np.abs(t - times[k]))  # to the nearest knot
    on = np.flatnonzero(gap <= 1e-9 * float(np.min(np.diff(knots))))
    cuts = [0] + [int(i) for i in on if 0 < i < len(t) - 1] + [len(t) - 1]
    return sum(integrate(t[a:b + 1], f[a:b + 1]) for a, b in zip(cuts[:-1], cuts[1:]))


def for_balance(result, mo: Motion):
    """The run and its motion on rows dense enough for the balance's quadrature: about
    ``ROWS_PER_SCALE`` rows per time scale of the point's law or of the spin, whichever is
    shorter (at most ``MAX_BALANCE_ROWS``).  Rows an adaptive step apart (a tenth of a
    second on the built-in scene) or a coarse ``output_dt`` would leave the quadrature's
    error, not the run's, in the residual.  One more run of the C with ``output_dt`` set:
    the steps and events are the run's own (checked); only where they are read differs."""
    s = result.scene
    spin = float(np.max(np.linalg.norm(mo.omega, axis=1))) if len(mo.omega) else 0.0
    scale = min(s.law_summary.time_scale, 1.0 / spin if spin > 0 else np.inf, s.duration)
    knots = _knots(s)
    dt = max(scale / ROWS_PER_SCALE, s.duration / MAX_BALANCE_ROWS)
    if knots is not None:
        # a table's acceleration has a kink at every knot, and so has the drive's power:
        # rows on the knots (equal spacing: a whole number of rows per interval, the
        # grid from t0 on a knot) let the quadrature stop there (_integrate_pieces);
        # otherwise rows much closer than the knots bound the error of a rule across one
        gaps = np.diff(knots)
        per = max(int(np.ceil(gaps.min() / dt)), 1)
        dt = float(gaps.min()) / (per if _on_grid(s, knots) else 4 * per)
        dt = max(dt, s.duration / MAX_BALANCE_ROWS)
    steps = np.diff(result.t)
    if len(steps) == 0 or float(np.max(steps)) <= dt * (1 + 1e-9):
        return result, mo
    fine = rerun(result, dt)
    if fine is None or not _same_run(result, fine):
        return result, mo
    return fine, motion(fine)


def _resampled(result, a: int, b: int):
    """The rows [a, b) of a phase with ``ROWS_PER_SCALE`` more inside it: one more run of
    the C from row a's state to row b-1's time (the same integrator and settings), its
    rows strictly inside the phase and before any event of its own.  None when that run
    meets an event before the phase's end (its rows would not be the phase's)."""
    s = result.scene
    t0, t1 = float(result.t[a]), float(result.t[b - 1])
    span = t1 - t0
    if not span > 0.0:
        return None
    opt = options(s, result.model)
    o = abi.OPT
    opt[o["output_dt"]] = span / (ROWS_PER_SCALE + 1)
    opt[o["time_scale"]] = span
    opt[o["hmax"]] = min(opt[o["hmax"]], span / 4.0)
    opt[o["max_events"]] = 1
    prm = choice.parameters(s, result.start.constants)
    mode = int(result.modes[a]) if result.rough else abi.MODE["flight"]
    if mode in _ROUGH_CONTACT:       # a rough contact phase: resumed in its mode
        v = result.slip[a] if np.hypot(*result.slip[a]) > 0 else result.slip[b - 1]
        raw = result.session.run_in_contact(t0, span, result.model_q[a], opt, prm, mode,
                                            v if np.hypot(*v) > 0 else (1.0, 0.0))
    else:
        raw = result.session.run(t0, span, result.model_q[a], opt, prm)
    eps = 1e-9 * max(abs(t1), 1.0)
    if len(raw.events) and raw.events[0, 0] < t1 - eps:
        return None
    inside = (raw.t > t0 + eps) & (raw.t < t1 - eps) & (raw.kinds == abi.ROW_KIND["step"])
    t = np.concatenate([[t0], raw.t[inside], [t1]])
    q = np.concatenate([result.model_q[a:a + 1], raw.q[inside], result.model_q[b - 1:b]])
    sub = replace(result, t=t, model_q=q, row_kind=np.zeros(len(t), dtype=np.intc),
                  event_rows=np.zeros((0, raw.events.shape[1])), rates=None)
    if mode in _ROUGH_CONTACT:
        sub.__dict__["modes"] = np.full(len(t), mode)       # (no events to read it from)
        sub.__dict__["couples"] = np.full(len(t), int(result.couples[a]))
    return sub


def step_rows(result):
    """The run with a row at the end of every step (its own when ``output_dt`` is 0,
    else the run again with it 0; None when it cannot be repeated or differs)."""
    if result.scene.output_dt <= 0:
        return result
    again = rerun(result, 0.0)
    return again if again is not None and _same_run(result, again) else None


def frozen_sliding(result, steps, a: int, b: int, budget: list):
    """A sliding phase [a, b) on the rows where the runtime's friction kept its reference:
    below ``v_freeze`` (Session.slip_band, set as the mode began) the runtime slides along
    the direction the slip had at the start of the step (crt_follow_dir), which turns
    where the slip does not stay on one line (a 2-D slip dying out at the end of
    accumulating impacts: the friction, and through omega' the drives' power, differs
    from those along the slip itself, 3.1 W against 1.2 W on README's two.toml).  Rows:
    the phase's, its steps' ends (``steps``: :func:`step_rows`; twice where a step that
    reaches v_freeze begins or ends, with the direction of the step before and of the
    next: the power jumps there) and, in a short phase, :func:`_resampled`'s rows in the
    steps that stay above v_freeze (while ``budget`` lasts).  Returns (the rows as a
    Result, their directions, pieces [i, j) to integrate apart), or None where no row is
    frozen, the held directions are the slip's (a slip on one line) or nothing knows the
    steps."""
    if not result.rough or result.couples_on or steps is None \
            or result.modes[a] != abi.MODE["sliding"]:
        return None
    band = result.session.slip_band(result.t[a], result.model_q[a])
    if not np.any(np.hypot(*result.slip[a:b].T) <= band["freeze"]):
        return None
    t0, t1 = float(result.t[a]), float(result.t[b - 1])
    eps = 1e-12 * max(abs(t1), 1.0)
    # the steps' rows inside (t0, t1), found by bisection in the rows' times (in order):
    # a mask over every row of the run, for each of a chatter's 100,000 phases, was
    # quadratic
    lo = int(np.searchsorted(steps.t, t0 + eps, side="right"))
    hi = max(int(np.searchsorted(steps.t, t1 - eps, side="left")), lo)
    inside = lo + np.flatnonzero(steps.row_kind[lo:hi] == abi.ROW_KIND["step"])
    starts = np.concatenate([[t0], steps.t[inside]])         # the steps' starts
    start_slip = np.concatenate([result.slip[a:a + 1], steps.slip[inside]])
    armed = np.hypot(*start_slip.T) > band["arm"]
    end_slip = np.concatenate([steps.slip[inside], result.slip[b - 1:b]])
    free = (np.hypot(*start_slip.T) > band["freeze"]) & (np.hypot(*end_slip.T) > band["freeze"])
    t_rows, q_rows = [result.t[a:b]], [result.model_q[a:b]]
    sub = None
    if b - a < ROWS_PER_SCALE and budget[0] > 0:
        budget[0] -= 1
        sub = _resampled(result, a, b)
    if sub is not None:     # its rows in the steps that stay above v_freeze (along the slip)
        k = np.clip(np.searchsorted(starts, sub.t, side="left") - 1, 0, len(starts) - 1)
        keep = free[k] & (sub.t > t0 + eps) & (sub.t < t1 - eps)
        t_rows.append(sub.t[keep])
        q_rows.append(sub.model_q[keep])
    t_all, q_all = np.concatenate(t_rows), np.concatenate(q_rows)
    if len(inside):         # the steps' ends are added below: not twice
        ends = steps.t[inside]
        j = np.clip(np.searchsorted(ends, t_all), 1, len(ends) - 1) if len(ends) > 1 \
            else np.zeros(len(t_all), int)
        near = np.minimum(np.abs(t_all - ends[j]), np.abs(t_all - ends[j - 1])) \
            if len(ends) > 1 else np.abs(t_all - ends[0])
        t_all, q_all = t_all[near > eps], q_all[near > eps]
    # a step's end next to a step that reaches v_freeze twice: the power jumps there
    cut = inside[~free[:-1] | ~free[1:]]
    side = np.concatenate([np.zeros(len(t_all) + len(inside), int), np.ones(len(cut), int)])
    t_all = np.concatenate([t_all, steps.t[inside], steps.t[cut]])
    q_all = np.concatenate([q_all, steps.model_q[inside], steps.model_q[cut]])
    order = np.lexsort((side, t_all))
    t_all, q_all, side = t_all[order], q_all[order], side[order]
    rows = replace(result, t=t_all, model_q=q_all,
                   row_kind=np.zeros(len(t_all), dtype=np.intc),
                   event_rows=np.zeros((0, result.event_rows.shape[1])), rates=None)
    rows.__dict__["modes"] = np.full(len(t_all), abi.MODE["sliding"])
    rows.__dict__["couples"] = np.zeros(len(t_all), dtype=int)
    rows.__dict__["session"] = result.session      # (the run's: the same scene and start)
    k = np.clip(np.searchsorted(starts, t_all, side="left") - 1 + side, 0, len(starts) - 1)
    v = rows.slip
    speed = np.hypot(*v.T)
    along = sliding_directions(rows, 0, len(t_all))
    directions = along.copy()
    own = armed[k] & (speed > band["freeze"])
    kept = armed[k] & ~own
    directions[own] = v[own] / speed[own][:, None]
    ref = start_slip[k[kept]]
    directions[kept] = ref / np.hypot(*ref.T)[:, None]
    if not np.any(np.hypot(*(directions - along).T) > TURNED):
        return None     # a slip on one line (a capsule's): its rows as before, resampled
    cuts = [0, *np.flatnonzero(side == 1).tolist(), len(t_all)]
    pieces = [(i, j) for i, j in zip(cuts[:-1], cuts[1:]) if j - i > 1]
    return rows, directions, pieces


def _works(scene, t: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Each drive's work: its row of ``p`` (drives, rows) integrated over ``t``."""
    return np.array([_integrate_pieces(scene, t, row) for row in p])


def _phase_work(result, mo: Motion, a: int, b: int, state: str, p: np.ndarray,
                budget: list) -> np.ndarray:
    """Each drive's work over a phase: its power ``p`` (drives, rows [a, b)) integrated by
    :func:`integrate`; a phase with fewer rows than the rule's order (a flight between
    accumulating impacts is often shorter than a row's spacing: two rows) is resampled
    first, while ``budget`` lasts."""
    if b - a >= QUADRATURE_POINTS or result.model not in _OMEGA_RATE or budget[0] <= 0:
        return _works(result.scene, mo.t[a:b], p)
    budget[0] -= 1
    fine = _resampled(result, a, b)
    if fine is None:
        return _works(result.scene, mo.t[a:b], p)
    fm = motion(fine)
    fp = drive_powers_in_flight(result.scene, fm) if state == "flight" else \
        drive_powers_in_contact(fine, fm, 0, len(fine.t))
    return _works(result.scene, fm.t, fp)


def _impulsive_work(result, mo: Motion, V_P, i: int) -> np.ndarray | None:
    """Each drive's work in the impact between rows i and i + 1 (None without the
    attitude)."""
    if mo.bodies is not None:
        q = result.model_q
        return bm.impulsive_work(result.scene, mo.bodies, i, q[i], q[i + 1])
    if V_P is None:
        return None
    return np.array([result.scene.m * float(np.dot(V_P[i + 1] - V_P[i], mo.v_r[i]))])


def kinetic_by_body(mo: Motion, names: tuple) -> dict:
    """Each body's kinetic energy at the start and the end, [start, end] by name (the
    carrier's counts its rotors as locked; a rotor's is its spin beyond that); {} when
    the split is not known (no attitude)."""
    if mo.T_carrier is None:
        return {}
    rows = [mo.T_carrier, *mo.T_points, *mo.T_rotors]
    return {name: [float(T[0]), float(T[-1])] for name, T in zip(("carrier", *names), rows)}


def energy_balance(result, mo: Motion, trace: list | None = None) -> dict | None:
    """Start and end energy and where the difference went (see the module's docstring);
    ``residual`` closes the balance up to the integration error and the quadrature.
    ``trace``: told each flight phase's share of the residual, ``(t at its end, E's
    change over it - the drives' work in it)`` (overview.png draws their running sum)."""
    if mo.T is None:
        return None
    run, steps = result, False          # (the steps' ends: read when a phase asks)
    result, mo = for_balance(result, mo)
    s = result.scene
    E = mo.T + mo.U
    V_P = point_velocity_body(s, mo) if mo.bodies is None else None
    jumps = {"impact": 0.0, "contact": 0.0, "lift_off": 0.0, "graze": 0.0, "event": 0.0}
    restitution = friction_impacts = friction_contact = 0.0
    names = drive_names(s)
    zero = np.zeros(len(names))
    drive_impacts, impulsive_known = zero.copy(), V_P is not None or mo.bodies is not None
    drive_events = zero.copy()     # the drives' impulsive work at the other events' jumps
    rough = result.rough
    for i, ev in event_rows(result):
        kind = ev["kind"]
        if i + 1 >= len(E):                  # the run's ending event (a flat landing)
            continue
        jumps[kind] = jumps.get(kind, 0.0) + float(E[i + 1] - E[i])
        if kind == "impact":
            if rough:       # the work of the impulse, normal and tangential (Darboux-Keller)
                restitution += ev["work_normal"]
                friction_impacts += ev["work_friction"]
            else:
                restitution += 0.5 * ev["value"] * (ev["v_minus"] + ev["v_plus"])
        works = _impulsive_work(result, mo, V_P, i)
        if works is None:
            impulsive_known = False
        elif kind == "impact":
            drive_impacts += works
        else:           # a stick's slip removed by an impulse at S, a contact's plastic cut
            drive_events += works
    power = drive_powers_in_flight(s, mo)
    drive_flight, drive_contact, contact = zero.copy(), zero.copy(), 0.0
    unchecked = False
    budget = [MAX_PHASE_RUNS]
    for a, b, state in phases(result):
        if state == "flight":
            work = _phase_work(result, mo, a, b, state, power[:, a:b], budget)
            drive_flight += work
            if trace is not None:
                trace.append((float(result.t[b - 1]), float(E[b - 1] - E[a] - work.sum())))
            continue
        if rough:
            if steps is False:
                steps = step_rows(run)
            frozen = frozen_sliding(result, steps, a, b, budget)
            if frozen is not None:
                rows, directions, pieces = frozen
                rm = motion(rows)
                p, pf = rough_contact_power(rows, rm, 0, len(rows.t), directions)
                for i, j in pieces:      # (_integrate_pieces: a table's knots too)
                    drive_contact += _works(s, rm.t[i:j], p[:, i:j])
                    friction_contact += _integrate_pieces(s, rm.t[i:j], pf[i:j])
                continue
            fine, fm, fa, fb = result, mo, a, b
            # a phase of a few rows: a slip that a push or an impact starts decays on its
            # own time scale, shorter than the law's the rows were spaced for (a 32 ms slip
            # on 9 rows had left 1 % of friction's work in the residual)
            if b - a < ROWS_PER_SCALE and budget[0] > 0:
                budget[0] -= 1
                sub = _resampled(result, a, b)
                if sub is not None:
                    fine, fm, fa, fb = sub, motion(sub), 0, len(sub.t)
            p, pf = rough_contact_power(fine, fm, fa, fb)
            drive_contact += _works(s, fm.t[fa:fb], p)
            friction_contact += _integrate_pieces(s, fm.t[fa:fb], pf)
            continue
        p = drive_powers_in_contact(result, mo, a, b)
        if p is None:
            contact += float(E[b - 1] - E[a])
            unchecked = True
        else:
            drive_contact += _phase_work(result, mo, a, b, state, p, budget)
    E0, E1 = float(E[0]), float(E[-1])
    by_drive = drive_flight + drive_contact + (drive_impacts + drive_events
                                               if impulsive_known else 0.0)
    drive_flight, drive_contact = float(drive_flight.sum()), float(drive_contact.sum())
    out = {
        "start": E0, "end": E1, "change": E1 - E0,
        "kinetic_start": float(mo.T[0]), "kinetic_end": float(mo.T[-1]),
        "at_impacts": jumps["impact"],
        "lost_at_impacts": -jumps["impact"],
        "restitution_at_impacts": restitution,
        "drive_work_at_impacts": float(drive_impacts.sum()) if impulsive_known else None,
        "drive_work_in_flight": drive_flight,
        "drive_work_in_contact": drive_contact,
        # each drive's work in all (flight, contact and its impulses at impacts)
        "drive_work_by_body": dict(zip(names, by_drive.tolist())),
        "change_in_contact_not_split": contact if unchecked else None,
        "at_other_events": sum(v for k, v in jumps.items() if k != "impact"),
        # of which the drives' impulsive work (the rest: the impulse's own, second order)
        "drive_work_at_other_events": float(drive_events.sum()) if impulsive_known else None,
        "quadrature_rows": int(len(mo.t)),
        "kinetic_by_body": kinetic_by_body(mo, names),
    }
    if rough:
        out.update({"friction_at_impacts": friction_impacts,
                    "friction_in_contact": friction_contact,
                    "work_of_friction": friction_impacts + friction_contact})
    out["residual"] = (E1 - E0 - out["at_impacts"] - drive_flight - drive_contact - contact
                       - friction_contact - out["at_other_events"])
    return out
