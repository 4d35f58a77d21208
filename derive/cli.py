"""The ``derive`` command line.

Exit status: 0 success, 1 a check or comparison failed, 2 bad input (the message names
the field and the rule; no traceback).
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence

from . import shapes
from .progress import count


class UsageError(Exception):
    """Bad input from the user: printed as one line, exit status 2."""


# ---- equations --------------------------------------------------------------------
def cmd_equations(args: argparse.Namespace) -> int:
    from .equations import BUILDERS, compact, derived, render_latex, render_text
    ids = [args.id] if args.id else list(BUILDERS)
    for eid in ids:
        if eid not in BUILDERS:
            raise UsageError(f"--id: {eid!r} is not a derived equation; "
                             f"choose one of {', '.join(BUILDERS)}")
    render = render_latex if args.latex else render_text
    for k, eid in enumerate(ids):
        if k:
            print()
        entry = derived(eid)
        print(render(compact(entry) if args.compact else entry))
    return 0


# ---- prove ------------------------------------------------------------------------
def _load_paper_checks():
    try:
        from paper_checks import catalogue, runner
    except ImportError as exc:
        raise UsageError("prove: the paper_checks/ folder is not importable from here "
                         f"({exc}); run from a checkout installed with pip install -e .")
    return catalogue, runner


def cmd_prove(args: argparse.Namespace) -> int:
    import time
    catalogue, runner = _load_paper_checks()
    entries = catalogue.entries()
    if args.section:
        entries = [e for e in entries if e.section in args.section]
    if args.id:
        known = {e.id for e in entries}
        bad = [i for i in args.id if i not in known]
        if bad:
            raise UsageError(f"--id: {', '.join(bad)} not in CLAIMS.md or EXTENSIONS.md "
                             f"(section filter {args.section or 'all'})")
        entries = [e for e in entries if e.id in args.id]
    start = time.perf_counter()
    outcomes, clipped = [], False
    width = max(len(e.id) for e in entries) if entries else 4
    print(f"{'ID':<{width}}  {'status':<8} {'seconds':>8}  detail")
    for entry in entries:
        outcome = runner.run(entry.id)
        outcomes.append(outcome)
        detail = _clip(outcome.detail, 90)
        clipped = clipped or detail != (outcome.detail or "")
        print(f"{entry.id:<{width}}  {outcome.status:<8} {outcome.seconds:8.2f}  {detail}",
              flush=True)
    total = time.perf_counter() - start
    errata = [er for o in outcomes for er in o.errata]
    if errata:
        print("\nErrata found by the checks:")
        for er in errata:
            print(f"  {er.id}: printed   {er.printed}\n"
                  f"  {' ' * len(er.id)}  correct   {er.correct}\n"
                  f"  {' ' * len(er.id)}  so        {er.consequence}")
    bad = [o for o in outcomes if o.status not in ("pass", "erratum")]
    counts = {s: sum(o.status == s for o in outcomes)
              for s in ("pass", "erratum", "fail", "error", "missing")}
    plural = {"erratum": "errata", "error": "errors"}
    summary = ", ".join(f"{v} {plural.get(k, k) if v > 1 else k}"
                        for k, v in counts.items() if v)
    print(f"\n{len(outcomes)} IDs in {total:.1f} s: {summary}")
    if clipped and not args.report:
        print("details cut at '…' are whole in the report: derive prove --report DIR")
    if args.report:
        from paper_checks.report import write_report
        paths = write_report(args.report, entries, outcomes)
        print("report: " + ", ".join(str(p) for p in paths))
    return 1 if bad else 0


def _clip(text: str | None, width: int) -> str:
    """The first line of `text`, ending in '…' where it is cut (at a line or at `width`)."""
    lines = (text or "").splitlines() or [""]
    first = lines[0]
    if len(first) > width:
        return first[:width - 1] + "…"
    return first + (" …" if len(lines) > 1 else "")


# ---- emit -------------------------------------------------------------------------
class _EmitProgress:
    """derive emit's progress on stderr (half a minute of SymPy and CSE had been silent):
    a line as each stage begins, and a bar through the functions and the models."""

    def __init__(self):
        self.bar, self.stage = None, None

    def __call__(self, stage: str, done: int, total: int, name: str) -> None:
        from .progress import Bar
        if stage != self.stage:
            self.close()
            self.stage = stage
            self.bar = Bar(f"emit: {stage}", delay=0.0) if total > 1 else None
            if self.bar is None:
                print(f"  emit: {stage} ...", file=sys.stderr, flush=True)
        if self.bar is not None:
            self.bar.update(done / total, f"{done}/{total} {name}")

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def cmd_emit(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path
    from . import paths
    from .emit import driver
    if args.output:
        root = Path(args.output)
    elif paths.CHECKOUT or args.check:
        root = paths.GENERATED
    else:
        raise UsageError(f"derive emit: the generated code of this installation "
                         f"({paths.GENERATED}) is not rewritten; render into a folder with "
                         "-o DIR")
    start = time.perf_counter()
    told = _EmitProgress() if not args.quiet else None
    try:
        files = driver.render_all(told)
    finally:
        if told is not None:
            told.close()
    if args.check:
        delta = driver.diff(files, root)
        if delta:
            sys.stdout.write(delta)
            print(f"\n{root} differs from a fresh render: run `derive emit`",
                  file=sys.stderr)
            return 1
        print(f"{root} matches a fresh render ({len(files)} files, "
              f"{time.perf_counter() - start:.1f} s)")
        return 0
    changed = driver.write(files, root)
    print(f"rendered {len(files)} files into {root} in {time.perf_counter() - start:.1f} s; "
          f"{len(changed)} changed" + (": " + ", ".join(changed) if changed else ""))
    return 0


# ---- simulate ---------------------------------------------------------------------
def _scene_doc(args) -> tuple[dict, object, str]:
    """(the scene as a dict with --set applied, its folder, its name for messages)."""
    from pathlib import Path
    from .scene import builtin_doc, load_scene, overrides
    if args.scene:
        doc, base, origin = load_scene(args.scene).doc, Path(args.scene).parent, args.scene
    else:
        doc, base, origin = builtin_doc(), None, "built-in scene"
    for name, value in _assignments(args):
        overrides.apply_to_doc(doc, name, value)
    return doc, base, origin


def _once(flag: str, texts, parse, twice: str) -> tuple[dict, list]:
    """Each of ``texts`` parsed (``parse``: name first), a field given twice refused by
    ``flag`` (the last would win silently); (where each field was given: its name, the
    parsed)."""
    from .scene import overrides
    seen, out = {}, []
    for text in texts or []:
        parsed = parse(text)
        name = parsed[0]
        where = overrides.target(name, flag).where
        if where in seen:
            also = f" (also as {seen[where]})" if seen[where] != name else ""
            raise overrides.OverrideError(flag, f"{name}: {twice.format(also=also)}")
        seen[where] = name
        out.append(parsed)
    return seen, out


def _assignments(args) -> list:
    """``--set``'s (name, value) pairs, each field once, none that ``--sweep`` also varies
    (the sweep would win)."""
    from .scene import overrides
    given, out = _once("--set", args.set, overrides.parse_assignment,
                       "is set twice{also}; give it once")
    for text in getattr(args, "sweep", None) or []:
        name = overrides.parse_sweep(text)[0]
        where = overrides.target(name, "--sweep").where
        if where in given:
            raise overrides.OverrideError("--sweep", f"{name}: is also given by --set "
                                                     f"{given[where]}; give it one of the two")
    return out


def _check_output_folder(folder) -> None:
    """Refuse, before any work, an output folder that cannot be written: a file of that
    name, a parent that is not a folder, no permission."""
    import os
    from pathlib import Path
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise UsageError(f"-o {folder}: is a file, not a folder")
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"-o {folder}: {probe} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"-o {folder}: {probe} is not writable")
    if not path.exists():
        # the permission bits do not say everything (root, /proc, a read-only mount):
        # make the folder and its missing parents, then remove what was made
        made = [p for p in [path, *path.parents] if not p.exists()]
        try:
            path.mkdir(parents=True)
        except OSError as exc:
            raise UsageError(f"-o {folder}: cannot be created ({exc.strerror or exc})") \
                from None
        for p in made:
            try:
                p.rmdir()
            except OSError:
                break


def _workers(n: int) -> str:
    return count(n, "worker")


def _check_simulate_options(args) -> None:
    """The options of ``derive simulate`` that go together, and the output folder."""
    if args.scheduler and not args.sweep:
        raise UsageError("--scheduler: runs the variants of a sweep on a Dask cluster, "
                         "so it goes only with --sweep")
    if args.scheduler and args.workers is not None:
        raise UsageError("--scheduler: the cluster's workers run the sweep; --workers "
                         "(local threads) does not go with it")
    if args.workers is not None and not args.sweep:
        raise UsageError("--workers: runs the variants of a sweep, so it goes only with --sweep")
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers: must be >= 1 (got {args.workers})")
    if args.plot is not None:
        from .runtime.sweep_plot import PLOTTABLE
        if not args.sweep:
            raise UsageError("--plot: names the column sweep.png draws, so it goes only with "
                             "--sweep")
        if args.plot not in PLOTTABLE:
            raise UsageError(f"--plot: must be one of {', '.join(PLOTTABLE)} (got "
                             f"{args.plot!r})")
    _check_output_folder(args.output)


def _run_scene(args):
    """(the scene, its run, the closed loop or None): the run its tables ask for
    (derive.control.run: closed around [control], pushed by a [disturbance], or plain)."""
    from .scene import SceneError, parse_scene
    try:
        doc, base, origin = _scene_doc(args)
        scene = parse_scene(doc, origin, base=base)
        from .control.run import run_scene
        result = run_scene(scene, progress=not args.quiet)
        return scene, result, result.loop
    except SceneError as exc:
        raise UsageError(str(exc)) from None


def _write_run(args, result, closed) -> list:
    """The output files of a run (derive.runtime.outputs), with a progress bar."""
    from .progress import Bar
    from .runtime.outputs import write_all
    bar = Bar("writing the trajectory", enabled=not args.quiet)
    try:
        return write_all(result, args.output, plot=not args.no_plots,
                         animation=not (args.no_animation or args.no_plots),
                         fmt=args.format, progress=bar.update, announce=bar.stage,
                         extra=closed.files(plot=not args.no_plots)
                         if closed is not None else None)
    finally:
        bar.close()


def cmd_simulate(args: argparse.Namespace) -> int:
    import time
    start = time.perf_counter()
    _check_simulate_options(args)
    if args.sweep:
        return _simulate_sweep(args, start)
    scene, result, closed = _run_scene(args)
    t_written = time.perf_counter()
    written = _write_run(args, result, closed)
    t_done = time.perf_counter()
    from .runtime import report
    loop = closed.describe() if closed is not None else None
    print("\n".join(report.lines(scene, result, loop)))
    print(report.timing_line(result, t_done - t_written, t_done - start))
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    return 0 if result.status == "done" else 1


def _simulate_sweep(args, start: float) -> int:
    """``--sweep``: every combination of the swept values, through simulate_many."""
    import time
    from pathlib import Path
    from .scene import SceneError, overrides, parse_scene
    try:
        doc, base, origin = _scene_doc(args)
        parse_scene(doc, origin, base=base)                     # the base must be valid
        grid = dict(_once("--sweep", args.sweep, overrides.parse_sweep,
                          "is swept twice{also}; a field takes one --sweep: give all its "
                          "values in it (a,b,c)")[1])
        n = 1
        for values in grid.values():
            n *= len(values)
        if n > 1_000_000:
            raise SceneError("--sweep", f"{n} variants (at most 1e6)")
        formulas = {k: v for k, v in grid.items() if isinstance(v, overrides.Formulas)}
        from .runtime.batch import csv_columns
        csv_columns(list(grid), formulas)          # sweep.csv's names, each once, before a run
        from .control.run import run_many
        out = run_many(doc, grid, workers=args.workers, scheduler=args.scheduler,
                       progress=not args.quiet, strict=False)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    bad = sum(1 for r in out.rows if "error" in r)
    if out.rows and bad == len(out.rows):
        # no variant could run (an override that is never valid): a usage error, as an
        # unknown field is, and nothing written
        first = next(r["error"] for r in out.rows if "error" in r)
        raise UsageError(f"--sweep: every variant was refused, e.g. {first}")
    folder = Path(args.output)
    folder.mkdir(parents=True, exist_ok=True)
    out.to_csv(folder / "sweep.csv", formulas)
    statuses = {}
    for r in out.rows:
        key = r.get("status", "refused")
        statuses[key] = statuses.get(key, 0) + 1
    from .json_text import dumps
    (folder / "sweep.json").write_text(dumps(
        {"scene": origin, "sweep": {k: list(v) for k, v in grid.items()},
         "swept_by": {k: {"name": v.symbol, "values": v.numbers} for k, v in grid.items()
                      if isinstance(v, overrides.Formulas)},
         "variants": len(out.rows), "statuses": statuses, "seconds": out.seconds,
         "executor": out.executor, "workers": out.workers, "tasks": out.tasks}),
        encoding="utf-8")
    written = ["sweep.csv", "sweep.json"]
    if not args.no_plots and len(grid) <= 2:
        from .runtime.sweep_plot import sweep_plot
        written.append(sweep_plot(out, grid, folder, args.plot or "impacts").name)
    where = {"serial": "this thread", "threads": f"{out.workers} threads",
             "processes": f"{out.workers} processes"}.get(
        out.executor, f"a Dask cluster of {_workers(out.workers)}")
    outcome = ", ".join(f"{v} {k}" for k, v in statuses.items() if k != "refused")
    if bad:
        print(f"{len(out.rows)} variants of {origin}: {len(out.rows) - bad} ran in "
              f"{out.seconds:.2f} s on {where}, {bad} refused (not run); {outcome}")
    else:
        print(f"{len(out.rows)} variants of {origin} ran in {out.seconds:.2f} s on {where}: "
              f"{outcome}")
    if out.executor == "dask":
        from .runtime.batch import CLUSTER_CHUNK
        # what a call costs on a cluster: a worker's first task readies the runtime
        # library (loads it, or builds it where the machine has not)
        ready, run = max(out.ready_s), [t - r for t, r in zip(out.task_s, out.ready_s)]
        print(f"  Dask: imported and connected in {out.connect_s:.2f} s; {out.tasks} task"
              f"{'s' if out.tasks != 1 else ''} of {min(run):.2f}-{max(run):.2f} s in the "
              "workers" + (f", and {ready:.2f} s readying the runtime library on a "
                           "worker's first task (once per worker)" if ready >= 0.01
                           else " (the runtime library ready in under 0.01 s: already built "
                                "on the worker's machine, or already loaded)")
              + (f"; a task holds at least {CLUSTER_CHUNK[0]} variants, so a study this "
                 "small keeps one worker busy" if out.tasks == 1 and out.workers > 1 else ""))
    if bad:
        first = next(r["error"] for r in out.rows if "error" in r)
        print(f"  {bad} refused, e.g. {first}")
    print(f"  wrote {', '.join(written)} to {args.output}; "
          f"{time.perf_counter() - start:.2f} s in all")
    return 0 if statuses.get("done", 0) == len(out.rows) else 1


# ---- scene --------------------------------------------------------------------------
def cmd_export(args: argparse.Namespace) -> int:
    """``derive export SCENE -o DIR``: the scene as a standalone C project."""
    from .runtime import export
    from .scene import SceneError, parse_scene
    from pathlib import Path
    out = Path(args.output)
    _check_output_folder(args.output)
    if out.exists() and not args.force:
        raise UsageError(f"-o {args.output}: exists (--force writes into it)")
    try:
        doc, base, origin = _scene_doc(args)
        project = export.files(parse_scene(doc, origin, base=base))
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    export.write(project, out, force=args.force)
    print(f"wrote {len(project)} files to {args.output}: make -C {args.output} && "
          f"{args.output}/scene {args.output} (README.md there: the calls)")
    return 0


def cmd_scene(args: argparse.Namespace) -> int:
    from .scene import SceneError, load_scene, schema_table, template
    if args.action == "schema":
        if args.file:
            raise UsageError("scene schema: takes no file (it prints the README's table)")
        print(schema_table())
        return 0
    if args.action == "new":
        if args.file:
            raise UsageError("scene new: takes no file (it prints a template: redirect it)")
        sys.stdout.write(template(args.shape))
        return 0
    if not args.file:
        raise UsageError("scene check: give the scene file")
    try:
        scene = load_scene(args.file)
        from .runtime.choice import choose
        kind, why = choose(scene)
        if not scene.one_point:
            return _check_bodies(args.file, scene, kind, why)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    law = scene.law
    print(f"{args.file}: valid; model {kind} ({why})")
    summary = scene.law_summary
    given = f"a table of {len(law.knots)} samples" if law.kind == "table" else "formulas"
    print(f"  law: {given}; P within {summary.max_radius:.4g} of O, |OP''| up to "
          f"{summary.max_acceleration:.4g}; C^2 over the run")
    if any(name.startswith("[stability].") for name in scene.given):
        from .scene.stability_keys import refuse_unread
        try:
            refuse_unread(scene)
            print("  [stability]: read by `derive stability` only (`derive simulate` "
                  "ignores it)")
        except SceneError as exc:
            print("  [stability]: read by `derive stability` only (`derive simulate` "
                  f"ignores it), which refuses {exc}")
    return 0


def _check_bodies(file, scene, kind: str, why: str) -> int:
    """``derive scene check`` of a scene whose internal bodies are not one point: valid,
    its model, and each body's law proved."""
    print(f"{file}: valid; model {kind} ({why})")
    for p in scene.points:
        s = p.summary
        given = f"a table of {len(p.law.knots)} samples" if p.law.kind == "table" \
            else "formulas"
        print(f"  {p.name}: m = {p.mass:g}; {given}; P within {s.max_radius:.4g} of O, "
              f"|OP''| up to {s.max_acceleration:.4g}; C^2 over the run")
    for r in scene.rotors:
        s = r.summary
        axis = ", ".join(f"{c:.6g}" for c in r.axis)
        print(f"  {r.name}: axis ({axis}), I = {r.inertia:g}; |psi'| up to "
              f"{s.max_speed:.4g} rad/s, |psi''| up to {s.max_acceleration:.4g} rad/s^2; "
              "C^2 over the run")
    return 0


# ---- stability --------------------------------------------------------------------
def cmd_stability(args: argparse.Namespace) -> int:
    from dataclasses import replace
    from .scene import SceneError, load_scene, parse_scene
    from .scene.bodies import refuse_analysis
    from .stability import scenes, sweep
    from .stability.families import FamilyError
    if bool(args.scene) == bool(args.family):
        raise UsageError("give a SCENE file or --family (not both)")
    if args.set and not args.family:
        raise UsageError("--set: only with --family")
    try:
        values = None
        if args.family:
            from .stability.families import family
            settings = sweep.parse_settings(args.set)
            values = family(args.family).values(settings)
            scene = parse_scene(scenes.example(args.family, settings), f"--family {args.family}")
        else:
            scene = load_scene(args.scene)
        refuse_analysis(scene, "derive stability")
        if args.long is not None:
            if args.long < 0:
                raise SceneError("--long", f"must be >= 0 (got {args.long})")
            scene = replace(scene, stability=replace(scene.stability, long_periods=args.long))
        result = scenes.analyse(scene, progress=not args.quiet)
    except (SceneError, FamilyError) as exc:
        raise UsageError(str(exc)) from None
    if values is not None:
        result["family"] = {"name": args.family, "parameters": dict(values)}
    if args.json:                        # strict JSON: a NaN (no orbit) becomes null
        from . import json_text
        sys.stdout.write(json_text.dumps(result))
    else:
        print(scenes.text(result))
    return 0 if scenes.checks_hold(result) else 1


def cmd_chart(args: argparse.Namespace) -> int:
    if args.what == "modes":
        return _chart_modes(args)
    if args.periods is not None:
        raise UsageError("--periods: only with modes (the length of each run)")
    if args.scene is not None:
        raise UsageError("--scene: only with modes (a stability family is its own model)")
    args.family = args.family or "C4.1"
    from .stability import chart, sweep
    from .stability.families import FamilyError, family
    try:
        family(args.family)
        default_x, default_y = (("e=0.1:0.9:17", "Gamma=0.5:3.5:21") if args.family == "bounce"
                                else ("a=0:0.8:41", "J_z=0.03:0.22:39"))
        x = sweep.parse_axis(args.x or default_x, args.family, "--x")
        y = sweep.parse_axis(args.y or default_y, args.family, "--y")
        fixed = sweep.parse_settings(args.set)
        result = sweep.run(args.family, x, y, fixed, workers=args.workers,
                           scheduler=args.scheduler, progress=not args.quiet)
    except FamilyError as exc:
        raise UsageError(str(exc)) from None
    paths = chart.write(result, args.output)
    c = chart.counts(result)
    print(f"{args.family}: {x} against {y}: {c['points']} points, {c['unstable']} unstable, "
          f"{c['stable_linear']} linearly stable, {c['critical_jordan']} critical with a "
          f"Jordan block at rho = 1" +
          (f", {c['no_body']} with {chart.missing_name(args.family)}" if c["no_body"]
           else "") +
          f"; {result.seconds:.2g} s on {result.executor} ({_workers(result.workers)})")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _modes_axis(text: str, name: str, flag: str, lo: float, hi: float) -> list:
    """``mu=0.02:0.8:27`` (or ``=0.1,0.3``): the values, each in (lo, hi)."""
    from .scene import overrides
    given, sep, spec = text.partition("=")
    if not sep or given.strip() != name:
        raise UsageError(f"{flag}: must be {name}=lo:hi:n or {name}=a,b,c (got {text!r})")
    try:
        values = overrides.parse_sweep(f"body.mass={spec}")[1]
    except overrides.OverrideError as exc:
        raise UsageError(f"{flag}: {exc.rule.replace('body.mass', name)}") from None
    bad = [v for v in values if not lo < v < hi]
    if bad:
        raise UsageError(f"{flag}: {name} must be in ({lo:g}, {hi:g}) (got {bad[0]:g})")
    return values


def _chart_modes(args) -> int:
    """``derive chart modes``: Bardin and Panev's mode types over (mu, beta)."""
    for flag, given in (("--family", args.family), ("--set", args.set),
                        ("--scheduler", args.scheduler)):
        if given:
            raise UsageError(f"{flag}: not read by chart modes (its scene is --scene, "
                             "by default derive/scene/examples/bardin-panev.toml; it runs "
                             "on local threads)")
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers: must be >= 1 (got {args.workers})")
    periods = 40 if args.periods is None else args.periods
    if not 2 <= periods <= 10_000:
        raise UsageError(f"--periods: must be a whole number in [2, 10000] (got {periods})")
    mus = _modes_axis(args.x or "mu=0.02:0.8:27", "mu", "--x", 0.0, 100.0)
    betas = _modes_axis(args.y or "beta=0.05:0.95:19", "beta", "--y", 0.0, 1.0)
    from .runtime import modes
    from .scene import SceneError
    try:
        result = modes.chart(mus, betas, periods, workers=args.workers,
                             progress=not args.quiet, scene=args.scene)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    paths = modes.write(result, args.output)
    found = ", ".join(f"{n} {t}" for t, n in modes.counts(result).items())
    print(f"modes: {len(mus)} values of mu against {len(betas)} of beta, {periods} periods "
          f"each: {len(result.types)} cells: {found}; {result.seconds:.3g} s on "
          f"{_workers(result.workers)}")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


# ---- bench and verify: commands declared once (derive/bench, derive/verify) -------------
def _progress(message: str) -> None:
    print(f"  ... {message}", file=sys.stderr, flush=True)


def _execute(command, dests: list, args: argparse.Namespace) -> int:
    """Run a declared command: exit 0 when every target passed, 1 when one failed."""
    import time
    start = time.perf_counter()
    result = command.function("run")(**{d: getattr(args, d) for d in dests},
                                     progress=_progress)
    print(command.function("report")(result))
    ok = command.function("passed")(result)
    if not isinstance(ok, bool):
        raise TypeError(f"{command.module}: passed() returned {ok!r}, not a bool")
    print(f"{time.perf_counter() - start:.1f} s in all")
    return 0 if ok else 1


def _add_commands(sub, name: str, help: str, commands) -> None:
    """``derive NAME COMMAND``: one parser per declared command, from its own arguments."""
    import functools
    p = sub.add_parser(name, help=help)
    group = p.add_subparsers(dest=name, required=True, parser_class=_Parser)
    for command in commands:
        c = group.add_parser(command.name, help=command.help)
        dests = [c.add_argument(*a.flags, **a.options).dest for a in command.arguments]
        c.set_defaults(func=functools.partial(_execute, command, dests))


# ---- parser -----------------------------------------------------------------------
def _section(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"section must be 1, 2, 3 or 4, not {text!r}")
    if value not in (1, 2, 3, 4):
        raise argparse.ArgumentTypeError(f"section must be 1, 2, 3 or 4, not {value}")
    return value


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.set_defaults(_parser=self)      # the deepest (sub)command parsed wins

    def parse_args(self, args=None, namespace=None):
        # an unknown option is reported by the command it was given to, with its usage
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            parsed._parser.error("unrecognized arguments: " + " ".join(extras))
        return parsed

    def parse_known_args(self, args=None, namespace=None):
        self._given = list(sys.argv[1:] if args is None else args)   # for error()
        return super().parse_known_args(args, namespace)

    def error(self, message: str):  # argparse's own errors: exit 2, one line
        unknown = [a.split("=", 1)[0] for a in getattr(self, "_given", [])
                   if a.startswith("--") and a.split("=", 1)[0] not in self._option_string_actions]
        line = _one_line(message, self.prog)
        if unknown and "unrecognized arguments" not in message:
            line += f"; {', '.join(unknown)}: is not an option of {self.prog}"
        print(f"{self.prog}: {line}", file=sys.stderr)
        raise SystemExit(2)


# argparse's messages, said as the project says a refusal: the option, then the rule
_ARGPARSE = (
    (r"argument (\S+): invalid choice: (.+?) \(choose from (.+)\)\Z",
     lambda m, prog: f"{m[1]}: must be one of {m[3].replace(chr(39), '')} (got {m[2]})"),
    (r"argument (\S+): invalid int value: (.+)\Z",
     lambda m, prog: f"{m[1]}: must be a whole number (got {m[2]})"),
    (r"argument (\S+): invalid float value: (.+)\Z",
     lambda m, prog: f"{m[1]}: must be a number (got {m[2]})"),
    (r"argument (\S+): expected one argument\Z",
     lambda m, prog: f"{m[1]}: needs a value"),
    (r"argument (\S+): (.+)\Z", lambda m, prog: f"{m[1]}: {m[2]}"),
    (r"the following arguments are required: (.+)\Z",
     lambda m, prog: f"{m[1]}: {'are' if ', ' in m[1] else 'is'} required ({prog} -h: "
                     "its arguments)"),
    (r"unrecognized arguments: (.+)\Z", lambda m, prog: _unrecognized(m[1].split(), prog)),
)


def _unrecognized(extras: list, prog: str) -> str:
    what = "option" if all(a.startswith("-") for a in extras) else "argument"
    extras = [a.split("=", 1)[0] if a.startswith("-") else a for a in extras]
    verb = f"is not an {what}" if len(extras) == 1 else f"are not {what}s"
    return f"{', '.join(extras)}: {verb} of {prog} ({prog} -h: its options)"


def _one_line(message: str, prog: str) -> str:
    """argparse's ``message`` as one line naming the option and the rule."""
    import re
    message = " ".join(message.split())
    for pattern, say in _ARGPARSE:
        m = re.match(pattern, message)
        if m:
            return say(m, prog)
    return message


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="derive", description=(
        "Dynamics of a rigid body carrying a moving material point and bouncing on a "
        "plane (Markeev 2012): derive, prove, emit, simulate, measure."))
    from importlib.metadata import PackageNotFoundError, version
    try:
        release = version("markeev-carrier")
    except PackageNotFoundError:             # a checkout that is not installed
        release = "unknown (not installed)"
    parser.add_argument("--version", action="version", version=f"derive {release}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("equations", help="print the derived equations with their IDs")
    p.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    p.add_argument("--id", help="only this ID (e.g. E1.7)")
    p.add_argument("--compact", action="store_true", help="the compact (factored) form: "
                   "J_ij, K, d, CS, |n| kept by name and defined below each equation (each "
                   "checked equal to the expanded form before it is printed)")
    p.set_defaults(func=cmd_equations)

    p = sub.add_parser("prove", help="run paper_checks/: every ID of CLAIMS.md and "
                       "EXTENSIONS.md")
    p.add_argument("--section", type=_section, action="append",
                   help="only this section (repeatable)")
    p.add_argument("--id", action="append", help="only this ID (repeatable)")
    p.add_argument("--report", metavar="DIR",
                   help="also write DIR/prove.md, prove.tex (claims, derived "
                        "expressions, verdicts, errata), prove.json and prove.xml (JUnit, "
                        "for CI dashboards)")
    p.set_defaults(func=cmd_prove)

    p = sub.add_parser("emit", help="render generated/ (CasADi functions, standalone C)")
    p.add_argument("--check", action="store_true",
                   help="compare generated/ (or DIR) with a fresh render; exit 1 with a diff")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="render into DIR instead of the checkout's generated/ (the only "
                        "way from an installed wheel)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=cmd_emit)

    p = sub.add_parser("simulate", help="simulate a scene (default: the built-in one)")
    p.add_argument("scene", nargs="?", help="scene TOML file (omit for the built-in "
                   "bouncing ball)")
    p.add_argument("-o", "--output", default="out", help="output folder (default: out)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--no-plots", action="store_true", help="write the tables and the "
                   "summary only (no overview.png, no motion.gif)")
    p.add_argument("--no-animation", action="store_true", help="skip motion.gif (the "
                   "animation takes about as long as everything else together)")
    p.add_argument("--format", choices=["csv", "npz"], default="csv", help="tables as CSV "
                   "files (default) or one run.npz of named arrays (numpy.load), for long "
                   "runs")
    p.add_argument("--set", action="append", metavar="TABLE.KEY=VALUE",
                   help="override a field of the scene, e.g. --set body.mass=1.3 or --set "
                        "initial.com[2]=2.0 (repeatable)")
    p.add_argument("--sweep", action="append", metavar="TABLE.KEY=LO:HI:N",
                   help="run every combination of the swept values (lo:hi:n or a,b,c; "
                        "repeatable): sweep.csv, sweep.json and a plot; a formula by one "
                        "of its numbers: 'point.law[0]=0.05*sin(W*t) for W=8:16:9'")
    p.add_argument("--workers", type=int, help="--sweep: local threads (default: every "
                   "core; 1: serial)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="--sweep: run the "
                   "variants on the Dask cluster of this scheduler instead (pip install -e "
                   "'.[cluster]'); many variants per task")
    p.add_argument("--plot", metavar="COLUMN", help="--sweep: the column sweep.png draws "
                   "against the swept values (default impacts; e.g. distance, "
                   "mean_speed, X_C_end, Z_C_end, min_height)")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("export", help="a scene as a standalone C project (the runtime, the "
                       "scene's numbers, an example main.c, a Makefile and CMakeLists.txt): "
                       "no Python at run time", description=(
                           "Write DIR: the runtime of the model the scene chooses "
                           "(model_<kind>.c and the crt_*.h it includes), scene.h and scene.c "
                           "(its options, parameters, initial state and law as C data; "
                           "scene_law_jets for a law of formulas), main.c (runs the scene, "
                           "writes trajectory.csv, event_states.csv, events.csv), a Makefile, "
                           "a CMakeLists.txt and a README.md with the calls in order.  "
                           "[control] and [disturbance] are refused: a loop Python closes "
                           "runs them.  See derive/docs/embedding.md."))
    p.add_argument("scene", help="scene TOML file")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="the project's folder (refused if it exists, unless --force)")
    p.add_argument("--force", action="store_true", help="write into DIR even if it exists "
                   "(the files a previous export wrote, listed in DIR/.derive-export, are "
                   "replaced or removed; other files are left)")
    p.add_argument("--set", action="append", metavar="TABLE.KEY=VALUE",
                   help="override a field of the scene, as derive simulate's --set")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("scene", help="scene files: a commented template, a check, the "
                                     "schema table")
    p.add_argument("action", choices=["new", "check", "schema"], help="new: print a "
                   "template with every field; check: validate a file and say which model "
                   "would run it; schema: print the README's schema table (after a change "
                   "to derive/shapes.py or the schema)")
    p.add_argument("file", nargs="?", help="check: the scene file")
    p.add_argument("--shape", choices=[*shapes.SHAPE_NAMES, shapes.NONE], default="sphere",
                   help="new: the body's shape (default sphere)")
    p.set_defaults(func=cmd_scene)

    p = sub.add_parser("stability", help="multipliers and verdict of a scene's periodic "
                       "motion (a stationary rotation in flight, or periodic bouncing)")
    p.add_argument("scene", nargs="?", help="scene TOML file, with an optional [stability] "
                   "table")
    p.add_argument("--family", help="instead of a scene: a member of C4.1, C4.2, C4.3 (a "
                   "stationary rotation) or bounce (reference [5])")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="with --family: a parameter (repeatable, each name once; "
                        "bounce: Gamma or a, not both)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--long", type=int, metavar="PERIODS",
                   help="perturbed runs this many periods long where the linear test is "
                        "critical (overrides [stability].long_periods)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_stability)

    p = sub.add_parser("chart", help="charts over two parameters: a family's stability, "
                       "Bardin and Panev's mode types")
    p.add_argument("what", choices=["stability", "modes"], help="stability: max |rho| of a "
                   "family's periodic motions (stationary rotations or bouncing) over a "
                   "grid; modes: the type of Bardin and Panev's periodic mode over (mu, "
                   "beta), from runs of derive/scene/examples/bardin-panev.toml")
    p.add_argument("--family", help="stability: C4.1 (default), C4.2 or C4.3 "
                   "(stationary rotations), or bounce (periodic bouncing of reference [5])")
    p.add_argument("--x", help="x axis, name=lo:hi:n (default a=0:0.8:41; bounce: "
                   "e=0.1:0.9:17; modes: mu=0.02:0.8:27)")
    p.add_argument("--y", help="y axis, name=lo:hi:n (default J_z=0.03:0.22:39; bounce: "
                   "Gamma=0.5:3.5:21; modes: beta=0.05:0.95:19)")
    p.add_argument("--scene", help="modes: the scene run (default derive/scene/examples/"
                   "bardin-panev.toml): one point on a vertical circle at a constant rate, "
                   "one friction coefficient; mu and beta vary its friction and body mass")
    p.add_argument("--periods", type=int, help="modes: periods of the point each run "
                   "lasts (default 40; the type compares the last two)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="fix a parameter (repeatable); others keep their defaults")
    p.add_argument("--workers", type=int, help="local processes (modes: threads; default: "
                   "every core; 1: serial)")
    p.add_argument("--scheduler", help="a Dask scheduler address (tcp://host:port): run "
                   "the sweep on that cluster instead")
    p.add_argument("-o", "--output", default="chart-out", help="output folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_chart)

    from .bench import COMMANDS as BENCHES
    from .verify import COMMANDS as CHECKS
    _add_commands(sub, "bench", "benchmarks: ratios against peers measured in the same run, "
                  "each target marked PASS or FAIL (exit 1 on FAIL)", BENCHES)
    _add_commands(sub, "verify", "verification: fuzzing and property checks over many "
                  "scenes, each goal marked PASS or FAIL (exit 1 on FAIL)", CHECKS)

    from .planner.cli import add_parser as _add_plan_parser
    _add_plan_parser(sub)
    from .control.cli import add_parser as _add_control_parser
    _add_control_parser(sub)
    return parser


def _terminate_cleanly() -> None:
    """SIGTERM (a killed job, a timeout) unwinds like Ctrl-C: ``finally`` blocks run, so
    the outputs' staging folder is removed and no half-written file is left; exit 143."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        return

    import os
    owner = os.getpid()

    def terminated(signum, frame):
        if os.getpid() != owner:               # a forked worker: die as it would have
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        print("terminated", file=sys.stderr)
        raise SystemExit(128 + signum)
    signal.signal(signal.SIGTERM, terminated)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command in ("bench", "verify"):
        # the benchmarks time single-threaded code on a shared machine: BLAS worker
        # threads spinning after a NumPy call (the SciPy routes) would take a core from
        # the code timed next.  Only before NumPy loads; a caller's setting wins.
        import os
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, "1")
    _terminate_cleanly()
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"derive {args.command}: {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:            # SceneError from a subcommand that raises it
        from .scene import SceneError
        if not isinstance(exc, SceneError):
            raise
        print(f"derive {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except RuntimeError as exc:          # BuildError: the compiler refused the runtime
        from .cbuild import BuildError
        if not isinstance(exc, BuildError):
            raise
        lines = str(exc).splitlines()
        first = next((ln for ln in lines if "error" in ln), lines[-1] if lines else "")
        print(f"derive {args.command}: {lines[0] if lines else 'build failed'} (first "
              f"error: {first.strip()}); a bug in derive, not in the input: please "
              "report it", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # the reader of our output went away (``| head``): stop quietly, as cat does
        import os
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    raise SystemExit(main())
