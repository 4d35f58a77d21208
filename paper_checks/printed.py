"""The paper's printed formulas, transcribed as printed (section 1).

"(x, y, z)" after a formula means the other two follow by cyclic permutation of those
symbols; :func:`cyclic` does that, so each formula is typed once, as in the paper.
Vector operations use SymPy's own ``Matrix.cross``/``Matrix.dot``, not the
derivation's helpers.
"""
from __future__ import annotations

import sympy as sp

from derive.notation import (I, J_x, J_y, J_z, M, W, X_C, X_Cdd, Y_C, Y_Cdd, Z_C, Z_Cd,
                             Z_Cdd, a, e, g, m, mu, omega_x, omega_xd, omega_y, omega_yd,
                             omega_z, omega_zd, t, x, x_s, xd, xdd, y, y_s, yd, ydd, z,
                             z_s, zd, zdd)

XYZ = [(x, y, z), (xd, yd, zd), (xdd, ydd, zdd), (omega_x, omega_y, omega_z),
       (omega_xd, omega_yd, omega_zd), (J_x, J_y, J_z)]


def cyclic(expr, cycles) -> list:
    """``[expr, expr with each cycle advanced once, ... twice]``."""
    forward = {}
    for cyc in cycles:
        for k in range(3):
            forward[cyc[k]] = cyc[(k + 1) % 3]
    out = [expr]
    for _ in range(2):
        out.append(out[-1].xreplace(forward))
    return out


OP = sp.Matrix([x, y, z])
V_r = sp.Matrix([xd, yd, zd])
omega = sp.Matrix([omega_x, omega_y, omega_z])
n = sp.Matrix([a[2, 0], a[2, 1], a[2, 2]])

# (1.1): dQ/dt = -(m + M) g n ;  dK/dt = 0   (in fixed axes n = (0, 0, 1))
E1_1_FORCE = -(m + M) * g * sp.Matrix([0, 0, 1])

# (1.2)
E1_2 = sp.Matrix([0, 0, -g])              # (X_C'', Y_C'', Z_C'')
E1_2_LHS = (X_Cdd, Y_Cdd, Z_Cdd)

# (1.3): dK~/dt + omega x K = 0, K with body components K_x(t), K_y(t), K_z(t)
K_t = sp.Matrix([sp.Function(f"K_{c}", real=True)(t) for c in "xyz"])
omega_t = sp.Matrix([sp.Function(f"omega_{c}", real=True)(t) for c in "xyz"])
E1_3 = K_t.diff(t) + omega_t.cross(K_t)

# (1.4) with mu = mM/(m + M);  (1.5)
MU = m * M / (m + M)
E1_5 = sp.Matrix([[J_x + mu * (y**2 + z**2), -mu * x * y, -mu * x * z],
                  [-mu * x * y, J_y + mu * (z**2 + x**2), -mu * y * z],
                  [-mu * x * z, -mu * y * z, J_z + mu * (x**2 + y**2)]])
E1_4 = E1_5 * omega + mu * OP.cross(V_r)

# (1.6)
E1_6 = sp.Matrix(cyclic(
    (J_x + mu * (y**2 + z**2)) * omega_x - mu * x * y * omega_y - mu * x * z * omega_z
    + mu * (y * zd - z * yd), XYZ))

# (1.7)
E1_7 = sp.Matrix(cyclic(
    (J_x + mu * (y**2 + z**2)) * omega_xd - mu * x * y * omega_yd - mu * x * z * omega_zd
    + (J_z - J_y) * omega_y * omega_z
    + mu * ((x * omega_x + y * omega_y + z * omega_z) * (y * omega_z - z * omega_y)
            + 2 * (y * yd + z * zd) * omega_x
            - 2 * xd * (y * omega_y + z * omega_z)
            + y * zdd - z * ydd), XYZ))

# (1.8): a_i1' = omega_z a_i2 - omega_y a_i3   (1, 2, 3; x, y, z),  i = 1, 2, 3
E1_8 = sp.Matrix(3, 3, lambda i, j: cyclic(
    omega_z * a[i, 1] - omega_y * a[i, 2],
    [(a[i, 0], a[i, 1], a[i, 2]), (omega_x, omega_y, omega_z)])[j])

# (1.8a): O_aO = O_aC - A m/(m + M) OP
E1_8A = sp.Matrix([X_C, Y_C, Z_C]) - a * (m / (m + M)) * OP

# (1.9)
E1_9 = sum((k**2 for k in E1_6), sp.Integer(0))

# (1.10): d_x = (y_* - m/(m+M) y) a33 - (z_* - m/(m+M) z) a32   (x, y, z; a31, a32, a33)
E1_10_D = sp.Matrix(cyclic(
    (y_s - m / (m + M) * y) * a[2, 2] - (z_s - m / (m + M) * z) * a[2, 1],
    [(x_s, y_s, z_s), (x, y, z), (a[2, 0], a[2, 1], a[2, 2])]))

# (1.11): X_C'+ = X_C'-,  Y_C'+ = Y_C'-,  Z_C'+ = Z_C'- + I/(m + M)
E1_11_JUMP = sp.Matrix([0, 0, I / (m + M)])

# (1.12) as printed: omega-dot+ = omega-dot- + I J^-1 d  (the dots are a typo)
OMEGA_DOT = sp.Matrix([omega_xd, omega_yd, omega_zd])
E1_12_AS_PRINTED = (OMEGA_DOT, OMEGA_DOT + I * W)      # (lhs, rhs); W stands for J^-1 d

# (1.13)
def E1_13(vn_minus):
    return -e * vn_minus


# (1.14): v_n = Z_C' - m/(m+M) (V_r, n) + (omega, d)
E1_14 = Z_Cd - m / (m + M) * V_r.dot(n) + omega.dot(E1_10_D)

# (1.16): k = 1/(m + M) + (J^-1 d, d)
E1_16 = 1 / (m + M) + W.dot(E1_10_D)

# (1.15): I = -(1 + e)/k [Z_C'- - m/(m+M)(V_r, n) + (omega-, d)]
E1_15 = -(1 + e) / E1_16 * (Z_Cd - m / (m + M) * V_r.dot(n) + omega.dot(E1_10_D))
