"""Where each quantity sits in a model's state vector, by name (Pinocchio's
``model.idx_qs``/``nqs``): nobody writes ``q[15:18]``, they write ``GENERAL.n``.

The one list of every model's states is here; :mod:`derive.models` maps these labels
to the derivation's symbols, the emitters render the C offsets from them
(``MODEL_Z``, where the vertical ``n`` and ``omega`` sit), and the runtime, the
planner, the stability tools and the benchmarks slice states through them.  No SymPy:
the runtime imports this.

Also the point law's two orders: ``u = (x, y, z, x', y', z', x'', y'', z'')`` (what the
derived functions read, :data:`U`) and the jets of a law ``(x, x', x'', y, y', y'', z,
z', z'')`` (what :meth:`derive.scene.law.Program.jets` returns), and the map between
them (:func:`u_of_jets`).

And the moments of any number of points and rotors (:data:`MOMENTS`): the 27 numbers the
``moments_*`` functions read in place of ``u``, and what each body's share takes.
"""
from __future__ import annotations

import numpy as np


def plain(label: str) -> str:
    """A state's name as a user reads it (``Result.state_names``, trajectory.csv, the
    summary): an identifier NumPy, pandas and spreadsheets keep, ``X_C'`` -> ``dX_C``.  The
    labels here keep the derivation's primes (the C's ``crt_state_name``)."""
    stripped = label.rstrip("'")
    return "d" * (len(label) - len(stripped)) + stripped


class StateRow(dict):
    """One row of a run by name (``Result.row``): ``t`` and the states under their plain
    names; the derivation's spelling with primes (``Z_C'``) finds ``dZ_C`` too, and an
    unknown name's KeyError names the known ones."""

    def __missing__(self, key):
        if isinstance(key, str) and plain(key) != key and plain(key) in self:
            return self[plain(key)]
        primes = [k for k in self if k.startswith("d") and k[1:] in self]
        raise KeyError(f"no state {key!r} in this row: its names are {', '.join(self)}"
                       + (f" ({primes[0]} is {primes[0][1:]}', and may be written so)"
                          if primes else ""))


def _is_row(value) -> bool:
    """One state's part: a 1-D array, or a list or tuple of numbers (np.ndim, asked of a
    list, builds an array first)."""
    if isinstance(value, np.ndarray):
        return value.ndim == 1
    return isinstance(value, (list, tuple)) and not (
        value and isinstance(value[0], (list, tuple, np.ndarray)))


def _as_list(value):
    return value.tolist() if isinstance(value, np.ndarray) else value


class Layout:
    """A model's state labels and named parts: ``layout.omega`` is a slice,
    ``layout.Z`` an index (``None`` where the model has no such part); ``nq`` states."""

    def __init__(self, model: str, labels: tuple, parts: dict, indices: dict):
        self.model, self.labels, self.nq = model, tuple(labels), len(labels)
        self.parts = {}
        for name, names in parts.items():
            k = self.labels.index(names[0])
            if self.labels[k:k + len(names)] != tuple(names):
                raise ValueError(f"{model}: the part {name} is not contiguous")
            self.parts[name] = slice(k, k + len(names))
        self.indices = {name: self.labels.index(label) for name, label in indices.items()}
        self._plans: dict = {}
        for name, where in {**self.parts, **self.indices}.items():
            setattr(self, name, where)

    def index(self, label: str) -> int:
        return self.labels.index(label)

    def assemble(self, **parts) -> np.ndarray:
        """States from their parts (``com=..., omega=...``: rows, or one state), every
        state covered once."""
        plan = self._plans.get(tuple(parts))
        if plan is None:
            plan = self._plans[tuple(parts)] = self._plan(tuple(parts))
        if plan and all(_is_row(parts[name]) for name in plan):
            # one list, one array (the parts' own arrays as lists: half a concatenation)
            row = []
            for name in plan:
                row += _as_list(parts[name])
            if len(row) == self.nq:             # (a part of the wrong size: numpy says so)
                return np.array(row, dtype=float)
        n = {np.shape(v)[0] for v in parts.values() if np.ndim(v) == 2}
        out = np.empty((*n, self.nq)) if n else np.empty(self.nq)
        for name, value in parts.items():
            out[..., getattr(self, name)] = value
        return out

    def _plan(self, names: tuple) -> tuple:
        """The parts in the order they tile the state (for one state made by one
        concatenation), or () when they are not all slices; ValueError unless they cover
        every state once."""
        covered = np.zeros(self.nq, dtype=int)
        for name in names:
            covered[getattr(self, name)] += 1
        if not np.all(covered == 1):
            raise ValueError(f"{self.model}: {names} do not cover the state once")
        if not all(name in self.parts for name in names):
            return ()
        return tuple(sorted(names, key=lambda name: self.parts[name].start))

    def __repr__(self) -> str:
        return f"Layout({self.model}, {self.nq} states)"


_A = ("a11", "a12", "a13", "a21", "a22", "a23", "a31", "a32", "a33")
_OMEGA = ("omega_x", "omega_y", "omega_z")
_N = ("a31", "a32", "a33")

# a_ij = cos(fixed axis i, body axis j); the row a3j is the vertical n in body axes
GENERAL = Layout("general",
                 ("X_C", "Y_C", "Z_C", "X_C'", "Y_C'", "Z_C'", *_OMEGA, *_A),
                 {"com": ("X_C", "Y_C", "Z_C"), "com_velocity": ("X_C'", "Y_C'", "Z_C'"),
                  "horizontal": ("X_C", "Y_C"), "horizontal_velocity": ("X_C'", "Y_C'"),
                  "omega": _OMEGA, "A": _A, "n": _N},
                 {"Z": "Z_C", "Zd": "Z_C'"})
VERTICAL = Layout("vertical", ("Z_C", "Z_C'", *_OMEGA, *_N),
                  {"omega": _OMEGA, "n": _N}, {"Z": "Z_C", "Zd": "Z_C'"})
ATTITUDE = Layout("attitude", _OMEGA, {"omega": _OMEGA}, {})
TRANSLATIONAL = Layout("translational", ("Z_C", "Z_C'"), {}, {"Z": "Z_C", "Zd": "Z_C'"})
PLANAR = Layout("planar", ("Z_C", "Z_C'", "kappa", "phi"), {},
                {"Z": "Z_C", "Zd": "Z_C'", "kappa": "kappa", "phi": "phi"})
AXISYMMETRIC = Layout("axisymmetric", ("psi", "phi"), {}, {"psi": "psi", "phi": "phi"})
_PHI = tuple(f"Phi[{i},{j}]" for i in range(VERTICAL.nq) for j in range(VERTICAL.nq))
VARIATIONAL = Layout("variational", VERTICAL.labels + _PHI,
                     {"omega": _OMEGA, "n": _N, "Phi": _PHI}, {"Z": "Z_C", "Zd": "Z_C'"})
# the base model (issue 33): a body on its face, O's horizontal position and the yaw psi
# (fixed axes; derive/base.py's STATE_LABELS)
BASE = Layout("base", ("X_O", "Y_O", "psi", "X_O'", "Y_O'", "psi'"),
              {"position": ("X_O", "Y_O"), "velocity": ("X_O'", "Y_O'")},
              {"psi": "psi", "psi_rate": "psi'"})
LAYOUTS = {lay.model: lay for lay in (GENERAL, VERTICAL, ATTITUDE, TRANSLATIONAL, PLANAR,
                                      AXISYMMETRIC, VARIATIONAL, BASE)}
# the rough model (Coulomb friction at S) runs the general state, and so do the models of
# internal bodies other than one point (moments, moments_rough: their input u is the
# MOMENTS below, not a state)
ROUGH = GENERAL
LAYOUTS["rough"] = ROUGH
LAYOUTS["moments"] = LAYOUTS["moments_rough"] = GENERAL


def of(model: str) -> Layout:
    return LAYOUTS[model]


def vertical_of_general(q: np.ndarray) -> np.ndarray:
    """The vertical model's state from general states (rows or one state)."""
    q = np.asarray(q)
    return np.concatenate([q[..., [GENERAL.Z, GENERAL.Zd]], q[..., GENERAL.omega],
                           q[..., GENERAL.n]], axis=-1)


# ---- the point law ---------------------------------------------------------------------
U_LABELS = ("x", "y", "z", "x'", "y'", "z'", "x''", "y''", "z''")
U = Layout("u", U_LABELS, {"r": ("x", "y", "z"), "v": ("x'", "y'", "z'"),
                           "a": ("x''", "y''", "z''")}, {})
JET_LABELS = ("x", "x'", "x''", "y", "y'", "y''", "z", "z'", "z''")
# the rows of a law's jets that hold OP, OP' and OP'' (x, y, z each)
JET_R, JET_V, JET_A = ((0, 3, 6), (1, 4, 7), (2, 5, 8))
# jets -> u: u[i] = jets[JET_TO_U[i]]
JET_TO_U = tuple(JET_LABELS.index(label) for label in U_LABELS)


def u_of_jets(jets):
    """u = (x, y, z, x', y', z', x'', y'', z'') from a law's jets (x, x', x'', y, ...):
    (9, N) -> (9, N), or a sequence of nine (CasADi's entries) -> nine."""
    if isinstance(jets, np.ndarray):
        return jets[list(JET_TO_U)]
    return [jets[i] for i in JET_TO_U]


# ---- the moments of the internal bodies (the moments family, derive/system.py) ------------
# The carrier sees its points and rotors only through these sums, in body axes about O
# (rho_j = OP_j, m_j the points' masses; a_k, I_k, psi_k a rotor's unit axis, axial moment
# and angle relative to the body; a rotor's mass and locked inertia are part of [body]):
#
#   s      = sum m_j rho_j                                   first moment, OC = s/(M + m)
#   s', s''                                                  its rates (relative to the body)
#   Theta  = sum m_j (|rho_j|^2 E - rho_j rho_j^T)           the points' inertia about O
#   Theta'                                                   its rate
#   h      = sum m_j rho_j x rho_j' + sum I_k psi_k' a_k     internal angular momentum
#   h'     = sum m_j rho_j x rho_j'' + sum I_k psi_k'' a_k   its rate
#
# 27 numbers, the input ``u`` of every ``moments_*`` function (derive.models_moments); the
# 28th, m = sum m_j, is constant and sits in ``p = (M, m, J_x, J_y, J_z, g)`` as the one
# point's mass does (derive.abi's parameter ``m``).  Theta and Theta' are symmetric: their
# upper triangle row by row (xx, xy, xz, yy, yz, zz).  Each body's share is a function of its
# own law (``point_moments``, ``rotor_moments``); the sum over the bodies is the moments.
# For one point of mass m: s = m OP, Theta = m (|OP|^2 E - OP OP^T), h = m OP x OP'.
_XYZ = ("x", "y", "z")
_UPPER = ("xx", "xy", "xz", "yy", "yz", "zz")
MOMENTS_LABELS = (*(f"s_{c}" for c in _XYZ), *(f"s_{c}'" for c in _XYZ),
                  *(f"s_{c}''" for c in _XYZ),
                  *(f"Theta_{ij}" for ij in _UPPER), *(f"Theta_{ij}'" for ij in _UPPER),
                  *(f"h_{c}" for c in _XYZ), *(f"h_{c}'" for c in _XYZ))


def _run(fmt: str, keys) -> tuple:
    return tuple(fmt.format(k) for k in keys)


MOMENTS = Layout("moments", MOMENTS_LABELS,
                 {"s": _run("s_{}", _XYZ), "s_rate": _run("s_{}'", _XYZ),
                  "s_acc": _run("s_{}''", _XYZ),
                  "theta": _run("Theta_{}", _UPPER), "theta_rate": _run("Theta_{}'", _UPPER),
                  "h": _run("h_{}", _XYZ), "h_rate": _run("h_{}'", _XYZ),
                  # what a rotor adds (rotor_moments' output): h and h', contiguous
                  "spin": (*_run("h_{}", _XYZ), *_run("h_{}'", _XYZ))},
                 {})
# (i, j) of each entry of a symmetric part's upper triangle
UPPER_INDEX = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
# a point's input to point_moments: its mass, and its jet in the order of u above (U_LABELS)
POINT_JET_LABELS = U_LABELS
# a rotor's inputs to rotor_moments: its unit axis (body axes), axial moment, and the rates
# of its angle psi (the angle itself does not enter: the rotor is symmetric about its axis)
ROTOR_AXIS_LABELS = ("a_x", "a_y", "a_z")
ROTOR_RATE_LABELS = ("psi'", "psi''")
# a rotor's law has one output, psi(t); its jets are (psi, psi', psi'')
ROTOR_JET_LABELS = ("psi", "psi'", "psi''")


# ---- the law of several internal bodies (derive.scene.law.bodies, crt_law.h) ------------
# u of a law of n_points points and n_rotors rotors: each point's u as above (U_LABELS),
# then each rotor's angle relative to the body and its two derivatives (ROTOR_JET_LABELS)


def law_width(n_points: int, n_rotors: int) -> int:
    """The numbers of a law's u: 9 per point, 3 per rotor (crt_law_width)."""
    return 9 * n_points + 3 * n_rotors


def point_slice(j: int) -> slice:
    """Point j's (x, y, z, x', y', z', x'', y'', z'') in u."""
    return slice(9 * j, 9 * j + 9)


def rotor_slice(n_points: int, r: int) -> slice:
    """Rotor r's (psi, psi', psi'') in u."""
    return slice(9 * n_points + 3 * r, 9 * n_points + 3 * r + 3)
