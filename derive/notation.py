"""The paper's notation as SymPy symbols, and the vector algebra used by the derivation.

Two families of symbols live here:

* time functions (``x(t)``, ``omega_x(t)``, ``a_ij(t)``, ...) that the derivation
  differentiates, and
* plain symbols (``x``, ``x'``, ``x''``, ``omega_x``, ``omega_x'``, ``a11``, ...) that the
  derived equations are stated in once the differentiation is done (:func:`freeze`).

Nothing in this module is an equation of the paper: only names, the definition of
``mu`` and of the centre-of-mass fraction, and vector helpers.
"""
from __future__ import annotations

import sympy as sp

t = sp.Symbol("t", real=True)

# ---- masses, inertia, field, restitution --------------------------------------------
M = sp.Symbol("M", positive=True)          # carrier mass
m = sp.Symbol("m", positive=True)          # point mass
mu = sp.Symbol("mu", positive=True)        # reduced mass, defined by MU_DEFINITION
nu = sp.Symbol("nu", positive=True)        # mass fraction m/(m+M), by MASS_FRACTION
J_x, J_y, J_z = sp.symbols("J_x J_y J_z", positive=True)   # principal central inertia
g = sp.Symbol("g", positive=True)
e = sp.Symbol("e", nonnegative=True)       # restitution coefficient
I = sp.Symbol("I", real=True)              # impact impulse (magnitude along n)
N = sp.Symbol("N", real=True)              # normal reaction in persistent contact

MU_DEFINITION = m * M / (m + M)            # mu = mM/(m+M)
MASS_FRACTION = m / (m + M)                # OC = m/(m+M) OP

# ---- the point law as time functions, and its frozen values ------------------------
x_t, y_t, z_t = (sp.Function(n, real=True)(t) for n in ("x", "y", "z"))
x, y, z = sp.symbols("x y z", real=True)
xd, yd, zd = sp.symbols("x' y' z'", real=True)
xdd, ydd, zdd = sp.symbols("x'' y'' z''", real=True)

# ---- angular velocity (body axes) ---------------------------------------------------
omega_t = tuple(sp.Function(f"omega_{c}", real=True)(t) for c in "xyz")
omega_x, omega_y, omega_z = sp.symbols("omega_x omega_y omega_z", real=True)
omega_xd, omega_yd, omega_zd = sp.symbols("omega_x' omega_y' omega_z'", real=True)

# ---- direction cosines a_ij = cos(fixed axis i, body axis j) ------------------------
a_t = sp.Matrix(3, 3, lambda i, j: sp.Function(f"a{i + 1}{j + 1}", real=True)(t))
a = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"a{i + 1}{j + 1}", real=True))
ad = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"a{i + 1}{j + 1}'", real=True))

# ---- centre of mass C in fixed axes -------------------------------------------------
X_C_t, Y_C_t, Z_C_t = (sp.Function(n, real=True)(t) for n in ("X_C", "Y_C", "Z_C"))
X_C, Y_C, Z_C = sp.symbols("X_C Y_C Z_C", real=True)
X_Cd, Y_Cd, Z_Cd = sp.symbols("X_C' Y_C' Z_C'", real=True)
X_Cdd, Y_Cdd, Z_Cdd = sp.symbols("X_C'' Y_C'' Z_C''", real=True)

# ---- lowest point S of the carrier's surface, OS in body axes -----------------------
x_s, y_s, z_s = sp.symbols("x_* y_* z_*", real=True)
x_sd, y_sd, z_sd = sp.symbols("x_*' y_*' z_*'", real=True)   # its rate (persistent contact)

# ---- J^-1 d, an unknown defined by J w = d (never formed by inversion) --------------
w_x, w_y, w_z = sp.symbols("w_x w_y w_z", real=True)

# ---- the moments of the internal bodies about O, body axes (derive/moments.py) -----------
# s = sum m_j OP_j, Theta = sum m_j (|OP_j|^2 E - OP_j OP_j^T), h = sum m_j OP_j x OP_j' +
# sum I_k psi_k' a_k: time functions, and their frozen values and rates (the order of the
# moments vector is derive/layout.py's MOMENTS)
_UPPER = (("xx", 0, 0), ("xy", 0, 1), ("xz", 0, 2), ("yy", 1, 1), ("yz", 1, 2), ("zz", 2, 2))


def _symmetric(entry) -> sp.Matrix:
    """A symmetric 3x3 matrix from ``entry(name)`` of its upper triangle's names."""
    out = sp.zeros(3, 3)
    for name, i, j in _UPPER:
        out[i, j] = out[j, i] = entry(name)
    return out


s_m_t = sp.Matrix([sp.Function(f"s_{c}", real=True)(t) for c in "xyz"])
s_m = sp.Matrix(sp.symbols("s_x s_y s_z", real=True))
s_md = sp.Matrix(sp.symbols("s_x' s_y' s_z'", real=True))
s_mdd = sp.Matrix(sp.symbols("s_x'' s_y'' s_z''", real=True))
Theta_t = _symmetric(lambda ij: sp.Function(f"Theta_{ij}", real=True)(t))
Theta = _symmetric(lambda ij: sp.Symbol(f"Theta_{ij}", real=True))
Theta_d = _symmetric(lambda ij: sp.Symbol(f"Theta_{ij}'", real=True))
h_m_t = sp.Matrix([sp.Function(f"h_{c}", real=True)(t) for c in "xyz"])
h_m = sp.Matrix(sp.symbols("h_x h_y h_z", real=True))
h_md = sp.Matrix(sp.symbols("h_x' h_y' h_z'", real=True))


def upper(matrix: sp.Matrix) -> tuple:
    """The upper triangle of a symmetric 3x3 matrix, row by row (xx, xy, xz, yy, yz, zz)."""
    return tuple(matrix[i, j] for _, i, j in _UPPER)


# ---- vectors ------------------------------------------------------------------------
OP_t = sp.Matrix([x_t, y_t, z_t])
OP = sp.Matrix([x, y, z])
V_r = sp.Matrix([xd, yd, zd])              # velocity of P relative to the body
A_r = sp.Matrix([xdd, ydd, zdd])           # acceleration of P relative to the body
omega_vec_t = sp.Matrix(omega_t)
omega = sp.Matrix([omega_x, omega_y, omega_z])
omega_dot = sp.Matrix([omega_xd, omega_yd, omega_zd])
n = sp.Matrix([a[2, 0], a[2, 1], a[2, 2]])   # the vertical O_aZ_a in body axes
n_t = sp.Matrix([a_t[2, 0], a_t[2, 1], a_t[2, 2]])
OS = sp.Matrix([x_s, y_s, z_s])
OS_rate = sp.Matrix([x_sd, y_sd, z_sd])
W = sp.Matrix([w_x, w_y, w_z])
R_C = sp.Matrix([X_C, Y_C, Z_C])
V_C = sp.Matrix([X_Cd, Y_Cd, Z_Cd])
E_Z = sp.Matrix([0, 0, 1])                  # the upward vertical in fixed axes


def cross(u: sp.Matrix, v: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([u[1] * v[2] - u[2] * v[1],
                      u[2] * v[0] - u[0] * v[2],
                      u[0] * v[1] - u[1] * v[0]])


def dot(u: sp.Matrix, v: sp.Matrix) -> sp.Expr:
    return sum((u[i] * v[i] for i in range(len(u))), sp.Integer(0))


def skew(u: sp.Matrix) -> sp.Matrix:
    """The matrix of ``u x (.)``."""
    return sp.Matrix([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])


# ---- freezing: time functions and their derivatives -> plain symbols -----------------
def _freeze_table() -> dict:
    table = {}
    for f, s0, s1, s2 in ((x_t, x, xd, xdd), (y_t, y, yd, ydd), (z_t, z, zd, zdd)):
        table[sp.Derivative(f, (t, 2))] = s2
        table[sp.Derivative(f, t)] = s1
        table[f] = s0
    for f, s0, s1 in zip(omega_t, omega, omega_dot):
        table[sp.Derivative(f, t)] = s1
        table[f] = s0
    for i in range(3):
        for j in range(3):
            table[sp.Derivative(a_t[i, j], t)] = ad[i, j]
            table[a_t[i, j]] = a[i, j]
    for f, s0, s1, s2 in ((X_C_t, X_C, X_Cd, X_Cdd), (Y_C_t, Y_C, Y_Cd, Y_Cdd),
                          (Z_C_t, Z_C, Z_Cd, Z_Cdd)):
        table[sp.Derivative(f, (t, 2))] = s2
        table[sp.Derivative(f, t)] = s1
        table[f] = s0
    # the moments: s to its second rate, Theta and h to their first (what the derivation
    # needs; a higher rate stays unfrozen and is refused where it is used)
    for f, s0, s1, s2 in zip(s_m_t, s_m, s_md, s_mdd):
        table[sp.Derivative(f, (t, 2))] = s2
        table[sp.Derivative(f, t)] = s1
        table[f] = s0
    for f, s0, s1 in [*zip(upper(Theta_t), upper(Theta), upper(Theta_d)),
                      *zip(h_m_t, h_m, h_md)]:
        table[sp.Derivative(f, t)] = s1
        table[f] = s0
    return table


FREEZE = _freeze_table()


def freeze(expr):
    """Replace time functions and their derivatives by the plain symbols.

    ``xreplace`` matches whole subtrees top-down, so ``Derivative(x(t), t)`` becomes
    ``x'`` before its argument ``x(t)`` could become ``x``.
    """
    return expr.xreplace(FREEZE)


def thaw(expr):
    """Inverse of :func:`freeze` for the point law, omega and the direction cosines."""
    return expr.xreplace({v: k for k, v in FREEZE.items()})


# ---- names for printing in the paper's style ------------------------------------------
def _latex_names() -> dict:
    names = {mu: r"\mu", J_x: "J_x", J_y: "J_y", J_z: "J_z", I: "I", N: "N", e: "e"}
    for c, s0, s1, s2 in (("x", x, xd, xdd), ("y", y, yd, ydd), ("z", z, zd, zdd)):
        names[s0], names[s1], names[s2] = c, rf"\dot{{{c}}}", rf"\ddot{{{c}}}"
    for c, s0, s1 in zip("xyz", omega, omega_dot):
        names[s0], names[s1] = rf"\omega_{c}", rf"\dot{{\omega}}_{c}"
    for i in range(3):
        for j in range(3):
            names[a[i, j]] = f"a_{{{i + 1}{j + 1}}}"
            names[ad[i, j]] = rf"\dot{{a}}_{{{i + 1}{j + 1}}}"
    for c, s0, s1, s2 in (("X", X_C, X_Cd, X_Cdd), ("Y", Y_C, Y_Cd, Y_Cdd),
                          ("Z", Z_C, Z_Cd, Z_Cdd)):
        names[s0], names[s1], names[s2] = f"{c}_C", rf"\dot{{{c}}}_C", rf"\ddot{{{c}}}_C"
    for c, s0, s1 in zip("xyz", OS, OS_rate):
        names[s0], names[s1] = f"{c}_*", rf"\dot{{{c}}}_*"
    for c, s0 in zip("xyz", W):
        names[s0] = rf"(\mathbf{{J}}^{{-1}}\mathbf{{d}})_{c}"
    return names


LATEX_NAMES = _latex_names()


def to_paper_notation(expr: sp.Expr) -> sp.Expr:
    """Rewrite an expression polynomial in everything but ``M, m`` with ``mu``.

    Every coefficient (a rational function of ``M`` and ``m``) that is a rational
    multiple of ``mM/(m+M)`` becomes that multiple of the symbol ``mu``; a coefficient
    that is not is left as it is.  The result is expanded and grouped by ``mu``.
    """
    expr = sp.expand(expr)
    gens = sorted(expr.free_symbols - {M, m}, key=sp.default_sort_key)
    if not gens:
        ratio = sp.cancel(expr / MU_DEFINITION)
        return ratio * mu if not ratio.free_symbols & {M, m} else expr
    poly = sp.Poly(expr, *gens)
    out = sp.Integer(0)
    for monom, coeff in poly.terms():
        ratio = sp.cancel(coeff / MU_DEFINITION)
        if not ratio.free_symbols & {M, m}:
            coeff = ratio * mu
        term = coeff
        for gen, k in zip(gens, monom):
            term *= gen ** k
        out += term
    return sp.collect(out, mu)


def from_paper_notation(expr: sp.Expr) -> sp.Expr:
    """Replace the symbols ``mu`` and ``nu`` by their definitions in ``M`` and ``m``."""
    return expr.xreplace({mu: MU_DEFINITION, nu: MASS_FRACTION})
