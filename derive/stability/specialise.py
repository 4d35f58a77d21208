"""Scene-specific symbolic functions for the stability analyses.

The runtime never specialises (every model is compiled once and reads a scene's numbers at
run time).  The stability tools still want a few derived functions of one scene as
CasADi or NumPy functions of ``(t, q)``: the trace of the flight Jacobian (Liouville's
check), the gradients of the integrals (the trivial multipliers) and the derivatives of
the gap and the impact map (the saltation matrix).  Here the scene's numbers and its
point law (as SymPy, from :meth:`derive.scene.law.Program.sympy`) are substituted into
the derived specifications of :mod:`derive.models`.
"""
from __future__ import annotations

import sympy as sp

from .. import models as dm
from .. import notation as nt
from .. import shapes, surfaces
from ..scene import Scene

T_VEC = dm.Vector("t", (nt.t,), ("t",))


def _float(x: float) -> sp.Float:
    return sp.Float(repr(float(x)), 17)


def number_subs(scene: Scene) -> dict:
    subs = {nt.M: _float(scene.M), nt.m: _float(scene.m), nt.J_x: _float(scene.J[0]),
            nt.J_y: _float(scene.J[1]), nt.J_z: _float(scene.J[2]), nt.g: _float(scene.g),
            nt.e: _float(scene.e)}
    return subs


def law_parts(scene: Scene) -> tuple[dict, list]:
    """The point law: constant entries as substitutions, the others as definitions
    evaluated once per call (so that CSE shares them, as it shares the inputs ``u`` of
    the generic code)."""
    t = nt.t
    subs, definitions = {}, []
    syms_all, values_all = [], []
    for f, syms in zip(scene.law.sympy(), ((nt.x, nt.xd, nt.xdd), (nt.y, nt.yd, nt.ydd),
                                   (nt.z, nt.zd, nt.zdd))):
        for sym, value in zip(syms, (f, sp.diff(f, t), sp.diff(f, t, 2))):
            syms_all.append(sym)
            values_all.append(sp.sympify(value))
    for sym, value in zip(syms_all, values_all):
        if value.free_symbols:
            definitions.append((sym, value))
        else:
            subs[sym] = sp.Float(value, 17) if not value.is_Integer else value
    return subs, definitions


def shape_subs(scene: Scene) -> dict:
    """OS and its rate as expressions in n (and omega) for the scene's shape."""
    if scene.shape == "none":
        return {}
    lp = surfaces.lowest_point(scene.shape)
    geo = dict(zip(surfaces.center, (_float(c) for c in scene.center)))
    geo.update(zip(surfaces.shape_symbols(shapes.of(scene.shape)),
                   (_float(a) for a in scene.size)))
    subs = dict(zip(nt.OS, lp.point.xreplace(geo)))
    subs.update(zip(nt.OS_rate, lp.rate.xreplace(geo)))
    return subs


def specialise(spec: dm.FunctionSpec, subs: dict, definitions: list, q: tuple,
               q_labels: tuple, name: str, outputs: list | None = None) -> dm.FunctionSpec:
    """``spec`` with ``subs`` applied everywhere and ``definitions`` (symbol, value)
    computed first; inputs ``(t, q)``; optionally new outputs ``[(name, exprs,
    labels)]`` written in the spec's symbols."""
    def sub(e):
        e = sp.sympify(e).xreplace(subs)
        return e.xreplace(subs)        # shape expressions bring symbols subs also maps

    outs = outputs if outputs is not None else [(v.name, v.entries, v.labels)
                                                for v in spec.outputs]
    solves = tuple(dm.LinearSolve(matrix=s.matrix.applyfunc(sub),
                                  rhs=tuple(r.applyfunc(sub) for r in s.rhs),
                                  unknowns=s.unknowns,
                                  diagonal=tuple(sub(v) for v in s.diagonal),
                                  rank_one=tuple(sub(v) for v in s.rank_one))
                   for s in spec.solves)
    new_outputs = [dm.Vector(oname, tuple(sub(e) for e in exprs), labels)
                   for oname, exprs, labels in outs]
    defs = tuple((sym, sub(v)) for sym, v in definitions)
    defs += tuple((sym, sub(v)) for sym, v in spec.definitions)
    used = set()
    for vec in new_outputs:
        for v in vec.entries:
            used |= v.free_symbols
    for _, v in defs:
        used |= v.free_symbols
    solves = tuple(s for s in solves if any(sym in used for vec in s.unknowns for sym in vec))
    return dm.FunctionSpec(name=name, doc=spec.doc, inputs=(T_VEC, dm.Vector("q", q, q_labels)),
                           outputs=tuple(new_outputs), solves=solves, definitions=defs)


def common(scene: Scene) -> tuple[dict, list]:
    subs = number_subs(scene)
    law_s, law_d = law_parts(scene)
    subs.update(law_s)
    subs.update(shape_subs(scene))
    return subs, law_d


