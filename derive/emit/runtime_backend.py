"""The C runtime, written once into ``generated/runtime/`` by ``derive emit``.

One C file per model (``model_<kind>.c``, rendered from ``templates/runtime/model.c.jinja``):
the derived functions it calls (generic in every number of a scene: the parameters arrive
at run time in ``prm[]``), the model's thin wrappers, and ``#include "crt_core.h"``, the top
of the runtime's headers.  Those are plain C, kept in ``templates/runtime/*.h`` and copied
verbatim; a stack in which each includes only those below it (crt_session.h lists them):

* ``crt_math.h``, ``crt_law.h``: max, min, sin and cos; the point-law interpreter and
  splines;
* ``crt_session.h``: the session record, the output buffers, the helpers all stages share;
* ``crt_plane.h``: the gap, the projection onto the plane, lift-off;
* ``crt_contact.h``: the contact's variant, chosen once by the model's macros:
  ``crt_smooth.h``, or Coulomb friction at S (``crt_friction_state.h``,
  ``crt_rough_modes.h``, ``crt_rough.h``, with Darboux-Keller's impacts in ``crt_dk.h``);
* ``crt_rhs.h``, ``crt_integrators.h``, ``crt_lie.h``, ``crt_step.h``: the right-hand side,
  RK4, DOPRI5, DOP853, the Lie-group methods of the momentum form and their dispatcher;
* ``crt_events.h``: event location and the events' application;
* ``crt_call.h``, ``crt_control.h``: the closed loop;
* ``crt_loop.h``, ``crt_core.h``, ``crt_rough_api.h``: the loop and the public API (the
  comments of crt_core.h are the runtime's manual);

and rendered only where numbers or names come from Python (``templates/runtime/*.h.jinja``):

* ``crt_abi.h``: enums, return codes and name tables from :mod:`derive.abi`;
* ``crt_constants.h``: the constants of the runtime's sine and cosine
  (:mod:`derive.emit.sincos`) and the limits of the Lie methods;
* ``crt_rk_steps.h``, ``crt_lie_steps.h``, ``crt_dk_steps.h``: the steps of DOPRI5 and
  DOP853, classical, Lie and Darboux-Keller's, with their tableaus
  (:mod:`derive.emit.tableaus`) written out term by term.

The per-hop controller in C (``templates/control/crt_hop.c``, ``crt_hop.h``) is copied into
``generated/control/`` (:func:`render_controllers`).  Nothing of a scene reaches this code:
it is rendered from the derivation alone, and :mod:`derive.runtime.build` compiles each
model once per machine.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from .. import friction_models
from .. import models as dm
from .. import models_moments as mmo
from .. import abi, face, layout, shapes
from . import tableaus as T
from . import sincos
from .c_backend import body
from .render import TEMPLATES, environment, versions


# the models of internal bodies other than one point (issue 32): the general state, u the
# moments of derive/layout.py's MOMENTS summed by the runtime from the bodies' law
MOMENTS_KINDS = ("moments", "moments_rough")


@dataclass(frozen=True)
class RuntimeModel:
    kind: str
    plane: bool
    normalize: str            # matrix | vector | none
    summary: str

    @property
    def layout(self) -> layout.Layout:
        return layout.of(self.kind)

    @property
    def labels(self) -> tuple:
        return self.layout.labels

    @property
    def z_index(self) -> int:
        return getattr(self.layout, "Z", -1)

    @property
    def zd_index(self) -> int:
        return getattr(self.layout, "Zd", -1)

    @property
    def lie(self) -> bool:
        """The momentum form applies (crt_lie.h): the model carries omega and the
        attitude, or only omega in free flight."""
        return self.kind in ("general", "vertical", "attitude", "rough", *MOMENTS_KINDS)

    @property
    def friction(self) -> bool:
        """Coulomb friction at S (crt_rough.h): the general state with the rough
        plane's functions (derive/friction_models.py)."""
        return self.kind in ("rough", "moments_rough")

    @property
    def moments(self) -> bool:
        """The internal bodies seen through their moments (derive/models_moments.py):
        the law of any number of points and rotors, summed in C (crt_bodies.h)."""
        return self.kind in MOMENTS_KINDS

    @property
    def base(self) -> str:
        """The prefix of the derived functions it calls: the rough model's are general's,
        the moments models' the moments family's."""
        return "moments" if self.moments else "general" if self.kind == "rough" else self.kind

    def plain(self, what: str) -> str:
        """The name of a function of no model in this model's family (``lie_stage``;
        the moments models': ``moments_lie_stage``)."""
        return f"moments_{what}" if self.moments else what

    @property
    def sums_bodies(self) -> bool:
        """u is the bodies' moments summed in C (crt_bodies.h): the moments models' and
        the base model's."""
        return self.moments or self.kind == "base"

    def specs(self) -> list:
        # S and its rate for every shape of derive/shapes.py (model_shape picks one by
        # prm[CRT_P_shape])
        surface = [f(name) for name in shapes.SHAPE_NAMES
                   for f in (dm.lowest_point, dm.lowest_point_rate)]
        if self.moments:
            # the bodies' shares (summed by crt_bodies.h), then the general model's
            # functions of the moments family; the pushes' impulse map is the rough
            # plane's apply_impulse, which moments_rough has already
            fam = mmo.family()
            base = [mmo.point_moments(), mmo.rotor_moments(), mmo.flight_rhs(),
                    dm.gap("general", fam), dm.impact("general", fam),
                    dm.runtime_contact("general", fam), *surface, dm.lie_stage(fam),
                    dm.lie_point(fam), dm.fixed_kinetic_moment(fam), dm.exp_map(),
                    dm.flight_parabola()]
            return base + (friction_models.runtime_specs("moments") if self.friction
                           else [friction_models.apply_impulse("moments")])
        if self.kind == "base":
            # a body on its face (derive/base.py): the bodies' shares, then its functions
            from .. import base as db
            return [mmo.point_moments(), mmo.rotor_moments(), *db.base_specs()]
        momentum = [dm.lie_stage(), dm.lie_point(), dm.fixed_kinetic_moment(), dm.exp_map()]
        if self.kind in ("general", "vertical", "rough"):
            base = [dm.flight_rhs(self.base), dm.gap(self.base), dm.impact(self.base),
                    dm.runtime_contact(self.base), *surface, *momentum,
                    dm.flight_parabola()]
            # the rough plane's functions (derive/friction_models.py); the general state
            # also applies the closed loop's pushes: an impulse at a body point (the
            # impulse map at S, with S that point), which the rough model has already
            if self.friction:
                base += friction_models.runtime_specs()
            elif self.kind == "general":
                base.append(friction_models.apply_impulse())
            return base
        if self.kind == "attitude":
            return [dm.flight_rhs("attitude"), *momentum]
        if self.kind == "translational":
            return [dm.gap("vertical"), dm.impact("vertical"), dm.runtime_contact("vertical"),
                    *surface]
        if self.kind == "planar":
            return [dm.gap("vertical"), dm.impact("vertical"), dm.runtime_contact("vertical"),
                    *dm.planar_functions(), *surface]
        if self.kind == "axisymmetric":
            return [dm.axisymmetric_rates()]
        if self.kind == "variational":
            return [dm.flight_rhs("vertical"), dm.flight_jacobian("vertical")]
        raise ValueError(self.kind)


MODELS = (
    RuntimeModel("general", True, "matrix",
                 "E1.2, E1.7, E1.8 in flight; impacts (E1.10-E1.16); persistent contact."),
    RuntimeModel("rough", True, "matrix",
                 "the general model on a rough plane: Coulomb friction at S in impacts "
                 "(Darboux-Keller) and in sliding and sticking contact (derive/friction.py)."),
    RuntimeModel("vertical", True, "vector",
                 "the general model without the horizontal motion of C and the heading."),
    RuntimeModel("attitude", False, "none", "E1.7 alone: free flight, omega only."),
    RuntimeModel("translational", True, "none",
                 "omega = 0 kept by the law of areas (C2.1-C2.4): the vertical motion of C."),
    RuntimeModel("planar", True, "none",
                 "z = 0, omega along z (E4.1, E4.2): omega_z from the integral kappa = K_z."),
    RuntimeModel("axisymmetric", False, "none",
                 "J_x = J_y, P on the axis, free flight: the quadratures of E3.14."),
    RuntimeModel("variational", False, "none",
                 "the vertical flight with its variational equations Phi' = (df/dq) Phi."),
    RuntimeModel("moments", True, "matrix",
                 "the general model of any number of points and rotors, seen through their "
                 "moments (derive/models_moments.py), summed from their laws in C "
                 "(crt_bodies.h): flight, impacts, persistent contact, pushes."),
    RuntimeModel("base", False, "none",
                 "a box or a cylinder on its face (derive/base.py): O's horizontal motion and "
                 "the yaw, driven by the points and rotors through their moments; Coulomb "
                 "friction over the face with Contensou's coupling (crt_face.h), stick and "
                 "slip as exact events, lift-off and tipping as stops (crt_base.h)."),
    RuntimeModel("moments_rough", True, "matrix",
                 "the moments model on a rough plane: Coulomb friction at S in impacts "
                 "(Darboux-Keller) and in sliding and sticking contact, and the couples."),
)
KINDS = tuple(m.kind for m in MODELS)


def model(kind: str) -> RuntimeModel:
    for m in MODELS:
        if m.kind == kind:
            return m
    raise KeyError(kind)


def _c(x) -> str:
    return repr(float(x))


def _pairs(values) -> list:
    return [(j, _c(v)) for j, v in enumerate(values) if float(v) != 0.0]


# a Lie step is kept below this turn at the rate of its start (radians; below
# derive.lie.THETA_MAX, beyond which a step is refused)
LIE_MAX_TURN = 1.0
# the method lie takes the DOP853 coefficients below this rtol, the DOPRI5 ones above
# (measured on the work-precision charts of derive bench precision)
LIE_TIGHT = 1e-6


@lru_cache(maxsize=None)
def tableau_context() -> dict:
    def dense_rows(rows, n):
        out = []
        for i in range(n):
            row = [0.0] * i
            for j, v in rows[i] if i < len(rows) else ():
                row[j] = float(v)
            out.append([_c(v) for v in row])
        return out
    return {
        "dopri5": {"a": dense_rows(T.DOPRI5_A, 7), "c": [_c(v) for v in T.DOPRI5_C],
                   "e": [_c(v) for v in T.DOPRI5_E], "d": [_c(v) for v in T.DOPRI5_D]},
        "dop853": {"a_pairs": [[(j, _c(v)) for j, v in row if float(v) != 0.0]
                               for row in T.DOP853_A],
                   "c": [_c(v) for v in T.DOP853_C], "b_pairs": _pairs(T.DOP853_B),
                   "e3_pairs": _pairs(T.DOP853_E3), "e5_pairs": _pairs(T.DOP853_E5),
                   "d_pairs": [_pairs(row) for row in T.DOP853_D],
                   # the stages and the weights as full rows (crt_base_steps.h)
                   "a": dense_rows(T.DOP853_A, 16),
                   "e3": [_c(v) for v in T.DOP853_E3], "e5": [_c(v) for v in T.DOP853_E5],
                   "d": [[_c(v) for v in row] for row in T.DOP853_D]},
    }


def _offsets(lay: layout.Layout) -> list:
    """(NAME, index) of each part's start and each named index of a layout, in order."""
    named = [(name.upper(), where.start) for name, where in lay.parts.items()]
    named += [(name.upper(), k) for name, k in lay.indices.items()]
    return sorted(named, key=lambda item: (item[1], item[0]))


def render_model(m: RuntimeModel) -> str:
    env = environment()
    functions = []
    for spec in m.specs():
        b = body(spec)
        functions.append({"name": spec.name, "doc": spec.doc, **b})
    ctx = {"template": "templates/runtime/model.c.jinja", "versions": versions(),
           "kind": m.kind, "base": m.base, "friction": m.friction, "nq": len(m.labels),
           "labels": m.labels, "plane": m.plane,
           "offsets": _offsets(m.layout),
           "vertical_offsets": (_offsets(layout.VERTICAL) + [("COUNT", layout.VERTICAL.nq)]
                                if m.kind in ("translational", "planar", "variational")
                                else []),
           "z_index": m.z_index, "zd_index": m.zd_index, "normalize": m.normalize,
           "summary": m.summary, "functions": functions, "lie": m.lie,
           "moments": m.sums_bodies,
           "base_vectors": [layout.MOMENTS.parts[k].start for k in
                            ("s", "s_rate", "s_acc", "h", "h_rate")],
           "base_tensors": [layout.MOMENTS.parts[k].start for k in ("theta", "theta_rate")],
           "moments_count": layout.MOMENTS.nq, "moments_spin": layout.MOMENTS.spin.start,
           "lie_functions": [(f"MODEL_{name.upper()}", m.plain(name)) for name in
                             ("lie_stage", "lie_point", "fixed_kinetic_moment")],
           # each shape's size as its functions read it (one number by value)
           "shapes": [(name, "p[CRT_P_size_a]" if shapes.of(name).size_count == 1
                       else "p + CRT_P_size_a") for name in shapes.SHAPE_NAMES],
           "may_jump": [name for name in shapes.SHAPE_NAMES
                        if not shapes.of(name).strictly_convex],
           # how far the vertical turns to find a point across the body as low as S
           "line_tol": repr(face.LINE_TOL)}
    return env.get_template("runtime/model.c.jinja").render(**ctx)


# the headers rendered from templates/runtime/<name>.jinja; every other templates/runtime/*.h
# is plain C, copied verbatim
RENDERED = ("crt_abi.h", "crt_constants.h", "crt_rk_steps.h", "crt_lie_steps.h", "crt_dk_steps.h",
            "crt_face_rules.h", "crt_base_steps.h")


@lru_cache(maxsize=None)
def face_rules_context() -> dict:
    """The rules of the friction over a face (crt_face.h) from derive/face.py's: the
    angle's Gauss-Legendre rule (its default order), the product rule where the instant
    centre is far, and how far that is."""
    import numpy as np
    from .. import face

    def gl(n):
        x, w = np.polynomial.legendre.leggauss(n)
        return [(_c(a), _c(b)) for a, b in zip(x, w)]
    n = face.ANGLE_ORDER
    x, w = np.polynomial.legendre.leggauss(n)
    half = [(_c(math.sin(a * math.pi / 2)), _c(math.cos(a * math.pi / 2)), _c(b))
            for a, b in zip(x[n // 2:], w[n // 2:])]          # the symmetric rule's phi > 0
    m = 2 * face.FAR_ORDER + 2
    far = [(_c(math.cos((j + 0.5) * 2 * math.pi / m)), _c(math.sin((j + 0.5) * 2 * math.pi / m)))
           for j in range(m)]
    return {"face_angle": half, "face_angle_n": n,
            "face_quarter": [_c(math.cos(j * math.pi / (2 * n))) for j in range(n + 1)],
            "face_far": gl(face.FAR_ORDER), "face_far_angles": far,
            "face_far_sizes": _c(face.FAR), "face_rim": _c(face.RIM)}


def plain_headers() -> dict[str, str]:
    """The hand-written C of the runtime, ``templates/runtime/*.h``, by name, as text."""
    folder = TEMPLATES / "runtime"
    return {path.name: path.read_bytes().decode("utf-8") for path in sorted(folder.glob("*.h"))}


# the controllers of the closed loop written in C by hand (templates/control/), copied
# into generated/control/ for embedding (CMake target carrier::hop); the MPC
# controller is rendered per task by derive control, not here
CONTROLLERS = ("crt_hop.c", "crt_hop.h")


def render_controllers() -> dict[str, str]:
    """Every file of ``generated/control``: the hand-written controllers, as text."""
    folder = TEMPLATES / "control"
    return {f"control/{name}": (folder / name).read_bytes().decode("utf-8")
            for name in CONTROLLERS}


def _macro_lines(text: str, breaks: tuple) -> str:
    """A long macro body on continued lines, broken before each of ``breaks``."""
    for b in breaks:
        text = text.replace(b, " \\\n  " + b.lstrip(), 1)
    return text


def render_runtime(progress=None) -> dict[str, str]:
    """Every file of ``generated/runtime`` as text; ``progress``: told ``(done, total,
    name)`` after each model's file (the long part)."""
    env = environment()
    from .. import lie
    theta = float(lie.THETA_MAX)
    consts = sincos.template_context()
    for key in ("sincos_sin_poly", "sincos_cos_poly"):
        consts[key] = _macro_lines(consts[key], (" + z4 * ",))
    common = {"versions": versions(), **abi.c_context(), **tableau_context(), **consts,
              "lie_theta_max": repr(theta), "lie_theta_max2": repr(theta * theta),
              "lie_max_turn": repr(LIE_MAX_TURN), "lie_tight": repr(LIE_TIGHT),
              **face_rules_context()}
    files = {}
    for name in RENDERED:
        files[f"runtime/{name}"] = env.get_template(f"runtime/{name}.jinja").render(
            template=f"templates/runtime/{name}.jinja", **common)
    for name, text in plain_headers().items():
        if name in RENDERED:
            raise ValueError(f"templates/runtime/{name} and {name}.jinja both exist")
        files[f"runtime/{name}"] = text
    for k, m in enumerate(MODELS):
        files[f"runtime/model_{m.kind}.c"] = render_model(m)
        if progress is not None:
            progress(k + 1, len(MODELS), m.kind)
    return files
