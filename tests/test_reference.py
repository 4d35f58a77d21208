"""Issue 5: the exact reference solutions against the runtime's `general` integration:
agreement to 1e-10, and an error that shrinks with the tolerance."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import tomllib

from derive import reference
from derive.runtime.driver import simulate
from derive.scene import DEFAULT_SCENE, parse_scene


def free_doc(**updates):
    doc = tomllib.loads(DEFAULT_SCENE)
    doc.pop("plane")
    for section, values in updates.items():
        doc[section].update(values)
    doc["run"].update(model="general", outputs=["pose"], output_dt=0.05)
    return doc


def _errors(doc, solution, method="dop853"):
    errs = []
    for tol in (1e-8, 1e-10, 1e-12):
        d = copy.deepcopy(doc)
        d["run"].update(method=method, rtol=tol, atol=tol * 1e-2, output_dt=0.05)
        res = simulate(d, progress=False)
        assert res.status == "done"
        rows = res.row_kind == 0
        exact = solution(parse_scene(d), res.t[rows])
        errs.append(float(np.max(np.abs(res.q[rows] - exact))))
    return errs


def _shrinks(errs):
    print("errors at rtol 1e-8, 1e-10, 1e-12:", ", ".join(f"{e:.1e}" for e in errs))
    assert errs[-1] < 1e-10, errs
    assert errs[0] > errs[1] > errs[2] or errs[1] < 1e-12, errs


AXI = dict(body={"inertia": [0.1, 0.1, 0.15]}, point={"mass": 0.4, "law": ["0", "0",
                                                                             "0.3*sin(4*t)"]},
           run={"duration": 3.0})


# the classical DOP853 and the Lie-group method of the momentum form (crt_lie.h)
METHODS = ["dop853", "lie"]


@pytest.mark.parametrize("method", METHODS)
def test_axisymmetric_quadrature_against_the_runtime(method):
    _shrinks(_errors(free_doc(**AXI), reference.axisymmetric, method))


def test_axisymmetric_closed_form_equals_quadrature():
    s = parse_scene(free_doc(**AXI))
    ts = np.linspace(0, 3, 31)
    closed = reference.inverse_inertia_integral(s, ts, s.J[0])
    from scipy.integrate import quad
    numeric = [quad(lambda u: 1 / (s.J[0] + s.reduced_mass * (0.3 * math.sin(4 * u)) ** 2), 0, tk,
                    epsabs=1e-14, epsrel=1e-13, limit=200)[0] for tk in ts]
    assert np.max(np.abs(closed - numeric)) < 1e-13


@pytest.mark.parametrize("method", METHODS)
def test_axisymmetric_with_a_non_harmonic_law_by_quadrature(method):
    doc = free_doc(**AXI)
    doc["point"]["law"] = ["0", "0", "0.2*sin(3*t) + 0.1*t"]
    _shrinks(_errors(doc, reference.axisymmetric, method))


@pytest.mark.parametrize("method", METHODS)
def test_planar_against_the_runtime(method):
    doc = free_doc(point={"mass": 0.3, "law": ["0.2*cos(3*t)", "0.1*sin(2*t)", "0"]},
                   initial={"omega": [0.0, 0.0, 1.5]}, run={"duration": 3.0})
    _shrinks(_errors(doc, reference.planar, method))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", ["C4.1", "C4.2", "C4.3"])
def test_stationary_rotations_against_the_runtime(case, method):
    doc = reference.stationary_scene(case, omega=2.0, duration=2.0)
    doc["run"]["output_dt"] = 0.05
    errs = _errors(doc, reference.stationary, method)
    if method == "lie":
        # a uniform rotation is exact in exponential coordinates: rounding only
        print("errors:", errs)
        assert max(errs) < 1e-12, errs
    else:
        _shrinks(errs)


@pytest.mark.parametrize("method", METHODS)
def test_free_parabola_of_C(method):
    doc = free_doc(run={"duration": 2.0, "method": method})
    res = simulate(doc, progress=False)
    R, V = reference.free_parabola(parse_scene(doc), res.t)
    assert np.max(np.abs(res.q[:, 0:3] - R)) < 1e-12
    assert np.max(np.abs(res.q[:, 3:6] - V)) < 1e-12


def test_a_wrong_reference_is_detected():
    """The comparison is sharp: a stationary reference for a scene that is not
    stationary (omega off the axis) disagrees with the runtime."""
    doc = reference.stationary_scene("C4.2", omega=2.0, duration=2.0)
    doc["initial"]["omega"] = [0.01, 0.0, 2.0]
    res = simulate(doc, progress=False)
    exact = reference.stationary(parse_scene(doc), res.t)
    assert np.max(np.abs(res.q - exact)) > 1e-4
