"""The schema of every file a user writes, in one table of :class:`Field`: the scene's
tables (``[body]``, ``[point]`` or ``[[point]]``, ``[[rotor]]``, ``[plane]``,
``[initial]``, ``[run]``, ``[stability]``) and a planning task's ``[plan]``.  Validation
of single values (types, ranges, lists, nested tables), the defaults, the README's tables
and the template of ``derive scene new`` all read it; the rules across fields are in
:mod:`derive.scene.rules`.

A :class:`Schema` is a selection of fields (a scene's, a task's); its :meth:`~Schema.read`
turns a parsed document into the values of every field, and the set of fields the
document gave, refusing unknown keys with the nearest known one suggested.

The internal bodies are arrays of tables (:data:`ARRAYS`): ``[[point]]`` (zero or more
points, each with the fields of ``[point]``; ``[point]``, a single table, is one point)
and ``[[rotor]]``; their elements are read into :class:`Element` objects, and a message
names the element and its field: ``[[rotor]] 2: axis: must be a unit vector``.
"""
from __future__ import annotations

import difflib
import math
import numbers
import re
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .. import abi, shapes
from .errors import SceneError, type_name


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()     # a field's default when the document must give it


@dataclass(frozen=True)
class Field:
    table: str                 # "" for the top level
    key: str                   # "region.radius" for a field of a nested table
    kind: str                  # number integer vector string choice choices bool laws bodies
                               # matrix rotation numbers samples table tables
    default: Any               # REQUIRED, None (may be absent) or the default value
    doc: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False      # lo excluded
    size: int = 0              # vectors: the number of entries
    choices: tuple = ()
    example: Any = None        # what `derive scene new` writes (None: the default)
    when: str = ""             # the condition under which the field applies
    fields: tuple = ()         # a nested table's own fields (kind = "table")
    modes: tuple = ()          # [control]: the modes that read the field (): every mode
    models: tuple = ()         # the models that read the field (): every model; the
                               # others refuse it by name when given (runtime/choice.py)
    methods: tuple = ()        # [run].method's that read the field (): every method; the
                               # others refuse it by name when given (runtime/choice.py)

    @cached_property
    def where(self) -> str:
        """How messages name the field: ``[body].mass``, ``name``, ``[[rotor]].axis``
        (an element's: :meth:`Element.where`)."""
        if self.table in ARRAY_ONLY:
            return f"[[{self.table}]].{self.key}"
        return f"[{self.table}].{self.key}" if self.table else self.key

    @cached_property
    def path(self) -> str:
        """How overrides name the field: ``body.mass``, ``name``."""
        return f"{self.table}.{self.key}" if self.table else self.key

    @property
    def rule(self) -> str:
        if self.choices:
            return "one of " + ", ".join(self.choices)
        if self.lo is None and self.hi is None:
            return ""
        lo = "(" if self.lo_open else "["
        if self.hi is None:
            return f"{'>' if self.lo_open else '>='} {self.lo:g}"
        return f"in {lo}{self.lo:g}, {self.hi:g}]"


F = Field
MAX_MASS = 1e9
MAX_LENGTH = 1e6
MAX_DURATION = 1e7
MAX_ROWS = 10_000_000
MIN_DURATION = 1e-12       # s: the runtime's steps (duration / 2000, / 4) stay normal floats
MAX_TABLES = 1000          # entries of a list of tables ([disturbance].pushes)
NAME_CHARACTERS = "- _ . , : ; = + ( ) [ ] / # @ & '"
# the tables a scene may give several of (arrays of tables, [[point]]), with the most
# elements each (derive/abi.py: the C law's limits); ARRAY_ONLY: never a single table
ARRAYS = {"point": abi.LAW_MAX_POINTS, "rotor": abi.LAW_MAX_ROTORS}
ARRAY_ONLY = ("rotor",)
AXIS_TOLERANCE = 1e-6      # |a| of a rotor's axis within this of 1 (then normalised)
_NAME = re.compile(r"[A-Za-z0-9 _.,:;=+()\[\]/#@&'\-]{1,80}", re.ASCII)

# who reads [stability]: one scene file serves several commands, so the others accept it
STABILITY_READER = ("read by `derive stability` only: derive simulate and the other "
                    "commands accept and ignore it; refused in a scene that is not one point")
# the [stability] keys each motion `derive stability` analyses reads, and why the other
# does not read a key: given there, the key is refused with that reason
# (derive/stability/scenes.py; derive/docs/stability.md lists the same)
STABILITY_KEYS = {
    "free flight": {"period": None, "long_periods": None, "perturbations": None,
                    "impacts_every": "it has no impacts; its period is "
                                     "[stability].period or the law's"},
    "periodic bouncing": {"impacts_every": None, "long_periods": None, "perturbations": None,
                          "period": "its period is impacts_every periods of the "
                                    "point's law: set impacts_every"},
}


def stability_readers(key: str) -> str:
    """Which motions read ``[stability].key`` (the schema table's words for STABILITY_KEYS)."""
    words = {"free flight": "free flight", "periodic bouncing": "on the plane"}
    return " and ".join(words[k] for k, keys in STABILITY_KEYS.items() if keys[key] is None)


STABILITY_PERTURBATIONS_RULE = ("sizes the perturbed runs, so it needs long_periods > 0 "
                                "([stability].long_periods or --long)")
SCENE_FIELDS = (
    F("", "name", "string", "scene", "a label for the outputs: at most 80 ASCII letters, "
      f"digits, spaces and {NAME_CHARACTERS}", example="my-scene"),
    F("body", "mass", "number", REQUIRED, "M, mass of the carrier", 0, MAX_MASS, True,
      example=1.0),
    F("body", "inertia", "vector", REQUIRED, "J_x, J_y, J_z, principal central moments of "
      "the carrier; each at most the sum of the other two", 0, MAX_MASS, True, size=3,
      example=[0.10, 0.12, 0.14]),
    F("body", "shape", "choice", REQUIRED, "the surface that meets the plane (none: no "
      "contact possible)", choices=(*shapes.SHAPE_NAMES, shapes.NONE), example="sphere"),
    *(F("body", size.key, "number" if size.count == 1 else "vector", None,
        f"{', '.join(names)} {size.doc}", 0, MAX_LENGTH, True,
        size=size.count if size.count > 1 else 0, example=size.example,
        when="shape = " + " or ".join(f'"{n}"' for n in names))
      for size, names in shapes.size_fields()),
    F("body", "center", "vector", [0.0, 0.0, 0.0], "centre of the shape in body axes",
      -MAX_LENGTH, MAX_LENGTH, size=3),
    F("point", "mass", "number", REQUIRED, "m, mass of the point", 0, MAX_MASS, True,
      example=0.2),
    F("point", "law", "laws", None, "x(t), y(t), z(t) in body axes: formulas in t, pi, "
      "numbers, + - * / ** ^ and sin cos tan exp log sqrt sinh cosh tanh asin acos atan",
      example=["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"], when="one of law, table, samples"),
    F("point", "table", "string", None, "a CSV file (path relative to the scene) with "
      "columns t, x, y, z: the law as samples, interpolated by a cubic spline",
      when="one of law, table, samples"),
    F("point", "samples", "samples", None, "the law as rows [t, x, y, z] in the scene itself",
      when="one of law, table, samples"),
    F("point", "ends", "choice", "free", "a table's ends: periodic (the law repeats), rest "
      "(P at rest at both ends), free (not-a-knot; the run stays inside the table)",
      choices=("periodic", "rest", "free"), when="table or samples"),
    F("point", "max_distance", "number", None, "how far P may go from O (default: 10 body "
      "sizes)", 0, MAX_LENGTH, True),
    F("rotor", "axis", "vector", REQUIRED, "a, the rotor's axis in body axes: a unit "
      f"vector (|a| within {AXIS_TOLERANCE:g} of 1, then normalised)", -1.0 - AXIS_TOLERANCE,
      1.0 + AXIS_TOLERANCE, size=3, example=[0.0, 0.0, 1.0]),
    F("rotor", "inertia", "number", REQUIRED, "I, the rotor's moment of inertia about its "
      "axis (its mass and transverse moments belong to [body], as if it were locked)", 0,
      MAX_MASS, True, example=0.01),
    F("rotor", "law", "formula", None, "psi(t), the rotor's angle about a relative to "
      "the body, in radians (right-handed): a formula as [point].law's", example="20*t",
      when="one of law, table"),
    F("rotor", "table", "string", None, "a CSV file (path relative to the scene) with "
      "columns t, psi: the angle as samples, interpolated by a cubic spline (a plan's "
      "rotors are written so)", example="psi.csv", when="one of law, table"),
    F("rotor", "ends", "choice", "free", "a table's ends, as [point].ends' (rest: the rotor "
      "at rest relative to the body at both ends)", choices=("periodic", "rest", "free"),
      example="free", when="table"),
    F("plane", "restitution", "number", REQUIRED, "e of Newton's law v_n+ = -e v_n- (E1.13); "
      "with friction, e of restitution_model", 0, 1, example=0.9,
      when="[plane] given (absent: free flight); a box or a cylinder started on its face "
      "(on_plane) on a rough plane may leave it out: the base model has no impacts, and "
      "its run then stops where the body lifts off (given, the flight after a lift-off "
      "reads it)"),
    F("plane", "friction", "number", 0.0, "mu_f, Coulomb's coefficient of friction at S (0: "
      "the paper's smooth plane; > 0: the rough model, one coefficient for static and "
      "kinetic friction: derive/docs/friction.md)", 0, 100),
    F("plane", "restitution_model", "choice", "energetic", "how a frictional impact's "
      "restitution ends: energetic (Stronge: the normal impulse's work in restitution is "
      "-e^2 times that in compression; never gains energy), poisson (normal impulses in the "
      "ratio e), newton (v_n+ = -e v_n-; energy-consistent only where mu_f |W_tn| = 0, and "
      "elsewhere the run stops with restitution_refused); with friction = 0 all three are "
      "E1.13", choices=("energetic", "poisson", "newton")),
    F("plane", "spin_friction", "number", 0.0, "mu_s, a length: drilling friction, a couple "
      "about the vertical at S with |T_Z| <= mu_s N that opposes the spin (a contact "
      "patch's; 0: none).  In contact only, with friction > 0", 0, MAX_LENGTH),
    F("plane", "rolling_resistance", "number", 0.0, "mu_r, a length: rolling resistance, a "
      "couple about the horizontal at S with |(T_X, T_Y)| <= mu_r N that opposes the "
      "rolling (a flat face of half-width mu_r that must not tip; 0: none).  In contact "
      "only, with friction > 0", 0, MAX_LENGTH),
    F("plane", "static_friction", "number", None, "mu_s, the static coefficient over a "
      "face (>= friction; default: friction): the base model's rest holds while the wrench "
      "it needs is within the limit surface of mu_s (derive/docs/bodies.md); refused on "
      "the other models", 0, 100, models=("base",)),
    F("plane", "pressure", "choice", "uniform", "the pressure over a face on the plane (the "
      "base model): uniform, or linear (Sakharov's: affine, its centroid at the centre of "
      "pressure the tipping moment needs; the run stops with face_lifting where that "
      "centre leaves the face's kern); refused on the other models",
      choices=abi.names(abi.PRESSURES), models=("base",)),
    F("initial", "time", "number", 0.0, "t0", -1e9, 1e9),
    F("initial", "com", "vector", [0.0, 0.0, 0.0], "X_C, Y_C, Z_C: C, the centre of mass of "
      "the whole system (the carrier and its points), fixed axes; with on_plane, Z_C is "
      "computed (give 0)", -1e9, 1e9, size=3, example=[0.0, 0.0, 1.5]),
    F("initial", "on_plane", "bool", False, "S on the plane at the start: Z_C computed from "
      "the shape, the attitude and where the points are (needs [plane] and a shape); "
      "pressed onto it and not leaving, the run begins in contact (no impact)"),
    F("initial", "com_velocity", "vector", [0.0, 0.0, 0.0], "X_C', Y_C', Z_C': C's velocity "
      "(the whole system's; the points' motion moves C); or give carrier_velocity", -1e6,
      1e6, size=3, example=[0.3, 0.0, 0.0]),
    F("initial", "carrier_velocity", "vector", None, "instead of com_velocity: the velocity "
      "of O, the carrier's own centre of mass (fixed axes): a carrier at rest is [0, 0, 0] "
      "whatever its points do (C's follows: V_O + A (omega x OC + OC'))", -1e6, 1e6, size=3),
    F("initial", "omega", "vector", [0.0, 0.0, 0.0], "angular velocity in body axes", -1e6,
      1e6, size=3, example=[0.5, -0.3, 1.0]),
    F("initial", "quaternion", "vector", [1.0, 0.0, 0.0, 0.0], "attitude as a unit "
      "quaternion (w, x, y, z), normalised; or give matrix", -1e9, 1e9, size=4),
    F("initial", "matrix", "matrix", None, "attitude as the matrix a_ij = cos(fixed axis i, "
      "body axis j), a rotation", -1.0 - 1e-6, 1.0 + 1e-6),
    F("run", "duration", "number", 5.0, "length of the run", 0, MAX_DURATION, True),
    F("run", "method", "choice", "lie", "integrator: lie (the momentum form: K and C's "
      "parabola constants of each flight, the attitude on SO(3); derive/docs/runtime.md), lie5, "
      "lie8, dopri5, dop853, rk4", choices=("lie", "lie5", "lie8", "dopri5", "dop853", "rk4")),
    F("run", "rtol", "number", 1e-10, "relative tolerance of the adaptive methods (lie, "
      "lie5, lie8, dopri5, dop853, and the base model's own DOP853): each step's error "
      "within atol + rtol times the state's size, and accumulating impacts end in contact "
      "once the next hop would rise less than 10 (atol + rtol (Z_C + L)), L the body's "
      "reach; lie runs lie8's coefficients below 1e-6.  rk4 keeps no tolerance (its step "
      "is [run].step, its hops resolved down to round-off): under it rtol acts only with "
      "friction (the slip's resolution, a frictional impact's own integration); "
      "derive/docs/runtime.md", 1e-15, 1e-2),
    F("run", "atol", "number", 1e-12, "absolute tolerance of the adaptive methods, with "
      "rtol's; under rk4 it acts only with friction (the slip's resolution)", 0, 1, True),
    F("run", "g", "number", 9.81, "gravity", 0, 1e4),
    F("run", "outputs", "choices", ["pose", "impacts"], "what the result holds",
      choices=("pose", "omega", "height", "impacts", "momentum")),
    F("run", "step", "number", None, "the fixed step of method rk4 (default: the least of "
      "duration/2000, 0.04 rad over omega(0)'s magnitude and a tenth of the law's time "
      "scale), cut to a quarter of a hop shorter than it and doubled back after; the "
      "adaptive methods choose their own steps from rtol and atol and refuse it", 0,
      MAX_DURATION, True, methods=("rk4",)),
    F("run", "max_events", "integer", 100_000, "stop after this many events", 1, 1e9),
    F("run", "max_steps", "integer", 10_000_000, "stop after this many steps", 1, 1e10),
    F("run", "output_dt", "number", 0.0, "rows every output_dt (0: one per step)", 0,
      MAX_DURATION),
    F("run", "keep_orthonormal", "bool", False, "project the attitude onto the rotations "
      "after every step of dopri5, dop853 or rk4, and of lie, lie5, lie8 in contact phases "
      "(where DOPRI5 or DOP853 stands in: a flight's Lie step stays on the rotations); "
      "refused where no step reads it: a Lie method without a plane, a model without an "
      "attitude (attitude, translational, planar, axisymmetric, base)"),
    F("run", "model", "choice", "auto", "the model (auto: the smallest that answers the "
      "scene; moments, moments_rough: any points and rotors through their moments, the "
      "only models of scenes that are not one point; base: a box or a cylinder resting "
      "on a face, on_plane, on a rough plane: derive/docs/bodies.md)",
      choices=("auto", "general", "rough", "vertical", "attitude", "translational",
               "planar", "axisymmetric", "moments", "moments_rough", "base")),
    F("run", "zeno_dt", "number", 1e-9, "accumulating impacts: enter contact when the "
      "remaining flights sum to less than zeno_dt x duration", 0, 1, True),
    F("stability", "period", "number", None, f"{stability_readers('period')}: the period "
      "(default: the law's)", 0, MAX_DURATION, True, when=STABILITY_READER),
    F("stability", "impacts_every", "integer", 1, f"{stability_readers('impacts_every')}: one "
      "impact per n periods", 1, 64, when=STABILITY_READER),
    F("stability", "long_periods", "integer", 0, f"{stability_readers('long_periods')}: "
      "perturbed runs this many periods long where the linear test is critical", 0,
      1_000_000, when=STABILITY_READER),
    F("stability", "perturbations", "numbers", [1e-6, 1e-4, 1e-2],
      f"{stability_readers('perturbations')}: their sizes (with long_periods > 0)", 0, 0.1,
      True, when=STABILITY_READER),
)

# ``[plan]`` of a planning task (derive plan): the goals, bounds and options of the OCP
PLAN_FIELDS = (
    F("plan", "goal", "choice", REQUIRED, "what the carrier should do (travel: the fastest "
      "periodic crawl of a body on its face, derive/docs/planning.md)",
      choices=("reorient", "land", "hop", "travel")),
    F("plan", "horizon", "number", None, "s; reorient: the duration (objective = time: its "
      "upper bound); land, hop: optional upper bound of the touchdown time / the period",
      0, MAX_DURATION, True, when="required for reorient"),
    F("plan", "target_matrix", "rotation", None, "a_ij at the end (reorient; land with "
      "at_touchdown = attitude), a rotation", -1.0 - 1e-6, 1.0 + 1e-6),
    F("plan", "at_touchdown", "choice", None, "land: attitude (needs target_matrix) or "
      "d_zero (d = CS x n = 0: the impact keeps omega, C2.4); default attitude when "
      "target_matrix is given, else d_zero", choices=("attitude", "d_zero"),
      when='goal = "land"'),
    F("plan", "spin_weight", "number", 0.0, "land: the weight of |omega+|^2 just after the "
      "touchdown impact (omega+ in rad/s) beside the effort, which the objective scales to 1 "
      "at the initial guess (derive control's re-plans: scaled by max_acceleration^2 T); 0: "
      "not weighed, so the impact's lever arm CS x n may leave the body spinning "
      "(at_touchdown = d_zero keeps omega instead)", 0, 1e9,
      when='goal = "land"'),
    F("plan", "region", "table", None, "P stays in this ball (body axes)",
      when="one of region, circle", fields=(
          F("plan", "region.center", "vector", [0.0, 0.0, 0.0], "the ball's centre",
            -MAX_LENGTH, MAX_LENGTH, size=3),
          F("plan", "region.radius", "number", REQUIRED, "the ball's radius", 0,
            MAX_LENGTH, True))),
    F("plan", "circle", "table", None, "instead of region: P moves on this circle in the "
      "body plane z = 0", when="one of region, circle; not for hop", fields=(
          F("plan", "circle.center", "vector", [0.0, 0.0], "the circle's centre (c_x, c_y)",
            -MAX_LENGTH, MAX_LENGTH, size=2),
          F("plan", "circle.radius", "number", REQUIRED, "its radius", 0, MAX_LENGTH, True),
          F("plan", "circle.start_angle", "number", 0.0, "where P starts on it (rad)",
            -1e6, 1e6))),
    F("plan", "start", "vector", None, "P at t = 0 (default: the region's centre)",
      -MAX_LENGTH, MAX_LENGTH, size=3, when="with region"),
    F("plan", "decide", "bodies", None, "the bodies whose laws the plan makes, named as "
      "their elements: \"point 1\", \"rotor 2\", ... (a [point] task plans its point); "
      "the others keep the law their element gives (formulas)",
      when="required with [[point]] or [[rotor]]"),
    F("plan", "max_acceleration", "number", None, "bound on |OP''| of each decided point",
      0, MAX_MASS, True, when="required when a point is decided"),
    F("plan", "direction", "vector", None, "travel: the guide P moves along (body axes, "
      "horizontal with the face on the plane; normalised), through region.center",
      -MAX_LENGTH, MAX_LENGTH, size=3, when='required for goal = "travel"'),
    F("plan", "max_velocity", "number", None, "travel: bound on |OP'| (absent: the region "
      "and max_acceleration bound the law alone)", 0, MAX_MASS, True,
      when='goal = "travel"'),
    F("plan", "max_rotor_rate", "number", None, "bound on |psi'| of each decided rotor "
      "(rad/s: the wheel's speed limit)", 0, MAX_MASS, True,
      when="required when a rotor is decided"),
    F("plan", "max_rotor_acceleration", "number", None, "bound on |psi''| of each decided "
      "rotor (rad/s^2: its motor's torque limit over its inertia I)", 0, MAX_MASS, True,
      when="required when a rotor is decided"),
    F("plan", "rest_at_ends", "bool", None, "P at rest at both ends (x' = x'' = 0); in a "
      "region it also returns to its start (the law repeats); hop: at rest at the impact "
      "(default: true but for hop)"),
    F("plan", "objective", "choice", "effort", "effort (integral of |OP''|^2) or time "
      "(reorient only)", choices=("effort", "time")),
    F("plan", "apex_height", "number", None, "hop: the highest Z_C of every hop (the period "
      "follows); the orbit keeps the spin omega_z of [initial]", 0, MAX_LENGTH, True,
      when='required for goal = "hop"'),
    F("plan", "require_stable", "bool", None, "hop: fail unless the orbit is stable "
      "(default false: prefer a stable one)", when='goal = "hop"'),
    F("plan", "intervals", "integer", 16, "pieces of the law = multiple-shooting intervals",
      4, 200),
    F("plan", "substeps", "integer", 2, "RK4 steps per interval in the NLP", 1, 50),
    F("plan", "tolerance", "number", 1e-10, "final accuracy of the defect-corrected plan",
      0, 1e-3, True),
    F("plan", "max_iterations", "integer", 400, "IPOPT iterations per solve", 10, 100_000),
)

# ``[control]``: the loop closed around a run (derive control, derive simulate)
CONTROL_FIELDS = (
    F("control", "mode", "choice", REQUIRED, "hop: per-hop feedback on the impact-to-impact "
      "map of a periodic hop (acts at impacts); mirror: the mirror law of Buehler and "
      "Koditschek (the vertical bounce; acts every period); replan: the plan re-solved in "
      "flight every period from the state read (reorient, land)",
      choices=("hop", "mirror", "replan")),
    F("control", "period", "number", None, "the sample period (replan default 0.02 s, "
      "mirror 0.002 s; hop acts at impacts)", 0, 10, True),
    F("control", "gain", "choice", "lqr", "hop: a discrete LQR gain, or deadbeat (both "
      "multipliers of the controlled block placed at 0)", choices=("lqr", "deadbeat"),
      modes=("hop",)),
    F("control", "state_weight", "number", 1.0, "hop: the LQR's weight of the hop's "
      "deviation (phase in rad, velocity in units of the orbit's)", 0, 1e9, True,
      modes=("hop",)),
    F("control", "input_weight", "number", 1.0, "hop: the LQR's weight of the law's "
      "correction (relative to the gait's amplitude)", 0, 1e9, True, modes=("hop",)),
    F("control", "apex_height", "number", None, "hop: steer the apex of C to this height "
      "above its impact height (the gait's frequency follows); mirror: the apex it "
      "steers to (default: the scene's own periodic hop)", 0, MAX_LENGTH, True,
      modes=("hop", "mirror")),
    F("control", "intervals", "integer", 30, "replan: intervals of the re-planned horizon",
      4, 200, modes=("replan",)),
    F("control", "iterations", "integer", 1, "replan: SQP iterations per sample (1: a "
      "real-time iteration)", 1, 100, modes=("replan",)),
    F("control", "solver", "choice", "sqp", "replan: sqp, the generated C controller "
      "(Gauss-Newton SQP: CasADi's code of the QP's data, a dense dual active-set QP), or "
      "ipopt (in-process, converged every sample, for comparison)",
      choices=("sqp", "ipopt"), modes=("replan",)),
    F("control", "duration", "number", None, "how long the loop runs (default: land, the "
      "plan's touchdown and a fifth more; reorient, the plan's horizon; else two seconds)",
      0, MAX_DURATION, True),
)

# ``[disturbance]``: the pushes (in every run), and with [control] the plant that differs
# from the model and the noise on what the controller reads, seeded and recorded
DISTURBANCE_FIELDS = (
    F("disturbance", "seed", "integer", 0, "the seed of the noise (given without noise: "
      "refused)", 0, 2 ** 53),
    F("disturbance", "mass_factor", "number", 1.0, "the plant's M over the model's (with "
      "[control] only: an open run has one body)", 0, 100, True),
    F("disturbance", "point_mass_factor", "number", 1.0, "the plant's m over the model's "
      "(with [control] only)", 0, 100, True),
    F("disturbance", "inertia_factor", "vector", [1.0, 1.0, 1.0], "the plant's J_x, J_y, "
      "J_z over the model's (with [control] only)", 0, 100, True, size=3),
    F("disturbance", "restitution", "number", None, "the plant's e where it differs from "
      "the model's (with [control] only)", 0, 1),
    F("disturbance", "noise", "table", None, "standard deviations of what the controller "
      "reads (with [control] only)", fields=(
          F("disturbance", "noise.omega", "number", 0.0, "of omega (rad/s)", 0, 1e3),
          F("disturbance", "noise.attitude", "number", 0.0, "of the attitude (rad, a "
            "rotation about each body axis)", 0, 1),
          F("disturbance", "noise.com", "number", 0.0, "of C's position (m)", 0, 1e3),
          F("disturbance", "noise.com_velocity", "number", 0.0, "of C's velocity (m/s)", 0,
            1e3))),
    F("disturbance", "pushes", "tables", None, "impulsive pushes, in every run, with or "
      "without [control]: a scene of one point runs the general model (on a rough plane "
      "the rough one), a scene of several points or rotors its moments model (moments, "
      "moments_rough), whose impulse maps take them (Delta V_C = P / (M + sum m))", fields=(
        F("disturbance", "pushes.time", "number", REQUIRED, "when (s)", -1e9, 1e9),
        F("disturbance", "pushes.impulse", "vector", REQUIRED, "the impulse P in fixed axes "
          "(N s)", -1e6, 1e6, size=3),
        F("disturbance", "pushes.at", "vector", [0.0, 0.0, 0.0], "the body point it acts at "
          "(body axes, from O)", -MAX_LENGTH, MAX_LENGTH, size=3))),
)

FIELDS = SCENE_FIELDS + PLAN_FIELDS + CONTROL_FIELDS + DISTURBANCE_FIELDS


# ---- single values -----------------------------------------------------------------------
def in_range(f: Field, x):
    """The range rule of a number field with a lower bound: ``x`` in [lo, hi] ((lo, hi]
    when ``lo_open``; no upper bound when ``hi`` is None); NaN is in no range.  ``x`` a
    float, or an array of them (a study's variants at once: derive.scene.bulk), for which
    the answer is an array."""
    above = x > f.lo if f.lo_open else x >= f.lo
    return above if f.hi is None else above & (x <= f.hi)


def check_number(f: Field, value, where: str | None = None) -> float:
    where = where or f.where
    if type(value) is float and f.lo is not None and in_range(f, value):
        return value                        # the common case, checked in one line
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(where, f"must be a number, not {type_name(value)}")
    if isinstance(value, numbers.Integral):              # int, NumPy integers
        value = int(value)
    if isinstance(value, int) and abs(value) > 2 ** 53:
        shown = f"{value:.3e}" if abs(value).bit_length() <= 1000 else \
            f"about 2^{abs(value).bit_length() - 1}"
        raise SceneError(where, f"is too large ({shown} exceeds 2^53)")
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(where, "must be finite (no NaN or infinity)")
    if f.lo is not None:
        low_bad = x <= f.lo if f.lo_open else x < f.lo
        high_bad = f.hi is not None and x > f.hi
        got = value if isinstance(value, int) else x      # echoed as typed: -1, not -1.0
        if (low_bad or high_bad) and f.hi is not None and f.hi <= 1.0:
            raise SceneError(where, f"must be {f.rule} (got {got!r})")     # a fraction
        if low_bad:
            raise SceneError(where, f"must be {'>' if f.lo_open else '>='} {f.lo:g} "
                                    f"(got {got!r})")
        if high_bad:
            raise SceneError(where, f"must be at most {f.hi:g} (got {got!r}): beyond any "
                                    "physical scene this runtime is meant for")
    return x


def check_vector(f: Field, value, where: str | None = None) -> tuple:
    where = where or f.where
    size = f.size
    if type(value) is list and len(value) == size and f.hi is not None:
        # the common case at once: floats in range (a NaN fails x <= hi)
        lo, hi, lo_open = f.lo, f.hi, f.lo_open
        for x in value:
            if type(x) is not float or not (x <= hi and (x > lo if lo_open else x >= lo)):
                break
        else:
            return tuple(value)
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != size:
        raise SceneError(where, f"must be a list of {size} numbers")
    return tuple(check_number(f, v, f"{where}[{k}]") for k, v in enumerate(value))


def check_matrix(f: Field, value, where: str | None = None) -> np.ndarray:
    """A 3x3 matrix of numbers in the field's range."""
    where = where or f.where
    if isinstance(value, np.ndarray) and value.shape == (3, 3):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise SceneError(where, "must be a list of 3 rows of 3 numbers")
    rows = []
    for i, row in enumerate(value):
        if isinstance(row, np.ndarray) and row.ndim == 1:
            row = row.tolist()
        if not isinstance(row, (list, tuple)) or len(row) != 3:
            raise SceneError(f"{where}[{i}]", "must be a row of 3 numbers")
        rows.append([check_number(f, v, f"{where}[{i}][{j}]") for j, v in enumerate(row)])
    return np.array(rows)


def as_rotation(A: np.ndarray, where: str) -> np.ndarray:
    """A matrix orthonormal to 1e-6 with det +1, projected onto SO(3)."""
    err = float(np.max(np.abs(A @ A.T - np.eye(3))))
    if err > 1e-6:
        raise SceneError(where, f"must be orthonormal (A A^T - 1 is {err:.1e})")
    if np.linalg.det(A) < 0:
        raise SceneError(where, "must be a rotation (det = +1), not a reflection")
    u, _, vt = np.linalg.svd(A)
    return u @ vt


def _shown(text: str) -> str:
    return text if len(text) <= 30 else text[:27] + "..."


def check_value(f: Field, value, where: str | None = None):
    """``value`` of field ``f`` validated (and converted: tuples for vectors, a rotation
    matrix, the dict of a nested table)."""
    where = where or f.where
    k = f.kind
    if k == "number":
        return check_number(f, value, where)
    if k == "integer":
        x = check_number(f, value, where)
        if x != int(x):
            raise SceneError(where, f"must be an integer (got {value!r})")
        return int(x)
    if k == "vector":
        return check_vector(f, value, where)
    if k == "bool":
        if not isinstance(value, bool):
            raise SceneError(where, "must be true or false")
        return value
    if k == "string":
        if not isinstance(value, str):
            raise SceneError(where, f"must be a string, not {type_name(value)}")
        if f.key == "name" and not _NAME.fullmatch(value):
            raise SceneError(where, "must be 1 to 80 ASCII letters, digits, spaces or "
                                    f"{NAME_CHARACTERS}")
        if len(value) > 4096:
            raise SceneError(where, "is longer than 4096 characters")
        return value
    if k == "choice":
        if not isinstance(value, str):
            raise SceneError(where, f"must be a string, not {type_name(value)}")
        if value not in f.choices:
            raise SceneError(where, f"must be {f.rule}; got {_shown(value)!r}" +
                             suggestion(value, f.choices))
        return value
    if k == "choices":
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise SceneError(where, f"must be a list of strings, each {f.rule}")
        for v in value:
            if v not in f.choices:
                raise SceneError(where, f"{_shown(v)!r} is not {f.rule}" +
                                 suggestion(v, f.choices))
        return tuple(dict.fromkeys(value))
    if k == "numbers":
        if not isinstance(value, list) or not value or len(value) > 64:
            raise SceneError(where, "must be a list of 1 to 64 numbers")
        return tuple(check_number(f, v, f"{where}[{i}]") for i, v in enumerate(value))
    if k == "matrix":
        return check_matrix(f, value, where)
    if k == "rotation":
        return as_rotation(check_matrix(f, value, where), where)
    if k == "formula":
        if not isinstance(value, str):
            raise SceneError(where, f"must be a string (a formula in t), not {type_name(value)}")
        return value
    if k == "laws":
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise SceneError(where, "must be a list of three strings: x(t), y(t), z(t)")
        for i, text in enumerate(value):
            if not isinstance(text, str):
                raise SceneError(f"{where}[{i}]", f"must be a string, not {type_name(text)}")
        return tuple(value)
    if k == "samples":
        return _samples(where, value)
    if k == "bodies":
        return _bodies(where, value)
    if k == "table":
        return read_nested(f, value, where)
    if k == "tables":
        if not isinstance(value, list) or len(value) > MAX_TABLES:
            raise SceneError(where, f"must be a list of at most {MAX_TABLES} tables")
        return tuple(read_nested(f, item, f"{where}[{i}]") for i, item in enumerate(value))
    raise AssertionError(k)


_CELL = Field("point", "samples", "number", None, "")
_BODY = re.compile(r"(point|rotor) ([1-9][0-9]{0,2})", re.ASCII)


def body_name(text: str) -> tuple | None:
    """("point", 1) of "point 1" (an element of [[point]] or [[rotor]], from 1), else
    None."""
    m = _BODY.fullmatch(text) if isinstance(text, str) else None
    return (m.group(1), int(m.group(2))) if m else None


def _bodies(where: str, value) -> tuple:
    """A list of bodies' names (``"point 1"``, ``"rotor 2"``), each once."""
    limit = ARRAYS["point"] + ARRAYS["rotor"]
    if not isinstance(value, list) or not 1 <= len(value) <= limit:
        raise SceneError(where, f"must be a list of 1 to {limit} names, each \"point N\" "
                                "or \"rotor N\"")
    for i, text in enumerate(value):
        if body_name(text) is None:
            shown = _shown(text) if isinstance(text, str) else type_name(text)
            raise SceneError(f"{where}[{i}]", f"must be \"point N\" or \"rotor N\" (N "
                                              f"from 1: the element's number); got "
                                              f"{shown!r}")
    return tuple(dict.fromkeys(value))


def _samples(where: str, value) -> list:
    if not isinstance(value, list) or not 4 <= len(value) <= 100_000:
        raise SceneError(where, "must be a list of 4 to 100000 rows [t, x, y, z]")
    rows = []
    isfinite = math.isfinite
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != 4:
            raise SceneError(f"{where}[{i}]", "must be a row of 4 numbers [t, x, y, z]")
        if all(type(v) is float and isfinite(v) for v in row):
            rows.append(row)            # the common case, checked without messages
            continue
        rows.append([check_number(_CELL, v, f"{where}[{i}][{j}]") for j, v in enumerate(row)])
    return rows


def _tail(f: Field) -> str:
    return f.key.rpartition(".")[2]


def read_nested(f: Field, value, where: str | None = None) -> dict:
    """A nested table (``[plan].region``): its keys checked against ``f.fields``, each
    value validated, defaults filled in; keyed by the sub-field's own name."""
    where = where or f.where
    if not isinstance(value, dict):
        example = ", ".join(f"{_tail(s)} = ..." for s in f.fields)
        raise SceneError(where, f"must be a table, e.g. {{ {example} }}")
    subs = {_tail(s): s for s in f.fields}
    out = {}
    for key in value:
        if key not in subs:
            raise SceneError(f"{where}.{str(key)[:40]}", unknown_key(key, subs))
    for key, s in subs.items():
        if key in value:
            out[key] = check_value(s, value[key], f"{where}.{key}")
        elif s.default is REQUIRED:
            raise SceneError(f"{where}.{key}", "is required")
        else:
            out[key] = None if s.default is None else check_value(s, s.default)
    return out


# ---- unknown keys ------------------------------------------------------------------------
def suggestion(got, known) -> str:
    """'; did you mean "mass"?' when one of ``known`` is close to ``got``, else ''."""
    if not isinstance(got, str) or len(got) > 80:
        return ""
    near = difflib.get_close_matches(got, list(known), n=1, cutoff=0.6)
    return f"; did you mean {near[0]!r}?" if near else ""


def unknown_key(got, known) -> str:
    """The rule of an unknown key: the nearest known one if any is close, else all of
    them."""
    near = suggestion(got, known)
    if near:
        return "is not a known key" + near
    return f"is not a known key (known: {', '.join(known)})"


# ---- a document against a selection of fields --------------------------------------------
class Schema:
    """The fields of one kind of file (a scene, a task) and how to read a document of
    it: ``values, given = schema.read(doc)``, ``values`` keyed by ``Field.where`` (every
    field: its value, its default, or REQUIRED), ``given`` the fields the document gave;
    ``values["__tables__"]`` the tables it has."""

    def __init__(self, fields: tuple, tables: tuple, what: str = "scene",
                 arrays: dict | None = None):
        self.fields = fields
        self.tables = tables                       # "" first: the top level
        self.what = what
        self.arrays = arrays or {}                 # tables that may be arrays: their limit
        self.by_table = {t: {f.key: f for f in fields if f.table == t} for t in tables}
        self.by_where = {f.where: f for f in fields}
        self.by_path = {f.path: f for f in fields}
        # how read checks each key of a table, by table: (where, fast, lo, hi, lo_open,
        # size, field), fast 1 for a number with both bounds, 2 for a vector, 0 otherwise
        self.plans = {t: {f.key: (f.where, _fast(f), f.lo, f.hi, f.lo_open, f.size, f)
                          for f in fields if f.table == t} for t in tables}
        self.required = tuple(f for f in fields if f.default is REQUIRED)
        self.top_keys = tuple(sorted(set(tables[1:]) | set(self.by_table[""])))
        self._top = frozenset(self.top_keys)
        self._defaults = None

    def defaults(self) -> dict:
        """Every field's default, validated once."""
        if self._defaults is None:
            self._defaults = {f.where: (f.default if f.default is None or f.default is REQUIRED
                                        else check_value(f, f.default)) for f in self.fields}
        return self._defaults

    def read(self, doc: dict) -> tuple[dict, set]:
        if not doc.keys() <= self._top:
            key = sorted(str(k) for k in doc if k not in self._top)[0]
            where = f"[{key[:40]}]" if isinstance(doc.get(key), dict) else key[:40]
            if key == "plan" and self.what == "scene":    # a task given as a scene
                raise SceneError(where, "belongs to a task, not a scene: plan it with "
                                        "`derive plan`, or close the loop around it with "
                                        "`derive control` ([control] mode replan)")
            raise SceneError(where, unknown_key(key, self.top_keys))
        out = dict(self.defaults())
        given: set = set()
        for table in self.tables:
            self.read_table(doc, table, out, given)
        out["__tables__"] = frozenset(t for t in self.tables[1:] if t in doc)
        return out, given

    def read_table(self, doc: dict, table: str, out: dict, given: set) -> None:
        """The fields of one table of ``doc`` (``""``: the top level) into ``out`` and
        ``given``."""
        if table == "":
            tab = doc
        else:
            if table not in doc:
                return
            tab = doc[table]
            if table in self.arrays and (isinstance(tab, list) or table in ARRAY_ONLY):
                out[f"[[{table}]]"] = self.read_array(table, tab)
                return
            if not isinstance(tab, dict):
                raise SceneError(f"[{table}]", "must be a table")
        if not tab:
            return
        plan = self.plans[table]
        seen = []
        for key, value in tab.items():
            entry = plan.get(key)
            if entry is None:
                if table == "":
                    continue                   # the tables themselves
                raise SceneError(f"[{table}].{str(key)[:40]}",
                                 unknown_key(key, self.by_table[table]))
            where, fast, lo, hi, lo_open, size, f = entry
            if fast == 1 and type(value) is float and value <= hi and \
                    (value > lo if lo_open else value >= lo):
                out[where] = value              # a number in range (NaN fails <=)
            elif fast == 2:
                out[where] = check_vector(f, value)
            else:
                out[where] = check_value(f, value)
            seen.append(where)
        given.update(seen)


    def read_array(self, table: str, items) -> tuple:
        """The elements of an array of tables (``[[point]]``), each read against the
        table's fields: a tuple of :class:`Element`."""
        limit = self.arrays[table]
        if not isinstance(items, list):
            raise SceneError(f"[{table}]", f"must be an array of tables: write [[{table}]] "
                                           f"once per {table} (at most {limit})")
        if len(items) > limit:
            raise SceneError(f"[[{table}]]", f"at most {limit} {table}s (the runtime's "
                                             f"limit; got {len(items)})")
        fields = self.by_table[table]
        out = []
        for i, item in enumerate(items, start=1):
            el = Element(table, i, {}, set())
            if not isinstance(item, dict):
                raise SceneError(el.name, f"must be a table, not {type_name(item)}")
            for key, value in item.items():
                f = fields.get(key)
                if f is None:
                    raise SceneError(el.where(str(key)[:40]), unknown_key(key, fields))
                el.values[key] = check_value(f, value, el.where(key))
                el.given.add(key)
            for key, f in fields.items():
                if key in el.values:
                    continue
                if f.default is REQUIRED:
                    raise SceneError(el.where(key), "is required" +
                                     (f" ({f.rule})" if f.choices else ""))
                el.values[key] = None if f.default is None else check_value(f, f.default)
            out.append(el)
        return tuple(out)


@dataclass
class Element:
    """One element of an array of tables (``[[point]]`` 2), or the single ``[point]``
    table: its fields' values by key (defaults filled in), the keys it gave, and how
    messages name it and its fields."""
    table: str
    index: int                 # from 1; 0 for a single table ([point])
    values: dict
    given: set

    @property
    def name(self) -> str:
        """``[[point]] 2`` (``[point]`` for the single table)."""
        return f"[[{self.table}]] {self.index}" if self.index else f"[{self.table}]"

    def where(self, key: str) -> str:
        """``[[point]] 2: mass`` (``[point].mass`` for the single table)."""
        return f"{self.name}: {key}" if self.index else f"[{self.table}].{key}"


def _fast(f: Field) -> int:
    if f.kind == "number" and f.hi is not None and f.lo is not None:
        return 1
    return 2 if f.kind == "vector" else 0


SCENE_TABLES = ("", "body", "point", "rotor", "plane", "initial", "run", "stability", "control",
                "disturbance")
SCENE = Schema(SCENE_FIELDS + CONTROL_FIELDS + DISTURBANCE_FIELDS, SCENE_TABLES, "scene",
               ARRAYS)

# a task's scene tables: a scene without a law and without the run's integration (the
# plan sets the duration and integrates), and [plan]; its internal bodies [point] (one,
# whose law the plan makes) or [[point]] and [[rotor]], each with a law (a formula) unless
# [plan].decide names it
_TASK_SCENE = tuple(f for f in SCENE_FIELDS
                    if f.table in ("", "body", "initial")
                    or (f.table, f.key) in (("point", "mass"), ("point", "law"),
                                            ("rotor", "axis"), ("rotor", "inertia"),
                                            ("rotor", "law"), ("plane", "restitution"),
                                            ("plane", "friction"),
                                            ("plane", "static_friction"),
                                            ("plane", "pressure"), ("run", "g")))
TASK = Schema(_TASK_SCENE + PLAN_FIELDS + CONTROL_FIELDS + DISTURBANCE_FIELDS,
              ("", "body", "point", "rotor", "plane", "initial", "run", "plan", "control",
               "disturbance"), "task", ARRAYS)
