"""Jacobians of the model functions, for CasADi's ``jac_<name>`` external convention.

:func:`jacobian` turns a :class:`~derive.models.FunctionSpec` ``f(x_0, ..., x_{n-1}) ->
(y_0, ..., y_{m-1})`` into the specification of ``jac_<name>``: the blocks
``d y_i / d x_j`` (output-major, as CasADi's ``Function.jacobian()`` orders them), each
with its structural sparsity, differentiated symbolically from the same expressions the
function is emitted from.

Forward mode over the specification, entry by entry of every input:

* a definition ``d = expr`` gets ``dd/dx = ∂expr/∂x + sum_s ∂expr/∂s ds/dx`` over the
  definitions and unknowns ``s`` it reads (a new definition when not zero);
* an unknown ``w`` of a solve ``J w = F`` gets ``J dw/dx = dF/dx - (dJ/dx) w``: more
  right-hand sides of the *same* matrix, solved after ``w`` (the emitted program reuses
  its factorisation: the adjugate and the reciprocal of the determinant, as
  :mod:`derive.emit.linalg` chooses), never a symbolic inverse;
* an output entry ``y`` gets ``dy/dx`` by the same chain rule.

Entries that are identically zero are left out of the blocks' sparsity; right-hand
sides that are identically zero make their unknowns zero before anything is
differentiated (``<model>_flight_jacobian`` solves for every state, most of them with
``dF/dq_k = 0``).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sp

from .models import FunctionSpec, Vector


@dataclass(frozen=True)
class Block:
    """``d out / d inp``: ``nrow x ncol`` in CasADi's column-compressed form."""
    out: str
    inp: str
    nrow: int
    ncol: int
    colind: tuple         # ncol + 1 offsets into ``row``
    row: tuple            # row of each structural nonzero, column by column

    @property
    def name(self) -> str:
        return f"jac_{self.out}_{self.inp}"

    @property
    def nnz(self) -> int:
        return len(self.row)

    @property
    def dense(self) -> bool:
        return self.nnz == self.nrow * self.ncol

    def sparsity(self) -> tuple:
        """CasADi's compressed sparsity: ``(nrow, ncol, 1)`` when dense, else
        ``(nrow, ncol, colind..., row...)``."""
        if self.dense:
            return (self.nrow, self.ncol, 1)
        return (self.nrow, self.ncol, *self.colind, *self.row)

    def to_dense(self, nonzeros):
        """A row-major list of lists from the nonzeros (tests and examples)."""
        out = [[0.0] * self.ncol for _ in range(self.nrow)]
        for col in range(self.ncol):
            for k in range(self.colind[col], self.colind[col + 1]):
                out[self.row[k]][col] = nonzeros[k]
        return out


@dataclass(frozen=True)
class JacobianSpec:
    """``jac_<name>``: CasADi calls it with the inputs of ``of`` followed by its nominal
    outputs (``out_<name>``, not read: their sparsity has no nonzeros) and receives every
    block; ``spec`` computes the blocks that have nonzeros (its outputs, in block
    order, each the nonzeros of one block)."""
    of: FunctionSpec
    spec: FunctionSpec
    blocks: tuple         # every block, output-major

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def nominal(self) -> tuple:
        return tuple(Vector(f"out_{v.name}", v.entries, v.labels) for v in self.of.outputs)


def _without_zero_solves(spec: FunctionSpec):
    """Solves whose right-hand side is identically zero have zero unknowns: drop them
    and substitute 0.  Returns (solves, substitution)."""
    zero = {}
    solves = []
    for solve in spec.solves:
        rhs, unknowns = [], []
        for b, w in zip(solve.rhs, solve.unknowns):
            b = tuple(sp.sympify(v).xreplace(zero) for v in b)
            if all(v == 0 for v in b):
                zero.update({s: sp.Integer(0) for s in w})
            else:
                rhs.append(b)
                unknowns.append(tuple(w))
        if rhs:
            solves.append(replace(solve, rhs=tuple(rhs), unknowns=tuple(unknowns)))
    return solves, zero


class _Chain:
    """Total derivatives through definitions and unknowns.  ``partials`` caches, per
    expression, its free symbols and its partial derivatives by the dependent symbols,
    so that each large expression is walked once whatever the number of inputs."""

    def __init__(self):
        self.derivative: dict = {}     # (dependent symbol, input symbol) -> expr
        self.dependent: set = set()
        self._cache: dict = {}

    def _info(self, expr):
        hit = self._cache.get(expr)
        if hit is None:
            free = expr.free_symbols
            hit = (free, {s: expr.diff(s) for s in sorted(free & self.dependent,
                                                           key=sp.default_sort_key)})
            self._cache[expr] = hit
        return hit

    def __call__(self, expr, x):
        expr = sp.sympify(expr)
        free, partials = self._info(expr)
        total = expr.diff(x) if x in free else sp.Integer(0)
        for s, ds in partials.items():
            dsx = self.derivative.get((s, x), 0)
            if dsx != 0 and ds != 0:
                total += ds * dsx
        return total


def _name(sym, x_name: str) -> str:
    return f"D_{sym.name}_{x_name}"


def jacobian(spec: FunctionSpec) -> JacobianSpec:
    """The ``jac_<name>`` of a specification (see the module's docstring)."""
    solves, zero = _without_zero_solves(spec)
    inputs = [(sym, f"{vec.name}{k}") for vec in spec.inputs
              for k, sym in enumerate(vec.entries)]
    chain = _Chain()
    chain.dependent = {s for s, _ in spec.definitions}
    chain.dependent |= {w for solve in solves for vec in solve.unknowns for w in vec}

    definitions = list(spec.definitions)
    for sym, expr in spec.definitions:
        expr = sp.sympify(expr).xreplace(zero)
        for x, x_name in inputs:
            value = chain(expr, x)
            if value == 0:
                continue
            if value.is_Atom:
                chain.derivative[(sym, x)] = value
            else:
                d = sp.Symbol(_name(sym, x_name), real=True)
                definitions.append((d, value))
                chain.derivative[(sym, x)] = d

    derived_solves = []
    for solve in solves:
        J = solve.matrix
        rhs, unknowns = [], []
        for x, x_name in inputs:
            dJ = sp.Matrix(3, 3, lambda i, j: chain(J[max(i, j), min(i, j)], x))
            for b, w in zip(solve.rhs, solve.unknowns):
                w_vec = sp.Matrix(w)
                db = [chain(b[i], x) - (dJ[i, :] * w_vec)[0, 0] for i in range(3)]
                if all(v == 0 for v in db):
                    continue
                d = tuple(sp.Symbol(_name(s, x_name), real=True) for s in w)
                rhs.append(tuple(db))
                unknowns.append(d)
                chain.derivative.update({(s, x): ds for s, ds in zip(w, d)})
        if rhs:
            derived_solves.append(replace(solve, rhs=tuple(rhs), unknowns=tuple(unknowns)))

    blocks, outputs = [], []
    for out in spec.outputs:
        entries = [sp.sympify(v).xreplace(zero) for v in out.entries]
        for vec in spec.inputs:
            colind, row, values, labels = [0], [], [], []
            for k, x in enumerate(vec.entries):
                for i, y in enumerate(entries):
                    value = chain(y, x)
                    if value != 0:
                        row.append(i)
                        values.append(value)
                        labels.append(f"d({out.labels[i]})/d({vec.labels[k]})")
                colind.append(len(row))
            block = Block(out.name, vec.name, len(entries), len(vec.entries),
                          tuple(colind), tuple(row))
            blocks.append(block)
            if values:
                outputs.append(Vector(block.name, tuple(values), tuple(labels)))

    jac = FunctionSpec(
        name=f"jac_{spec.name}",
        doc=f"Jacobian of {spec.name} (every output by every input, column-compressed "
            "nonzeros), CasADi's jac_ convention.",
        inputs=spec.inputs, outputs=tuple(outputs),
        solves=tuple(solves) + tuple(derived_solves), definitions=tuple(definitions))
    return JacobianSpec(of=spec, spec=jac, blocks=tuple(blocks))
