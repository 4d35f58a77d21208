"""Direct numeric evaluation of a :class:`~derive.models.FunctionSpec` with NumPy.

The reference the emitted code is compared with, and the "lambdified NumPy" peer of the
benchmarks: the matrix and right-hand sides are lambdified, solved with
``numpy.linalg.solve``, and the outputs evaluated with the unknowns substituted.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import sympy as sp

from ..models import FunctionSpec


def compile_spec(spec: FunctionSpec) -> Callable[..., tuple]:
    """Return ``f(*inputs) -> tuple of output arrays`` (inputs in the spec's order)."""
    args = [list(v.entries) for v in spec.inputs]
    stage1 = []
    for solve in spec.solves:
        stage1.append([spec.inlined(v) for v in solve.matrix])
        stage1 += [[spec.inlined(v) for v in r] for r in solve.rhs]
    unknowns = [list(u) for solve in spec.solves for u in solve.unknowns]
    f1 = sp.lambdify(args, stage1, modules="numpy", cse=True) if stage1 else None
    outs = [[spec.inlined(v) for v in vec.entries] for vec in spec.outputs]
    f2 = sp.lambdify(args + unknowns, outs, modules="numpy", cse=True)

    def evaluate(*inputs):
        inputs = [np.asarray(x, dtype=float).reshape(-1) for x in inputs]
        solved = []
        if f1 is not None:
            values = f1(*inputs)
            k = 0
            for solve in spec.solves:
                mat = np.array(values[k], dtype=float).reshape(3, 3)
                k += 1
                for _ in solve.rhs:
                    solved.append(np.linalg.solve(mat, np.array(values[k], dtype=float)))
                    k += 1
        result = f2(*inputs, *solved)
        return tuple(np.array(r, dtype=float) for r in result)

    return evaluate
