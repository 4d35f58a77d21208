"""The runtime's names, in one place: options, parameters, statuses, event kinds, counters,
row kinds and the opcodes of the point-law interpreter.

Everything the C runtime and Python exchange by position or by code is listed here once.
``derive emit`` renders ``generated/runtime/crt_abi.h`` from these lists (enums, and
name tables the compiled library exports), and Python reads the same lists; the library
compares its name tables with these when it is loaded (:mod:`derive.runtime.build`).
Nothing else in the project numbers an option, a status or a counter.
"""
from __future__ import annotations

from dataclasses import dataclass

from . import shapes


@dataclass(frozen=True)
class Name:
    name: str
    doc: str
    rule: str = ""      # options: what crt_init requires of the value ("" : nothing)


def _names(*pairs) -> tuple:
    return tuple(Name(*p) for p in pairs)


# Options: a double vector the caller fills by these indices (crt_init copies it).  The
# third field is the rule crt_init checks (CRT_BAD_OPTIONS, and crt_bad_option gives the
# index of the first option that breaks its rule); tests/test_runtime_status.py breaks
# each rule and expects its option named.
OPTIONS = _names(
    ("method", "integrator (enum crt_method)", "an integer index into METHODS"),
    ("plane", "1: the plane is there (a model with contact); 0: free flight"),
    ("rtol", "relative tolerance of the adaptive methods", "> 0"),
    ("atol", "absolute tolerance of the adaptive methods", "> 0"),
    ("h0", "first step (0: chosen automatically)"),
    ("hmax", "largest step", "> 0"),
    ("rk4_step", "step of the fixed-step RK4", "> 0"),
    ("max_steps", "stop with max_steps after this many accepted steps", ">= 1"),
    ("max_events", "stop with max_events after this many events", ">= 1"),
    ("output_dt", "rows every output_dt from the dense output (0: one row per step)", ">= 0"),
    ("orthonormal", "1: project the attitude onto the rotations after every step"),
    ("time_scale", "the scene's time scale (its duration): tolerances of time are relative "
                   "to it", "> 0"),
    ("event_tol", "event location tolerance, relative to the time scale", "> 0"),
    ("length_scale", "the largest |CS| (surface and point): heights are resolved relative "
                     "to it", ">= 0"),
    ("zeno_dt", "accumulating impacts: enter contact when the remaining flights sum to less "
                "than zeno_dt times the time scale"),
    ("output_phase", "the output_dt grid's offset: rows at t0, then t0 + output_phase + k "
                     "output_dt (0: t0 + output_dt, ...); a run that goes on from another's "
                     "state keeps that run's grid (a hand-over after a lift-off)", ">= 0"),
    ("start_on_plane", "1: S starts on the plane ([initial].on_plane): pressed onto it and "
                       "not leaving, the run begins in contact, without an impact"),
)

# the internal bodies (issue 32): what the runtime needs to sum their moments (the
# layout of the moments in derive/layout.py; m above is the points' total): the counts,
# each point's mass, each rotor's unit axis in body axes and axial moment.  One point:
# n_points 1, m_1 = m.  Unused entries are 0.
LAW_MAX_POINTS = 16
LAW_MAX_ROTORS = 8
_BODY_PARAMETERS = (
    ("n_points", "the internal points ([point]: 1; [[point]]: 0 to LAW_MAX_POINTS)"),
    ("n_rotors", "the rotors ([[rotor]]: 0 to LAW_MAX_ROTORS)"),
    *((f"m_{j}", f"mass of point {j}" if j == 1 else "...")
      for j in range(1, LAW_MAX_POINTS + 1)),
    *((f"a_{r}_{c}", f"unit axis of rotor {r} in body axes" if (r, c) == (1, "x") else "...")
      for r in range(1, LAW_MAX_ROTORS + 1) for c in "xyz"),
    *((f"I_{r}", f"axial moment of inertia of rotor {r}" if r == 1 else "...")
      for r in range(1, LAW_MAX_ROTORS + 1)),
)

# the moments models' rule on the bodies' parameters (crt_bodies.h, crt_bodies_fault)
BODY_PARAMETERS = frozenset(("m", *(name for name, _ in _BODY_PARAMETERS)))
BODIES_RULE = ("describe the law's bodies: n_points and n_rotors the law's, each m_j >= 0 "
               "and m their sum, each rotor's axis (named by a_r_x) a unit vector, I_r >= 0")

# Parameters: a double vector of the scene's numbers, read by the model functions.
PARAMETERS = _names(
    ("M", "mass of the carrier"),
    ("m", "mass of the point"),
    ("J_x", "principal central moment of inertia of the carrier about Ox"),
    ("J_y", "... about Oy"),
    ("J_z", "... about Oz"),
    ("g", "gravity"),
    ("e", "restitution coefficient of the plane"),
    ("shape", "the surface: CRT_SHAPE_<name>, its place in derive/shapes.py"),
    ("size_a", "the shape's size numbers in the order of its fields (derive/shapes.py): a "
               "sphere's radius; an ellipsoid's semi-axes or a box's half-extents along Ox, "
               "Oy, Oz; a cylinder's radius and half-length"),
    ("size_b", "..."),
    ("size_c", "..."),
    ("center_x", "centre of the shape in body axes"),
    ("center_y", "..."),
    ("center_z", "..."),
    ("n0_x", "translational and planar models: the vertical n in body axes at the start"),
    ("n0_y", "..."),
    ("n0_z", "..."),
    ("K", "axisymmetric model: |K|, constant in flight"),
    ("omega_z0", "axisymmetric model: omega_z, constant in flight (E3.6)"),
    ("friction", "rough model: mu_f, Coulomb's friction coefficient at S (>= 0)"),
    ("restitution_model", "rough model: how an impact's restitution ends (enum "
                          "crt_restitution: energetic, poisson or newton)"),
    ("spin_friction", "rough model: mu_s, a length: |T_Z| <= mu_s N in contact (0: none)"),
    ("rolling_resistance", "rough model: mu_r, a length: |(T_X, T_Y)| <= mu_r N in contact "
                           "(0: none)"),
    ("static_friction", "base model: mu_s, the static coefficient over the face (>= "
                        "friction, which is the kinetic one)"),
    ("pressure", "base model: the pressure over the face (enum crt_pressure: uniform, or "
                 "linear: affine with its centroid at the centre of pressure)"),
    *_BODY_PARAMETERS,
)

# Values of prm[CRT_P_restitution_model] (derive/friction.py: darboux_keller's
# terminations).  With mu_f = 0 the three agree (X1.1), and the smooth models apply E1.13.
RESTITUTION_MODELS = _names(
    ("energetic", "Stronge: the normal impulse's work in restitution is -e^2 times that in "
                  "compression; never gains energy"),
    ("poisson", "the normal impulse of restitution is e times that of compression"),
    ("newton", "v_n+ = -e v_n-; only where it is energy-consistent (mu_f |W_tn| = 0 at the "
               "impact), else the run stops with restitution_refused"),
)

# Values of prm[CRT_P_pressure] (derive/face.py's PRESSURES, in its order): the base model's
# pressure over the face.
PRESSURES = _names(
    ("uniform", "N / A over the face"),
    ("linear", "affine over the face, its centroid at the centre of pressure (a rigid face "
               "on an elastic floor, Sakharov 2015); positive while cp is in the face's kern"),
)

METHODS = _names(
    ("rk4", "classical Runge-Kutta, fixed step, cubic Hermite dense output"),
    ("dopri5", "Dormand-Prince 5(4), adaptive, 4th-order dense output"),
    ("dop853", "Dormand-Prince 8(5,3), adaptive, 7th-order dense output"),
    ("lie", "flight on the integral (the default): K constant in fixed axes (E1.1), C on its "
            "parabola (E1.2), the attitude on SO(3) by Runge-Kutta-Munthe-Kaas with the "
            "exponential map; the coefficients of lie8 when rtol < 1e-6, of lie5 otherwise"),
    ("lie5", "the momentum form with the DOPRI5 coefficients (order 5, 4th-order dense "
             "output); DOPRI5 in persistent contact and in models without an attitude"),
    ("lie8", "the momentum form with the DOP853 coefficients (order 8, 7th-order dense "
             "output); DOP853 in persistent contact and in models without an attitude"),
)
# the methods that keep a flight's attitude on the rotations themselves (the Lie group's)
LIE_METHODS = tuple(m.name for m in METHODS if m.name.startswith("lie"))



@dataclass(frozen=True)
class Status:
    name: str
    code: int
    doc: str


# Return codes, in the manner of SUNDIALS' CVODE: 0 is success (a law or a run accepted),
# positive codes are stops that are not errors (the buffer is full, the end time or the
# caller's own event budget reached), negative codes are errors: the integration failed
# (-1 to -4: CVODE's CV_TOO_MUCH_WORK, CV_ERR_FAILURE, CV_RHSFUNC_FAIL, CV_RTFUNC_FAIL)
# or the call's input was refused (-20 and below: CVODE's CV_ILL_INPUT).  max_steps is an
# error as CVODE's mxstep is (work ran out before t_end); max_events is the caller's own
# budget of events, a stop like CVODE's root return.  The codes are part of the ABI:
# never renumber one.
STATUSES = (
    Status("ok", 0, "accepted: the law (crt_set_law_*), or the run is ready (crt_init)"),
    Status("paused", 1, "an output buffer is full: read the rows, call crt_advance again"),
    Status("done", 2, "the end time was reached"),
    Status("max_events", 3, "max_events events happened (opt[CRT_OPT_MAX_EVENTS])"),
    Status("stopped", 4, "the controller stopped the run (its call returned a negative "
                         "value)"),
    Status("lift_off", 5, "base model: the normal force N under the face reached 0 (the "
                          "body leaves the plane; the run stops there)"),
    Status("tipping", 6, "base model: the centre of pressure reached the face's edge (the "
                         "body tips about it; the run stops there)"),
    Status("face_lifting", 7, "base model, linear pressure: the centre of pressure left the "
                              "face's kern (the affine pressure would turn negative at an "
                              "edge: the face starts to lift there; the run stops there)"),
    Status("flat_landing", 8, "a box or a cylinder in flight came down on a face flat: every "
                              "corner of the face (the rim) at once, within the height "
                              "resolution, a multi-point impact no model makes; the run "
                              "stops at the touch"),
    Status("max_steps", -1, "max_steps steps were taken before the end time"),
    Status("step_underflow", -2, "the step size fell below 1e-14 of the time scale"),
    Status("nonfinite", -3, "the state or the right-hand side became NaN or infinite"),
    Status("penetration", -4, "S went below the plane and the event could not be located"),
    Status("painleve", -5, "sliding friction leaves no consistent normal reaction (Painleve: "
                           "dv_n/dp <= 0 in an impact, or k_f <= 0 while sliding)"),
    Status("restitution_refused", -6, "restitution_model newton at an impact where it is not "
                                      "energy-consistent (mu_f |W_tn| > 0)"),
    Status("surface_jump", -7, "in contact, the lowest point S jumped (a surface that is not "
                               "strictly convex, e.g. a capsule whose axis passes the "
                               "horizontal), or another point reached the plane with it (a "
                               "line or a face down): the one-point contact cannot hold it"),
    Status("bad_argument", -20, "an output buffer is smaller than CRT_MIN_ROWS rows or "
                                "CRT_MIN_EVENTS events (nothing is done: call again with "
                                "larger ones)"),
    Status("bad_options", -21, "an option breaks its rule: crt_bad_option names it"),
    Status("bad_parameters", -22, "a parameter is not finite, or shape is no CRT_SHAPE_*: "
                                  "crt_bad_parameter names it"),
    Status("bad_law", -23, "crt_set_law_* refused the law (malformed), or crt_init found "
                           "no law set"),
    Status("bad_control", -24, "the controller's law is refused (its knots, or x or x' "
                               "not continuous at its start): crt_control_fault says why"),
)
STATUS = {s.name: s.code for s in STATUSES}


def status_name(code: int) -> str:
    """The name of a return code (as ``crt_status_name``), or ``status <code>``."""
    for s in STATUSES:
        if s.code == code:
            return s.name
    return f"status {code}"


PHASES = _names(
    ("flight", "S above the plane"),
    ("contact", "S held on the plane by the reaction N >= 0"),
)

# The contact mode, a finer phase: what column "mode" of an event row says comes after the
# event (friction models; the smooth models leave it 0), and what crt_contact_mode gives.
MODES = _names(
    ("flight", "S above the plane"),
    ("smooth", "S on the plane, no friction"),
    ("sliding", "S on the plane, slipping: R = N (e_Z - mu_f dir)"),
    ("sticking", "S on the plane at rest: R inside the friction cone"),
)

EVENT_KINDS = _names(
    ("none", "(unused)"),
    ("impact", "S hit the plane with v_n < 0: the impact map applied"),
    ("contact", "impacts accumulated: S now rests on the plane"),
    ("lift_off", "N reached 0: S leaves the plane"),
    ("graze", "S touched the plane without approaching it"),
    ("push", "an impulsive push of the disturbances (value: |P|)"),
    ("stick", "the slip of S reached 0 with the reaction inside the cone: S sticks"),
    ("slip", "the sticking reaction left the friction cone: S starts to slip"),
    ("reversal", "the slip reached 0 and the cone cannot hold S: it slips again, along "
                 "-R_t"),
    ("spin_stop", "the spin about the vertical reached 0 and the drilling couple holds it "
                  "(value: |T_Z|/(mu_s N))"),
    ("spin_start", "the drilling couple reached mu_s N (or cannot hold the spin it stopped): "
                   "the body spins from rest against it (value: |T_Z|/(mu_s N))"),
    ("roll_stop", "the rolling (the horizontal angular velocity) reached 0 and the rolling "
                  "resistance holds it (value: |T_t|/(mu_r N))"),
    ("roll_start", "the rolling resistance reached mu_r N (or cannot hold the rolling it "
                   "stopped): the body rolls from rest against it (value: |T_t|/(mu_r N))"),
    ("tipping", "base model: the centre of pressure reached the face's edge (value: its "
                "distance from the face's centroid)"),
    ("face_lifting", "base model, linear pressure: the centre of pressure reached the "
                     "face's kern (the pressure reaches 0 at an edge; value: the kern margin)"),
    ("flat_landing", "a box or a cylinder in flight touched the plane coming down with a face "
                     "flat (value: the corners' spread in height, v_minus: v_n, v_plus: NaN; "
                     "no impact applied, the run stops)"),
)

STATS = _names(
    ("steps", "accepted steps"),
    ("rejected", "rejected steps"),
    ("rhs_evaluations", "right-hand side evaluations"),
    ("event_function_evaluations", "evaluations of the gap or of N"),
    ("impacts", "impacts"),
    ("contacts", "entries into persistent contact"),
    ("lift_offs", "lift-offs"),
    ("grazes", "grazes"),
    ("law_evaluations", "evaluations of the point law"),
    ("controller_calls", "calls of the controller (crt_control.h)"),
    ("law_changes", "laws the controller set"),
    ("pushes", "pushes applied"),
    ("sticks", "stick events (slip to stick in contact)"),
    ("slips", "slip events (stick to slip in contact)"),
    ("reversals", "reversal events (the slip reached 0 and restarted)"),
    ("couple_stops", "spin_stop and roll_stop events"),
    ("couple_starts", "spin_start and roll_start events"),
)

ROW_KINDS = _names(
    ("step", "a step's end or an output_dt sample"),
    ("before_event", "the state just before an event"),
    ("after_event", "the state just after an event"),
)

# Summary values the runtime keeps while it runs (crt_summary).
SUMMARY = _names(
    ("min_height", "lowest height of S at the ends of steps and at events, in flight"),
    ("min_normal", "smallest reaction N seen in contact (inf if never in contact)"),
    ("t_min_height", "when the lowest height was seen"),
    ("max_friction_ratio", "friction models: the largest |R_t|/(mu_f R_Z) at the ends of "
                           "contact steps (at most 1: the cone holds; 1 while sliding)"),
)

# Law kinds and opcodes of the interpreter (derive/scene/law/ compiles to these).
LAW_KINDS = _names(
    ("none", "not set yet"),
    ("program", "one point: an expression program, opcodes over a table of constants"),
    ("table", "one point: a cubic spline through samples"),
    ("bodies", "several points and rotors: each output a node of one program or a column "
               "of one spline"),
)

OPCODES = _names(
    ("const", "the constant consts[a]"),
    ("t", "the time"),
    ("add", "a + b"), ("sub", "a - b"), ("mul", "a * b"), ("div", "a / b"), ("neg", "-a"),
    ("powi", "a ** n, n = consts[b] an integer"),
    ("powr", "a ** r, r = consts[b] a non-integer, a > 0"),
    ("pow", "a ** b = exp(b log a), a > 0"),
    ("sin", ""), ("cos", ""), ("tan", ""), ("exp", ""), ("log", ""), ("sqrt", ""),
    ("sinh", ""), ("cosh", ""), ("tanh", ""), ("asin", ""), ("acos", ""), ("atan", ""),
    ("hsin", "a harmonic A sin(w t + p), (A, w, p) = consts[a], consts[a+1], consts[a+2]"),
    ("hcos", "a harmonic A cos(w t + p), (A, w, p) = consts[a], consts[a+1], consts[a+2]"),
)

LAW_MAX_NODES = 1024      # nodes of one law (every body's): the C jet workspace
# (LAW_MAX_POINTS and LAW_MAX_ROTORS, the internal bodies of a scene, [[point]] with 3
# outputs each and [[rotor]] with 1, are above with the parameters they size)

# The closed loop (crt_control.h): why the controller is called, why its law is refused,
# the most knots of one law it sets, and the rows of pushes and of the realised law.
CALL_REASONS = _names(
    ("start", "once, at the start of the run"),
    ("sample", "at a sample time t0 + k period"),
    ("event", "after an impact, an entry into contact or a lift-off"),
)
CONTROL_FAULTS = _names(
    ("none", "no fault"),
    ("knot_count", "n_knots outside [2, CRT_CTL_MAX_KNOTS]"),
    ("first_knot", "knots[0] is not the time of the call"),
    ("knot_order", "the knots do not increase, or one is not finite"),
    ("nonfinite", "a coefficient is not finite"),
    ("position_jump", "x, y or z of the new law at its start differs from the law's"),
    ("velocity_jump", "x', y' or z' of the new law at its start differs from the law's"),
    ("bodies", "the session's law is of several bodies (crt_set_law_bodies) and the "
               "controller drives none of them (crt_control_channels)"),
)
CTL_MAX_KNOTS = 256
PUSH_COLUMNS = ("time", "P_X", "P_Y", "P_Z", "at_x", "at_y", "at_z")
LOG_COLUMNS = ("knot", "t_from", "t_to", *(f"{c}_{k}" for c in "xyz" for k in range(4)))
# The smallest output buffers crt_advance takes (rows, events); smaller ones are refused
# with bad_argument: a step needs room for its rows and an event's (before, after, and
# the rows of output_dt up to it), else no call could make progress.
MIN_ROWS = 8
MIN_EVENTS = 4


def index(table: tuple, name: str) -> int:
    for k, entry in enumerate(table):
        if entry.name == name:
            return k
    raise KeyError(name)


def names(table: tuple) -> tuple:
    return tuple(entry.name for entry in table)


OPT = {entry.name: k for k, entry in enumerate(OPTIONS)}
PRM = {entry.name: k for k, entry in enumerate(PARAMETERS)}
OP = {entry.name: k for k, entry in enumerate(OPCODES)}
MODE = {entry.name: k for k, entry in enumerate(MODES)}
ROW_KIND = {entry.name: k for k, entry in enumerate(ROW_KINDS)}


# The columns of an event row.  The first six for every model; the rest are the friction
# models' (zero otherwise): the mode after the event (MODES), the tangential impulse of an
# impact, the slip of S (X, Y) before and after, the work of the normal impulse and of
# friction in an impact (E_n, E_t), and what happened inside it: 0 S slipped to the end
# (or did not slip), 1 the slip stopped and S stuck, 2 it stopped and S re-slid; and
# in contact the couples' channels held after the event (COUPLE_BITS: spin friction's
# and rolling resistance's; 0 without them).
EVENT_COLUMNS = ("t", "kind", "value", "v_minus", "v_plus", "t_accumulation", "mode", "P_X",
                 "P_Y", "slip_X_minus", "slip_Y_minus", "slip_X_plus", "slip_Y_plus",
                 "work_normal", "work_friction", "stage", "couples")
COUPLE_BITS = (("spin", 1), ("roll", 2))
COUPLE_BIT = dict(COUPLE_BITS)
# Column "stage" of an impact's event row: what happened inside the impact.
IMPACT_STAGES = _names(
    ("slip", "S slipped to the end of the impact (or never slipped)"),
    ("stick", "the slip stopped and S stuck to the end"),
    ("reslide", "the slip stopped and S slid again, along a new direction"),
)
# The contact's wrench at S with the couples (crt_eval_wrench_rows' rows, fixed axes): the
# force, then the couple; each channel of COUPLE_BITS its columns and its bound (the
# parameter, a length: |T| <= bound N)
WRENCH_COLUMNS = ("R_X", "R_Y", "R_Z", "T_X", "T_Y", "T_Z")
COUPLE_COLUMNS = {"spin": ("T_Z",), "roll": ("T_X", "T_Y")}
COUPLE_BOUNDS = {"spin": "spin_friction", "roll": "rolling_resistance"}

# What crt_count(CRT_COUNT_<NAME>) reports, with the value abi.py expects.
COUNTS = (
    ("options", len(OPTIONS)), ("parameters", len(PARAMETERS)), ("stats", len(STATS)),
    ("summary", len(SUMMARY)), ("opcodes", len(OPCODES)),
    ("event_columns", len(EVENT_COLUMNS)), ("law_max_nodes", LAW_MAX_NODES),
    ("law_max_points", LAW_MAX_POINTS), ("law_max_rotors", LAW_MAX_ROTORS),
    ("min_rows", MIN_ROWS), ("min_events", MIN_EVENTS),
    ("ctl_max_knots", CTL_MAX_KNOTS), ("push_columns", len(PUSH_COLUMNS)),
    ("log_columns", len(LOG_COLUMNS)),
)


def c_context() -> dict:
    """What ``templates/runtime/crt_abi.h.jinja`` renders."""
    return {"options": OPTIONS, "parameters": PARAMETERS, "methods": METHODS,
            "statuses": STATUSES, "phases": PHASES, "modes": MODES,
            "restitution_models": RESTITUTION_MODELS, "pressures": PRESSURES,
            "event_kinds": EVENT_KINDS,
            "stats": STATS, "row_kinds": ROW_KINDS, "summary": SUMMARY,
            "law_kinds": LAW_KINDS, "opcodes": OPCODES, "law_max_nodes": LAW_MAX_NODES,
            "law_max_points": LAW_MAX_POINTS, "law_max_rotors": LAW_MAX_ROTORS,
            "event_columns": EVENT_COLUMNS, "min_rows": MIN_ROWS, "min_events": MIN_EVENTS,
            "counts": COUNTS, "call_reasons": CALL_REASONS, "control_faults": CONTROL_FAULTS,
            "ctl_max_knots": CTL_MAX_KNOTS, "push_columns": PUSH_COLUMNS,
            "log_columns": LOG_COLUMNS,
            "shapes": [shapes.of(name) for name in shapes.SHAPE_NAMES]}
