"""The paper checks are not vacuous: a wrong printed form makes them fail."""
from __future__ import annotations

import sympy as sp

from derive import notation as nt
from paper_checks import printed
from paper_checks.runner import run


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


def test_a_wrong_sign_in_e3_3_is_caught(monkeypatch):
    monkeypatch.setattr(printed, "E3_3", printed.E3_3.xreplace({nt.J_z: -nt.J_z}))
    assert run("E3.3").status == "fail"


def test_c3_2_without_the_typo_is_not_an_erratum(monkeypatch):
    monkeypatch.setattr(printed, "E3_9_V4_RESTRICTED_AS_PRINTED",
                        printed.E3_9_V4_RESTRICTED_AS_PRINTED * nt.J_z)
    assert run("C3.2").status == "fail"


def test_a_wrong_stationary_condition_is_caught(monkeypatch):
    monkeypatch.setattr(printed, "E4_5", printed.E4_5 + 2 * nt.x * nt.zd * printed.omega_s)
    assert run("E4.5").status == "fail"


def test_a_law_outside_the_claim_fails_c4_2(monkeypatch):
    # z'' + omega^2 z/4 = 0 is C4.3's axial law, not C4.2's: with it (4.4) does not vanish
    monkeypatch.setattr(printed, "E4_7_ZDD", printed.E4_8_ZDD)
    assert run("C4.2").status == "fail"


def test_a_wrong_psi_rate_is_caught(monkeypatch):
    monkeypatch.setattr(printed, "E3_14_PSI_DOT", printed.E3_14_PSI_DOT * 2)
    assert run("E3.14").status == "fail"


# ---- X1.1 (EXTENSIONS.md): the rough plane reduces to the smooth one at mu_f = 0 ----------
def _patched(monkeypatch, name, **changes):
    """Replace ``derive.friction.<name>()`` by its result with ``changes``."""
    import dataclasses

    from derive import friction
    value = dataclasses.replace(getattr(friction, name)(), **changes)
    monkeypatch.setattr(friction, name, lambda: value)


def test_x1_1_catches_a_wrong_mass_term_in_w(monkeypatch):
    from derive import friction
    W = friction.delassus().matrix
    _patched(monkeypatch, "delassus",
             matrix=W + sp.diag(0, 0, 1 / nt.M - 1 / (nt.M + nt.m)))
    assert run("X1.1").status == "fail"


def test_x1_1_catches_a_wrong_energetic_termination(monkeypatch):
    from derive import friction
    dk = friction.darboux_keller()
    terms = dict(dk.terminations)
    terms["energetic"] = friction.E_N - (1 - nt.e) * friction.E_C      # e for e^2
    _patched(monkeypatch, "darboux_keller", terminations=terms)
    assert run("X1.1").status == "fail"


def test_x1_1_catches_a_sliding_normal_force_without_the_mass_term(monkeypatch):
    from derive import friction
    sc = friction.sliding_contact()
    _patched(monkeypatch, "sliding_contact",
             normal_force=-sc.a_free / (sc.k_f - 1 / (nt.M + nt.m)))
    assert run("X1.1").status == "fail"


def test_x1_1_catches_friction_in_the_wrong_lever(monkeypatch):
    # a lever that keeps a friction-like term at mu_f = 0 (CS x e_X instead of mu_f ...)
    from derive import friction
    from derive.impact import lever
    CS, _ = lever()
    sc = friction.sliding_contact()
    _patched(monkeypatch, "sliding_contact",
             lever=sc.lever + nt.cross(CS, nt.a.T * sp.Matrix([1, 0, 0])) / 1000)
    assert run("X1.1").status == "fail"


def test_prove_marks_a_cut_detail_and_the_report_keeps_it_whole(tmp_path, monkeypatch,
                                                                capsys):
    """The table shows one line of each detail: a longer or multi-line detail ends in '…'
    and the run says where the whole text is; the report carries it whole."""
    from derive.cli import main
    from paper_checks import catalogue, runner
    first = catalogue.entries()[0].id
    long = "x" * 120 + "\nsecond line"
    monkeypatch.setattr(runner, "run", lambda i: runner.Outcome(i, "pass", 0.0, long))
    assert main(["prove", "--id", first]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith(first))
    assert row.endswith("x…") and "x" * 90 not in row
    assert "--report DIR" in out
    assert main(["prove", "--id", first, "--report", str(tmp_path)]) == 0
    assert "x" * 120 + "<br>second line" in (tmp_path / "prove.md").read_text()


def test_the_latex_report_sets_code_spans_and_escapes_specials():
    """prove.tex had CLAIMS.md's Markdown backticks and a tilde accent (\\~{}) where the
    claim reads `dK~/dt`: code spans are now \\texttt, specials escaped."""
    from paper_checks.report import _escape
    assert _escape("the rate `dK~/dt = 0` of K_x, 5% & #1") == (
        r"the rate \texttt{dK\textasciitilde{}/dt = 0} of K\_x, 5\% \& \#1")
    assert _escape("an odd ` backtick") == "an odd ` backtick"


# ---- X2 (EXTENSIONS.md): internal motion as data ------------------------------------------
def test_x2_catches_a_first_moment_term_with_the_wrong_mass(monkeypatch):
    """k = h - s x s'/M (the carrier's mass for the whole's): X1.2 and X1.3 fail."""
    import dataclasses

    from derive import moments
    S = moments.moments_system()
    own = nt.h_m - nt.cross(nt.s_m, nt.s_md) / nt.M
    wrong = dataclasses.replace(S, momentum=dataclasses.replace(
        S.momentum, own=own, K=S.momentum.J * nt.omega + own))
    monkeypatch.setattr(moments, "moments_system", lambda: wrong)
    assert run("X1.2").status == "fail"
    assert run("X1.3").status == "fail"


def test_x2_1_catches_a_rotor_share_without_its_inertia(monkeypatch):
    from derive import moments
    share = moments.rotor_share()
    values = tuple(v.xreplace({moments.I_AXIAL: 1}) for v in share.values)
    monkeypatch.setattr(moments, "rotor_share", lambda: moments.Share(values, share.inputs))
    assert run("X1.2").status == "fail"


def test_x2_1_catches_a_point_share_with_a_wrong_inertia(monkeypatch):
    from derive import layout, moments
    real = moments.point_share

    def wrong(mass=moments.m_j):
        share = real(mass)
        values = list(share.values)
        values[layout.MOMENTS.theta.start] *= 2          # Theta_xx
        return moments.Share(tuple(values), share.inputs)
    monkeypatch.setattr(moments, "point_share", wrong)
    assert run("X1.2").status == "fail"


def test_the_machine_reports_carry_every_verdict(tmp_path, monkeypatch):
    """prove.json and the JUnit prove.xml: a failed check is a JUnit failure, an error an
    error, an erratum a pass with its correction in the output; read back by json and by
    ElementTree, not by the writer."""
    import json
    import xml.etree.ElementTree as ET

    from derive.cli import main
    from paper_checks import catalogue, runner
    from paper_checks.registry import Erratum
    ids = [e.id for e in catalogue.entries()[:4]]
    verdicts = dict(zip(ids, ("pass", "fail", "error", "erratum")))
    wrong = Erratum(ids[3], "a & <b>", "c", "d")
    monkeypatch.setattr(runner, "run", lambda i: runner.Outcome(
        i, verdicts[i], 0.5, f"detail of {i}", [wrong] if verdicts[i] == "erratum" else []))
    assert main(["prove", *(a for i in ids for a in ("--id", i)),
                 "--report", str(tmp_path)]) == 1
    records = json.loads((tmp_path / "prove.json").read_text())["checks"]
    assert [(r["id"], r["status"]) for r in records] == list(verdicts.items())
    assert records[3]["errata"][0]["printed"] == "a & <b>"
    suite = ET.parse(tmp_path / "prove.xml").getroot().find("testsuite")
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("4", "1", "1")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert cases[ids[1]].find("failure").text == f"detail of {ids[1]}"
    assert cases[ids[2]].find("error") is not None
    assert cases[ids[0]].find("failure") is None and cases[ids[3]].find("failure") is None
    assert "printed a & <b>" in cases[ids[3]].find("system-out").text
