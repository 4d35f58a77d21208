"""derive/layout.py: states assembled from named parts agree with slicing them back out,
whatever form the parts come in (lists, tuples, arrays, rows of states)."""
import numpy as np
import pytest

from derive import layout
from derive.layout import GENERAL, VERTICAL

PARTS = {"general": ("com", "com_velocity", "omega", "A"), "vertical": ("Z", "Zd", "omega", "n")}


def _forms(value, rng):
    return [value, list(value) if value.ndim == 1 else value, tuple(value.tolist())
            if value.ndim == 1 else value][rng.integers(3)]


@pytest.mark.parametrize("lay", [GENERAL, VERTICAL])
def test_assemble_round_trip(lay):
    rng = np.random.default_rng(7)
    for trial in range(400):
        rows = (trial % 2) * int(rng.integers(1, 5))        # one state or a few rows
        q = rng.normal(size=(rows, lay.nq) if rows else lay.nq)
        names = PARTS[lay.model]
        parts = {}
        for name in rng.permutation(names):
            where = getattr(lay, name)
            part = q[..., where]
            parts[name] = part if np.ndim(part) == 0 or rows else _forms(part, rng)
        got = lay.assemble(**parts)
        assert got.shape == q.shape and got.dtype == float
        assert np.array_equal(got, q)


def test_assemble_refuses_parts_that_do_not_fit():
    with pytest.raises(ValueError):
        GENERAL.assemble(com=[0.0, 0.0], com_velocity=[0.0] * 3, omega=[0.0] * 3,
                         A=[0.0] * 9)
    with pytest.raises(ValueError, match="cover"):
        GENERAL.assemble(com=[0.0] * 3, omega=[0.0] * 3, A=[0.0] * 9)


def test_vertical_of_general_picks_the_named_parts():
    q = np.arange(GENERAL.nq, dtype=float)
    v = layout.vertical_of_general(q)
    assert v[VERTICAL.Z] == q[GENERAL.Z] and v[VERTICAL.Zd] == q[GENERAL.Zd]
    assert np.array_equal(v[VERTICAL.omega], q[GENERAL.omega])
    assert np.array_equal(v[VERTICAL.n], q[GENERAL.n])
