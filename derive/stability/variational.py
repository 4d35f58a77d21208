"""Variational equations as generated code, integrated by the runtime.

The ``variational`` model of the runtime (``generated/runtime/model_variational.c``) is
the vertical flight right-hand side ``q' = f(t, q)`` with ``Phi' = (df/dq) Phi``, the
Jacobian taken from the derived expressions (:func:`derive.models.flight_jacobian`:
where ``f`` reads the unknown ``omega'`` of ``J omega' = F``, ``d omega'/dq_k`` are
further right-hand sides of the same closed-form solve, no symbolic inverse).  It is
compiled once per machine like every model, reading the scene's numbers and its law at
run time, so one library serves every scene, family member and sweep.  ``Phi(T)`` over
a period is the monodromy matrix.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import models as dm
from ..runtime import choice
from ..runtime.build import library
from ..runtime.driver import options
from ..runtime.session import Session
from ..scene import Scene


def augmented_labels(base: str = "vertical") -> tuple:
    """The state labels followed by those of Phi, row-major."""
    n = len(dm.STATES[base])
    return dm.STATE_LABELS[base] + tuple(f"Phi[{i},{j}]" for i in range(n) for j in range(n))


class Monodromy:
    """Flows of the variational runtime for one scene (free flight)."""

    def __init__(self, scene: Scene, rtol: float = 1e-12):
        self.scene = replace(scene, plane=False, method="dop853", rtol=rtol,
                             atol=rtol * 1e-2, output_dt=0.0, keep_orthonormal=False)
        self.n = len(dm.STATES["vertical"])
        self.library = library("variational")
        self.session = Session(self.library, chunk=512)
        self.session.set_law(scene.law)
        self.prm = choice.parameters(self.scene, {})

    def flow(self, t0: float, q0, duration: float):
        """(q(t0 + duration), Phi(t0 + duration, t0)) from q(t0) = q0, Phi(t0) = I."""
        n = self.n
        sc = replace(self.scene, t0=float(t0), duration=float(duration))
        opt = options(sc, "variational")
        z0 = np.r_[np.asarray(q0, dtype=float), np.eye(n).ravel()]
        raw = self.session.run(sc.t0, sc.duration, z0, opt, self.prm)
        if raw.status != "done":
            raise RuntimeError(f"variational integration ended with {raw.status}")
        end = raw.q[-1]
        return end[:n], end[n:].reshape(n, n)
