"""What a run of the base model did (a box or a cylinder on its face, crt_base.h), for
``summary.json``, ``derive simulate``'s lines and the overview: the face's contact (the
stick and slip phases from the events, the normal force ``N = (M + m) g + s_z''`` along
the rows from the bodies' moments), how C travelled (for a periodic law, the mean
velocity per period: C's displacement over the whole periods run, from runs of the
scene ending at them), and the statuses ``lift_off`` and ``tipping`` said in words.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import abi, face as faces
from ..progress import count
from . import bodies, choice
from .events import face_modes as modes

STOPS = {"lift_off": "N reached 0: the body leaves the plane (lift-off)",
         "tipping": "the centre of pressure reached the face's edge: the body tips",
         "face_lifting": "the centre of pressure left the face's kern: the linear pressure "
                         "reaches 0 at an edge, and the face starts to lift there"}
METHOD = ("dop853 (a translation is a quadrature of the law, other slips along a line in t, "
          "the rest in arc time; the base model's own integrator)")
_SLIDING, _STICKING = abi.MODE["sliding"], abi.MODE["sticking"]


def normal_force(result) -> np.ndarray:
    """N along the rows: ``(M + m) g + n . s''`` (n the vertical in body axes: the body does
    not tilt), the vertical balance of derive/base.py."""
    s = result.scene
    mo = bodies.moments(bodies.along(s, result.t))
    return (s.M + mo.m) * s.g + mo.sdd @ np.asarray(s.A0[2], dtype=float)


def contact(result) -> dict:
    """The face's contact: the coefficients, the pressure, the events counted, the time
    sticking and sliding, the smallest N."""
    s, t = result.scene, result.t
    face = choice.base_face(s)
    m = modes(result)[:-1]
    dt = np.diff(t)
    kinds = [ev["kind"] for ev in result.events]
    N = normal_force(result)
    return {"face": face.kind, "friction": s.friction, "static_friction": s.mu_static,
            "pressure": s.pressure or "uniform", "sticks": kinds.count("stick"),
            "slips": kinds.count("slip"), "reversals": kinds.count("reversal"),
            "time_sticking": float(dt[m == _STICKING].sum()),
            "time_sliding": float(dt[m == _SLIDING].sum()),
            "min_normal_force": float(N.min()), "t_min_normal_force": float(t[np.argmin(N)])}


def law_period(scene) -> float | None:
    """The common period of every body's law: the formulas' common period (read from the
    compiled laws, no SymPy), a periodic table's span (a plan's law; every periodic table
    of a scene has one span), both when the span is a whole number of the formulas'
    periods (None: not periodic)."""
    from ..scene.law.period import NotPeriodic, program_period
    programs, spans = [], set()
    for body in (*scene.points, *scene.rotors):
        law = body.law
        kind = getattr(law, "kind", None)
        if kind == "table":
            if not law.periodic:
                return None
            spans.add(law.t_last - law.t_first)
            continue
        if kind != "program":
            return None
        programs.append(law)
    span = max(spans) if spans else None
    if not programs:
        return span
    try:
        T = program_period(programs)
    except NotPeriodic:
        return None
    if span is None:
        return T
    k = round(span / T)
    return span if k >= 1 and abs(span - k * T) <= 1e-9 * span else None


# two periods are the same when their displacements agree to this fraction of the largest
# (plus a picometre): far above the dense output's error (rtol 1e-10), far below a change
STEADY_TOL = 1e-6


def _c_at_periods(scene, n: int, T: float) -> np.ndarray | None:
    """C at t0, t0 + T, ..., t0 + n T (rows (n + 1, 3)), from one run of the scene to
    t0 + n T on the grid of one period ([run].output_dt = T: the dense output's rows);
    None where that run stopped before."""
    from .driver import simulate
    run = simulate(dataclasses.replace(scene, duration=n * T, output_dt=T))
    if run.status != "done":
        return None
    t = np.asarray(run.t)
    rows = np.flatnonzero(np.asarray(run.row_kind) == abi.ROW_KIND["step"])
    k = np.rint((t[rows] - scene.t0) / T).astype(int)
    on = np.abs(t[rows] - (scene.t0 + k * T)) <= 1e-9 * T * max(n, 1)
    at = {int(j): int(i) for j, i in zip(k[on], rows[on])}
    if any(j not in at for j in range(n + 1)):
        return None
    return np.array([choice.base_c_at(scene, float(t[at[j]]), run.model_q[at[j]])
                     for j in range(n + 1)])


def steady(per_period: np.ndarray) -> int | None:
    """The first period (1-based) from which every period's displacement is the last
    one's to STEADY_TOL: the periodic crawl, which Chernousko's and Bardin and Panev's
    mean speeds are of; None unless the last two periods at least agree (not yet
    periodic, or one period run)."""
    d = np.asarray(per_period, dtype=float)
    if len(d) < 2:
        return None
    tol = STEADY_TOL * float(np.max(np.hypot(d[:, 0], d[:, 1]))) + 1e-12
    same = np.hypot(*(d - d[-1]).T) <= tol
    if not same[-2]:
        return None
    first = len(d) - 1
    while first > 0 and same[first - 1]:
        first -= 1
    return first + 1


def travel(result) -> dict:
    """C's horizontal displacement (the vector), and for a periodic law the whole periods
    run: each period's displacement (C at the periods' ends from one run on their grid),
    their mean and the mean velocity over them (the start-up from rest included), the
    last one's, and ``steady``: from which period the displacement repeats (STEADY_TOL)
    and the mean displacement and velocity per period from there (None: not periodic
    yet)."""
    s = result.scene
    t_end = float(result.t[-1])
    c0 = np.asarray(s.com, dtype=float)
    end = choice.base_c_at(s, t_end, result.model_q[-1])
    out = {"displacement": [float(end[0] - c0[0]), float(end[1] - c0[1])]}
    T = law_period(s)
    if T is None:
        out["period"] = None
        return out
    n = int(math.floor((t_end - s.t0) / T * (1 + 1e-12)))
    out.update({"period": T, "whole_periods": n})
    if n < 1:
        return out
    ends = _c_at_periods(s, n, T)
    if ends is None:
        return out
    ends[0] = c0
    each = np.diff(ends[:, :2], axis=0)
    d = (ends[n] - c0)[:2] / n
    out.update({"displacement_per_period": [float(x) for x in d],
                "mean_velocity": [float(x / T) for x in d],
                "mean_speed": float(np.hypot(*d) / T),
                "last_period_displacement": [float(x) for x in each[-1]],
                "period_displacements": [[float(x), float(y)] for x, y in each]})
    first = steady(each)
    if first is None:
        out["steady"] = None
        return out
    ds = each[first - 1:].mean(axis=0)
    out["steady"] = {"from_period": first, "periods": n - first + 1,
                     "displacement_per_period": [float(x) for x in ds],
                     "mean_velocity": [float(x / T) for x in ds],
                     "mean_speed": float(np.hypot(*ds) / T)}
    return out


def energy(result, mo) -> dict:
    """The energy at the start and the end, and where the change went: each drive's work
    and the work of friction over the face (uniform pressure), with the residual that
    closes the balance up to the integration's and the quadrature's error.

    On rows dense enough for the quadrature (motion.for_balance), split at the events
    (the accelerations jump where a slip starts or stops):

    * the drives' power (bodies.drive_powers) with O's acceleration from the C's rates
      on a slipping row (the slip's own friction) and 0 on a sticking one (the state is
      constant while the body sticks);
    * friction's power -D(v, w) = -mu int p |v + w e_z x r| dA over the face, from
      derive/face.py's instant-centre integrals (apart from the C's crt_face.h) with N =
      (M + m) g + n.s'' (normal_force), 0 while sticking (the face's points do not move).

    Under linear pressure D needs the centre of pressure the slip gives, which the rows do
    not hold: the friction's work is then the change less the drives' (not split)."""
    from . import motion as mm
    result, mo = mm.for_balance(result, mo)
    s, t = result.scene, result.t
    E = mo.T + mo.U
    Q = result.model_q
    face = choice.base_face(s)
    ell = face.size
    moving = np.hypot(np.hypot(Q[:, 3], Q[:, 4]), ell * Q[:, 5]) > 0.0
    rates = np.zeros_like(Q)
    kinds = result.row_kind
    at = Q.copy()
    # a stop's row (before its event) reads the slip's rates as their limit from the
    # slip's side: a slip along a line stops where its speed changes sign, so its last
    # row's velocity is round-off of either sign (the friction's direction then reversed);
    # the last row's direction, scaled to 1e-150, gives the limit's friction
    for i in np.flatnonzero(kinds == abi.ROW_KIND["before_event"]):
        if i > 0 and moving[i - 1] and float(np.dot(Q[i, 3:6], Q[i - 1, 3:6])) <= \
                1e-3 * float(np.dot(Q[i - 1, 3:6], Q[i - 1, 3:6])):
            v = Q[i - 1, 3:6]
            at[i, 3:6] = 1e-150 * v / np.linalg.norm(v)
            moving[i] = True
    if moving.any():
        rates[moving] = result.session.rhs_rows(t[moving], at[moving])
    n_up = np.asarray(s.A0[2], dtype=float)
    a_O = np.column_stack([rates[:, 3], rates[:, 4], np.full(len(t), s.g)])  # + g e_Z
    carrier = np.einsum("nji,nj->ni", mo.A, a_O)                             # A^T (...)
    b = bodies.along(s, t)
    power = bodies.drive_powers(s, b, mo.omega, rates[:, 5:6] * n_up[None], carrier=carrier)
    linear = s.pressure == "linear"
    friction = np.zeros(len(t))
    if not linear:
        N = normal_force(result)
        for i in np.flatnonzero(moving):
            c, sn = math.cos(Q[i, 2]), math.sin(Q[i, 2])
            twist = (c * Q[i, 3] + sn * Q[i, 4], -sn * Q[i, 3] + c * Q[i, 4], Q[i, 5])
            friction[i] = -faces.centre_wrench(face, float(N[i]), None, "uniform",
                                               s.friction, twist)[1]
    cuts = [0]
    for i in range(1, len(t) - 1):
        if kinds[i] == abi.ROW_KIND["before_event"]:
            cuts.append(i)
        elif kinds[i] == abi.ROW_KIND["after_event"] and cuts[-1] != i:
            cuts.append(i)
    cuts.append(len(t) - 1)
    drives = np.zeros(len(power))
    work_f = 0.0
    dense = s.output_dt if s.output_dt > 0 else s.law_summary.time_scale / mm.ROWS_PER_SCALE
    for a, z in zip(cuts[:-1], cuts[1:]):
        seg = slice(a, z + 1)
        # across an event: a slip's start from rest (crt_base.h's series, up to about a
        # millisecond, the body's twist below 1e-6 sqrt(g ell)): the drives' power at rest
        # on a grid of its own as a stick's below, plus the twist's share; friction's (of
        # order mu N times the 1e-10 m moved) by the trapezoid of the two rows
        start = (kinds[a] == abi.ROW_KIND["before_event"]
                 and kinds[z] == abi.ROW_KIND["after_event"])
        if start:
            work_f += mm.integrate(t[seg], friction[seg])
        if not start and (moving[a + 1:z].any() or z - a < 2 or t[z] <= t[a]):
            drives += [mm.integrate(t[seg], p[seg]) for p in power]
            work_f += mm.integrate(t[seg], friction[seg])
            continue
        if t[z] <= t[a]:
            continue
        # sticking: the state is constant, the drives' power is the laws'; the C samples
        # a stick coarsely (its events are functions of t alone), so on a grid of its own
        tg = np.linspace(t[a], t[z], max(int(np.ceil((t[z] - t[a]) / dense)), 8) + 1)
        at_rest = np.repeat(mo.A[a][None], len(tg), axis=0)
        p_rest = bodies.drive_powers(s, bodies.along(s, tg), np.zeros((len(tg), 3)),
                                     np.zeros((len(tg), 3)), carrier=np.einsum(
                                         "nji,j->ni", at_rest, [0.0, 0.0, s.g]))
        drives += [mm.integrate(tg, p) for p in p_rest]
        if start:
            # the twist's share (the carrier's acceleration, which jumps at the start where
            # mu_s > mu and grows about linearly): the trapezoid of the power less its
            # value at rest, at the start's first row from the slip's side (the twist
            # 1e-150 along the next row's)
            ends = [a, z]
            q_a = Q[a].copy()
            q_a[3:6] = 1e-150 * Q[z, 3:6] / max(float(np.linalg.norm(Q[z, 3:6])), 1e-300)
            r_a = result.session.rhs_rows(t[[a]], q_a[None])[0]
            acc = np.column_stack([[r_a[3], rates[z, 3]], [r_a[4], rates[z, 4]],
                                   [s.g, s.g]])
            spin = np.array([r_a[5], rates[z, 5]])[:, None] * n_up[None]
            p_ends = bodies.drive_powers(s, bodies.along(s, t[ends]), mo.omega[ends], spin,
                                         carrier=np.einsum("nji,nj->ni", mo.A[ends], acc))
            p_zero = bodies.drive_powers(s, bodies.along(s, t[ends]), np.zeros((2, 3)),
                                         np.zeros((2, 3)), carrier=np.einsum(
                                             "nji,j->ni", mo.A[[a, a]], [0.0, 0.0, s.g]))
            drives += [mm.integrate(t[ends], pe - p0) for pe, p0 in zip(p_ends, p_zero)]
    E0, E1 = float(E[0]), float(E[-1])
    names = mm.drive_names(s)
    out = {"start": E0, "end": E1, "change": E1 - E0,
           "kinetic_start": float(mo.T[0]), "kinetic_end": float(mo.T[-1]),
           "drive_work": float(drives.sum()),
           "drive_work_by_body": dict(zip(names, drives.tolist())),
           "quadrature_rows": int(len(t))}
    if linear:
        out.update({"work_of_friction": None,
                    "not_split": "under linear pressure the friction's work is the change "
                                 "less the drives' (the rows do not hold the centre of "
                                 "pressure D needs)"})
    else:
        out.update({"work_of_friction": work_f,
                    "residual": E1 - E0 - float(drives.sum()) - work_f})
    return out


def lines(result, tr: dict | None = None) -> list[str]:
    """``derive simulate``'s lines of a base run: the stop said plainly, the contact, the
    travel per period."""
    out = []
    if result.status in STOPS:
        out.append(f"  stopped at t = {float(result.t[-1]):.6g} s: {STOPS[result.status]}; "
                   "the base model does not go on past it")
    c = contact(result)
    mu = f"mu = {c['friction']:g}" + (f", mu_s = {c['static_friction']:g}"
                                      if c["static_friction"] != c["friction"] else "")
    out.append(f"  friction over the {c['face']} ({mu}, {c['pressure']} pressure): "
               f"{count(c['slips'], 'slip')}, {count(c['sticks'], 'stick')}, "
               f"{count(c['reversals'], 'reversal')}; sticking "
               f"{c['time_sticking']:.4g} s, sliding {c['time_sliding']:.4g} s; smallest N "
               f"{c['min_normal_force']:.4g} N")
    tr = tr if tr is not None else travel(result)
    if tr.get("displacement_per_period") is not None:
        d = tr["displacement_per_period"]
        last = tr["last_period_displacement"]
        out.append(f"  C moved ({d[0]:.6g}, {d[1]:.6g}) m a period over {tr['whole_periods']}"
                   f" whole periods of {tr['period']:.6g} s (mean speed {tr['mean_speed']:.6g}"
                   f" m/s, from rest); the last period ({last[0]:.6g}, {last[1]:.6g}) m")
        st = tr.get("steady")
        if st is not None:
            ds = st["displacement_per_period"]
            out.append(f"  steady from period {st['from_period']}: ({ds[0]:.6g}, {ds[1]:.6g}) "
                       f"m a period, mean speed {st['mean_speed']:.6g} m/s")
        elif "steady" in tr:
            out.append(f"  not yet periodic: the last two periods differ by more than "
                       f"{STEADY_TOL:g} of the largest")
    return out


def handover_energy(h) -> dict:
    """The balance of a run that handed over (h: its handover.Handover): the base run's
    (energy), the flight's (motion.energy_balance) and the energy on both sides of the
    hand-over (the same state: equal to round-off)."""
    from .motion import energy_balance, motion
    base = energy(h.base, motion(h.base))
    flight = energy_balance(h.flight, motion(h.flight))
    return {"start": base["start"], "end": flight["end"],
            "change": flight["end"] - base["start"],
            "at_handover": flight["start"] - base["end"],
            "base": base, "flight": flight}


def handover_lines(h) -> list[str]:
    """derive simulate's lines on a hand-over (h: a handover.Handover)."""
    out = [f"  lifted off at t = {h.t:.6g} s (N reached 0): handed over to the "
           f"{h.flight.model} model, the face flat and v_n = 0"]
    out += [line for line in lines(h.base) if "stopped at" not in line]
    if h.landing is not None:
        out.append(f"  landed flat at t = {h.landing['t']:.6g} s (v_n = "
                   f"{h.landing['v_n']:.4g} m/s, the face's corners within "
                   f"{h.landing['spread']:.3g} m of each other, the height resolution "
                   f"{h.landing['resolution']:.3g} m): a multi-point impact no "
                   "model makes; the run stops there")
    return out
