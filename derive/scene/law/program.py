"""A law compiled: :class:`Program`, nodes of the opcodes (:mod:`.ops`) in topological
order over a table of float constants, with any number of outputs (a point's x, y, z;
several points' and rotors' coordinates).  Data for the C interpreter
(:meth:`Program.arrays`), for NumPy and floats (:meth:`Program.jets`,
:meth:`Program.point`) and, when a symbolic tool asks, for SymPy (:meth:`Program.sympy`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .ops import OPS, Arrays, Floats, harmonic_jet

@dataclass(eq=False)
class Program:
    """Nodes in topological order: ``ops[k]`` with arguments ``a[k]``, ``b[k]`` (node
    indices, or for ``const``/``powi``/``powr`` an index into ``consts``); the nodes
    ``outputs``: a point's x, y, z (a rotor's psi; every body's, in a law of several).
    Constant nodes come first, then ``t``, then the rest."""
    kind = "program"
    ops: tuple
    a: tuple
    b: tuple
    consts: tuple
    outputs: tuple
    text: tuple = ()                       # the source strings, one per output
    _sympy: tuple | None = field(default=None, repr=False, compare=False)

    def is_zero(self, k: int) -> bool:
        node = self.outputs[k]
        return self.ops[node] == "const" and self.consts[self.a[node]] == 0.0

    def is_constant(self, k: int) -> bool:
        return self.ops[self.outputs[k]] == "const"

    def constant(self, k: int) -> float:
        node = self.outputs[k]
        return self.consts[self.a[node]] if self.ops[node] == "const" else math.nan

    def _jets(self, xp, t, one, zero) -> list:
        """Every node's jet: (value, d/dt, d2/dt2) in the arithmetic of ``xp``."""
        val: list = [None] * len(self.ops)
        consts = self.consts
        for k, name in enumerate(self.ops):
            a, b = self.a[k], self.b[k]
            op = OPS[name]
            if op.shape == "const":
                val[k] = (consts[a] * one, zero, zero)
            elif op.shape == "t":
                val[k] = (t, one, zero)
            elif op.shape == "harmonic":
                val[k] = harmonic_jet(name, *consts[a:a + 3], xp.sin, xp.cos, t)
            elif op.shape == "power":
                val[k] = op.jet(xp, val[a], None, consts[b])
            else:
                val[k] = op.jet(xp, val[a], val[b] if op.reads_b else None, 0.0)
        return val

    def output_jets(self, xp, t) -> list:
        """Each output's jet (value, d/dt, d2/dt2) in the arithmetic of the namespace
        ``xp`` (the functions of :class:`~.ops.Floats`: sin, ..., arctan, power) at ``t``,
        a number or a symbol (the planner's CasADi)."""
        val = self._jets(xp, t, 1.0, 0.0)
        return [val[node] for node in self.outputs]

    def node_jets(self, ts) -> list:
        """Every node's jet (value, d/dt, d2/dt2) at the times ``ts`` (NumPy arrays, NaN
        or inf where a value does not exist)."""
        ts = np.asarray(ts, dtype=float).reshape(-1)
        n = ts.size
        with np.errstate(all="ignore"):
            val = self._jets(Arrays, ts, np.ones(n), np.zeros(n))
        return [tuple(_read_only(v, n) for v in jet) for jet in val]

    def jets(self, ts) -> np.ndarray:
        """(3 n_outputs, N): each output's value and two derivatives at the times ``ts``
        (a point's: x, x', x'', y, y', y'', z, z', z'')."""
        ts = np.asarray(ts, dtype=float).reshape(-1)
        n = ts.size
        with np.errstate(all="ignore"):
            val = self._jets(Arrays, ts, np.ones(n), np.zeros(n))
        out = np.empty((3 * len(self.outputs), n))
        for r, v in enumerate(v for node in self.outputs for v in val[node]):
            out[r] = v                       # (a constant's entries broadcast)
        return out

    def point(self, t: float) -> np.ndarray:
        """u = (x, y, z, x', y', z', x'', y'', z'') at one time (float arithmetic: for a
        single point this is faster than :meth:`jets`; NaN where a value does not
        exist)."""
        out = np.empty(9)
        try:
            val = self._jets(Floats, float(t), 1.0, 0.0)
        except (ValueError, OverflowError, ZeroDivisionError):
            out[:] = math.nan
            return out
        for c, node in enumerate(self.outputs):
            out[c], out[3 + c], out[6 + c] = val[node]
        return out

    # -- for the C interpreter -----------------------------------------------------------
    def arrays(self) -> dict:
        """int32 ``code`` rows (op, a, b) and float64 ``consts`` for the runtime."""
        from ... import abi
        code = np.array([[abi.OP[op], a, b] for op, a, b in zip(self.ops, self.a, self.b)],
                        dtype=np.int32).reshape(-1, 3)
        n_const = sum(1 for op in self.ops if op == "const")
        return {"code": np.ascontiguousarray(code),
                "consts": np.ascontiguousarray(self.consts or (0.0,), dtype=float),
                "outputs": np.array(self.outputs, dtype=np.int32), "n_const": n_const}

    # -- text and SymPy ----------------------------------------------------------------------
    def node_text(self, k: int, depth: int = 0) -> str:
        name, a, b = self.ops[k], self.a[k], self.b[k]
        op = OPS[name]
        if depth > 12:
            return "..."
        if op.shape == "const":
            return f"{self.consts[a]:.15g}"
        if op.shape == "t":
            return "t"
        if op.shape == "harmonic":
            A, w, ph = self.consts[a:a + 3]
            return f"{A:.15g}*{name[1:]}({w:.15g}*t + {ph:.15g})"
        x = self.node_text(a, depth + 1)
        if op.shape == "power":
            return f"{x}**{self.consts[b]:.15g}"
        if name == "pow":
            return f"{x}**{self.node_text(b, depth + 1)}"
        if op.infix:
            return f"({x}{op.infix}{self.node_text(b, depth + 1)})"
        if name == "neg":
            return f"-{x}"
        return f"{name}({x})"

    def sympy(self) -> tuple:
        """The three coordinates as SymPy expressions in ``derive.notation.t`` (for the
        symbolic tools; the runtime never needs this)."""
        if self._sympy is None:
            self._sympy = _to_sympy(self)
        return self._sympy

    def arguments(self, k: int) -> tuple:
        """The nodes node ``k`` reads."""
        op = OPS[self.ops[k]]
        if op.leaf:
            return ()
        return (self.a[k], self.b[k]) if op.reads_b else (self.a[k],)

    def coordinate_of(self, node: int) -> int:
        """The first coordinate whose expression uses ``node``."""
        for k, out in enumerate(self.outputs):
            if node in _reachable(self, out):
                return k
        return 0


def _read_only(v, n: int) -> np.ndarray:
    """``v`` as a read-only array of shape (n,): a view of it where it is one already
    (np.broadcast_to's view, without its cost), else broadcast (the nodes share arrays:
    t's ones and zeros)."""
    if type(v) is np.ndarray and v.shape == (n,):
        v = v.view()
        v.flags.writeable = False
        return v
    return np.broadcast_to(v, (n,))


def _reachable(p: Program, root: int) -> set:
    seen, stack = set(), [root]
    while stack:
        k = stack.pop()
        if k not in seen:
            seen.add(k)
            stack.extend(p.arguments(k))
    return seen


def _to_sympy(p: Program) -> tuple:
    import sympy as sp
    from ... import notation as nt

    def number(c: float):
        if c == math.pi:
            return sp.pi
        return sp.Integer(int(c)) if c == int(c) and abs(c) < 2 ** 53 else sp.Float(repr(c), 17)
    val: list = []
    for name, a, b in zip(p.ops, p.a, p.b):
        op = OPS[name]
        if op.shape == "const":
            v = number(p.consts[a])
        elif op.shape == "t":
            v = nt.t
        elif op.shape == "harmonic":
            A, w, ph = (sp.Float(repr(c), 17) for c in p.consts[a:a + 3])
            v = A * (sp.sin if name == "hsin" else sp.cos)(w * nt.t + ph)
        elif op.shape == "power":
            r = p.consts[b]
            v = val[a] ** (sp.Integer(int(r)) if name == "powi" else sp.Float(repr(r), 17))
        else:
            v = op.sympy(sp, val[a], val[b] if op.reads_b else None)
        val.append(v)
    return tuple(val[k] for k in p.outputs)

