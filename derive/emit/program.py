"""A :class:`~derive.models.FunctionSpec` as a straight-line program.

One common-subexpression elimination over everything the function computes: its named
definitions (``nu``, ``mu``, a scene's point law ...), the matrices and right-hand sides
of its solves, and its outputs.  The steps are then scheduled by dependency: a
temporary is emitted once what it reads is available, the numeric solve of each one
(:mod:`derive.emit.linalg`) as soon as its matrix and right-hand sides are, and the
temporaries that read the unknowns after it.  Definitions that are plain numbers are
propagated first.  The steps that do not read the state (:data:`HOT`) come first.  The
program is what the C backend prints; its operation count is what the preambles and the
benchmarks report.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..models import FunctionSpec
from .linalg import FACTORED, solve_values, solver_for

# the input vectors an integrator feeds back: each call's state is computed from the last
# call's output, so what reads them is on the loop's chain (the law and the parameters are
# not: what reads only them can run ahead)
HOT = ("q", "W")


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


def _propagate_constants(spec: FunctionSpec):
    """Definitions whose value is a number are substituted everywhere, repeatedly."""
    definitions = [(s, sp.sympify(v)) for s, v in spec.definitions]
    constants: dict = {}
    changed = True
    while changed:
        changed = False
        kept = []
        for sym, value in definitions:
            value = value.xreplace(constants) if constants else value
            if value.is_Number:
                constants[sym] = value
                changed = True
            else:
                kept.append((sym, value))
        definitions = kept
    return definitions, constants


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


def _state_last(steps: list, spec: FunctionSpec) -> list:
    """The steps that do not read the state (an input named in :data:`HOT`, directly or
    through other steps) first, then the others, each group in its order.  A processor
    takes a call's instructions in this order: the law's and the parameters' part (J, the
    factors of its solve) is then under way before the state arrives from the caller's
    last stage."""
    hot = {s for vec in spec.inputs if vec.name in HOT for s in vec.entries}
    cold, warm = [], []
    for sym, expr in steps:
        if expr.free_symbols & hot:
            hot.add(sym)
            warm.append((sym, expr))
        else:
            cold.append((sym, expr))
    return cold + warm


def build(spec: FunctionSpec, solver: str | None = None) -> Program:
    """CSE over everything the function computes, then scheduling around the solves
    (``solver``: a name of :data:`derive.emit.linalg.SOLVERS`, default the emitted
    one; :func:`derive.emit.linalg.solver_for` picks, per solve)."""
    definitions, constants = _propagate_constants(spec)

    def prepared(v):
        v = sp.sympify(v)
        return v.xreplace(constants) if constants else v

    pool = [value for _, value in definitions]
    n_def = len(pool)
    kinds = [solver_for(solve, solver) for solve in spec.solves]
    for solve, kind in zip(spec.solves, kinds):
        pool += [prepared(v) for v in solve_values(solve, kind)]
        for rhs in solve.rhs:
            pool += [prepared(v) for v in rhs]
    n_stage1 = len(pool)
    pool += [prepared(v) for vec in spec.outputs for v in vec.entries]
    unknowns = {s for solve in spec.solves for vec in solve.unknowns for s in vec}

    replacements, reduced = sp.cse(pool, symbols=_temps("_c"), order="canonical")

    # pending assignments: CSE temporaries and definitions, in their natural order
    pending = list(replacements) + [(sym, reduced[k]) for k, (sym, _) in enumerate(definitions)]
    # the solves, each waiting for its matrix and right-hand sides
    solve_blocks = []
    k = n_def
    for index, (solve, kind) in enumerate(zip(spec.solves, kinds)):
        n_matrix = len(solve_values(solve, kind))
        n_values = n_matrix + 3 * len(solve.rhs)
        values = reduced[k:k + n_values]
        k += n_values
        own = {s for vec in solve.unknowns for s in vec}
        if any(v.free_symbols & own for v in values):
            raise ValueError(f"{spec.name}: a solve's matrix or right-hand side needs "
                             "its own unknown")
        solve_blocks.append((index, solve, kind, n_matrix, values))
    assert k == n_stage1
    out_values = list(reduced[n_stage1:])

    assigned = {s for vec in spec.inputs for s in vec.entries}
    produced = {sym for sym, _ in pending} | unknowns
    steps: list = []
    factored: dict = {}       # (solver, matrix after CSE) -> its factors, computed once
    while pending or solve_blocks:
        progress = False
        for item in list(pending):
            sym, expr = item
            if (expr.free_symbols & produced) <= assigned:
                steps.append((sym, expr))
                assigned.add(sym)
                pending.remove(item)
                progress = True
        for block in list(solve_blocks):
            index, solve, kind, n_matrix, values = block
            if not all((v.free_symbols & produced) <= assigned for v in values):
                continue
            names = _temps(f"_s{index}_")

            def assign(_label, value, names=names):
                if value.is_Atom:
                    return value
                sym = next(names)
                steps.append((sym, value))
                return sym

            # a solve with the matrix of an earlier one (the derivatives of its
            # unknowns, derive.jacobians) reuses that one's factors
            factor3, apply3 = FACTORED[kind]
            key = (kind, *values[:n_matrix])
            factors = factored.get(key)
            if factors is None:
                tri = [assign("a", v) for v in values[:n_matrix]]
            rhs = [[assign("b", v) for v in values[n_matrix + 3 * j:n_matrix + 3 + 3 * j]]
                   for j in range(len(solve.rhs))]
            if factors is None:
                factors = factored[key] = factor3(tri, assign)
            solution = apply3(factors, rhs, assign)
            for vec, sol in zip(solve.unknowns, solution):
                for u, val in zip(vec, sol):
                    steps.append((u, val))
                    assigned.add(u)
            solve_blocks.remove(block)
            progress = True
        if not progress:
            missing = sorted(str(s) for _, e in pending
                             for s in (e.free_symbols & produced) - assigned)
            raise ValueError(f"{spec.name}: cannot schedule (waiting for {missing[:5]})")

    # unknowns were bound to their solution values: substitute the trivial ones away
    alias = {sym: val for sym, val in steps if sym in unknowns and val.is_Atom}
    steps = [(sym, expr.xreplace(alias)) for sym, expr in steps if sym not in alias]
    out_values = [v.xreplace(alias) for v in out_values]
    steps = _prune(steps, out_values)
    steps = _state_last(steps, spec)
    grouped, pos = [], 0
    for vec in spec.outputs:
        grouped.append(tuple(out_values[pos:pos + len(vec.entries)]))
        pos += len(vec.entries)
    inputs = tuple(tuple(vec.entries) for vec in spec.inputs)
    return Program(spec=spec, steps=tuple(steps), outputs=tuple(grouped), inputs=inputs)
