"""Verification apart from benchmarks: fuzzers and property checks over many scenes.

Modules, by role:

* :mod:`~derive.verify.generators`: random valid bouncing scenes and seeded hostile ones
  (with :mod:`~derive.verify.laws`, the law grammar's trees and hostile law texts; a case
  is written as a scene file by the one TOML writer, :mod:`derive.scene.toml`);
* :mod:`~derive.verify.oracle`: what the answer should be, computed another way (law
  derivatives, properties of any honest run, references of hard scenes);
* :mod:`~derive.verify.reaction`: the contact reaction of a run's rows by Newton–Euler
  for the carrier, its points and its rotors, apart from the runtime (what the rough
  plane's judge holds the cone and the couples' bounds against);
* :mod:`~derive.verify.sandbox`: running a case where it can do no harm (a forked worker
  with time and memory limits; the command line in a private folder);
* :mod:`~derive.verify.judges`: the verdict on what came out, against the README's
  contract;
* the drivers, one per command: :mod:`~derive.verify.fuzz` (hostile scenes through the
  parser, the runtime and the CLI), :mod:`~derive.verify.robustness` (random valid
  scenes through the runtime), :mod:`~derive.verify.failures` (hard scenes through every
  method and peer), :mod:`~derive.verify.mutants` (small mutations of the runtime's C
  through the tests; :mod:`~derive.verify.csites` reads the C's sites).

``COMMANDS`` declares ``derive verify``'s subcommands (see :mod:`derive.commands`): the
same spelling for the same thing (``-n/--cases``, ``--seed``, ``--workers``), and exit
status 1 when the report says FAIL.
"""
from __future__ import annotations

from ..commands import Arg, Command, count, positive_float

CASES = count(1, 10_000_000)
WORKERS = count(1, 4096)

COMMANDS = (
    Command("fuzz", "seeded hostile scenes through the parser, the runtime and the "
            "command line: each refused in one line naming the field, or run right",
            "derive.verify.fuzz", (
                Arg.of("-n", "--cases", dest="n", type=CASES, default=2000,
                       help="number of cases (default 2000)"),
                Arg.of("--seed", type=int, default=12, help="the generator's seed"),
                Arg.of("--mode", choices=["api", "cli", "both"], default="both",
                       help="through the API (parse_scene and the simulation), the command "
                            "line, or both (default: every case through the API, "
                            "--cli-cases of them through the CLI too)"),
                Arg.of("--cli-cases", type=CASES, metavar="N",
                       help="--mode both: cases through the CLI too (default: a tenth)"),
                Arg.of("--workers", type=WORKERS, metavar="N",
                       help="command lines at once (default: every core; the API cases "
                            "run one at a time in one sandboxed worker)"),
                Arg.of("--no-simulate", dest="simulate", action="store_false",
                       help="API cases: validation only, accepted scenes not run"),
            )),
    Command("robustness", "random valid bouncing scenes through the runtime, on the smooth "
            "and the rough plane: falls, statuses, invariants, the friction cone, energy, "
            "cost", "derive.verify.robustness", (
                Arg.of("-n", "--cases", dest="n", type=CASES, default=10_000,
                       help="number of scenes on each plane (default 10000)"),
                Arg.of("--plane", choices=["smooth", "rough", "couples", "both", "face"],
                       default="both",
                       help="the smooth plane's scenes, the rough plane's (friction; up to "
                            "20 s each), the rough plane's with spin friction and rolling "
                            "resistance (couples), smooth and rough (both, default), or "
                            "boxes and cylinders on a face (face: the base model, up to 3 s "
                            "each, its stops judged against the reference)"),
                Arg.of("--seed", type=int, default=11, help="the generator's seed"),
                Arg.of("--duration", dest="max_duration", type=positive_float, metavar="SECONDS",
                       default=60.0, help="longest scene duration in s (default 60)"),
                Arg.of("--workers", type=WORKERS, metavar="N",
                       help="processes at once (default: every core)"),
            )),
    Command("failures", "hard scenes (accumulating impacts, grazing, chatter, a thin rod, "
            "a fast spin) through every method and peer, against references computed "
            "another way", "derive.verify.failures"),
    Command("mutants", "small mutations of the runtime's and the controllers' hand-written "
            "C (bounds x1.05, flipped comparisons, dropped terms, events' directions, "
            "tolerances x10), each built in a scratch copy and run against the tests of "
            "what it reaches: killed, survived, and the kill rate", "derive.verify.mutants", (
                Arg.of("--file", dest="files", action="append", metavar="NAME",
                       help="only the mutants of this file of templates/runtime or "
                            "templates/control (e.g. crt_rough.h; repeatable)"),
                Arg.of("--kind", dest="kinds", action="append",
                       choices=["bound", "flip", "term", "event", "tolerance"],
                       help="only mutants of this kind (repeatable)"),
                Arg.of("--match", action="append", metavar="TEXT",
                       help="only the mutants whose id or text contains TEXT (repeatable)"),
                Arg.of("--sample", type=CASES, metavar="N",
                       help="N of the selected mutants at random (--seed)"),
                Arg.of("--seed", type=int, default=36, help="the sample's seed"),
                Arg.of("--workers", type=WORKERS, metavar="N",
                       help="mutants built and tested at once (default: every core)"),
                Arg.of("--journal", metavar="FILE",
                       help="append each verdict to FILE (JSON lines); a later run skips "
                            "the mutants it records killed under the same C"),
                Arg.of("--test", dest="tests", action="append", metavar="PYTEST_ARG",
                       help="run these tests against every mutant (a file or a test id; "
                            "repeatable) instead of the tests of what each one reaches"),
                Arg.of("--list", dest="listing", action="store_true",
                       help="list the selected mutants, run nothing"),
            )),
)
