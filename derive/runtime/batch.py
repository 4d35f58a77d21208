"""Parameter studies: ``derive.simulate_many(scene, variants)`` runs many variants of one
scene through the precompiled runtime, with no compilation and no Python per step.

Variants are overrides of the scene's fields by dotted name (``"body.mass"``,
``"plane.restitution"``, ``"initial.com"``, ``"point.law"``, ...): a list of dicts, one
per variant, or a grid, a dict of lists whose Cartesian product is taken.  Each variant
is validated like any scene (so a bad value is refused naming the variant and the
field) and its model chosen.  What comes back per variant is a summary row (``keep =
"summary"``: the variants of one model and law run in one call into C, which keeps per
run only what the row reads) or the whole :class:`~derive.runtime.driver.Result`
(``keep = "result"``).

Workers are local threads (``workers``, default every core: the C releases the GIL, so
threads run it in parallel with nothing to start or pickle), local processes
(``executor = "processes"``) or a Dask cluster (``scheduler``), through
:mod:`derive.parallel`.
"""
from __future__ import annotations

import copy
import itertools
import math
import time
from dataclasses import dataclass, field, fields as dataclass_fields

import numpy as np

from .. import parallel
from .. import abi
from ..progress import count
from . import choice
from .driver import Prepared, prepare, run_prepared, session_for
from ..scene import Scene, SceneError, build_scene, load_scene, overrides, parse_scene
from ..scene.rules import check_start_above_plane
from ..scene.schema import SCENE

SUMMARY_COLUMNS = ("status", "model", "t_end", "impacts", "contacts", "liftoffs", "steps",
                   "rhs_evaluations", "min_height", "first_contact_t", "Z_C_end", "run_ms")


class BatchError(overrides.OverrideError):
    """A bad variant, override or option of a study: ``where`` names it, ``rule`` says
    what."""


def expand(variants) -> list[dict]:
    """A list of override dicts from a list (as is) or a grid (Cartesian product)."""
    if isinstance(variants, dict):
        names = list(variants)
        for n in names:
            if not isinstance(variants[n], (list, tuple, np.ndarray)):
                raise BatchError(n, "a grid maps each field to a list of values")
        return [dict(zip(names, combo))
                for combo in itertools.product(*(list(variants[n]) for n in names))]
    return [dict(v) for v in variants]


TEXT_COLUMNS = ("error", "status", "model")
COUNT_COLUMNS = ("impacts", "contacts", "liftoffs", "steps", "rhs_evaluations")


@dataclass(repr=False)
class Batch:
    """The variants and what each gave (one row per variant, in order).  A refused
    variant's row holds only ``error``; a row that ran has no ``error``."""

    variants: list
    rows: list                       # dicts of SUMMARY_COLUMNS (or errors)
    results: list = field(default_factory=list)      # keep = "result"
    seconds: float = 0.0
    executor: str = "serial"
    workers: int = 1
    tasks: int = 0                   # how many tasks the variants ran in
    connect_s: float | None = None   # seconds connecting to a Dask scheduler
    ready_s: list = field(default_factory=list)   # per task: readying the runtime library
    task_s: list = field(default_factory=list)    # per task: seconds in its worker

    def __repr__(self) -> str:               # (the rows and results can be thousands)
        refused = sum("error" in r for r in self.rows)
        return (f"<Batch of {len(self.rows)} variants ({refused} refused) in "
                f"{self.seconds:.3g} s on {self.executor} ({count(self.workers, 'worker')})>")

    def column(self, name: str) -> np.ndarray:
        """One value per variant.  Text (``status``, ``model``, ``error``): an object
        array with None where there is none (a refused variant has no status, one that
        ran no error).  Numbers: a NumPy masked array, integers for the counts and
        floats for times and heights, masked where the variant was refused
        (``first_contact_t`` is NaN, not masked, when a run had no resting contact).  A
        field the variants override (``"body.mass"``): its values, a masked float array
        when they are numbers (masked where a variant leaves the field alone), else an
        object array with None."""
        if name in TEXT_COLUMNS:
            return _objects([r.get(name) for r in self.rows])
        if name in SUMMARY_COLUMNS:
            kind = np.int64 if name in COUNT_COLUMNS else np.float64
            missing = np.array([name not in r for r in self.rows], dtype=bool)
            data = np.array([r.get(name, 0) for r in self.rows], dtype=kind)
            return np.ma.MaskedArray(data, mask=missing)
        if any(name in v for v in self.variants):
            values = [v.get(name) for v in self.variants]
            if all(v is None or (isinstance(v, (int, float, np.integer, np.floating))
                                 and not isinstance(v, bool)) for v in values):
                return np.ma.MaskedArray([0.0 if v is None else float(v) for v in values],
                                         mask=[v is None for v in values])
            return _objects(values)
        fields = self._fields()
        raise BatchError("column", f"{name!r} is not a column (columns: "
                                   f"{', '.join(['error', *SUMMARY_COLUMNS, *fields])})")

    def _fields(self) -> list:
        """The fields the variants override, in the order they were given (a sweep's
        axes as typed)."""
        return list(dict.fromkeys(k for v in self.variants for k in v))

    def to_csv(self, path) -> None:
        """One row per variant: the fields it overrides, ``error``, then the summary
        columns; a value a row does not have (a refused variant's counts, the error of
        one that ran) is an empty cell."""
        names = self._fields()
        cols = list(names) + ["error", *SUMMARY_COLUMNS]
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(",".join(c.replace(".", "_").replace("[", "_").replace("]", "")
                              for c in cols) + "\n")
            for v, r in zip(self.variants, self.rows):
                vals = [v.get(n, "") for n in names] + [r.get("error", "")] + \
                    [r.get(c, "") for c in SUMMARY_COLUMNS]
                fh.write(",".join(_csv(x) for x in vals) + "\n")


def _objects(values: list) -> np.ndarray:
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def _csv(x) -> str:
    if isinstance(x, float):
        return repr(x)
    text = str(x)
    return '"' + text.replace('"', '""') + '"' if ("," in text or '"' in text) else text


def summary_row(result) -> dict:
    """The summary of one :class:`~derive.runtime.driver.Result` (the columns of
    :func:`_summary_rows`, which a batch fills in C)."""
    ev = result.event_rows
    contact = ev[ev[:, 1] == abi.index(abi.EVENT_KINDS, "contact")] if len(ev) else ev
    s = result.stats
    t_end = float(result.t[-1])
    return {"status": result.status, "model": result.model, "t_end": t_end,
            "impacts": s["impacts"], "contacts": s["contacts"], "liftoffs": s["liftoffs"],
            "steps": s["steps"], "rhs_evaluations": s["rhs_evaluations"],
            "min_height": result.min_height,
            "first_contact_t": float(contact[0, 0]) if len(contact) else math.nan,
            "Z_C_end": choice.height_of_c(result.scene, result.model, t_end,
                                          result.model_q[-1]),
            "run_ms": 1e3 * result.timings.get("run_s", math.nan)}


_STAT = {name: k for k, name in enumerate(abi.names(abi.STATS))}
_SUMMARY = {name: k for k, name in enumerate(abi.names(abi.SUMMARY))}


def _summary_rows(preps: list, session) -> list:
    """The summary rows of prepared variants of one model and one law: all of them in
    one call into C (no Python per run), the C time shared equally in ``run_ms``."""
    out = session.run_many([p.scene.t0 for p in preps],
                           [p.scene.t0 + p.scene.duration for p in preps],
                           np.array([p.start.q0 for p in preps]),
                           np.array([p.options for p in preps]),
                           np.array([p.parameters for p in preps]))
    ms = 1e3 * out["seconds"] / len(preps)
    stats, summ, last = out["stats"].tolist(), out["summary"], out["last"]
    rows = []
    for i, p in enumerate(preps):
        if out["init_status"][i] != abi.STATUS["ok"]:
            # crt_init again on this run's inputs: the C then names what it refused
            status = session.init_status(p.options, p.parameters, p.scene.t0, p.start.q0)
            rows.append({"error": str(session._refused(status))})
            continue
        st, t_end = stats[i], float(last[i, 0])
        rows.append({"status": abi.status_name(int(out["status"][i])), "model": p.kind,
                     "t_end": t_end,
                     "impacts": st[_STAT["impacts"]], "contacts": st[_STAT["contacts"]],
                     "liftoffs": st[_STAT["liftoffs"]], "steps": st[_STAT["steps"]],
                     "rhs_evaluations": st[_STAT["rhs_evaluations"]],
                     "min_height": float(summ[i, _SUMMARY["min_height"]]),
                     "first_contact_t": float(out["first_contact"][i]),
                     "Z_C_end": choice.height_of_c(p.scene, p.kind, t_end, last[i, 1:]),
                     "run_ms": ms})
    return rows


# Fields whose change reaches only the initial state (and the rule that S starts on or
# above the plane) or only the parameter vector: a variant that changes nothing else
# reuses the base scene's validation, model choice and options instead of redoing them
# (tests/test_batch.py checks that it equals the full path on random variants).
_STATE_FIELDS = {"[initial].com": "com", "[initial].com_velocity": "com_velocity"}
_PARAMETER_FIELDS = {"[plane].restitution": "e", "[run].g": "g"}
_PARAMETER_VALUES = frozenset(_PARAMETER_FIELDS.values())


def _quick_variant(base, v: dict, touched: set, label: str, doc: _VariantDoc):
    """The prepared variant by the fast path, or None when its fields need the full one."""
    changes = {}
    initial = base.scene.doc.get("initial", {})
    derived = initial.get("on_plane") or "carrier_velocity" in initial   # C's start computed
    for where in touched:
        attr = _STATE_FIELDS.get(where) or _PARAMETER_FIELDS.get(where)
        if attr is None or (attr == "e" and not base.scene.plane) or \
                (attr in ("com", "com_velocity") and derived):
            return None
        changes[attr] = v[where]
    scene = Scene.of_fields(base.scene.__dict__, **changes, source=label, doc_source=doc)
    if "com" in changes:
        check_start_above_plane(scene)
    st = choice.start(scene, base.kind)
    same = not (changes.keys() & _PARAMETER_VALUES or st.constants or base.start.constants)
    return Prepared(scene, base.kind, base.why, st, base.options,
                    base.parameters if same else choice.parameters(scene, st.constants))


class _VariantDoc:
    """A variant's scene dict (:attr:`Scene.doc`): the base's with the variant's
    overrides, made only when read."""
    __slots__ = ("_base", "_overrides")

    def __init__(self, base: dict, overrides: dict):
        self._base, self._overrides = base, overrides

    def get(self) -> dict:
        doc = copy.deepcopy(self._base)
        for name, value in self._overrides.items():
            overrides.apply_to_doc(doc, name, copy.deepcopy(value))
        return doc


def _differing_field(a: Scene, b: Scene) -> str | None:
    """The first field in which two Scenes differ (the law by its text or samples, the
    attitude by its matrix), or None."""
    for f in dataclass_fields(Scene):
        if f.name in ("doc_source", "law_summary", "source"):
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "A0":
            same = np.array_equal(x, y)
        elif f.name == "law":
            same = a.law_text == b.law_text and (bool(a.law_text) or (
                np.array_equal(x.knots, y.knots) and np.array_equal(x.coef, y.coef)))
        else:
            same = x == y
        if not same:
            return f.name
    return None


def _run_task(task: tuple) -> tuple[list, float, float]:
    """Runs in a worker: (rows of :func:`_run_chunk`, seconds readying the runtime
    library (loading it, or building it on a machine that has not: a worker's first
    task), seconds in all)."""
    start = time.perf_counter()
    ready = [0.0]
    out = _run_chunk(task, ready)
    return out, ready[0], time.perf_counter() - start


def _session(kind: str, ready: list):
    """This thread's session of a model, the time it took added to ``ready[0]`` (nothing
    but the first time in a thread)."""
    start = time.perf_counter()
    session = session_for(kind)
    ready[0] += time.perf_counter() - start
    return session


def _run_chunk(task: tuple, ready: list) -> list:
    """(base doc, origin, [(index, overrides)], keep) -> rows.  The base scene's fields
    are read once; a variant re-validates only what it overrides, then every cross-field
    rule (the law's analysis is cached by its text).  Summaries: the valid variants are
    grouped by model and law and each group runs in one call into C; whole results: one
    run per variant."""
    base, origin, items, keep = task
    try:
        base_v, base_given = SCENE.read(base)
    except SceneError as exc:
        return [(index, {"error": f"base scene: {exc}"}, None) for index, _ in items]
    try:
        base_prep = prepare(build_scene(dict(base_v), set(base_given), _VariantDoc(base, {}),
                                        "base scene", base=origin))
    except SceneError:
        base_prep = None                   # a variant may still make it valid
    out, groups = [], {}
    for index, changes in items:
        v, given = dict(base_v), set(base_given)
        try:
            touched = {overrides.apply_to_values(v, given, name, value)
                       for name, value in changes.items()}
            label = f"variant {index}"
            doc = _VariantDoc(base, changes)
            prep = _quick_variant(base_prep, v, touched, label, doc) if base_prep else None
            if prep is None:
                prep = prepare(build_scene(v, given, doc, label, base=origin))
            if keep == "result":
                result = run_prepared(prep, _session(prep.kind, ready))
                out.append((index, summary_row(result), result))
                continue
        except SceneError as exc:
            out.append((index, {"error": f"variant {index}: {exc}"}, None))
            continue
        groups.setdefault((prep.kind, id(prep.scene.law)), []).append((index, prep))
    for (kind, _), members in groups.items():
        session = _session(kind, ready)
        session.set_law(members[0][1].scene.law)
        rows = _summary_rows([p for _, p in members], session)
        for (index, _), row in zip(members, rows):
            if "error" in row:
                row = {"error": f"variant {index}: {row['error']}"}
            out.append((index, row, None))
    return out


def simulate_many(scene, variants, workers: int | None = None, scheduler: str | None = None,
                  keep: str = "summary", progress: bool = False, chunk: int | None = None,
                  strict: bool = True, executor: str = "threads") -> Batch:
    """Run ``variants`` (a list of override dicts, or a grid dict of lists) of ``scene``
    (a path, a dict or a Scene).  ``strict``: raise on the first invalid variant (else
    its row holds the error).  See the module's docstring."""
    from pathlib import Path
    if keep not in ("summary", "result"):
        raise BatchError("keep", f"must be 'summary' or 'result' (got {keep!r})")
    origin = None
    if isinstance(scene, Scene):
        # the Scene's own dict, which must still give that Scene (one changed with
        # dataclasses.replace, or made by hand, does not: its variants would be of another)
        base = scene.doc
        try:
            again = parse_scene(base, scene.source) if base else None
        except SceneError:
            again = None
        differs = _differing_field(again, scene) if again is not None else "doc"
        if differs:
            raise BatchError("scene", f"is a Scene whose {differs} is not what its scene dict "
                                      "gives (changed after parsing?): pass the dict or the "
                                      "file, with the change in it")
    elif isinstance(scene, dict):
        base = copy.deepcopy(scene)
    else:
        sc = load_scene(scene)
        base, origin = sc.doc, Path(scene).parent
    items = list(enumerate(expand(variants)))
    for k, v in items:                  # a field that does not exist fails the study
        for name in v:
            overrides.target(name, f"variant {k}")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int)
                              or chunk < 1):
        raise BatchError("chunk", f"must be a whole number >= 1 (got {chunk!r})")
    start = time.perf_counter()
    n_items = len(items)

    def tasks(threads: int) -> list:
        size = chunk or default_chunk(n_items, threads, cluster=bool(scheduler))
        return [(base, origin, items[k:k + size], keep) for k in range(0, n_items, size)]
    if workers is None and scheduler is None and n_items <= 8:
        workers = 1
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("variants")
    done = [0]

    def collect(_index, task):
        done[0] += len(task[0])
        if bar:
            bar.update(done[0] / n_items, f"{done[0]}/{n_items}")
    try:                                     # the base scene's model, loaded before the
        prepare(base if origin is None else scene).library     # workers fork
    except SceneError:
        pass
    info: dict = {}
    try:
        done_tasks, executor, n_workers = parallel.run(_run_task, tasks, workers, scheduler,
                                                       collect, local=executor, info=info)
    except parallel.ExecutorError as exc:
        raise BatchError(exc.where, exc.rule) from None
    if bar:
        bar.close()
    rows: list = [None] * n_items
    results: list = [None] * n_items if keep == "result" else []
    for ch, _, _ in done_tasks:
        for index, row, res in ch:
            rows[index] = row
            if keep == "result":
                results[index] = res
    if strict:
        bad = next((r for r in rows if "error" in r), None)
        if bad is not None:
            raise BatchError("variants", bad["error"])
    return Batch([v for _, v in items], rows, results, time.perf_counter() - start, executor,
                 n_workers, len(done_tasks), info.get("connect_s"),
                 [t[1] for t in done_tasks], [t[2] for t in done_tasks])


# A run of the built-in scene costs 0.1 ms of C, a Dask task 0.2 ms and more of
# scheduling, pickling and round trip, plus the base scene's validation in _run_chunk:
# about 2 ms a task in all (4000 variants on a local cluster of two workers: 250 tasks
# of 16 took 1.23 s in the workers, 2 of 2000 took 0.79 s).  So on a cluster a task
# holds hundreds of variants at least.
CLUSTER_CHUNK = (256, 10_000)


def default_chunk(n: int, threads: int, cluster: bool = False) -> int:
    """Variants per task for ``n`` variants on ``threads`` worker threads.  Local: a few
    tasks per thread, enough to balance, at most 64 variants each.  A Dask cluster: two
    tasks per worker thread, of CLUSTER_CHUNK[0] to CLUSTER_CHUNK[1] variants each (a
    task holds at most about a second of runs, so that a lost worker costs little)."""
    threads = max(threads, 1)
    if cluster:
        lo, hi = CLUSTER_CHUNK
        return min(hi, max(lo, -(-n // (2 * threads))))
    return max(1, min(64, n // (4 * threads) or 1))
