"""Variational equations as generated code, integrated by the runtime.

For a model's flight RHS ``q' = f(t, q)`` the augmented system ``(q, Phi)`` with
``Phi' = (df/dq) Phi`` is specialised to a scene like any model and rendered with the
runtime; ``Phi(T)`` over a period is the monodromy matrix.

The Jacobian is taken from the derived expressions: where ``f`` reads the unknown
``omega'`` of the solve ``J omega' = F(t, q)``, ``d omega'/dq_k = J^-1 dF/dq_k`` since
``J`` depends on the point's law only, not on the state; these are further right-hand
sides of the same LDL^T (no inverse is formed).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import sympy as sp

from .. import models as dm
from ..runtime.build import Library, compile_scene, render
from ..runtime.driver import Session
from ..runtime.scene import Scene
from ..runtime.scene_models import T_VEC, SceneModel, _common, specialise


def augmented_labels(base: str) -> tuple:
    """The state labels followed by those of Phi, row-major."""
    n = len(dm.STATES[base])
    return dm.STATE_LABELS[base] + tuple(f"Phi[{i},{j}]" for i in range(n) for j in range(n))


def variational_spec(scene: Scene, base: str = "vertical",
                     overrides: dict | None = None) -> tuple[dm.FunctionSpec, tuple]:
    """The augmented RHS for the scene, and its state labels: the derived flight RHS and
    its Jacobian (:func:`derive.models.flight_jacobian`) specialised to the scene, with
    one solve serving omega' and every column of d omega'/dq.  ``overrides`` replace
    some of the scene's numbers by symbols (a parametric model)."""
    subs, defs = _common(scene)
    subs.update(overrides or {})
    q = dm.STATES[base]
    labels = dm.STATE_LABELS[base]
    flight = specialise(dm.flight_rhs(base), subs, defs, q, labels, "flight")
    jac = specialise(dm.flight_jacobian(base), subs, defs, q, labels, "jacobian")
    (fs,), (js,) = flight.solves, jac.solves
    n = len(q)
    A = sp.Matrix(n, n, jac.outputs[0].entries)
    Phi = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"Phi_{i}_{j}", real=True))
    APhi = A * Phi
    outputs = tuple(flight.outputs[0].entries) + tuple(APhi[i, j] for i in range(n)
                                                       for j in range(n))
    aug = augmented_labels(base)
    spec = dm.FunctionSpec(
        name="variational", doc=f"{base} flight RHS with its variational equations",
        inputs=(T_VEC, dm.Vector("q", tuple(q) + tuple(Phi), aug)),
        outputs=(dm.Vector("dq", outputs, aug),),
        solves=(dm.LinearSolve(matrix=fs.matrix, rhs=fs.rhs + js.rhs,
                               unknowns=fs.unknowns + js.unknowns),),
        definitions=flight.definitions)
    return spec, aug


class Monodromy:
    """The compiled variational runtime of one scene (free flight).  With ``params``
    (symbols in ``overrides`` or in the scene's law) one library serves every value."""

    def __init__(self, scene: Scene, base: str = "vertical", rtol: float = 1e-12,
                 overrides: dict | None = None, params: tuple = (),
                 library_path: str | None = None):
        self.base = base
        self.scene = replace(scene, plane=False, method="dop853", rtol=rtol,
                             atol=rtol * 1e-2, output_dt=0.0, keep_orthonormal=False)
        self.n = len(dm.STATES[base])
        self.params = tuple(params)
        labels = augmented_labels(base)
        self.model = SceneModel(kind=f"variational-{base}", why="monodromy", labels=labels,
                                q0=np.zeros(len(labels)), specs={}, normalize="none")
        if library_path is not None:        # an existing build of the same model
            self.library = Library(library_path)
            if self.library.nq != len(labels) or self.library.n_params != len(self.params):
                raise ValueError(f"{library_path} is not this variational model")
            return
        spec, _ = variational_spec(self.scene, base, overrides)
        self.model.specs["rhs"] = spec
        self.library = compile_scene(render(self.model, scene.name, params=self.params))

    def flow(self, t0: float, q0, duration: float, values=None):
        """(q(t0 + duration), Phi(t0 + duration, t0)) from q(t0) = q0, Phi(t0) = I;
        ``values`` of the parameters for a parametric model."""
        n = self.n
        sc = replace(self.scene, t0=float(t0), duration=float(duration))
        self.model.q0 = np.r_[np.asarray(q0, dtype=float), np.eye(n).ravel()]
        session = Session(self.library, sc, self.model, chunk=4096)
        t, Q, kinds, _, _, status = session.run(params=values)
        if status != "done":
            raise RuntimeError(f"variational integration ended with {status}")
        end = Q[-1]
        return end[:n], end[n:].reshape(n, n)
