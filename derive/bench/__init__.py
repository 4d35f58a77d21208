"""Benchmarks: ratios against peers measured in the same run, each target PASS or FAIL.

``COMMANDS`` declares the subcommands of ``derive bench`` (see :mod:`derive.commands`):
each module's ``run`` takes the command's arguments, ``report`` prints its table and
``passed`` says whether every target printed PASS (exit 0) or one printed FAIL (exit 1).
Verification (fuzzing, random scenes, hard scenes) is :mod:`derive.verify`.
"""
from __future__ import annotations

import argparse
import shlex

from ..commands import Arg, Command, count


def _cflags(text: str) -> tuple:
    return tuple(shlex.split(text))


def _precision_scenes(text: str) -> list:
    from .precision import reference_scenes
    names, known = text.split(","), reference_scenes()
    if not set(names) <= set(known):
        raise argparse.ArgumentTypeError(f"choose from {', '.join(sorted(known))}")
    return names


REPEATS = count(1, 1000)

COMMANDS = (
    Command("rhs", "cost per evaluation of the generated functions against CasADi's C of "
            "the same graph and of the strongest hand-written RHS, CasADi from Python and "
            "NumPy", "derive.bench.rhs", (
                Arg.of("--cflags", type=_cflags, default=None,
                       help="compiler flags for every C build (default: the runtime's "
                            "flags, judged, then -O2, reported)"),
            ), run="derive.bench:rhs_run", report="derive.bench:rhs_report",
            passed="derive.bench:rhs_passed"),
    Command("sim", "what a simulation costs the user end to end (and the C run alone) "
            "against SciPy and CasADi at a 1e-9 error; the CLI, simulate_many and the first "
            "build", "derive.bench.sim", (
                Arg.of("--scene", help="scene TOML (default: the built-in scene and an offset "
                       "ellipsoid)"),
                Arg.of("--repeats", type=REPEATS, default=5,
                       help="timing repetitions (min taken)"),
                Arg.of("--quick", action="store_true", help="the scenes only (no CLI, batch "
                       "and first-build measurements)"),
            )),
    Command("rough", "what a rough plane costs: rough runs against their smooth twins (the "
            "C run and end to end, target <= 2x) and work-precision against a SciPy route "
            "with the same laws", "derive.bench.rough", (
                Arg.of("--repeats", type=REPEATS, default=3,
                       help="timing repetitions (min taken)"),
                Arg.of("--quick", action="store_true", help="the cost against the smooth "
                       "plane only (no work-precision)"),
            )),
    Command("bodies", "several points and rotors (the moments models): derivation, "
            "emission and compile once, RHS operations and the C run against N = 1..8 points "
            "and R = 0..4 rotors (a chart; no swell, 8 points and 4 rotors at most 3x one "
            "point), and against Pinocchio on the same flights", "derive.bench.bodies", (
                Arg.of("-o", "--output", dest="out_dir", default="bench-out", metavar="DIR",
                       help="output folder (bodies-cost.png)"),
                Arg.of("--repeats", type=REPEATS, default=5,
                       help="timing samples of each run (median and spread)"),
                Arg.of("--quick", action="store_true", help="the grid and the one-point "
                       "target only (no cold derivation and compile, no Pinocchio)"),
            )),
    Command("base", "a body resting on its face (issue 33): the base model's C run per "
            "simulated second against the flight model's (target <= 1x), and a friction x "
            "frequency study of 10^4 variants (target < 10 s)", "derive.bench.base", (
                Arg.of("--repeats", type=REPEATS, default=7,
                       help="timing samples (median and spread)"),
                Arg.of("--grid", type=count(2, 1000), default=100,
                       help="the study's grid per axis (default 100: 10^4 variants)"),
                Arg.of("--workers", type=count(1, 1024), default=None,
                       help="threads of the study (default: every core)"),
            )),
    Command("law", "the point law interpreted against compiled: ns per evaluation, compile "
            "time, share of a run", "derive.bench.law", (
                Arg.of("--repeats", type=REPEATS, default=7,
                       help="timing repetitions (min taken)"),
            )),
    Command("hop", "per-hop feedback on the reference-[5] hop: regions of attraction open "
            "loop, per-hop LQR and mirror law (a chart), the decay against the predicted "
            "eigenvalues, the C controller's cost", "derive.bench.hop", (
                Arg.of("-o", "--output", dest="out_dir", default="bench-out", metavar="DIR",
                       help="output folder (hop-region.png)"),
                Arg.of("--grid", type=count(3, 101), default=15,
                       help="starts per axis of the grid (default 15)"),
            )),
    Command("precision", "work-precision charts on reference scenes and the invariant "
            "drift of long runs", "derive.bench.precision", (
                Arg.of("-o", "--output", dest="out_dir", default="bench-out", metavar="DIR",
                       help="output folder"),
                Arg.of("--quick", action="store_true", help="three tolerances only"),
                Arg.of("--periods", type=count(0, 10_000_000), default=10_000,
                       help="length of the long run in periods of the point (0: none)"),
                Arg.of("--scenes", type=_precision_scenes,
                       help="comma-separated reference scene names"),
                Arg.of("--repeats", type=REPEATS, default=5,
                       help="timing repetitions (min taken)"),
            )),
    Command("control", "the re-planning controller on drawn landings (spheres and "
            "ellipsoids, drops, spins, model errors, pushes): the C controller against IPOPT "
            "at every sample (reachability) and the open loop, by disturbance size; its "
            "solve time per sample", "derive.bench.control", (
                Arg.of("--tasks", type=count(1, 10_000), default=12,
                       help="landing tasks drawn (default 12)"),
                Arg.of("--per-task", dest="per_task", type=count(1, 1000), default=4,
                       help="disturbances per task, the sizes in turn (default 4)"),
                Arg.of("--seed", type=count(0, 2 ** 31), default=1,
                       help="the draws' seed (default 1)"),
                Arg.of("--workers", type=count(1, 1024), default=None,
                       help="worker processes (default: every core)"),
                Arg.of("-o", "--output", dest="out_dir", default="bench-out", metavar="DIR",
                       help="output folder (control-robustness.png)"),
            )),
)


# ---- rhs: one harness per set of flags, the targets judged at the first ------------------
def rhs_run(cflags: tuple | None = None, progress=lambda msg: None) -> list:
    """[(flags, Report)]: the runtime's flags (judged) then -O2 (reported), or ``cflags``."""
    from . import rhs
    sets = [cflags] if cflags else list(rhs.FLAG_SETS)
    return [(flags, rhs.run(cflags=flags, progress=progress, python=k == 0))
            for k, flags in enumerate(sets)]


def rhs_report(reports: list) -> str:
    from . import rhs
    parts = []
    for k, (flags, rep) in enumerate(reports):
        text, _ = rhs.report(rep, judged=k == 0)
        parts.append(f"cost per evaluation, compiled with {' '.join(flags)} (C: throughput "
                     f"over 1024 states and a latency-bound loop, min of 60 interleaved "
                     f"trials){'' if k == 0 else '; reported, the targets are judged above'}"
                     f"\n{text}")
    return "\n\n".join(parts)


def rhs_passed(reports: list) -> bool:
    from . import rhs
    return rhs.report(reports[0][1], judged=True)[1]
