"""How the emitted C reads the state and orders its work (derive.emit.program,
derive.emit.c_backend, derive.emit.latency): each entry of a fed-back input read once
through a volatile lvalue, what reads only the law first, sums and products in the order
their values are ready.  (That the programs compute the same values is test_emit's.)"""
from __future__ import annotations

import re

import pytest
import sympy as sp

from derive.emit.c_backend import body
from derive.emit.latency import analyse
from derive.emit.program import HOT, build
from derive.emit.render import GENERATED
from derive.models import FunctionSpec, Vector, all_specs

SPECS = all_specs()


def _plain_body(name: str) -> str:
    text = (GENERATED / "c" / f"{name}.c").read_text()
    start = text.index("{", text.index(f"void carrier_{name}("))
    return text[start:text.index("\n}\n", start)]


@pytest.mark.parametrize("spec", SPECS, ids=[s.name for s in SPECS])
def test_state_is_read_once_per_entry_through_a_volatile_lvalue(spec):
    code = _plain_body(spec.name)
    hot = [v for v in spec.inputs if v.name in HOT and len(v.entries) > 1]
    if not hot:
        assert "volatile" not in code
        return
    for vec in hot:
        loads = re.findall(rf"\(\(const volatile double \*\){vec.name}\)\[(\d+)\]", code)
        assert loads and len(loads) == len(set(loads)), loads
        plain = re.sub(rf"\(\(const volatile double \*\){vec.name}\)\[\d+\]", "", code)
        assert not re.search(rf"\b{vec.name}\[", plain), f"{vec.name} read directly"


def _toy(expr) -> FunctionSpec:
    q = sp.symbols("q0:5", real=True)
    u = sp.symbols("u0:3", real=True)
    return FunctionSpec("toy", "", (Vector("q", q, tuple("abcde")), Vector("u", u, tuple("fgh"))),
                        (Vector("x", (expr(q, u),), ("x",)),))


def test_terms_that_read_only_the_law_come_first():
    """q0 q1 + u0 u1 + u2: the law's two terms are summed before the state's product
    enters, so that from the state the chain is one product and one addition."""
    spec = _toy(lambda q, u: q[0] * q[1] + u[0] * u[1] + u[2])
    program = build(spec)
    code = body(spec, program)["assigned"][0][0][1]
    assert code.replace(" ", "").endswith("+q0*q1"), code
    lat = {"add": 1.0, "mul": 2.0, "div": 10.0, "sqrt": 20.0, "call": 50.0}
    assert analyse(program, ("q",), lat).path.counts == {"mul": 1, "add": 1}


def test_of_two_products_the_later_is_printed_first():
    """q0 q1 + q2 q3 q4: a compiler contracts a*b + c*d into fma(a, b, c*d); the product
    that is ready last is printed first so that it waits for one operation, not two."""
    spec = _toy(lambda q, u: q[0] * q[1] + q[2] * q[3] * q[4])
    code = body(spec)["assigned"][0][0][1].replace(" ", "")
    assert code.startswith("q2*q3*q4+") or code.startswith("q3*q4*q2+"), code


def test_factors_that_read_only_the_law_multiply_first():
    spec = _toy(lambda q, u: q[0] * u[0] * u[1] * q[1] * q[2])
    code = body(spec)["assigned"][0][0][1].replace(" ", "")
    assert code.startswith("u[0]*u[1]*"), code


@pytest.mark.parametrize("name", ["general_flight_rhs", "lie_stage", "general_impact",
                                  "jac_general_flight_rhs"])
def test_steps_that_read_only_the_law_come_before_the_state_s(name):
    from derive.jacobians import jacobian
    from derive.models import flight_rhs
    spec = next((s for s in SPECS if s.name == name), None)
    if spec is None:
        spec = jacobian(flight_rhs("general")).spec
    program = build(spec)
    hot = {s for vec in spec.inputs if vec.name in HOT for s in vec.entries}
    seen_hot = False
    for sym, expr in program.steps:
        reads_state = bool(expr.free_symbols & hot)
        if reads_state:
            hot.add(sym)
            seen_hot = True
        assert reads_state or not seen_hot, f"{sym} reads only the law after the state's"
