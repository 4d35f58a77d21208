"""A :class:`~derive.models.FunctionSpec` as a straight-line program.

One common-subexpression elimination over every output of the function together with
the matrices and right-hand sides of its solves; temporaries that need the unknowns of a
solve are scheduled after the numeric LDL^T (:mod:`derive.emit.linalg`), the others
before it.  The program is what the C backend prints; its operation count is what the
preambles and the benchmarks report.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..models import FunctionSpec
from .linalg import ldlt3_solve, lower_triangle


@dataclass(frozen=True)
class Program:
    spec: FunctionSpec
    steps: tuple          # ((symbol, expr), ...) in execution order
    outputs: tuple        # one tuple of expressions per output vector of the spec
    inputs: tuple         # one tuple of symbols per input vector of the spec

    @property
    def ops(self) -> int:
        """Operation count as SymPy's ``count_ops`` of every step and output."""
        total = sum(int(sp.count_ops(expr)) for _, expr in self.steps)
        total += sum(int(sp.count_ops(expr)) for out in self.outputs for expr in out)
        return total


def _temps(prefix: str):
    k = 0
    while True:
        yield sp.Symbol(f"{prefix}{k}")
        k += 1


def _prune(steps: list, outputs: list) -> list:
    """Drop steps nothing downstream uses (a definition such as mu in a function that
    needs only nu)."""
    needed = set().union(*(sp.sympify(v).free_symbols for v in outputs)) if outputs else set()
    kept = []
    for sym, expr in reversed(steps):
        if sym in needed:
            kept.append((sym, expr))
            needed |= expr.free_symbols
    return kept[::-1]


def build(spec: FunctionSpec) -> Program:
    """CSE over everything the function computes, then scheduling around the solves."""
    stage1: list = []
    for solve in spec.solves:
        stage1 += [sp.sympify(v) for v in lower_triangle(solve.matrix)]
        for rhs in solve.rhs:
            stage1 += [sp.sympify(v) for v in rhs]
    outs = [sp.sympify(v) for vec in spec.outputs for v in vec.entries]
    unknowns = {s for solve in spec.solves for vec in solve.unknowns for s in vec}

    replacements, reduced = sp.cse(stage1 + outs, symbols=_temps("_c"), order="canonical")

    # schedule: a temporary is late if it depends on an unknown or on a late temporary
    late_syms: set = set()
    early, late = [], []
    for sym, expr in replacements:
        if expr.free_symbols & (unknowns | late_syms):
            late_syms.add(sym)
            late.append((sym, expr))
        else:
            early.append((sym, expr))

    steps = [(sym, sp.sympify(expr)) for sym, expr in spec.definitions] + early
    solution: dict = {}
    k = 0
    for index, solve in enumerate(spec.solves):
        if any(v.free_symbols & unknowns for v in reduced[k:k + 6 + 3 * len(solve.rhs)]):
            raise ValueError(f"{spec.name}: a solve's matrix or right-hand side needs "
                             "the unknown of a solve")
        tri = reduced[k:k + 6]
        k += 6
        rhs_values = []
        for _ in solve.rhs:
            rhs_values.append(reduced[k:k + 3])
            k += 3
        names = iter(_temps(f"_s{index}_"))

        def assign(_label, value, names=names):
            if value.is_Atom:
                return value
            sym = next(names)
            steps.append((sym, value))
            return sym

        tri = [assign("a", v) for v in tri]
        rhs_values = [[assign("b", v) for v in vec] for vec in rhs_values]
        solved = ldlt3_solve(tri, rhs_values, assign)
        for vec, values in zip(solve.unknowns, solved):
            solution.update(dict(zip(vec, values)))
    steps += [(sym, expr.xreplace(solution)) for sym, expr in late]
    out_values = [expr.xreplace(solution) for expr in reduced[k:]]

    steps = _prune(steps, out_values)
    grouped, pos = [], 0
    for vec in spec.outputs:
        grouped.append(tuple(out_values[pos:pos + len(vec.entries)]))
        pos += len(vec.entries)
    inputs = tuple(tuple(vec.entries) for vec in spec.inputs)
    return Program(spec=spec, steps=tuple(steps), outputs=tuple(grouped), inputs=inputs)
