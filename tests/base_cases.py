"""Helpers of the base model's tests: random internal motions (points on harmonic laws,
rotors) and their moments about O summed from the definitions (the contract of issue 32:
s, s', s'', Theta, Theta' as upper triangles, h, h')."""
import math

import numpy as np

from derive import base_reference as br

UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def harmonic(A, W, P, c=(0.0, 0.0, 0.0)):
    """rho = c + A sin(W t + P), componentwise, with its rates."""
    A, W, P, c = (np.asarray(x, dtype=float) for x in (A, W, P, c))

    def law(t):
        ph = W * t + P
        return c + A * np.sin(ph), A * W * np.cos(ph), -A * W * W * np.sin(ph)
    return law


def spinning(amplitude, rate):
    """psi' = amplitude sin(rate t), with psi''."""
    return lambda t: (amplitude * math.sin(rate * t), amplitude * rate * math.cos(rate * t))


def random_system(rng, face, points=2, rotors=1, pressure="uniform", mu=0.4):
    pts = tuple(br.Point(rng.uniform(0.1, 0.5),
                         harmonic(rng.uniform(-0.05, 0.05, 3), rng.uniform(1, 6, 3),
                                  rng.uniform(0, 6, 3), rng.uniform(-0.02, 0.02, 3)))
                for _ in range(points))
    rots = []
    for _ in range(rotors):
        axis = rng.normal(size=3)
        rots.append(br.Rotor(rng.uniform(0.001, 0.01), tuple(axis / np.linalg.norm(axis)),
                             spinning(rng.uniform(1, 20), rng.uniform(1, 5))))
    return br.System(M=rng.uniform(0.5, 2.0), J=tuple(rng.uniform(0.01, 0.05, 3)), face=face,
                     points=pts, rotors=tuple(rots), mu=mu, pressure=pressure)


def moments(system, t) -> np.ndarray:
    """The 27 moments about O of the system's points and rotors at t."""
    u = np.zeros(27)
    for p in system.points:
        r, rd, rdd = (np.asarray(x, dtype=float) for x in p.law(t))
        m = p.mass
        u[0:3] += m * r
        u[3:6] += m * rd
        u[6:9] += m * rdd
        theta = m * (r @ r * np.eye(3) - np.outer(r, r))
        theta_d = m * (2 * (r @ rd) * np.eye(3) - np.outer(rd, r) - np.outer(r, rd))
        u[9:15] += [theta[i, j] for i, j in UPPER]
        u[15:21] += [theta_d[i, j] for i, j in UPPER]
        u[21:24] += m * np.cross(r, rd)
        u[24:27] += m * np.cross(r, rdd)
    for r in system.rotors:
        pd, pdd = r.law(t)
        a = np.asarray(r.axis, dtype=float)
        u[21:24] += r.inertia * pd * a
        u[24:27] += r.inertia * pdd * a
    return u


def parameters(system) -> list:
    return [system.M, sum(p.mass for p in system.points), *system.J, system.g]
