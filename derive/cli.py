"""The ``derive`` command line.

Exit status: 0 success, 1 a check or comparison failed, 2 bad input (the message names
the field and the rule; no traceback).
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence


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
        from paper_checks import catalogue, registry
    except ImportError as exc:
        raise UsageError("prove: the paper_checks/ folder is not importable from here "
                         f"({exc}); run from a checkout installed with pip install -e .")
    return catalogue, registry


def cmd_prove(args: argparse.Namespace) -> int:
    import time
    catalogue, registry = _load_paper_checks()
    entries = catalogue.entries()
    if args.section:
        entries = [e for e in entries if e.section in args.section]
    if args.id:
        known = {e.id for e in entries}
        bad = [i for i in args.id if i not in known]
        if bad:
            raise UsageError(f"--id: {', '.join(bad)} not in CLAIMS.md (section filter "
                             f"{args.section or 'all'})")
        entries = [e for e in entries if e.id in args.id]
    start = time.perf_counter()
    outcomes = []
    width = max(len(e.id) for e in entries) if entries else 4
    print(f"{'ID':<{width}}  {'status':<8} {'seconds':>8}  detail")
    for entry in entries:
        outcome = registry.run(entry.id)
        outcomes.append(outcome)
        detail = outcome.detail.splitlines()[0][:90] if outcome.detail else ""
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
    summary = ", ".join(f"{v} {k}" for k, v in counts.items() if v)
    print(f"\n{len(outcomes)} IDs in {total:.1f} s: {summary}")
    if args.report:
        from paper_checks.report import write_report
        paths = write_report(args.report, entries, outcomes)
        print("report: " + ", ".join(str(p) for p in paths))
    return 1 if bad else 0


# ---- emit -------------------------------------------------------------------------
def cmd_emit(args: argparse.Namespace) -> int:
    import time
    from .emit import driver
    start = time.perf_counter()
    files = driver.render_all()
    if args.check:
        delta = driver.diff(files)
        if delta:
            sys.stdout.write(delta)
            print("\ngenerated/ differs from a fresh render: run `derive emit`",
                  file=sys.stderr)
            return 1
        print(f"generated/ matches a fresh render ({len(files)} files, "
              f"{time.perf_counter() - start:.1f} s)")
        return 0
    changed = driver.write(files)
    print(f"rendered {len(files)} files in {time.perf_counter() - start:.1f} s; "
          f"{len(changed)} changed" + (": " + ", ".join(changed) if changed else ""))
    return 0


# ---- simulate ---------------------------------------------------------------------
def cmd_simulate(args: argparse.Namespace) -> int:
    import time
    start = time.perf_counter()
    from .runtime.scene import SceneError, builtin_doc, load_scene, parse_scene
    try:
        scene = load_scene(args.scene) if args.scene else parse_scene(builtin_doc(),
                                                                      "built-in scene")
        from .runtime.driver import simulate
        result = simulate(scene, progress=not args.quiet)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    from .runtime.outputs import write_all
    t_written = time.perf_counter()
    written = write_all(result, args.output, plot=not args.no_plots,
                        animation=not (args.no_animation or args.no_plots), fmt=args.format)
    t_done = time.perf_counter()
    info = result.stats
    print(f"{scene.name}: {result.status}; model {result.model} ({result.why})")
    print(f"  {scene.method}, {info['steps']} steps ({info['rejected']} rejected), "
          f"{info['rhs_evaluations']} RHS evaluations, {info['impacts']} impacts, "
          f"{info['contacts']} contact phases, {info['liftoffs']} lift-offs")
    if scene.contact_possible:
        mh, mn = result.min_height, result.min_normal
        print(f"  lowest height of S {mh:.3g} m" +
              (f", smallest reaction in contact {mn:.4g} N" if mn < float("inf") else ""))
    t = result.timings
    build = f", library built in {t['library_build_s']:.2f} s (once per machine)" \
        if t.get("load_s", 0.0) > 0.05 else ""
    out_t = t.get("outputs", {})
    parts = ", ".join(f"{name[:-2]} {sec:.2f} s" for name, sec in out_t.items())
    print(f"  validate {1e3 * t['prepare_s']:.2f} ms, run {1e3 * t['run_s']:.2f} ms{build}, "
          f"outputs {t_done - t_written:.2f} s ({parts}); {t_done - start:.2f} s in all")
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    return 0 if result.status == "done" else 1


# ---- stability --------------------------------------------------------------------
def cmd_stability(args: argparse.Namespace) -> int:
    import json
    from dataclasses import replace
    from .runtime.scene import SceneError, load_scene, parse_scene
    from .stability import scenes, sweep
    from .stability.families import FamilyError
    if bool(args.scene) == bool(args.family):
        raise UsageError("give a SCENE file or --family (not both)")
    if args.set and not args.family:
        raise UsageError("--set: only with --family")
    try:
        if args.family:
            settings = dict(sweep.parse_setting(text) for text in args.set or [])
            scene = parse_scene(scenes.example(args.family, settings), f"--family {args.family}")
        else:
            scene = load_scene(args.scene)
        if args.long is not None:
            if args.long < 0:
                raise SceneError("--long", f"must be >= 0 (got {args.long})")
            scene = replace(scene, stability=replace(scene.stability, long_periods=args.long))
        result = scenes.analyse(scene, progress=not args.quiet)
    except (SceneError, FamilyError) as exc:
        raise UsageError(str(exc)) from None
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(scenes.text(result))
    return 0 if scenes.checks_hold(result) else 1


def cmd_chart(args: argparse.Namespace) -> int:
    from .stability import chart, sweep
    from .stability.families import FamilyError, family
    try:
        family(args.family)
        x = sweep.parse_axis(args.x, args.family, "--x")
        y = sweep.parse_axis(args.y, args.family, "--y")
        fixed = dict(sweep.parse_setting(text) for text in args.set or [])
        result = sweep.run(args.family, x, y, fixed, workers=args.workers,
                           scheduler=args.scheduler, progress=not args.quiet)
    except FamilyError as exc:
        raise UsageError(str(exc)) from None
    paths = chart.write(result, args.output)
    c = chart.counts(result)
    print(f"{args.family}: {x} against {y}: {c['points']} points, {c['unstable']} unstable, "
          f"{c['stable_linear']} linearly stable, {c['critical_jordan']} critical with a "
          f"Jordan block at rho = 1" +
          (f", {c['no_body']} with no body" if c["no_body"] else "") +
          f"; {result.seconds:.1f} s on {result.executor} ({result.workers} workers)")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


# ---- bench ------------------------------------------------------------------------
def _progress(message: str) -> None:
    print(f"  ... {message}", file=sys.stderr, flush=True)


def cmd_bench(args: argparse.Namespace) -> int:
    import shlex
    if args.what == "rhs":
        from .bench import rhs
        cflags = tuple(shlex.split(args.cflags))
        rows = rhs.run(cflags=cflags, progress=_progress)
        print(f"cost per evaluation, compiled with {' '.join(cflags)} "
              f"(C: throughput over 1024 states, min of 15 trials)")
        print(rhs.report(rows))
        return 0
    if args.what == "sim":
        from .bench import sim
        from .runtime.scene import SceneError, load_scene
        doc = None
        if args.scene:
            import tomllib
            try:
                load_scene(args.scene)
                doc = tomllib.loads(open(args.scene, encoding="utf-8").read())
            except SceneError as exc:
                raise UsageError(str(exc)) from None
        out = sim.run(doc, progress=_progress, repeats=args.repeats)
        print(sim.report(out))
        return 0
    if args.what == "precision":
        from .bench import precision
        scenes = args.scenes.split(",") if args.scenes else None
        known = set(precision.reference_scenes())
        if scenes and not set(scenes) <= known:
            raise UsageError(f"--scenes: choose from {', '.join(sorted(known))}")
        summary = precision.run(args.output, quick=args.quick, repeats=args.repeats,
                                periods=args.periods, scenes=scenes, progress=_progress)
        print(precision.report(summary))
        print(f"charts and data in {args.output}")
        return 0
    if args.what == "failures":
        from .bench import failures
        outcomes = failures.run(progress=_progress)
        print(failures.report(outcomes))
        return 0
    raise UsageError(f"unknown benchmark {args.what!r}")


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
    def error(self, message: str):  # argparse's own errors: exit 2, one line
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="derive", description=(
        "Dynamics of a rigid body carrying a moving material point and bouncing on a "
        "plane (Markeev 2012): derive, prove, emit, simulate, measure."))
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("equations", help="print the derived equations with their IDs")
    p.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    p.add_argument("--id", help="only this ID (e.g. E1.7)")
    p.add_argument("--compact", action="store_true", help="the compact (factored) form: "
                   "J_ij, K, d, CS, |n| kept by name and defined below each equation (each "
                   "checked equal to the expanded form before it is printed)")
    p.set_defaults(func=cmd_equations)

    p = sub.add_parser("prove", help="run paper_checks/: every ID of CLAIMS.md")
    p.add_argument("--section", type=_section, action="append",
                   help="only this section (repeatable)")
    p.add_argument("--id", action="append", help="only this ID (repeatable)")
    p.add_argument("--report", metavar="DIR",
                   help="also write DIR/prove.md and DIR/prove.tex (claims, derived "
                        "expressions, verdicts, errata)")
    p.set_defaults(func=cmd_prove)

    p = sub.add_parser("emit", help="render generated/ (CasADi functions, standalone C)")
    p.add_argument("--check", action="store_true",
                   help="compare generated/ with a fresh render; exit 1 with a diff")
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
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("stability", help="multipliers and verdict of a scene's periodic "
                       "motion (a stationary rotation in flight, or periodic bouncing)")
    p.add_argument("scene", nargs="?", help="scene TOML file, with an optional [stability] "
                   "table")
    p.add_argument("--family", help="instead of a scene: a member of C4.1, C4.2, C4.3 (a "
                   "stationary rotation) or bounce (reference [5])")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="with --family: a parameter (repeatable)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--long", type=int, metavar="PERIODS",
                   help="perturbed runs this many periods long where the linear test is "
                        "critical (overrides [stability].long_periods)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_stability)

    p = sub.add_parser("chart", help="stability charts: sweep two parameters of a family")
    p.add_argument("what", choices=["stability"], help="stability: max |rho| of the "
                   "stationary rotations of a family over a grid")
    p.add_argument("--family", default="C4.1", help="C4.1 (default), C4.2 or C4.3")
    p.add_argument("--x", default="a=0:0.8:41", help="x axis, name=lo:hi:n "
                   "(default a=0:0.8:41)")
    p.add_argument("--y", default="J_z=0.03:0.22:39", help="y axis, name=lo:hi:n "
                   "(default J_z=0.03:0.22:39)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="fix a parameter (repeatable); others keep their defaults")
    p.add_argument("--workers", type=int, help="local processes (default: every core; 1: "
                   "serial)")
    p.add_argument("--scheduler", help="a Dask scheduler address (tcp://host:port): run "
                   "the sweep on that cluster instead")
    p.add_argument("-o", "--output", default="chart-out", help="output folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_chart)

    p = sub.add_parser("bench", help="benchmarks: ratios against peers in the same run")
    p.add_argument("what", choices=["rhs", "sim", "precision", "failures"], help=(
        "rhs: cost per evaluation of the generated functions against CasADi's C, CasADi "
        "from Python and NumPy; sim: time to simulate a scene to a max state error of "
        "1e-9 against SciPy and CasADi routes; precision: work-precision charts on "
        "reference scenes and the invariant drift of long runs; failures: hard scenes "
        "through every method"))
    p.add_argument("-o", "--output", default="bench-out", help="precision: output folder")
    p.add_argument("--quick", action="store_true", help="precision: three tolerances only")
    p.add_argument("--periods", type=int, default=10_000,
                   help="precision: length of the long run in periods of the point")
    p.add_argument("--scenes", help="precision: comma-separated scene names")
    p.add_argument("--cflags", default="-O2", help="rhs: compiler flags for every C build "
                   "(default: -O2)")
    p.add_argument("--scene", help="sim: scene TOML (default: the built-in one)")
    p.add_argument("--repeats", type=int, default=5, help="timing repetitions (min taken)")
    p.set_defaults(func=cmd_bench)

    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"derive {args.command}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
