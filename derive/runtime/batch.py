"""Parameter studies: ``derive.simulate_many(scene, variants)`` runs many variants of one
scene through the precompiled runtime, with no compilation and no Python per step -- nor
per variant where the variants vary the numbers a study varies most.

Variants are overrides of the scene's fields by dotted name (``"body.mass"``,
``"plane.restitution"``, ``"initial.com"``, ``"point.law"``, ...): a list of dicts, one
per variant, or a grid, a dict of lists whose Cartesian product is taken.  Each variant
is validated like any scene (so a bad value is refused naming the variant and the
field) and its model chosen: in bulk, NumPy over a group of variants, where they
override only fields of :data:`derive.scene.bulk.BULK`, else one at a time
(:mod:`derive.runtime.study`).  What comes back per variant is a summary (``keep =
"summary"``: the variants of one model and law run in calls into C that keep per run
only what the summary reads; the columns are sliced out of the C's arrays) or the
whole :class:`~derive.runtime.driver.Result` (``keep = "result"``).

Workers are local threads (``workers``, default every core: the C releases the GIL, so
threads run it in parallel with nothing to start or pickle; the study is planned once,
here, and the threads run its chunks), local processes (``executor = "processes"``) or a
Dask cluster (``scheduler``), through :mod:`derive.parallel`; those plan and run their
own chunks of the variants.
"""
from __future__ import annotations

import copy
import itertools
import time
from dataclasses import dataclass, field, fields as dataclass_fields
from functools import cached_property

import numpy as np

from .. import parallel
from ..progress import count
from . import study
from .driver import prepare
from .study import COUNT_COLUMNS, FRICTION_COLUMNS, SUMMARY_COLUMNS, TEXT_COLUMNS  # noqa: F401 (the API's names)
from ..scene import Scene, SceneError, load_scene, overrides, parse_scene


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


@dataclass(repr=False)
class Batch:
    """The variants and what each gave, in order: ``columns`` (name -> one entry per
    variant: ``error`` and the summary columns), read through :meth:`column`; ``rows``,
    the same as one dict per variant (a refused variant's holds only ``error``, one that
    ran has no ``error``), made when first read."""

    variants: list
    columns: dict
    results: list = field(default_factory=list)      # keep = "result"
    seconds: float = 0.0
    executor: str = "serial"
    workers: int = 1
    tasks: int = 0                   # how many tasks the variants ran in
    connect_s: float | None = None   # seconds connecting to a Dask scheduler
    ready_s: list = field(default_factory=list)   # per task: readying the runtime library
    task_s: list = field(default_factory=list)    # per task: seconds in its worker

    def __repr__(self) -> str:               # (the rows and results can be thousands)
        refused = int(self._refused.sum())
        return (f"<Batch of {len(self.variants)} variants ({refused} refused) in "
                f"{self.seconds:.3g} s on {self.executor} ({count(self.workers, 'worker')})>")

    @property
    def _refused(self) -> np.ndarray:
        return self.columns["error"] != None           # noqa: E711 (entry by entry)

    @cached_property
    def rows(self) -> list:
        """One dict per variant: ``error`` alone for a refused one, else the summary
        columns (Python numbers and strings)."""
        listed = {name: self.columns[name].tolist() for name in ("error", *SUMMARY_COLUMNS)}
        out = []
        for k, err in enumerate(listed["error"]):
            out.append({"error": err} if err is not None else
                       {name: listed[name][k] for name in SUMMARY_COLUMNS})
        return out

    def column(self, name: str) -> np.ndarray:
        """One value per variant.  Text (``status``, ``model``, ``error``): an object
        array with None where there is none (a refused variant has no status, one that
        ran no error).  Numbers: a NumPy masked array, integers for the counts and
        floats for times and heights, masked where the variant was refused (and the
        ``slips``, ``sticks``, ``reversals`` where the run has no friction to count them:
        neither a rough model's nor a base run nor one that handed over at a lift-off;
        ``first_contact_t`` and
        ``handover_t`` are NaN, not masked, when a run had no resting contact, no
        hand-over).  A
        field the variants override (``"body.mass"``): its values, a masked float array
        when they are numbers (masked where a variant leaves the field alone), else an
        object array with None."""
        if name in TEXT_COLUMNS:
            return self.columns[name].copy()
        if name in SUMMARY_COLUMNS:
            mask = self._refused
            if name in FRICTION_COLUMNS:
                mask = mask | ~study.counts_friction(self.columns["model"],
                                                     self.columns["handover_t"])
            return np.ma.MaskedArray(self.columns[name].copy(), mask=mask)
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

    def to_csv(self, path, swept_by: dict | None = None) -> None:
        """One row per variant: its number ``variant`` (from 1, as the studies' messages
        count them: variant 1 is the first, ``rows[0]``), the fields it overrides (a
        formula swept by one of its numbers, ``swept_by`` {field:
        :class:`~derive.scene.overrides.Formulas`}, followed by that number's column, W
        say: :func:`csv_columns`), ``error``, then the summary columns; a value a
        row does not have (a refused variant's counts, the error of one that ran, a base
        run's impacts, contacts, min_height and first_contact_t: a body on its face has
        no impact and no point S; the slips, sticks and reversals of a run without
        friction, neither a rough model's nor one that began on a face) is an empty
        cell."""
        names = self._fields()
        swept_by = swept_by or {}
        head = csv_columns(names, swept_by)
        number = {n: dict(zip(f, f.numbers)) for n, f in swept_by.items()}
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(",".join(head) + "\n")
            for k, (v, r) in enumerate(zip(self.variants, self.rows)):
                vals = [k + 1]
                for n in names:
                    vals.append(v.get(n, ""))
                    if n in number:
                        vals.append(number[n].get(v.get(n), ""))
                if "error" in r:
                    blank = ()                    # (a refused row: every cell empty)
                elif r["model"] == "base":
                    blank = BASE_BLANK
                else:
                    counted = study.counts_friction(r["model"], r["handover_t"])
                    blank = () if counted else FRICTION_COLUMNS
                vals += [r.get("error", "")] + [
                    "" if c in blank else r.get(c, "") for c in SUMMARY_COLUMNS]
                fh.write(",".join(_csv(x) for x in vals) + "\n")


def csv_columns(names: list, swept_by: dict | None = None) -> list:
    """sweep.csv's header: ``variant``, each overridden field (``point.law[2]`` as
    ``point_law_2``) followed, where a formula is swept by one of its numbers
    (``swept_by``), by that number's name, then ``error`` and the summary columns.  A
    name twice (two formulas swept by numbers of one name, W and W) is refused: its
    columns could not be told apart."""
    swept_by = swept_by or {}
    fixed = ("variant", "error", *SUMMARY_COLUMNS)
    head, owner = ["variant"], {}
    for n in names:
        column = n.replace(".", "_").replace("[", "_").replace("]", "")
        head.append(column)
        owner.setdefault(column, f"the column of {n}")
        if n in swept_by:
            symbol = swept_by[n].symbol
            if symbol in owner or symbol in fixed:
                other = owner.get(symbol, f"sweep.csv's column {symbol}")
                raise BatchError("--sweep", f"{n}: {symbol}, the name of its swept number, "
                                            f"already names {other}: sweep.csv would have "
                                            "two columns of that name; give each swept "
                                            "number its own name")
            head.append(symbol)
            owner[symbol] = f"the swept number of {n}"
    return head + ["error", *SUMMARY_COLUMNS]


# the summary columns that mean nothing for a base run (no impact, no point S)
BASE_BLANK = frozenset(("impacts", "contacts", "min_height", "first_contact_t"))


def _objects(values: list) -> np.ndarray:
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def _csv(x) -> str:
    if isinstance(x, float):
        return repr(x)
    text = str(x)
    return '"' + text.replace('"', '""') + '"' if ("," in text or '"' in text) else text


def _differing_field(a: Scene, b: Scene) -> str | None:
    """The first field in which two Scenes differ (the law by its text or samples, the
    attitude by its matrix), or None."""
    for f in dataclass_fields(Scene):
        if f.name in ("doc_source", "law_summary", "source"):
            continue
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "A0":
            same = np.array_equal(x, y)
        elif f.name == "law":               # None for the moments family ([[point]] lists)
            same = a.law_text == b.law_text and (bool(a.law_text) or (x is None and y is None)
                                                 or (x is not None and y is not None and
                                                     np.array_equal(x.knots, y.knots) and
                                                     np.array_equal(x.coef, y.coef)))
        else:
            same = x == y
        if not same:
            return f.name
    return None


# ---- tasks: what a worker runs -----------------------------------------------------------
def _run_task(task: tuple) -> tuple:
    """Runs in a worker: (the variants' numbers, their columns, their whole results or
    None, seconds readying the runtime library (loading it, or building it on a machine
    that has not: a worker's first task), seconds in all).  A task is a chunk of a part
    (``("part", Part)``), variants one at a time (``("singles", base, origin, items,
    keep)``) or, on processes and Dask, variants to plan and run here (``("plan", base,
    origin, items, keep)``)."""
    start = time.perf_counter()
    ready = [0.0]
    what = task[0]
    if what == "part":
        index, cols, results = task[1].index, study.run_part(task[1], ready), None
    elif what == "singles":
        _, base, origin, items, keep = task
        index = np.array([i for i, _ in items], dtype=int)
        cols, results = study.run_singles(base, origin, items, keep, ready)
    else:
        _, base, origin, items, keep = task
        found = study.plan(base, origin, items, keep)
        pieces = [(p.index, study.run_part(p, ready), None) for p in found.parts]
        if found.singles:
            cols, results = study.run_singles(base, origin, found.singles, keep, ready)
            pieces.append((np.array([i for i, _ in found.singles], dtype=int), cols,
                           results))
        index, cols, results = _joined(pieces, keep)
    return index, cols, results, ready[0], time.perf_counter() - start


def _joined(pieces: list, keep: str) -> tuple:
    index = np.concatenate([p[0] for p in pieces]) if pieces else np.zeros(0, dtype=int)
    cols = study.empty_columns(len(index))
    results = [] if keep == "result" else None
    at = 0
    for idx, c, res in pieces:
        for name, col in c.items():
            cols[name][at:at + len(idx)] = col
        if results is not None:
            results += res if res is not None else [None] * len(idx)
        at += len(idx)
    return index, cols, results


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
    _check_names(items)
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int)
                              or chunk < 1):
        raise BatchError("chunk", f"must be a whole number >= 1 (got {chunk!r})")
    start = time.perf_counter()
    n_items = len(items)
    if workers is None and scheduler is None and n_items <= 8:
        workers = 1
    # local threads share this process: the study is planned once, here; processes and
    # Dask workers plan their own chunks (nothing but the variants is sent to them)
    here = scheduler is None and (executor == "threads" or workers == 1)
    planned = study.plan(base, origin, items, keep) if here else None

    def tasks(threads: int) -> list:
        if planned is None:                  # a task plans (reads in bulk) its variants
            size = chunk or (default_chunk(n_items, threads, cluster=True) if scheduler
                             else part_chunk(n_items, threads))
            return [("plan", base, origin, items[k:k + size], keep)
                    for k in range(0, n_items, size)]
        out = [("part", piece) for part in planned.parts
               for piece in part.pieces(chunk or part_chunk(len(part), threads))]
        size = chunk or default_chunk(len(planned.singles), threads)
        return out + [("singles", base, origin, planned.singles[k:k + size], keep)
                      for k in range(0, len(planned.singles), size)]
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("variants")
    done = [0]

    def collect(_index, task):
        done[0] += len(task[0])
        if bar:
            bar.update(done[0] / n_items, f"{done[0]}/{n_items}")
    if planned is None:
        try:                                     # the base scene's model, loaded before
            prepare(base if origin is None else scene).library     # the workers fork
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
    cols = study.empty_columns(n_items)
    results: list = [None] * n_items if keep == "result" else []
    for index, got, res, _, _ in done_tasks:
        for name, col in got.items():
            cols[name][index] = col
        if keep == "result" and res is not None:
            for i, r in zip(index.tolist(), res):
                results[i] = r
    if strict:
        refused = np.flatnonzero(cols["error"] != None)       # noqa: E711 (entry by entry)
        if len(refused):
            raise BatchError("variants", cols["error"][refused[0]])
    return Batch([v for _, v in items], cols, results, time.perf_counter() - start, executor,
                 n_workers, len(done_tasks), info.get("connect_s"),
                 [t[3] for t in done_tasks], [t[4] for t in done_tasks])


def _check_names(items: list) -> None:
    """A field that does not exist fails the study, naming the first variant that gives
    it (each set of names checked once)."""
    seen = set()
    for k, v in items:
        names = tuple(v)
        if names not in seen:
            seen.add(names)
            for name in names:
                overrides.target(name, f"variant {k + 1}")


# A run of the built-in scene costs 0.1 ms of C, a Dask task 0.2 ms and more of
# scheduling, pickling and round trip, plus its planning (the base scene read, a
# variant per model prepared alone: about 0.4 ms, then 2 us a variant): milliseconds a
# task in all (earlier, with a validation per variant: 4000 variants on a local cluster
# of two workers took 1.23 s in the workers in 250 tasks of 16, 0.79 s in 2 of 2000).
# So on a cluster a task holds hundreds of variants at least.
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


def part_chunk(n: int, threads: int) -> int:
    """Variants per call into C (or per task of local processes, which read them in bulk
    first) for ``n`` variants on ``threads`` local workers: four chunks per worker (to
    balance), of 8 to 10000 variants (a chunk's own cost, tens of microseconds of Python
    around the call, against the runs'; the progress bar's steps)."""
    return min(10_000, max(8, -(-n // (4 * max(threads, 1)))))
