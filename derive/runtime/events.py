"""The event timeline of a run: its event rows decoded, and what holds on each row.

The runtime returns an event table (columns :data:`derive.abi.EVENT_COLUMNS`) and a kind
per row (:data:`derive.abi.ROW_KINDS`: a step, or the state just before or just after an
event).  Here they are read, by name: :func:`decode` gives one dict per event
(``Result.events``), :func:`event_rows` pairs each event with its rows,
:func:`contact_modes` and :func:`contact_couples` say the contact mode
(:data:`derive.abi.MODES`) and the couples' channels (:data:`derive.abi.COUPLE_BITS`)
on every row, :func:`contact_intervals` and :func:`phases` cut the run into flight and
contact.

The functions read a run through its arrays only (``t``, ``row_kind``, ``events``,
``scene.duration``, ``couples_on``: a :class:`~derive.runtime.driver.Result` or a part of
one); nothing here runs the C.  The mechanics along the rows are
:mod:`derive.runtime.motion`'s.
"""
from __future__ import annotations

import numpy as np

from .. import abi

EVENT_KINDS = abi.names(abi.EVENT_KINDS)
MODES = abi.names(abi.MODES)
STAGES = abi.names(abi.IMPACT_STAGES)
COLUMN = {name: k for k, name in enumerate(abi.EVENT_COLUMNS)}
# the friction columns of an impact's row, by the name Result.events gives them
FRICTION_COLUMNS = ("P_X", "P_Y", "slip_X_minus", "slip_Y_minus", "slip_X_plus",
                    "slip_Y_plus", "work_normal", "work_friction")
# impacts.csv's friction columns (Result.impacts_friction)
IMPACT_FRICTION_COLUMNS = FRICTION_COLUMNS + ("stage",)
_BEFORE = abi.ROW_KIND["before_event"]
_IMPACT = abi.index(abi.EVENT_KINDS, "impact")
_CONTACT = abi.index(abi.EVENT_KINDS, "contact")


def decode(rows: np.ndarray, rough: bool, couples: bool) -> list:
    """One dict per event row: t, kind, value, v_minus, v_plus (t_accumulation for a
    contact).  ``rough`` adds ``mode`` (the contact mode after the event), and for
    impacts the tangential impulse P_X, P_Y, the slip of S before and after, the work of
    the normal impulse and of friction, and ``stage`` (abi.IMPACT_STAGES); ``couples``
    adds ``couples`` (the channels held after the event, abi.COUPLE_BITS)."""
    cols = abi.EVENT_COLUMNS
    out = []
    for r in rows:
        kind = int(r[1])
        ev = {"t": float(r[0]), "kind": EVENT_KINDS[kind], "value": float(r[2]),
              "v_minus": float(r[3]), "v_plus": float(r[4]),
              **({cols[5]: float(r[5])} if kind == _CONTACT else {})}
        if rough:
            ev["mode"] = MODES[int(r[COLUMN["mode"]])]
            if kind == _IMPACT:
                ev.update({c: float(r[COLUMN[c]]) for c in FRICTION_COLUMNS})
                ev["stage"] = STAGES[int(r[COLUMN["stage"]])]
            if couples:
                ev["couples"] = int(r[COLUMN["couples"]])
        out.append(ev)
    return out


def impacts(rows: np.ndarray) -> np.ndarray:
    """Per impact: t, I, v_n-, v_n+ ((0, 4) without impacts)."""
    if not len(rows):
        return np.zeros((0, 4))
    return rows[rows[:, 1] == _IMPACT][:, [0, 2, 3, 4]]


def impacts_friction(rows: np.ndarray) -> np.ndarray:
    """Per impact the columns of :data:`IMPACT_FRICTION_COLUMNS` (the rough model's)."""
    if not len(rows):
        return np.zeros((0, len(IMPACT_FRICTION_COLUMNS)))
    return rows[rows[:, 1] == _IMPACT][:, [COLUMN[c] for c in IMPACT_FRICTION_COLUMNS]]


def event_rows(result) -> list[tuple[int, dict]]:
    """Each pair of rows around an event (the index of its ``before`` row; ``after`` is
    the next) with its event.  Matched by time: a contact that begins at an impact has no
    rows of its own (the impact's pair is the impact's)."""
    befores = np.flatnonzero(result.row_kind == _BEFORE)
    events = result.events
    tol = 1e-9 * max(abs(result.scene.duration), 1.0)
    times = [ev["t"] for ev in events]
    # a row takes the first free event near its time that is not a contact, else the first
    # free contact near it: each kind is taken in its order, so one pointer into each
    # walks past the used and the early ones once (chatter puts thousands of events
    # inside the tolerance: rescanning them for every row had made this quadratic, 137 s
    # of a 100,000-event run)
    lists = ([k for k, ev in enumerate(events) if ev["kind"] != "contact"],
             [k for k, ev in enumerate(events) if ev["kind"] == "contact"])
    heads = [0, 0]
    used = [False] * len(events)
    out = []
    for i in befores.tolist():
        ti = float(result.t[i])
        found = None
        for which, ks in enumerate(lists):
            h = heads[which]
            while h < len(ks) and (used[ks[h]] or times[ks[h]] < ti - tol):
                h += 1
            heads[which] = h
            if h < len(ks) and abs(times[ks[h]] - ti) <= tol:
                found = ks[h]
                break
        if found is None:
            out.append((i, {"t": ti, "kind": "event"}))
            continue
        used[found] = True
        out.append((i, events[found]))
    return out


def impact_rows(result) -> np.ndarray:
    """Indices of the ``before`` rows of the impacts."""
    return np.array([i for i, ev in event_rows(result) if ev["kind"] == "impact"], dtype=int)


def _mode_after(ev: dict, mode: int) -> int:
    """The contact mode after an event (the rough model says it; the smooth ones by the
    kind: contact starts it, lift-off ends it)."""
    if "mode" in ev:
        return abi.MODE[ev["mode"]]
    if ev["kind"] == "contact":
        return abi.MODE["smooth"]
    if ev["kind"] == "lift_off":
        return abi.MODE["flight"]
    return mode


def contact_modes(result) -> np.ndarray:
    """The contact mode of every row (indices into abi.MODES): a step row has the mode
    after the last event at or before its time; the ``before`` row of an event the mode
    before the events at its time, the ``after`` row the mode after them."""
    t = result.t
    events = result.events
    out = np.zeros(len(t), dtype=int)
    if not events:
        return out
    times = np.array([ev["t"] for ev in events])
    after, mode = [], abi.MODE["flight"]
    for ev in events:
        mode = _mode_after(ev, mode)
        after.append(mode)
    return _per_row(result, times, np.array([abi.MODE["flight"]] + after))


def _per_row(result, times: np.ndarray, after: np.ndarray) -> np.ndarray:
    """What holds on each row, from ``after`` (the value before the first event, then
    after each event at ``times``): a step row has the value after the last event at or
    before its time, a ``before`` row the value before the events at its time."""
    k = np.searchsorted(times, result.t, side="right")
    k_before = np.searchsorted(times, result.t, side="left")
    return after[np.where(result.row_kind == _BEFORE, k_before, k)]


def contact_couples(result) -> np.ndarray:
    """The couples' channels held on every row (abi.COUPLE_BITS), as
    :func:`contact_modes` reads the modes: the event column ``couples`` after each event
    (0 after one that leaves contact)."""
    if not result.couples_on or not result.events:
        return np.zeros(len(result.t), dtype=int)
    times = np.array([ev["t"] for ev in result.events])
    after = np.array([0] + [ev["couples"] if ev.get("mode") not in (None, "flight") else 0
                            for ev in result.events])
    return _per_row(result, times, after)


def contact_intervals(result) -> list[tuple[float, float]]:
    """Times of persistent contact: from each ``contact`` event to the next lift-off."""
    out, since = [], None
    for ev in result.events:
        if ev["kind"] == "contact" and since is None:
            since = ev["t"]
        elif ev["kind"] == "lift_off" and since is not None:
            out.append((since, ev["t"]))
            since = None
    if since is not None:
        out.append((since, float("inf")))
    return out


def phases(result) -> list[tuple[int, int, str]]:
    """Row ranges [a, b) between events, each with its kind: ``flight`` or ``contact``."""
    kinds = result.row_kind
    bounds = [0] + [int(i) + 1 for i in np.flatnonzero(kinds == _BEFORE)] + [len(kinds)]
    contact = contact_intervals(result)
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b <= a:
            continue
        mid = 0.5 * (result.t[a] + result.t[b - 1])
        state = "contact" if any(c0 <= mid <= c1 for c0, c1 in contact) else "flight"
        out.append((a, b, state))
    return out


def face_modes(result) -> np.ndarray:
    """The face's mode on every row of a base run (abi.MODES: sliding, sticking) from its
    events: a slip starts sliding, a stick ends it (a reversal keeps it)."""
    sliding, sticking = abi.MODE["sliding"], abi.MODE["sticking"]
    t = result.t
    q0 = result.start.q0
    mode = sliding if np.hypot(np.hypot(q0[3], q0[4]), q0[5]) > 0.0 else sticking
    out = np.full(len(t), mode, dtype=int)
    for ev in result.events:
        if ev["kind"] in ("slip", "stick"):
            after = np.searchsorted(t, ev["t"], side="right")
            out[after:] = sliding if ev["kind"] == "slip" else sticking
    return out
