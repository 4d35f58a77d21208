"""Direct numeric evaluation of a :class:`~derive.models.FunctionSpec` with NumPy.

The reference the emitted code is compared with, and the "lambdified NumPy" peer of the
benchmarks: the matrix and right-hand sides are lambdified, solved with
``numpy.linalg.solve``, and the outputs evaluated with the unknowns substituted.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Callable

import numpy as np
import sympy as sp

from ..friction_models import friction_specs
from ..models import FunctionSpec


def compile_spec(spec: FunctionSpec) -> Callable[..., tuple]:
    """Return ``f(*inputs) -> tuple of output arrays`` (inputs in the spec's order).

    The solves run in their order; a solve's matrix and right-hand sides may read the
    unknowns of the solves before it (the sticking contact's solve with the Delassus
    matrix, derive.friction_models)."""
    args = [list(v.entries) for v in spec.inputs]
    stages = []          # one (function, number of right-hand sides) per solve
    known: list = []     # unknowns of the solves so far, as lambdify arguments
    for solve in spec.solves:
        values = [[spec.inlined(v) for v in solve.matrix]]
        values += [[spec.inlined(v) for v in r] for r in solve.rhs]
        stages.append((sp.lambdify(args + known, values, modules="numpy", cse=True),
                       len(solve.rhs)))
        known = known + [list(u) for u in solve.unknowns]
    outs = [[spec.inlined(v) for v in vec.entries] for vec in spec.outputs]
    f2 = sp.lambdify(args + known, outs, modules="numpy", cse=True)

    def evaluate(*inputs):
        inputs = [np.asarray(x, dtype=float).reshape(-1) for x in inputs]
        solved = []
        for stage, n_rhs in stages:
            values = stage(*inputs, *solved)
            mat = np.array(values[0], dtype=float).reshape(3, 3)
            for k in range(n_rhs):
                solved.append(np.linalg.solve(mat, np.array(values[1 + k], dtype=float)))
        result = f2(*inputs, *solved)
        return tuple(np.array(r, dtype=float) for r in result)

    return evaluate


@lru_cache(maxsize=None)
def numpy_function(name: str) -> Callable[..., tuple]:
    """The NumPy evaluation of the friction function ``name``
    (:func:`derive.friction_models.friction_specs`), compiled once."""
    return compile_spec(next(s for s in friction_specs() if s.name == name))
