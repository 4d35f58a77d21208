"""``derive verify fuzz``: seeded hostile scenes through the parser, the runtime and the
command line.

Scene files come from strangers.  :func:`derive.verify.generators.generate` makes, from
a seed, hostile cases in four families (scene mutations, laws, tabulated laws, TOML
text), each with what the README says must happen to it.  Each case runs

* through the API (``mode="api"``, :func:`run_api`): ``parse_scene`` and, if accepted,
  the simulation, in a sandboxed worker (:class:`derive.verify.sandbox.Worker`); an
  accepted law is compared with an independent evaluation of its value and first two
  derivatives and the run with what any honest run satisfies
  (:mod:`derive.verify.oracle`);
* or through the command line (``mode="cli"``, :func:`run_cli`): ``derive simulate`` in a
  subprocess with a private HOME and working folder (:func:`derive.verify.sandbox.run_cli`);

and is judged by :mod:`derive.verify.judges`.  ``run(n, seed, mode)`` returns the
outcomes, ``report(outcomes)`` a table and ``passed(outcomes)`` whether none is BAD.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

from ..commands import Target
from . import sandbox
from .generators import Case, base_scene, generate, table_rows
from .judges import (BAD, CLI_LIMIT_S, GOOD, PARSE_LIMIT_S, RUN_LIMIT_S, Outcome, judge_api,
                     judge_cli)
from .oracle import check_laws, check_run

SIMULATE = ["simulate", "-q", "--no-plots", "scene.toml", "-o", "out"]


# ---- through the API: what the sandboxed worker does with a job --------------------------
def evaluate(job: dict) -> dict:
    """Parse (and run) one case; the answer as a dict for :func:`judges.judge_api`."""
    import warnings
    from ..scene import SceneError, load_scene, parse_scene
    out: dict = {"status": "accepted", "warnings": []}
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if job.get("path"):
                scene = load_scene(job["path"])
            else:
                src = job["doc"] if job.get("doc") is not None else job["text"]
                if isinstance(src, bytes):
                    src = src.decode("utf-8", errors="strict")
                scene = parse_scene(src, "fuzz", Path(job["base"]) if job.get("base")
                                    else None)
        except SceneError as exc:
            return {"status": "refused", "where": getattr(exc, "where", None),
                    "rule": getattr(exc, "rule", None), "message": str(exc),
                    "seconds": time.perf_counter() - start}
        except BaseException as exc:
            return {"status": "error", "type": type(exc).__name__,
                    "message": str(exc)[:300], "tb": traceback.format_exc()[-3000:],
                    "seconds": time.perf_counter() - start}
        out["seconds"] = time.perf_counter() - start
        out["warnings"] += [f"{w.category.__name__}: {w.message}" for w in caught]
    # the law against an independent evaluation
    problems = []
    if job.get("laws"):
        try:
            problems += check_laws(scene, job["laws"], job["window"], job["size"])
        except Exception:
            problems.append("fuzzer-error: " + traceback.format_exc()[-600:])
    out["problems"] = problems
    if job.get("simulate"):
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                from ..runtime.driver import simulate
                result = simulate(scene)
            except SceneError as exc:
                return {"status": "refused", "where": getattr(exc, "where", None),
                        "rule": getattr(exc, "rule", None), "message": str(exc),
                        "late": True, "seconds": out["seconds"]}
            except BaseException as exc:
                return {"status": "error", "type": type(exc).__name__,
                        "message": str(exc)[:300], "tb": traceback.format_exc()[-3000:],
                        "seconds": time.perf_counter() - start, "stage": "simulate"}
            out["run_seconds"] = time.perf_counter() - start
            out["run_status"] = result.status
            try:
                problems += check_run(result, job)
            except Exception:
                problems.append("fuzzer-error: " + traceback.format_exc()[-600:])
            out["warnings"] += [f"{w.category.__name__}: {w.message}" for w in caught]
    return out


def run_api(cases: list[Case], simulate: bool = True, parse_limit: float = PARSE_LIMIT_S,
            run_limit: float = RUN_LIMIT_S, progress=None) -> list[Outcome]:
    """Each case through ``parse_scene`` (and ``simulate`` when accepted) in a worker."""
    from .. import scene  # noqa: F401  (imported once, before the fork)
    from ..runtime import driver  # noqa: F401
    warm = base_scene()                     # table laws import their own modules
    warm["point"] = {"mass": 0.2, "samples": table_rows()}
    try:
        scene.parse_scene(warm, "warm-up")
    except Exception:
        pass
    if simulate:
        from ..runtime.build import library
        library("general")
    out = []
    tmp = Path(tempfile.mkdtemp(prefix="derive-fuzz-"))
    outside = sandbox.write_outside(tmp / "outside.csv")
    worker = sandbox.Worker(evaluate)
    try:
        for case in cases:
            folder = tmp / f"c{case.index}" / "scene"
            job = {"simulate": simulate, "laws": case.laws, "window": case.window,
                   "size": case.size}
            doc = sandbox.case_doc(case, outside)
            if doc is not None and not (case.files or sandbox.has_table(doc)):
                job["doc"] = doc
            else:
                job["path"] = str(sandbox.lay_out(case, folder, outside))
            limit = parse_limit + (run_limit if simulate else 0.0) + 1.0
            res = worker.call(job, limit)
            if res.get("status") == "timeout" and simulate:
                # a hang in validation or in the run? ask once more without the run
                res2 = worker.call({**job, "simulate": False}, parse_limit + 1.0)
                if res2.get("status") != "timeout":
                    res = {**res2, "run_seconds": limit, "run_status": "timeout"}
                    o = judge_api(case, res, run_limit)
                    if not o.bad:
                        o = Outcome(case, "hang", f"run past {limit:.0f} s", limit)
                    out.append(o)
                    continue
            out.append(judge_api(case, res, run_limit))
            shutil.rmtree(tmp / f"c{case.index}", ignore_errors=True)
            if progress and len(out) % 100 == 0:
                progress(f"{len(out)}/{len(cases)}")
    finally:
        worker.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return out


# ---- through the command line ----------------------------------------------------------
def run_cli_one(case: Case, cache: Path, limit: float = CLI_LIMIT_S,
                keep: bool = False) -> Outcome:
    """``derive simulate scene.toml -o out`` on the case in the sandbox, judged."""
    return judge_cli(case, sandbox.run_cli(case, SIMULATE, cache, limit, keep=keep), limit)


def run_cli(cases: list[Case], cache: Path | None = None, limit: float = CLI_LIMIT_S,
            workers: int = 2, progress=None) -> list[Outcome]:
    """The cases through ``derive simulate``, ``workers`` at once; a fresh runtime cache
    unless one is given."""
    from concurrent.futures import ThreadPoolExecutor
    own = cache is None
    cache = cache or Path(tempfile.mkdtemp(prefix="derive-fuzz-cache-"))
    try:
        with ThreadPoolExecutor(workers) as pool:
            out = []
            for o in pool.map(lambda c: run_cli_one(c, cache, limit), cases):
                out.append(o)
                if progress and len(out) % 20 == 0:
                    progress(f"{len(out)}/{len(cases)}")
        return out
    finally:
        if own:
            shutil.rmtree(cache, ignore_errors=True)


# ---- the command -------------------------------------------------------------------
def run(n: int = 2000, seed: int = 12, mode: str = "both", simulate: bool = True,
        progress=None, cli_cases: int | None = None,
        workers: int | None = None) -> list[Outcome]:
    """n seeded cases through the API (``mode="api"``), the command line (``"cli"``) or
    both (``"both"``: all through the API, the first ``cli_cases`` (default a tenth) also
    through the CLI, ``workers`` at once)."""
    cases = generate(n, seed)
    out = []
    if mode in ("api", "both"):
        out += run_api(cases, simulate=simulate, progress=progress)
    if mode in ("cli", "both"):
        sub = cases if mode == "cli" else cases[: (cli_cases or max(1, n // 10))]
        out += run_cli(sub, workers=workers or os.cpu_count() or 1, progress=progress)
    return out


def targets(outcomes: list[Outcome]) -> list[Target]:
    bad = sum(o.bad for o in outcomes)
    return [Target(f"goal: no BAD outcome ({bad} of {len(outcomes)})", bad == 0)]


def passed(outcomes: list[Outcome]) -> bool:
    return all(t.ok for t in targets(outcomes))


def report(outcomes: list[Outcome], limit: int = 60) -> str:
    from collections import Counter
    counts = Counter(o.verdict for o in outcomes)
    secs = np.array([o.seconds for o in outcomes]) if outcomes else np.zeros(1)
    lines = [f"{len(outcomes)} hostile cases: " +
             ", ".join(f"{k} {counts[k]}" for k in GOOD + BAD if counts.get(k)),
             f"time per case: median {1e3 * np.median(secs):.1f} ms, max {secs.max():.2f} s"]
    fams = Counter((o.case.family, o.verdict) for o in outcomes)
    for fam in ("scene", "law", "table", "toml", "explicit"):
        row = {v: c for (f, v), c in fams.items() if f == fam}
        if row:
            lines.append(f"  {fam:6s} " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    bad = [o for o in outcomes if o.bad]
    seen = set()
    for o in bad:
        key = (o.verdict, o.case.family, o.detail[:50])
        if key in seen:
            continue
        seen.add(key)
        if len(seen) > limit:
            break
        lines.append(f"  BAD {o.verdict} #{o.case.index} [{o.case.short()}]: {o.detail}")
    groups: dict = {}
    for o in bad:
        groups.setdefault(o.verdict, []).append(f"#{o.case.index} {o.case.short()[:50]}")
    for v, items in groups.items():
        lines.append(f"  {v} ({len(items)}): " + "; ".join(items[:40]))
    lines += [str(t) for t in targets(outcomes)]
    return "\n".join(lines)
