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


# ======================================================================================
# Section 2
# ======================================================================================
# (2.1): y z'' - z y'' = 0 (x, y, z)
E2_1 = sp.Matrix(cyclic(y * zdd - z * ydd, XYZ))

# (2.2): x = x0 + x0' t (x, y, z)
x0, y0, z0 = sp.symbols("x_0 y_0 z_0", real=True)
x0d, y0d, z0d = sp.symbols("x_0' y_0' z_0'", real=True)
E2_2 = sp.Matrix([x0 + x0d * t, y0 + y0d * t, z0 + z0d * t])

# (2.3): y z' - z y' = c_x (x, y, z)
c_x, c_y, c_z = sp.symbols("c_x c_y c_z", real=True)
E2_3 = sp.Matrix(cyclic(y * zd - z * yd, XYZ))
E2_3_C = sp.Matrix([c_x, c_y, c_z])

# (2.4): K_x = [J_x + mu (y^2 + z^2)] omega_x - mu x y omega_y - mu x z omega_z (x, y, z)
E2_4 = sp.Matrix(cyclic((J_x + mu * (y**2 + z**2)) * omega_x - mu * x * y * omega_y
                        - mu * x * z * omega_z, XYZ))

# (2.5): V = K_x^2 + K_y^2 + K_z^2
E2_5 = sum((k**2 for k in E2_4), sp.Integer(0))

# ======================================================================================
# Section 3: J_x = J_y, x = y = 0, z = z(t)
# ======================================================================================
z_t = sp.Function("z", real=True)(t)
wx_t, wy_t, wz_t = (sp.Function(f"omega_{c}", real=True)(t) for c in "xyz")

# (3.1)
E3_1 = sp.Matrix([(J_x + mu * z**2) * omega_x, (J_x + mu * z**2) * omega_y, J_z * omega_z])

# (3.2)-(3.4), with d/dt taken on time functions
E3_2 = (sp.Derivative((J_x + mu * z_t**2) * wx_t, t).doit()
        + (J_z - J_x - mu * z_t**2) * wy_t * wz_t)
E3_3 = (sp.Derivative((J_x + mu * z_t**2) * wy_t, t).doit()
        - (J_z - J_x - mu * z_t**2) * wz_t * wx_t)
E3_4 = sp.Derivative(J_z * wz_t, t).doit()

# (3.5)
E3_5 = (J_x + mu * z**2)**2 * (omega_x**2 + omega_y**2) + J_z**2 * omega_z**2

# (3.6): omega_z = omega_z^0 = const
omega_z0 = sp.Symbol("omega_z0", real=True)

# (3.7), (3.8): alpha, the direction cosines of a fixed axis u in body axes
alpha_x, alpha_y, alpha_z = sp.symbols("alpha_x alpha_y alpha_z", real=True)
E3_7 = alpha_x**2 + alpha_y**2 + alpha_z**2
E3_8 = (J_x + mu * z**2) * (omega_x * alpha_x + omega_y * alpha_y) + J_z * omega_z * alpha_z

# the stationary rotation of C3.1
C3_1_OMEGA = sp.Matrix([0, 0, omega_z0])
C3_1_ALPHA = sp.Matrix([0, 0, 1])

# perturbations and the integrals V1..V4 as printed before (3.9)
xi = sp.symbols("xi_1:7", real=True)
K_sym = sp.Symbol("K", positive=True)
E3_9_V1 = (J_x + mu * z**2)**2 * (xi[0]**2 + xi[1]**2)
E3_9_V2 = xi[2]
E3_9_V3 = 2 * xi[5] + xi[3]**2 + xi[4]**2 + xi[5]**2
E3_9_V4 = (J_x + mu * z**2) * (xi[0] * xi[3] + xi[1] * xi[4]) + J_z * (omega_z0 + xi[2]) * xi[5]
# (3.10): xi_6 = -1/2 (xi_4^2 + xi_5^2) + ...
E3_10_XI6 = -sp.Rational(1, 2) * (xi[3]**2 + xi[4]**2)
# V4 on V1 = V2 = V3 = 0, as printed: -1/2 omega_z0 (xi_4^2 + xi_5^2) + ...
E3_9_V4_RESTRICTED_AS_PRINTED = -sp.Rational(1, 2) * omega_z0 * (xi[3]**2 + xi[4]**2)

# (3.11)-(3.14): Euler angles psi, theta, phi relative to axes with OZ~ along K
theta0 = sp.Symbol("theta_0", real=True)
psi_t, phi_t = sp.Function("psi", real=True)(t), sp.Function("phi", real=True)(t)
E3_11_COS = J_z * omega_z0 / K_sym
E3_12 = sp.Matrix([sp.Derivative(psi_t, t) * sp.sin(theta0) * sp.sin(phi_t),
                   sp.Derivative(psi_t, t) * sp.sin(theta0) * sp.cos(phi_t),
                   sp.Derivative(psi_t, t) * sp.cos(theta0) + sp.Derivative(phi_t, t)])
E3_13 = sp.Matrix([K_sym * sp.sin(theta0) * sp.sin(phi_t),
                   K_sym * sp.sin(theta0) * sp.cos(phi_t)])     # = (J_x + mu z^2) omega_{x,y}
E3_14_PSI_DOT = K_sym / (J_x + mu * z**2)
E3_14_PHI_DOT = omega_z0 * (1 - J_z / (J_x + mu * z**2))

# ======================================================================================
# Section 4
# ======================================================================================
# (4.1): [J_z + mu (x^2 + y^2)] omega_z' + mu [x y'' - y x'' + 2 (x x' + y y') omega_z] = 0
E4_1 = ((J_z + mu * (x**2 + y**2)) * omega_zd
        + mu * (x * ydd - y * xdd + 2 * (x * xd + y * yd) * omega_z))
# (4.2)
E4_2 = (J_z + mu * (x**2 + y**2)) * omega_z + mu * (x * yd - y * xd)
# (4.3): omega_x = 0, omega_y = 0, omega_z = omega
omega_s = sp.Symbol("omega", real=True)
E4_3 = sp.Matrix([0, 0, omega_s])
# (4.4)-(4.6)
E4_4 = z * y * omega_s**2 + y * zdd - z * ydd - 2 * xd * z * omega_s
E4_5 = -x * z * omega_s**2 + z * xdd - x * zdd - 2 * yd * z * omega_s
E4_6 = x * ydd - y * xdd + 2 * (x * xd + y * yd) * omega_s
# (4.7): x = x0, y = y0, z'' + omega^2 z = 0
E4_7_XY = (x0, y0)
E4_7_ZDD = sp.solve(sp.Eq(zdd + omega_s**2 * z, 0), zdd)[0]
# (4.8): x = R cos(omega t/2), y = -R sin(omega t/2), z'' + omega^2 z/4 = 0
R_cyl = sp.Symbol("R", positive=True)
E4_8_XY = (R_cyl * sp.cos(omega_s * t / 2), -R_cyl * sp.sin(omega_s * t / 2))
E4_8_ZDD = sp.solve(sp.Eq(zdd + omega_s**2 * z / 4, 0), zdd)[0]
