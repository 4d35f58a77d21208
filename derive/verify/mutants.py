"""``derive verify mutants``: do the tests notice when the runtime's C is slightly wrong?

A catalogue of small mutations of the runtime's and the controllers' hand-written C
(``templates/runtime`` and ``templates/control``: every ``.h`` and ``.c`` there that is no
jinja template), generated from the sites :mod:`derive.verify.csites` finds in them, never
from lines typed by hand:

* ``bound``: a factor of 1.05 on either side of every floating comparison whose sides
  are both non-zero (a threshold, or a bound such as ``rt <= mu_f R_Z``);
* ``flip``: every comparison turned around (``<`` to ``>``, ``<=`` to ``>=``, ``==`` to
  ``!=``), ``for`` headers apart;
* ``term``: each term of a sum dropped (multiplied by 0.0, so that what it reads stays
  read) in the sides of those floating comparisons and in what a ``double`` function
  returns (an event function's value);
* ``event``: both halves of a crossing test (``g0 > 0.0 && g1 <= 0.0``) turned around: the
  event's direction;
* ``tolerance``: every floating literal up to 1e-2 (and every ``#define`` of one) ten times
  larger, and every read of the user's tolerances (``opt[CRT_OPT_RTOL]``, ``ATOL``,
  ``EVENT_TOL``) ten times looser.

Each mutant is applied to a scratch copy of the C (``generated/runtime``, whose runtime
headers are the templates' verbatim twins, and ``templates/control``), never to the
worktree; the library is built from there (``$DERIVE_C_SOURCES``, :func:`derive.paths.
c_sources`, with a scratch ``$DERIVE_CACHE``) and a chosen subset of the tests runs
against it (:data:`UNIT_TESTS`: the tests of each compiled unit the mutation reaches,
found by preprocessing each model once).  A mutant is *killed* when a test fails or the
run crashes; it *survives* otherwise.  A run past its time is *timed out*, not killed: on a
loaded machine a survivor's tests can run long (crt_lie.h's ef8c8063 was miscalled killed
so), so each such mutant is run again once, alone, after the others, with RETRY times the
limit, and judged by that run; past that too it is killed as a hang, and said so.  A
survivor must be killed by a new test or recorded as equivalent, with the reason, in
``derive/verify/equivalent_mutants.toml`` (or its continuations,
``equivalent_mutants_*.toml``); the command exits 1 while any survivor is not.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from collections import Counter
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from ..commands import Target
from . import csites as cs

# the mutants' libraries are built at -O1: half the runtime's -O3 compile time, which is
# most of what a killed mutant costs (the tests hold their tolerances at either; the
# unmutated C is built the same way and must pass); $DERIVE_CFLAGS, when set, wins
MUTANT_CFLAGS = "-O1"
FACTOR = 1.05
LOOSER = 10.0
TOLERANCE_MAX = 1e-2
RETRY = 3.0      # a timed-out mutant is re-run alone with this many times the limit
PARTS = ("runtime", "control")
KINDS = ("bound", "flip", "term", "event", "tolerance")
TOLERANCE_OPTIONS = ("CRT_OPT_RTOL", "CRT_OPT_ATOL", "CRT_OPT_EVENT_TOL")
EQUIVALENTS = Path(__file__).with_name("equivalent_mutants.toml")
_REVERSED = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "!=", "!=": "=="}

# The tests a mutant runs, by the compiled units it reaches: the fast tests that exercise
# each unit (the sanitizer builds, the CLI's end-to-end runs and the long random sweeps
# are left to the suite), in an order that fails early (a killed mutant stops at its
# first failure).  "model_<kind>.c" units are the runtime's models, "control/<file>" the
# controllers' C (crt_hop.c the per-hop controller).  A survivor is run again
# against whole files (--test) before it is recorded as equivalent.
_ROUGH = "tests/test_friction_couples.py::"
_HOP = "tests/test_hop_control.py::"
_REPLAN = "tests/test_control_replan.py::"
_BODIES = "tests/test_multibody.py::"
UNIT_TESTS = {
    "model_rough.c": (
        "tests/test_friction_boundaries.py",
        "tests/test_rough_evaluators.py",
        "tests/test_friction_closed_forms.py",
        "tests/test_friction_runtime.py",
        _ROUGH + "test_a_spinning_sphere_stops_at_the_closed_form_time",
        _ROUGH + "test_a_rolling_ball_decelerates_at_the_closed_form_rate",
        _ROUGH + "test_a_body_held_from_rolling_slides_as_the_one_dimensional_coulomb_model",
        _ROUGH + "test_bardin_panevs_periodic_modes",
        _ROUGH + "test_the_wrench_equations_are_newton_eulers",
        "tests/test_friction_literature.py",
        "tests/test_contact_properties.py::test_random_rough_scenes_hold_every_property[0]",
    ),
    "model_general.c": (
        "tests/test_runtime.py",
        "tests/test_lie_runtime.py",
        "tests/test_bouncing.py",
        "tests/test_contact_newton_euler.py",
        "tests/test_runtime_status.py",
        "tests/test_contact_properties.py::test_random_bouncing_scenes_hold_every_property[0]",
    ),
    "model_moments_rough.c": (
        "tests/test_reaction_bodies.py",
        _BODIES + "test_random_scenes_on_a_rough_plane_keep_their_properties",
        _BODIES + "test_the_examples_of_several_bodies_do_what_the_readme_says",
    ),
    "model_moments.c": ("tests/test_multibody.py",),
    "model_base.c": ("tests/test_base_runtime.py", "tests/test_crt_face.py",
                     "tests/test_base_scene.py"),
    "model_vertical.c": ("tests/test_runtime.py", "tests/test_bouncing.py",
                         "tests/test_lie_runtime.py"),
    "model_attitude.c": ("tests/test_runtime.py", "tests/test_lie_runtime.py"),
    "model_translational.c": ("tests/test_events_boundaries.py", "tests/test_output_grid.py",
                              "tests/test_runtime.py"),
    "model_planar.c": ("tests/test_runtime.py",),
    "model_axisymmetric.c": ("tests/test_runtime.py",),
    "model_variational.c": ("tests/test_stability.py",),
    "control/crt_hop.c": (
        _HOP + "test_the_gait_correction_is_clamped_at_its_limit_and_a_law_renewed_a_period_"
        "before_its_end",
        _HOP + "test_the_c_controller_writes_the_python_routes_law_to_the_bit",
        _HOP + "test_where_impacts_stop_the_gait_goes_on_bounded_in_both_routes",
        _HOP + "test_the_apex_a_target_sets_is_the_runs",
        _HOP + "test_the_mirror_law_brings_the_apex_to_its_target",
        _HOP + "test_a_deadbeat_gain_settles_in_three_hops",
        _HOP + "test_feedback_holds_an_orbit_unstable_open_loop_at_the_predicted_rate",
    ),
    "control/ctl_qp.h": (
        "tests/test_qp_boundaries.py",
        _REPLAN + "test_qp_against_qpoases",
        _REPLAN + "test_soft_qp_against_qpoases_with_explicit_slacks",
        _REPLAN + "test_c_controller_returns_the_python_routes_law",
        _REPLAN + "test_closed_loop_replayed_with_its_realised_law",
        _REPLAN + "test_seeded_landings_upright_closed_not_open",
    ),
    "control/ctl_timing.c": (
        _REPLAN + "test_the_timed_controllers_logs_are_its_calls_seen_from_python",
        _REPLAN + "test_c_controller_returns_the_python_routes_law",
        _REPLAN + "test_closed_loop_replayed_with_its_realised_law",
    ),
}


# the base model's rules at their edges, its closed forms and edges, and its stops in the
# crawl's cells where a stick's sample had missed a short break, the face's integrals and
# margins against derive/face.py, the settle decision's reversals and tips, and the
# lift-off handed over to the flight, a spin in place to its stop, the translation up to
# its turn of 1e-12 (the base model's headers)
_BASE = ("tests/test_base_boundaries.py", "tests/test_crt_face.py",
         "tests/test_base_closed_forms.py", "tests/test_base_edges.py",
         "tests/test_base_tip_before_lift.py", "tests/test_base_flow_boundaries.py",
         "tests/test_capsule_modes.py::test_no_stop_is_missed",
         "tests/test_capsule_modes.py::test_the_cell_once_called_tipping_reverses",
         "tests/test_capsule_modes.py::test_the_three_types_and_every_stop_agree_with_the_"
         "one_dimensional_model",
         "tests/test_base_reversal_tip.py", "tests/test_handover.py",
         "tests/test_base_runtime.py::test_a_disc_spins_down_and_stops_when_the_closed_"
         "form_says",
         "tests/test_base_translation.py::test_a_slip_is_a_translation_up_to_a_turn_of_1e_"
         "12_of_its_speed")


# Tests of what one header does that the tests of the units it is compiled into do not
# reach (a controller sets the law during a run; rows on a uniform grid of output_dt;
# steps that end on a table's knots; a loop's law logged to a stop; a face landing flat at
# 0.98 and 1.02 of the height resolution, and that resolution as its rule's arithmetic):
# run for that header's mutants too.
HEADER_TESTS = {
    "crt_law.h": ("tests/test_law_boundaries.py", "tests/test_law.py"),
    "crt_control.h": ("tests/test_control_loop.py",
                      _HOP + "test_the_c_controller_writes_the_python_routes_law_to_the_bit",
                      _HOP + "test_where_impacts_stop_the_gait_goes_on_bounded_in_both_routes",
                      "tests/test_control_wheels.py"),
    "crt_events.h": (
        _HOP + "test_a_controllers_wider_gait_does_not_let_s_through_the_plane",
        "tests/test_events_boundaries.py::test_a_start_put_on_the_plane_begins_in_contact_"
        "within_round_off_of_it",
        "tests/test_flat_landing.py", "tests/test_face_spread_boundaries.py"),
    "crt_step.h": ("tests/test_outputs.py::test_tables_have_plain_names_and_a_uniform_grid",),
    "crt_loop.h": ("tests/test_law.py::test_rk4_steps_end_on_each_knot_never_longer",
                   _HOP + "test_a_loop_stopped_by_max_events_logs_its_law_to_the_stop",
                   "tests/test_control_loop.py",
                   "tests/test_output_grid.py::test_a_step_ending_just_short_of_a_grid_point_"
                   "leaves_its_row_to_the_grid",
                   "tests/test_runtime_status.py::test_a_first_step_whose_stages_overflow_is_"
                   "retried_not_a_nonfinite_stop"),
    "crt_core.h": ("tests/test_runtime_status.py", "tests/test_batch.py"),
    **{name: _BASE for name in ("crt_base.h", "crt_base_flow.h", "crt_base_model.h",
                                "crt_face.h")},
    "crt_lie.h": ("tests/test_lie_runtime.py::test_a_flight_from_a_half_turn_agrees_with_"
                  "dop853",),
    "crt_bodies.h": ("tests/test_bodies.py::test_crt_init_holds_the_bodies_parameters_to_"
                     "their_rule_at_its_edges",
                     _BODIES + "test_the_c_sums_the_moments_as_numpy_and_checks_the_bodies"),
    "crt_plane.h": ("tests/test_flat_starts.py::test_a_cylinder_a_hair_off_its_side_stops_where_"
                    "its_far_rim_is_within_the_tolerance",
                    "tests/test_flat_starts.py::test_a_box_a_hair_off_a_face_stops_on_the_lower_"
                    "of_its_far_corners",
                    "tests/test_face_spread_boundaries.py",
                    "tests/test_names_models_and_rk4.py::test_rk4s_impacts_end_where_its_steps_resolve_"
                    "them_whatever_rtol"),
    "crt_session.h": ("tests/test_runtime.py::test_max_events_is_a_status_not_a_hang",
                      "tests/test_flat_landing.py::test_trial_box_lands_flat_at_the_free_fall_"
                      "time"),
    "crt_smooth.h": ("tests/test_runtime.py::test_the_least_normal_reaction_of_a_resting_ball_"
                     "is_the_closed_forms",
                     "tests/test_control_loop.py::test_the_least_normal_reaction_holds_across_"
                     "two_contacts"),
}


@dataclass(frozen=True)
class Mutant:
    """One mutation: ``edits`` (start, end, new text) of the file's text."""
    part: str
    file: str
    function: str
    kind: str
    line: int
    before: str
    after: str
    edits: tuple
    occurrence: int = 1

    @property
    def key(self) -> str:
        """How the equivalents file names it: the function, the kind and the text, no
        line and no file (the C can move between headers)."""
        more = f" #{self.occurrence}" if self.occurrence > 1 else ""
        return f"{self.function}: {self.kind}: {self.before} -> {self.after}{more}"

    @property
    def id(self) -> str:
        return hashlib.sha1(self.key.encode()).hexdigest()[:8]

    @property
    def where(self) -> str:
        return f"{self.part}/{self.file}:{self.line} {self.function}"

    def apply(self, text: str) -> str:
        for start, end, new in sorted(self.edits, reverse=True):
            text = text[:start] + new + text[end:]
        return text


# ---- the catalogue ---------------------------------------------------------------------
def template_files() -> list[tuple[str, Path]]:
    """(part, path) of the hand-written C: ``*.h`` and ``*.c`` of templates/runtime and
    templates/control (jinja templates are not C)."""
    from ..paths import TEMPLATES
    out = []
    for part in PARTS:
        folder = TEMPLATES / part
        for path in sorted(folder.iterdir()):
            if path.suffix in (".h", ".c"):
                out.append((part, path))
    return out


def _line_text(src: cs.Source, a: int, b: int) -> str:
    return " ".join(src.span_text(a, b).split())


def _mutants_of(part: str, src: cs.Source, names: dict) -> list[Mutant]:
    out: list[Mutant] = []
    toks = src.tokens

    def add(kind, function, offset, before, after, edits):
        out.append(Mutant(part, src.name, function, kind, src.line_of(offset),
                          " ".join(before.split()), " ".join(after.split()), tuple(edits)))

    comps = cs.comparisons(src, names)
    for c in comps:
        op = toks[c.op]
        whole = (toks[c.left[0]].start, toks[c.right[1]].end)
        text = src.text[whole[0]:whole[1]]

        def rewrite(new_op=None, left=None, right=None):
            ltxt = left if left is not None else src.span_text(*c.left)
            rtxt = right if right is not None else src.span_text(*c.right)
            gap_l = src.text[toks[c.left[1]].end:op.start]
            gap_r = src.text[op.end:toks[c.right[0]].start]
            return ltxt + gap_l + (new_op or op.text) + gap_r + rtxt

        flipped = rewrite(new_op=_REVERSED[op.text])
        add("flip", c.function, op.start, text, flipped, [(whole[0], whole[1], flipped)])
        if c.kind == "double" and not c.zero and op.text in ("<", "<=", ">", ">="):
            for side in ("left", "right"):
                span = c.left if side == "left" else c.right
                new = f"{FACTOR} * ({src.span_text(*span)})"
                after = rewrite(**{side: new})
                add("bound", c.function, op.start, text, after,
                    [(whole[0], whole[1], after)])
        if c.kind == "double" and not c.zero:
            for span in (c.left, c.right):
                for a, b in cs.terms(src, *span):
                    s0, s1 = toks[a].start, toks[b].end
                    after = (src.text[whole[0]:s0] + f"0.0 * ({src.text[s0:s1]})"
                             + src.text[s1:whole[1]])
                    add("term", c.function, s0, text, after, [(whole[0], whole[1], after)])
    # the event's direction: g0 > 0.0 && g1 <= 0.0 both turned around
    for c1, c2 in zip(comps, comps[1:]):
        if not (c1.zero and c2.zero and c1.kind == c2.kind == "double"):
            continue
        if c1.right[1] + 2 != c2.left[0] or toks[c1.right[1] + 1].text != "&&":
            continue
        o1, o2 = toks[c1.op].text, toks[c2.op].text
        up = {"<": -1, "<=": -1, ">": 1, ">=": 1}
        if o1 not in up or o2 not in up or up[o1] == up[o2]:
            continue
        start, end = toks[c1.left[0]].start, toks[c2.right[1]].end
        text = src.text[start:end]
        after = (src.text[start:toks[c1.op].start] + _REVERSED[o1]
                 + src.text[toks[c1.op].end:toks[c2.op].start] + _REVERSED[o2]
                 + src.text[toks[c2.op].end:end])
        add("event", c1.function, toks[c1.op].start, text, after, [(start, end, after)])
    for fn, a, b in cs.returns_of(src):
        whole = (toks[a].start, toks[b].end)
        text = src.text[whole[0]:whole[1]]
        for x, y in cs.terms(src, a, b):
            s0, s1 = toks[x].start, toks[y].end
            after = src.text[whole[0]:s0] + f"0.0 * ({src.text[s0:s1]})" + src.text[s1:whole[1]]
            add("term", fn, s0, "return " + text, "return " + after,
                [(whole[0], whole[1], after)])
    for lit in cs.literals(src):
        if 0.0 < abs(lit.value) <= TOLERANCE_MAX:
            new = repr(lit.value * LOOSER)
            add("tolerance", lit.function, lit.start, lit.text, new,
                [(lit.start, lit.start + len(lit.text), new)])
    for start, end, text, fn in cs.tolerance_reads(src, TOLERANCE_OPTIONS):
        new = f"({LOOSER} * {text})"
        add("tolerance", fn, start, text, new, [(start, end, new)])
    return out


def catalogue() -> list[Mutant]:
    """Every mutant of the hand-written C, in file order, each with its occurrence number
    among mutants of the same key."""
    files = [(part, path, cs.parse(path.name, path.read_text(encoding="utf-8")))
             for part, path in template_files()]
    names = cs.names([src for _, _, src in files])
    out: list[Mutant] = []
    seen: dict = {}
    for part, _, src in files:
        for m in _mutants_of(part, src, names):
            if m.before == m.after:
                continue
            n = seen.get(m.key, 0) + 1
            seen[m.key] = n
            if n > 1:
                m = Mutant(m.part, m.file, m.function, m.kind, m.line, m.before, m.after,
                           m.edits, n)
            out.append(m)
    return out


def equivalents() -> dict[str, str]:
    """key -> reason, from equivalent_mutants.toml and its continuations
    (equivalent_mutants_*.toml beside it; an entry names one mutant, ``key``, or several
    of one site that share the reason, ``keys``)."""
    out = {}
    for path in sorted(EQUIVALENTS.parent.glob(EQUIVALENTS.stem + "*.toml")):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        for entry in data.get("mutant", []):
            for key in entry.get("keys", [entry.get("key")]):
                out[key] = entry["reason"]
    return out


# ---- where a mutant is compiled --------------------------------------------------------
def _compiled_lines(folder: Path, unit: str) -> dict[str, set]:
    """file name -> the lines of it that the preprocessor keeps in ``unit`` (a .c of
    ``folder``): the unit's models and options decide which #if blocks exist."""
    from ..cbuild import compiler
    proc = subprocess.run([compiler(), "-E", "-std=c99", "-I", str(folder), str(folder / unit)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"preprocessing {unit} failed:\n{proc.stderr[-2000:]}")
    out: dict[str, set] = {}
    current, line = None, 0
    marker = re.compile(r'^# (\d+) "([^"]+)"')
    for text in proc.stdout.splitlines():
        m = marker.match(text)
        if m:
            line, current = int(m.group(1)), Path(m.group(2)).name
            continue
        if current is not None and text.strip():
            out.setdefault(current, set()).add(line)
        line += 1
    return out


def units_of(mutants: list[Mutant], folder: Path) -> dict[str, tuple]:
    """mutant id -> the units it is compiled into (runtime: the .c files of ``folder``,
    each preprocessed once; control: the header or file itself)."""
    runtime_units = sorted(p.name for p in folder.iterdir() if p.suffix == ".c")
    lines = {u: _compiled_lines(folder, u) for u in runtime_units}
    out = {}
    for m in mutants:
        if m.part == "control":
            out[m.id] = (f"control/{m.file}",)
            continue
        if m.function.startswith("#define"):     # a macro: wherever its file is
            out[m.id] = tuple(u for u in runtime_units if lines[u].get(m.file))
            continue
        out[m.id] = tuple(u for u in runtime_units
                          if m.line in lines[u].get(m.file, ()))
    return out


def tests_for(units: tuple, files: tuple = ()) -> list[str]:
    """The pytest arguments of a mutant reaching ``units`` (in UNIT_TESTS' order, each
    once: the paper's models' tests before those of several bodies, which build one more
    model), then those of HEADER_TESTS for the mutated ``files``."""
    out: list[str] = []
    for unit in sorted(units, key=lambda u: (list(UNIT_TESTS).index(u) if u in UNIT_TESTS
                                             else len(UNIT_TESTS), u)):
        for t in UNIT_TESTS.get(unit, ()):
            if t not in out:
                out.append(t)
    for name in files:
        for t in HEADER_TESTS.get(name, ()):
            if t not in out:
                out.append(t)
    return out


# ---- running ----------------------------------------------------------------------------
@dataclass
class Outcome:
    mutant: Mutant
    status: str            # killed, survived, equivalent, stillborn, not compiled, untested
    detail: str = ""       # (timed out: only while its re-run alone is pending)
    seconds: float = 0.0
    units: tuple = ()
    timed_out: bool = False    # its first run went past the limit and it was re-run alone


_HASH_NAME = re.compile(r"[0-9a-f]{24}")


class Scratch:
    """A worker's copy of the C (``runtime/``, ``control/``) and its own build cache."""

    def __init__(self, root: Path):
        from ..paths import GENERATED, TEMPLATES
        self.root = root
        self.c = root / "c"
        shutil.copytree(GENERATED / "runtime", self.c / "runtime")
        shutil.copytree(TEMPLATES / "control", self.c / "control")
        self.cache = root / "cache"
        self.cache.mkdir()
        self.keep: set = set()

    def env(self) -> dict:
        from ..paths import C_SOURCES_ENV
        env = dict(os.environ)
        env.update({C_SOURCES_ENV: str(self.c), "DERIVE_CACHE": str(self.cache),
                    "PYTHONDONTWRITEBYTECODE": "1"})
        env.setdefault("DERIVE_CFLAGS", MUTANT_CFLAGS)
        return env

    def borrow(self, home: Path | None = None) -> None:
        """Another cache's libraries, linked in (default: the user's): the unmutated C
        built once, ever (the cache is keyed by the sources' content; a mutant's build
        is new).  Only finished entries (a folder named by its hash), never another
        process's build in progress."""
        from ..cbuild import cache_dir
        home = cache_dir() if home is None else home
        if not home.is_dir():
            return
        for entry in home.iterdir():
            link = self.cache / entry.name
            if _HASH_NAME.fullmatch(entry.name) and entry.is_dir() \
                    and not os.path.lexists(link):
                link.symlink_to(entry.resolve(), target_is_directory=True)

    def settle(self) -> None:
        """What the cache holds now is the unmutated build: kept from here on."""
        self.keep = set(os.listdir(self.cache))

    def forget(self) -> None:
        """Remove what a mutant built."""
        for name in os.listdir(self.cache):
            if name not in self.keep:
                path = self.cache / name
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink()


def check_twins() -> None:
    """The runtime's templates must be the verbatim twins of generated/runtime's files
    (``derive emit`` copies them): a mutant of one is built as the other."""
    from ..paths import GENERATED
    for part, path in template_files():
        if part == "runtime":
            twin = GENERATED / "runtime" / path.name
            if not twin.is_file() or twin.read_bytes() != path.read_bytes():
                raise SystemExit(f"derive verify mutants: generated/runtime/{path.name} "
                                 f"differs from templates/runtime/{path.name}: run derive emit")


# the signals a test run gets from outside (kill's default, ^C, a hang-up), never from
# the mutated C, whose crashes are SIGSEGV, SIGABRT, SIGFPE, SIGBUS, SIGILL
_FROM_OUTSIDE = frozenset({signal.SIGTERM, signal.SIGINT, signal.SIGHUP})
_RUNNING: set = set()          # the test runs in flight, ended if the harness is stopped
_LOCK = threading.Lock()


def _stop_all() -> None:
    with _LOCK:
        for proc in list(_RUNNING):
            proc.kill()


def _pytest(scratch: Scratch, tests: list[str], timeout: float,
            cache: Path | None = None) -> tuple[str, str, float]:
    """(killed/survived/timed out/error, the first failing test or why, seconds);
    ``cache``: build into this cache instead of the scratch one (the unmutated C: kept for
    later runs)."""
    from ..paths import ROOT
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-n", "0", "-p", "no:cacheprovider",
           "--no-header", "-W", "ignore", *tests]
    env = scratch.env()
    if cache is not None:
        env["DERIVE_CACHE"] = str(cache)
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with _LOCK:
        _RUNNING.add(proc)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return "timed out", f"ran past {timeout:.3g} s", time.perf_counter() - start
    except BaseException:
        proc.kill()
        raise
    finally:
        with _LOCK:
            _RUNNING.discard(proc)
    seconds = time.perf_counter() - start
    if proc.returncode == 0:
        return "survived", "", seconds
    if proc.returncode == 1:
        failed = re.findall(r"^FAILED (\S+)", out, re.M) or re.findall(r"^ERROR (\S+)", out,
                                                                        re.M)
        return "killed", failed[0] if failed else "a test failed", seconds
    if -proc.returncode in _FROM_OUTSIDE:
        # ended by someone (kill, ^C, a closed terminal), not by the mutant: no verdict,
        # so a journal does not keep it as killed and the next run tries it again
        return "error", (f"stopped from outside (signal {-proc.returncode}): no verdict, "
                         "run it again"), seconds
    if proc.returncode < 0:
        return "killed", f"crashed (signal {-proc.returncode})", seconds
    return "error", (out + err)[-600:], seconds


def _compiles(scratch: Scratch, unit: str) -> str:
    """'' when the mutated unit compiles under the project's warnings, else the error."""
    from ..cbuild import WARNINGS, compiler
    if unit.startswith("control/"):
        name = unit.split("/", 1)[1]
        if not name.endswith(".h"):
            return ""
        shim = scratch.c / "control" / "_shim.c"
        shim.write_text(f'#define CTL_QP_N 4\n#define CTL_QP_M 3\n#include "{name}"\n'
                        "int ctl_shim_unused(void);\nint ctl_shim_unused(void) { return 0; }\n",
                        encoding="utf-8")
        path, folder = shim, scratch.c / "control"
    else:
        folder = scratch.c / "runtime"
        path = folder / unit
    proc = subprocess.run([compiler(), *WARNINGS, "-fsyntax-only", "-I", str(folder), str(path)],
                          capture_output=True, text=True)
    return "" if proc.returncode == 0 else proc.stderr.strip().splitlines()[0][:200]


def _scratch_file(scratch: Scratch, m: Mutant) -> Path:
    return scratch.c / m.part / m.file


@dataclass
class Report:
    outcomes: list = field(default_factory=list)
    baseline_seconds: float = 0.0
    catalogue_size: int = 0

    def count(self, status: str) -> int:
        return sum(o.status == status for o in self.outcomes)

    @property
    def kill_rate(self) -> float:
        judged = self.count("killed") + self.count("survived") + self.count("equivalent")
        return self.count("killed") / judged if judged else 1.0


def select(mutants: list[Mutant], files=None, kinds=None, match=None, sample=None,
           seed: int = 36) -> list[Mutant]:
    """The mutants of the named files (template names, e.g. crt_rough.h), of the
    kinds, whose id or key contains one of ``match``; ``sample`` of them at random."""
    texts = [match] if isinstance(match, str) else list(match or ())
    out = [m for m in mutants
           if (not files or m.file in files) and (not kinds or m.kind in kinds)
           and (not texts or any(x in m.id or x in m.key for x in texts))]
    if sample and sample < len(out):
        import random
        out = sorted(random.Random(seed).sample(out, sample),
                     key=lambda m: (m.part, m.file, m.line))
    return out


def _basis() -> str:
    """A hash of the hand-written C: a journal's verdicts stand while it is unchanged."""
    h = hashlib.sha256()
    for _, path in template_files():
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:16]


def _read_journal(path: Path | None, basis: str) -> dict:
    if path is None or not path.is_file():
        return {}
    out = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            entry = json.loads(line)
        except ValueError:
            continue
        if entry.get("basis") == basis and entry.get("status") in ("killed", "stillborn",
                                                                   "not compiled"):
            out[entry["key"]] = entry
    return out


SCREEN = 6          # the tests that killed most mutants, run first on their own
_TEST_ID = re.compile(r"tests/\S+\.py::\S+")


def killers(path: Path | None):
    """How many mutants each test has killed, as a journal records it (under any C: a
    test that caught many mutants is likely to catch the next)."""
    count: Counter = Counter()
    if path is None or not path.is_file():
        return count
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            entry = json.loads(line)
        except ValueError:
            continue
        detail = entry.get("detail", "")
        if entry.get("status") == "killed" and _TEST_ID.fullmatch(detail):
            count[detail] += 1
    return count


def screen_of(chosen: list[str], kills, n: int = SCREEN) -> list[str]:
    """The ``n`` tests that killed most mutants (``kills``: test id -> count) among the
    mutant's tests ``chosen`` (a file, a test id, or one of a test's parameters)."""
    out = []
    for t, _ in sorted(kills.items(), key=lambda kv: (-kv[1], kv[0])):
        if any(t == c or t.startswith(c + "::") or t.startswith(c + "[") for c in chosen):
            out.append(t)
            if len(out) == n:
                break
    return out


def run(files=None, kinds=None, match=None, sample=None, seed: int = 36,
        workers: int | None = None, journal: str | None = None, listing: bool = False,
        tests: list | None = None, screen: int | None = None, progress=None) -> Report:
    """Build and test each selected mutant (``listing``: only list the catalogue).
    ``journal``: a file of verdicts (JSON lines) that a later run reuses for the mutants
    killed under the same C (a survivor is always run again: a new test may kill it).
    ``tests``: pytest arguments run against every mutant instead of UNIT_TESTS'.
    ``screen``: how many of the tests that killed most mutants (the journal's, and this
    run's) run first on their own, the rest of the subset only if they pass (0: none)."""
    check_twins()
    screen = SCREEN if screen is None else screen
    every = catalogue()
    mutants = select(every, files, kinds, match, sample, seed)
    report = Report(catalogue_size=len(every))
    if listing:
        report.outcomes = [Outcome(m, "listed") for m in mutants]
        return report
    equivalent = equivalents()
    basis = _basis()
    jpath = Path(journal) if journal else None
    done = _read_journal(jpath, basis)
    kills = killers(None if tests else jpath)   # grows as this run kills
    workers = max(1, min(workers or os.cpu_count() or 1, len(mutants) or 1))
    with tempfile.TemporaryDirectory(prefix="derive-mutants-") as tmp:
        scratches = [Scratch(Path(tmp) / f"w{k}") for k in range(workers)]
        for sc in scratches:
            sc.borrow()
        units = units_of(mutants, scratches[0].c / "runtime")
        todo = [m for m in mutants if m.key not in done]
        needed = list(tests) if tests else \
            tests_for(tuple(sorted({u for m in todo for u in units[m.id]})),
                      tuple(sorted({m.file for m in todo if units[m.id]})))
        # the unmutated C passes the tests (and its libraries are built once, shared)
        if needed:
            if progress:
                progress(f"the unmutated C through {len(needed)} test groups")
            from ..cbuild import cache_dir
            status, detail, secs = _pytest(scratches[0], needed, 3600.0, cache=cache_dir())
            if status != "survived":
                raise SystemExit(f"derive verify mutants: the tests fail on the unmutated C "
                                 f"({detail}); fix them first")
            report.baseline_seconds = secs
            for sc in scratches:
                sc.borrow()
        for sc in scratches:
            sc.settle()
        timeout = max(120.0, 4.0 * report.baseline_seconds)
        import queue
        free: queue.Queue = queue.Queue()
        for sc in scratches:
            free.put(sc)

        def one(m: Mutant) -> Outcome:
            if m.key in done:
                e = done[m.key]
                return Outcome(m, e["status"], e.get("detail", "") + " (journal)", 0.0,
                               units[m.id])
            us = units[m.id]
            if not us:
                return Outcome(m, "not compiled", "in no model (its #if blocks)")
            chosen = list(tests) if tests else tests_for(us, (m.file,))
            if not chosen:
                return Outcome(m, "untested", f"no tests for {', '.join(us)}", 0.0, us)
            with _LOCK:
                first = screen_of(chosen, kills, screen) if screen else []
            sc = free.get()
            try:
                status, detail, secs = attempt(m, sc, us, chosen, first, timeout)
            finally:
                free.put(sc)
            if status == "survived" and m.key in equivalent:
                status, detail = "equivalent", equivalent[m.key]
            return Outcome(m, status, detail, secs, us)

        def attempt(m: Mutant, sc: Scratch, us: tuple, chosen: list, first: list,
                    limit: float) -> tuple[str, str, float]:
            path = _scratch_file(sc, m)
            original = path.read_text(encoding="utf-8")
            try:
                path.write_text(m.apply(original), encoding="utf-8")
                err = _compiles(sc, us[0])
                if err:
                    return "stillborn", err, 0.0
                # a screen first (the tests that killed most mutants, collected alone),
                # then the rest of the subset without them; the mutant's libraries are
                # built once, in the screen, and reused (the scratch cache is kept)
                rest, secs = chosen, 0.0
                if first:
                    status, detail, secs = _pytest(sc, first, limit)
                    if status != "error":
                        rest = chosen + [f"--deselect={t}" for t in first]
                if not first or status == "survived" or status == "error":
                    status, detail, more = _pytest(sc, rest, limit)
                    secs += more
            finally:
                path.write_text(original, encoding="utf-8")
                sc.forget()
            return status, detail, secs

        def log(k: str, o: Outcome) -> None:
            if jpath is not None and "journal" not in o.detail and o.status != "timed out":
                with jpath.open("a", encoding="utf-8") as f:
                    f.write(json.dumps({"key": o.mutant.key, "id": o.mutant.id,
                                        "status": o.status, "detail": o.detail,
                                        "seconds": round(o.seconds, 2),
                                        "basis": basis}) + "\n")
            if progress:
                progress(f"[{k}] {o.status} {o.mutant.id} {o.mutant.where} "
                         f"{o.mutant.kind}: {o.mutant.before} -> {o.mutant.after}"
                         + (f" ({o.detail})" if o.detail else "")
                         + (" (re-run alone at the end)" if o.status == "timed out" else ""))

        n = len(mutants)
        pool = ThreadPoolExecutor(workers)
        try:
            futures = {pool.submit(one, m): i for i, m in enumerate(mutants)}
            got = {}
            for k, fut in enumerate(as_completed(futures), 1):
                o = fut.result()
                got[futures[fut]] = o
                if o.status == "killed" and not tests and _TEST_ID.fullmatch(o.detail):
                    with _LOCK:
                        kills[o.detail] += 1
                log(f"{k}/{n}", o)
            pool.shutdown()
            # the timed-out ones, each alone now (no other mutant's build or tests beside
            # it) with RETRY times the limit: judged by that run
            late = [o for o in got.values() if o.status == "timed out"]
            for k, o in enumerate(late, 1):
                m, sc = o.mutant, scratches[0]
                chosen = list(tests) if tests else tests_for(o.units, (m.file,))
                retry(o, lambda limit: attempt(m, sc, o.units, chosen, [], limit), timeout)
                if o.status == "survived" and m.key in equivalent:
                    o.status, o.detail = "equivalent", equivalent[m.key]
                log(f"alone {k}/{len(late)}", o)
        except BaseException:
            # stopped (a signal, ^C): no mutant after this one, the test runs ended now,
            # the scratch folders removed on the way out
            pool.shutdown(wait=False, cancel_futures=True)
            _stop_all()
            pool.shutdown(wait=True)
            raise
        report.outcomes = [got[i] for i in sorted(got)]
    return report


def retry(o: Outcome, rerun, limit: float) -> None:
    """Judge ``o``, timed out under ``limit``, by ``rerun(RETRY * limit)`` (a run of its
    tests alone: (status, detail, seconds)); past that limit too, it is killed as a hang."""
    status, detail, secs = rerun(RETRY * limit)
    o.timed_out, o.seconds = True, o.seconds + secs
    if status == "timed out":
        o.status, o.detail = "killed", (f"a hang: ran past {limit:.3g} s, and past "
                                        f"{RETRY * limit:.3g} s alone")
    else:
        o.status = status
        o.detail = (detail + "; " if detail else "") + \
            f"timed out at {limit:.3g} s, judged by its run alone ({secs:.3g} s)"


def targets(report: Report) -> list[Target]:
    surv = report.count("survived")
    untested = report.count("untested")
    return [Target(f"0 survivors not recorded as equivalent ({surv})", surv == 0),
            Target(f"0 mutants without tests ({untested})", untested == 0),
            Target(f"0 errors of the harness ({report.count('error')})",
                   report.count("error") == 0)]


def passed(report: Report) -> bool:
    if report.outcomes and all(o.status == "listed" for o in report.outcomes):
        return True
    return all(t.ok for t in targets(report))


def timeouts(rep: Report) -> str:
    """The mutants whose first run went past its limit and how their run alone ended
    ('' if none): a hang is killed, but counted apart from a failing test."""
    late = [o for o in rep.outcomes if o.timed_out or o.status == "timed out"]
    if not late:
        return ""
    hung = sum(o.status == "killed" and o.detail.startswith("a hang") for o in late)
    other = Counter(o.status for o in late
                    if not (o.status == "killed" and o.detail.startswith("a hang")))
    return (f"{len(late)} timed out and re-run alone: "
            + ", ".join([f"{hung} killed as a hang (past the longer limit too)"] * bool(hung)
                        + [f"{v} {k}" for k, v in sorted(other.items())]) + "; ")


def report(rep: Report) -> str:
    lines = []
    if rep.outcomes and all(o.status == "listed" for o in rep.outcomes):
        for o in rep.outcomes:
            m = o.mutant
            lines.append(f"{m.id} {m.where} {m.kind}: {m.before} -> {m.after}")
        kinds = Counter(o.mutant.kind for o in rep.outcomes)
        lines.append(f"{len(rep.outcomes)} of {rep.catalogue_size} mutants ("
                     + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())) + ")")
        return "\n".join(lines)
    for o in rep.outcomes:
        if o.status in ("survived", "untested", "error") or o.detail.startswith("a hang"):
            m = o.mutant
            lines.append(f"  {o.status} {m.id} {m.where} {m.kind}: {m.before} -> "
                         f"{m.after}" + (f" ({o.detail[:200]})" if o.detail else ""))
    by_file = Counter((o.mutant.file, o.status) for o in rep.outcomes)
    for name in sorted({o.mutant.file for o in rep.outcomes}):
        counts = {s: by_file[(name, s)] for s in ("killed", "survived", "equivalent",
                                                   "stillborn", "not compiled", "untested")
                  if by_file[(name, s)]}
        lines.append(f"{name}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    counts = Counter(o.status for o in rep.outcomes)
    judged = counts["killed"] + counts["survived"] + counts["equivalent"]
    lines.append(f"{len(rep.outcomes)} of {rep.catalogue_size} mutants: "
                 + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
                 + f"; kill rate {counts['killed']}/{judged} = {100 * rep.kill_rate:.1f}% "
                 f"({counts['equivalent']} survivors recorded as equivalent); "
                 + timeouts(rep) + f"the unmutated tests took {rep.baseline_seconds:.0f} s")
    ran = [o for o in rep.outcomes if o.seconds > 0.0]
    if ran:
        def mean(xs):
            return f"{sum(xs) / len(xs):.1f} s" if xs else "-"
        lines.append(
            f"cost: {mean([o.seconds for o in ran])} a mutant run ({len(ran)}): killed "
            + mean([o.seconds for o in ran if o.status == "killed"]) + ", survived or "
            "equivalent " + mean([o.seconds for o in ran
                                  if o.status in ("survived", "equivalent")]))
    lines.append("goal: " + "; ".join(str(t) for t in targets(rep)))
    return "\n".join(lines)
