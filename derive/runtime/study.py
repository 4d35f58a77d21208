"""How a parameter study runs (:func:`derive.runtime.batch.simulate_many`): its variants
planned into *parts*, runs of one model and law whose inputs are built for all their
variants at once, and *singles*, the variants taken one at a time; then each run in C,
and what the user reads assembled as columns.

Planning: the variants that override the same fields are read in bulk
(:func:`derive.scene.bulk.read`: the same fields and rules as one scene, over NumPy
columns); of those that pass, one per distinct value of what the model's choice reads
(:func:`derive.runtime.choice.symmetry_key`) is prepared alone, through the per-scene
path, for its model; then the options, parameters and start of every variant of that
model come at once from :func:`derive.runtime.driver.options`,
:func:`~derive.runtime.choice.parameters` and :func:`~derive.runtime.choice.start` over
the study's Scene of columns -- and must equal that variant's own, bit for bit, or the
study stops with an error (two validators that disagree are a bug).  The rest, and
studies that keep whole results, go one variant at a time through the per-scene path
(so a bad value is refused with the message one scene gets, naming the variant).

Running: a part in chunks, each one call into C (``crt_run_many``, which releases the
GIL: threads run chunks in parallel) that keeps per run only what the summary reads;
its columns are sliced out of the C's arrays, with no Python per variant.
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np

from .. import abi
from . import choice, handover
from .driver import options, prepare, run_scene, session_for
from ..scene import SceneError, build_scene, bulk, overrides
from ..scene.schema import SCENE

SUMMARY_COLUMNS = ("status", "model", "t_end", "impacts", "contacts", "lift_offs", "slips",
                   "sticks", "reversals", "steps", "rhs_evaluations", "min_height",
                   "first_contact_t", "handover_t", "X_C_end", "Y_C_end", "Z_C_end", "distance",
                   "mean_speed", "mean_velocity_X", "mean_velocity_Y", "run_ms")
TEXT_COLUMNS = ("error", "status", "model")
COUNT_COLUMNS = ("impacts", "contacts", "lift_offs", "slips", "sticks", "reversals", "steps",
                 "rhs_evaluations")
# the slip events, stick events and reversals: a column of the runs that count them, those
# with friction at S (the rough models) and those that began on a face (base runs, and
# those that handed over at a lift-off: handover_t not NaN, the base phase's counts and
# the flight's); empty (masked) for the other models, which have no friction
FRICTION_COLUMNS = ("slips", "sticks", "reversals")


def counts_friction(model, handover_t) -> np.ndarray | bool:
    """Whether a row's run counts FRICTION_COLUMNS: a rough model's (friction at S), a base
    run, or one that handed over (``handover_t`` a time, not NaN); of one row or of
    columns."""
    t = np.asarray(handover_t, dtype=float)
    kinds = np.asarray(model, dtype=object)
    out = (kinds == "base") | np.isin(kinds, choice.ROUGH_KINDS) | ~np.isnan(t)
    return bool(out) if out.ndim == 0 else out


_STAT = {name: k for k, name in enumerate(abi.names(abi.STATS))}
_SUMMARY = {name: k for k, name in enumerate(abi.names(abi.SUMMARY))}
_OK = abi.STATUS["ok"]


# ---- columns -----------------------------------------------------------------------------
def empty_columns(n: int) -> dict:
    """The columns of n variants, none filled: text None, numbers 0 (a refused variant's
    stay so, and Batch.column masks them)."""
    out = {}
    for name in ("error", *SUMMARY_COLUMNS):
        if name in TEXT_COLUMNS:
            out[name] = np.full(n, None, dtype=object)
        else:
            out[name] = np.zeros(n, dtype=np.int64 if name in COUNT_COLUMNS else float)
    return out


def columns_of_rows(rows: list) -> dict:
    """Columns from summary rows (dicts: the per-variant path's)."""
    out = empty_columns(len(rows))
    for k, row in enumerate(rows):
        for name, value in row.items():
            out[name][k] = value
    return out


def summary_row(result) -> dict:
    """The summary of one :class:`~derive.runtime.driver.Result` (the columns a part
    fills in C)."""
    ev = result.event_rows
    contact = ev[ev[:, 1] == abi.index(abi.EVENT_KINDS, "contact")] if len(ev) else ev
    s = result.stats
    t_end = float(result.t[-1])
    c0 = choice.start_of_c(result.scene)
    travel = choice.travel(result.model, result.scene.t0, t_end, result.model_q[-1], c0,
                           result.scene)
    return {"status": result.status, "model": result.model, "t_end": t_end,
            "impacts": s["impacts"], "contacts": s["contacts"], "lift_offs": s["lift_offs"],
            **{name: s[name] for name in FRICTION_COLUMNS}, "steps": s["steps"],
            "rhs_evaluations": s["rhs_evaluations"],
            "min_height": result.min_height,
            "first_contact_t": float(contact[0, 0]) if len(contact) else math.nan,
            "handover_t": result.handover.t if result.handover is not None else math.nan,
            **travel, **means(travel, c0, result.scene.t0, t_end),
            "Z_C_end": choice.height_of_c(result.scene, result.model, t_end,
                                          result.model_q[-1]),
            "run_ms": 1e3 * result.timings.get("run_s", math.nan)}


def means(travel: dict, c0, t0, t_end) -> dict:
    """C's net horizontal displacement over the run's time: the mean speed and velocity
    (X, Y), per period of a periodic law when the run is whole periods of it (nan for a
    run of no time); of one run or column by column."""
    span = np.asarray(t_end, dtype=float) - t0
    c0 = np.asarray(c0, dtype=float)
    out = {}
    with np.errstate(divide="ignore", invalid="ignore"):
        for name, moved in (("mean_speed", travel["distance"]),
                            ("mean_velocity_X", travel["X_C_end"] - c0[..., 0]),
                            ("mean_velocity_Y", travel["Y_C_end"] - c0[..., 1])):
            v = np.where(span > 0, np.asarray(moved, dtype=float) / span, np.nan)
            out[name] = float(v) if np.ndim(v) == 0 else v
    return out


# ---- the plan ----------------------------------------------------------------------------
@dataclass
class Part:
    """Variants of one model and law, their inputs built (one entry or row per variant).
    ``scenes``: their Scenes, where Z_C at the end needs them (the axisymmetric model's
    state does not hold it; the per-variant path's parts only), and ``starts`` their
    models' starts (choice.Start: the base model's places C from them)."""
    kind: str
    law: object
    index: np.ndarray          # the variants' numbers in the study
    t0: np.ndarray
    t_end: np.ndarray
    q0: np.ndarray
    opt: np.ndarray
    prm: np.ndarray
    c0: np.ndarray             # C's start (X, Y, Z, X', Y', Z') per variant: its travel
    scenes: list | None = None
    starts: list | None = None

    def __len__(self) -> int:
        return len(self.index)

    def pieces(self, size: int) -> list:
        """The part in chunks of at most ``size`` variants."""
        return [Part(self.kind, self.law, *(a[k:k + size] for a in (
                    self.index, self.t0, self.t_end, self.q0, self.opt, self.prm, self.c0)),
                     *(None if x is None else x[k:k + size] for x in (self.scenes, self.starts)))
                for k in range(0, len(self), size)]


@dataclass
class Plan:
    parts: list                # Part
    singles: list              # (index, overrides): one at a time


class VariantDoc:
    """A variant's scene dict (:attr:`Scene.doc`): the base's with the variant's
    overrides, made only when read."""
    __slots__ = ("_base", "_overrides")

    def __init__(self, base: dict, changes: dict):
        self._base, self._overrides = base, changes

    def get(self) -> dict:
        doc = copy.deepcopy(self._base)
        for name, value in self._overrides.items():
            overrides.apply_to_doc(doc, name, copy.deepcopy(value))
        return doc


def prepare_variant(base: dict, origin, base_v: dict, base_given: set, index: int,
                    changes: dict):
    """One variant through the per-scene path: its overrides validated into the base's
    field values, every rule, the model (SceneError names the field)."""
    v, given = dict(base_v), set(base_given)
    for name, value in changes.items():
        overrides.apply_to_values(v, given, name, value)
    return prepare(build_scene(v, given, VariantDoc(base, changes), f"variant {index + 1}",
                               base=origin))


def plan(base: dict, origin, items: list, keep: str = "summary") -> Plan:
    """The parts and singles of ``items`` ([(index, overrides)]) of the scene ``base``."""
    if keep != "summary":
        return Plan([], list(items))
    try:
        base_v, base_given = SCENE.read(base)
    except SceneError:
        return Plan([], list(items))      # (each single says so)
    groups: dict = {}
    for index, changes in items:
        groups.setdefault(tuple(changes), []).append((index, changes))
    parts, singles = [], []
    for names, members in groups.items():
        cols = bulk.read(base_v, base_given, names, [c for _, c in members], "variant",
                         origin)
        if cols is None:
            singles += members
            continue
        index = np.array([i for i, _ in members])
        singles += [members[k] for k in np.flatnonzero(~cols.ok)]
        found, alone = _parts(cols, index, members, base, origin, base_v, base_given)
        parts += found
        singles += alone
    singles.sort(key=lambda item: item[0])
    return Plan(parts, singles)


def _parts(cols, index: np.ndarray, members: list, base: dict, origin, base_v: dict,
           base_given: set) -> tuple[list, list]:
    """The parts of one group read in bulk (its variants that passed, by model), and the
    variants of a model whose start reads the law (to go one at a time)."""
    n = cols.n
    keys = choice.symmetry_key(cols.v["[initial].omega"], cols.v["[body].inertia"])
    code = sum(np.broadcast_to(b, (n,)).astype(int) << k for k, b in enumerate(keys))
    scene = cols.scene
    law = cols.draft.law if cols.draft.one_point else cols.draft.bodies   # the runtime's
    out, alone_ones = [], []
    for c in np.unique(code[cols.ok]):
        members_c = cols.ok & (code == c)
        first = int(np.flatnonzero(members_c)[0])
        i, changes = members[first]
        try:
            alone = prepare_variant(base, origin, base_v, base_given, i, changes)
        except SceneError as exc:
            raise RuntimeError(f"variant {i + 1} passed the study's bulk checks and the scene "
                               f"rules refuse it ({exc}): please report this study") from None
        if alone.kind not in choice.POSE_STARTS:    # its start reads the law: one by one
            alone_ones += [members[k] for k in np.flatnonzero(members_c)]
            continue
        st = choice.start(scene, alone.kind)
        q0 = np.broadcast_to(st.q0, (n, len(alone.start.q0)))
        opt = np.broadcast_to(options(scene, alone.kind), (n, len(alone.options)))
        prm = np.broadcast_to(choice.parameters(scene, st.constants),
                              (n, len(alone.parameters)))
        for what, mine, its in (("start", q0, alone.start.q0), ("options", opt, alone.options),
                                ("parameters", prm, alone.parameters)):
            if not np.array_equal(mine[first], its):
                raise RuntimeError(f"variant {i + 1}: its {what} read in bulk differ from its "
                                   "own (please report this study)")
        take = np.flatnonzero(members_c)
        out.append(Part(alone.kind, law, index[take], np.full(len(take), scene.t0),
                        np.full(len(take), scene.t0 + scene.duration), q0[take], opt[take],
                        prm[take], choice.start_of_c(scene)[take]))
    return out, alone_ones


# ---- running -----------------------------------------------------------------------------
def _session(kind: str, ready: list):
    """This thread's session of a model, the time it took added to ``ready[0]`` (nothing
    but the first time in a thread)."""
    start = time.perf_counter()
    session = session_for(kind)
    ready[0] += time.perf_counter() - start
    return session


def run_part(part: Part, ready: list, last: list | None = None) -> dict:
    """The columns of a part's variants: one call into C (``last``: a list given gets the
    C's last rows, t then q, the state a lift-off hands over)."""
    session = _session(part.kind, ready)
    session.set_law(part.law)
    n = len(part)
    out = session.run_many(part.t0, part.t_end, part.q0, part.opt, part.prm)
    if last is not None:
        last.append(out["last"])
    cols = empty_columns(n)
    codes = out["status"]
    found = np.unique(codes)
    names = np.array([abi.status_name(int(c)) for c in found], dtype=object)
    cols["status"][:] = names[np.searchsorted(found, codes)]
    cols["model"][:] = part.kind
    last = out["last"]
    cols["t_end"][:] = last[:, 0]
    stats = out["stats"]
    for name in COUNT_COLUMNS:
        cols[name][:] = stats[:, _STAT[name]]
    cols["min_height"][:] = out["summary"][:, _SUMMARY["min_height"]]
    cols["first_contact_t"][:] = out["first_contact"]
    cols["handover_t"][:] = math.nan           # (hand_over sets its variants')
    if part.scenes is None:                 # a model whose state holds Z_C (or attitude)
        cols["Z_C_end"][:] = choice.height_of_c(None, part.kind, last[:, 0], last[:, 1:])
        travel = choice.travel(part.kind, part.t0, last[:, 0], last[:, 1:], part.c0)
    elif part.kind == "base":               # C = O + A OC at each run's end, once
        starts = part.starts or [None] * len(part.scenes)
        ends = np.array([choice.base_c_at(sc, float(r[0]), r[1:], st)
                         for sc, r, st in zip(part.scenes, last, starts)]).reshape(-1, 3)
        cols["Z_C_end"][:] = ends[:, 2]
        travel = choice.displacement(ends[:, 0], ends[:, 1], part.c0)
    else:
        cols["Z_C_end"][:] = [choice.height_of_c(sc, part.kind, float(r[0]), r[1:])
                              for sc, r in zip(part.scenes, last)]
        travel = choice.travel(part.kind, part.t0, last[:, 0], last[:, 1:], part.c0,
                               part.scenes)
    for name, col in travel.items():
        cols[name][:] = col
    for name, col in means(cols, part.c0, part.t0, last[:, 0]).items():
        cols[name][:] = col
    cols["run_ms"][:] = 1e3 * out["seconds"] / n
    for k in np.flatnonzero(out["init_status"] != _OK):
        # crt_init again on this run's inputs: the C then names what it refused
        status = session.init_status(part.opt[k], part.prm[k], part.t0[k], part.q0[k])
        for name in SUMMARY_COLUMNS:
            cols[name][k] = None if name in TEXT_COLUMNS else 0
        cols["error"][k] = f"variant {part.index[k] + 1}: {session._refused(status)}"
    return cols


def part_of(kind: str, preps: list, index: list) -> Part:
    """A part of prepared scenes of one model and law, numbered ``index``."""
    return Part(kind, preps[0].scene.runtime_law, np.array(index),
                np.array([p.scene.t0 for p in preps]),
                np.array([p.scene.t0 + p.scene.duration for p in preps]),
                np.array([p.start.q0 for p in preps]), np.array([p.options for p in preps]),
                np.array([p.parameters for p in preps]),
                np.array([choice.start_of_c(p.scene) for p in preps]), [p.scene for p in preps],
                [p.start for p in preps])


def run_singles(base: dict, origin, items: list, keep: str, ready: list) -> tuple:
    """The variants one at a time through the per-scene path: (columns, whole results
    (keep = "result") or None).  Summaries: the valid variants of one model and law in
    one call into C."""
    cols = empty_columns(len(items))
    results: list = [None] * len(items)
    try:
        base_v, base_given = SCENE.read(base)
    except SceneError as exc:
        cols["error"][:] = f"base scene: {exc}"
        return cols, (results if keep == "result" else None)
    groups: dict = {}
    for k, (index, changes) in enumerate(items):
        try:
            prep = prepare_variant(base, origin, base_v, base_given, index, changes)
            if keep == "result":
                results[k] = run_scene(prep, _session(prep.kind, ready))
                for name, value in summary_row(results[k]).items():
                    cols[name][k] = value
                continue
        except SceneError as exc:
            cols["error"][k] = f"variant {index + 1}: {exc}"
            continue
        groups.setdefault((prep.kind, id(prep.scene.runtime_law)), []).append(
            (k, index, prep))
    for (kind, _), members in groups.items():
        part = part_of(kind, [p for _, _, p in members], [i for _, i, _ in members])
        last: list = []
        got = run_part(part, ready, last)
        if kind == "base":                  # lift-offs fly on, as derive.simulate's do
            hand_over(part, got, last[0], ready)
        at = np.array([k for k, _, _ in members])
        for name, col in got.items():
            cols[name][at] = col
    return cols, (results if keep == "result" else None)


# ---- the hand-over: a base variant that lifts off flies on (runtime/handover.py) ----------
def hand_over(part: Part, cols: dict, last: np.ndarray, ready: list) -> None:
    """The base variants of ``part`` that stopped at lift-off with ``[plane].restitution``
    go on in the general model, as :func:`derive.simulate`'s do (handover.hand_over): the
    flights from the hand-over's states in calls into C of their model, each the whole
    flight as handover.fly makes it (the C stops one that comes down on its face flat,
    flat_landing).
    Each such row then says the whole run, as summary_row of derive.simulate's Result:
    the flight's status, model, end, heights and first contact, the counts of both parts
    summed, C's travel and mean velocity from the base run's start.  In place; the other
    variants' rows as they were (no Python per variant)."""
    todo = []
    for k in np.flatnonzero(cols["status"] == "lift_off"):
        scene, t_l = part.scenes[k], float(last[k, 0])
        if not scene.restitution_given or not handover.flies(scene, t_l):
            continue                         # (no flight, as handover.hand_over)
        state = handover.general_state(scene, part.starts[k], t_l, last[k, 1:])
        todo.append((int(k), handover.flight_scene(scene, t_l, state)))
    if not todo:
        return
    flights = _flights(todo, ready)
    for k, _ in todo:
        row, end = flights[k]
        scene, t_end = part.scenes[k], float(end[0])
        for name in ("status", "model", "t_end", "min_height", "first_contact_t", "Z_C_end"):
            cols[name][k] = row[name]
        cols["handover_t"][k] = float(last[k, 0])          # (the lift-off)
        for name in COUNT_COLUMNS:
            cols[name][k] += row[name]
        cols["run_ms"][k] += row["run_ms"]
        travel = choice.travel(row["model"], scene.t0, t_end, end[1:], part.c0[k], scene)
        for name, value in {**travel, **means(travel, part.c0[k], scene.t0, t_end)}.items():
            cols[name][k] = value


def _flights(items: list, ready: list) -> dict:
    """{k: (the summary columns of the flight of scene fs, its last row: t then q)} for
    items [(k, fs)], the flights of one model and law in one call into C."""
    groups: dict = {}
    for k, fs in items:
        prep = prepare(fs)
        groups.setdefault((prep.kind, id(prep.scene.runtime_law)), []).append((k, prep))
    out = {}
    for (kind, _), members in groups.items():
        part = part_of(kind, [p for _, p in members], [k for k, _ in members])
        last: list = []
        got = run_part(part, ready, last)
        for j, (k, _) in enumerate(members):
            out[k] = ({name: got[name][j] for name in SUMMARY_COLUMNS}, last[0][j])
    return out
