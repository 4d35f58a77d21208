"""The paper checks are not vacuous: a wrong printed form makes them fail."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt
from paper_checks import printed
from paper_checks.registry import run


def test_a_sign_error_in_e1_7_is_caught(monkeypatch):
    wrong = printed.E1_7.copy()
    wrong[1] = wrong[1].xreplace({nt.J_z: -nt.J_z})
    monkeypatch.setattr(printed, "E1_7", wrong)
    assert run("E1.7").status == "fail"


def test_a_wrong_coefficient_in_d_is_caught(monkeypatch):
    wrong = printed.E1_10_D.copy()
    wrong[2] = wrong[2] + sp.Rational(1, 10**6) * nt.a[2, 0]
    monkeypatch.setattr(printed, "E1_10_D", wrong)
    assert run("E1.10").status == "fail"


def test_e1_12_without_the_typo_is_not_an_erratum(monkeypatch):
    lhs, rhs = printed.E1_12_AS_PRINTED
    monkeypatch.setattr(printed, "E1_12_AS_PRINTED",
                        (printed.omega, rhs.xreplace(dict(zip(lhs, printed.omega)))))
    assert run("E1.12").status == "fail"


def test_k_with_a_wrong_mass_term_is_caught(monkeypatch):
    monkeypatch.setattr(printed, "E1_16", printed.E1_16 + 1 / nt.M - 1 / (nt.M + nt.m))
    assert run("E1.16").status == "fail"
