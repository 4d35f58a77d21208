"""A capsule robot's fastest periodic crawl, in closed form: a body of mass M on a rough
plane (Coulomb, mu) driven by an internal point of mass m moving along a line (the x
axis) relative to it, the law periodic, its displacement bounded by L (range) and its
velocity by U.  The acceptance check of the planner's ``travel`` goal and of the base
model's runtime (issue 33; derived here: the search tool did not find the closed forms of
Chernousko's papers, J. Appl. Math. Mech. 66 (2002), Meccanica 2016, so their optimum is
not quoted).

**The class of laws.**  With nu = m/(M + m) and N = (M + m) g, the body stays at rest while
``m |x''| <= mu N``, i.e. ``|x''| <= a_s = mu g/nu``; a jump of the point's relative
velocity by ``-w`` throws the body forward at ``nu w`` (momentum is kept: friction gives no
impulse), and it then slides to rest in ``tau = nu w/(mu g)``, covering ``D = nu^2
w^2/(2 mu g)``, if the point moves at constant velocity meanwhile (any acceleration adds
to the braking).  So a period is: a jump from ``u1`` to ``-u2`` (``w = u1 + u2``); the slide
at ``x' = -u2`` (tau); a rest at ``-u2`` (t5 >= 0); a ramp back to ``u1`` at ``kappa a_s``
(``tau/kappa``, the body at rest as long as kappa <= 1); a rest at ``u1`` (t4 >= 0).  With
``r = u2/w`` the period closes (x periodic) for

* ``r = r_k = 1/(2 (1 + kappa))`` with t4 = t5 = 0: ``V = nu w kappa/(2 (1 + kappa))``,
  ``L = (nu w^2/(mu g)) (r + r^2/(2 kappa))``;
* ``r < r_k`` with t5 = tau ((1 - 2r)/(2 kappa r) - 1): ``V = nu w kappa r``, ``L = (nu
  w^2/(2 kappa mu g)) (1 - r)^2``;
* ``r > r_k`` with t4 = tau (r - (1 - 2r)/(2 kappa))/(1 - r): ``V = nu w kappa (1 -
  r)/(2 kappa + 1)``, ``L`` as for r_k.

At a given range L, V grows with r below r_k and falls above it, and at r_k it is
``V(kappa) = kappa/(2 kappa + 1) sqrt(2 kappa nu mu g L)``, growing with kappa.  Under a
velocity bound (``u1 = (1 - r) w <= U``) ``V = nu kappa U/(2 kappa + 1)``.  The best of the
class is at the sticking limit kappa = 1, u1 = 3 u2:

    V* = min( sqrt(2 nu mu g L)/3,  nu U/3 ).

(Kappa = 1 holds the rest on the edge of the friction cone, which an event-driven run
cannot resolve; the checks run kappa < 1.)

**A bounded acceleration** (``|x''| <= A``, the planner's ``travel`` goal).  The jump
becomes a throw at ``x'' = -A`` for ``w/A``; the rest breaks at once if ``A`` exceeds the
static limit ``mu_s g/nu``, and the body gains ``V1 = nu w (1 - beta)``, ``beta = a_k/A``
with ``a_k = mu g/nu``, then slides to rest at ``x' = -u2``.  The throw and the slide
cover ``D = nu w^2 (1 - beta)/(2 a_k)`` in ``w/a_k`` together (the throw's time is the
slide's lost time), so in units of ``w/a_k`` the period is ``1 + 1/kappa + t4 + t5``, the
ramp back at ``kappa mu_s g/nu`` (kappa here counts in ``a_k``: the sticking limit is
``kappa = mu_s/mu``).  The period closes with t4 = t5 = 0 at ``r = (kappa beta + 1)/(2
(kappa + 1))``, where

    V = nu w (1 - beta) kappa/(2 (kappa + 1)),
    L = (w^2/a_k) (r (1 - beta) + r^2 (beta + 1/kappa)/2),   u1 = (1 - r) w <= U;

at a given range this r is the best of the class and V grows with kappa, as for the jump
(a scan of r, kappa and beta checks both: tests/test_travel.py).  ``beta -> 0`` gives the
formulas above.

**The sawtooth: the return overlapping the slide** (what the planner's search found
faster, started from the class above).  The point's velocity is a sawtooth: the throw at
``-A`` from ``w/2`` to ``-w/2``, then at once the return at ``a = kappa a_k`` back to
``w/2``, no rests.  The body slides forward from the throw, braked by friction and by the
return together (``nu (a_k + a)``), and sticks until the next throw (the slide,
``w (1 - beta)/(a_k + a)``, ends within the return, ``w/a``).  In units ``a_k = 1``:

    D = nu w^2 (1 - beta) (beta + (1 - beta)/(1 + kappa))/2,   period w (beta + 1/kappa),
    L = w^2 (beta + 1/kappa)/8 (the negative lobe of a zero-mean triangle wave),
    u1 = u2 = w/2 <= U,

so ``V = nu w (1 - beta) (beta + (1 - beta)/(1 + kappa))/(2 (beta + 1/kappa))``, growing
with kappa (the scan again): at the sticking limit, for the jump (beta = 0, mu_s = mu),
``V = min(sqrt(nu mu g L/2), nu U/2)``, 1.5 times V* above.  Braking the slide by the
return costs distance, but the return no longer waits for the rest, and a zero-mean
sawtooth needs less stroke than the class above for the same velocity jump.

**The brake** (what the planner's search found faster still, with a phase of its own):
the throw at ``-A`` for t1, a coast for t2 while the body slides, a brake at ``+A`` for
``tb`` ending just as the body stops (``nu (A - a_k) t1 = nu a_k t2 + nu (A + a_k) tb``),
then the return at the static limit with the body at rest, for ``A (t1 - tb)/a_st``.  The
brake cuts the slow tail of the slide and does part of the return while the body still
slides (the static limit does not bind then).  The integral of x' over the period is
linear in u1, which the periodic position fixes; :func:`brake_bounded` scans the coast's
share ``rho = t2/t_stop`` (1: no brake, the rest class with t4 = t5 = 0).  None of the
three classes is proved the best of all laws.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Crawl:
    """One law of the class and what it does: velocities ``u1``, ``u2``, the phases
    ``tau`` (slide), ``t5``, ``ramp``, ``t4``, the period, the range and the mean speed."""
    u1: float
    u2: float
    a: float                 # the ramp's acceleration
    tau: float
    t5: float
    ramp: float
    t4: float
    period: float
    range: float
    speed: float
    nu: float

    def law(self, t: float) -> tuple[float, float, float]:
        """x, x', x'' relative to the body at t (periodic; just after the jump at t = 0,
        x = 0 at the jump)."""
        s = t % self.period
        x, v = 0.0, -self.u2
        if s < self.tau + self.t5:
            return x + v * s, v, 0.0
        x += v * (self.tau + self.t5)
        s -= self.tau + self.t5
        if s < self.ramp:
            return x + v * s + self.a * s * s / 2, v + self.a * s, self.a
        x += v * self.ramp + self.a * self.ramp ** 2 / 2
        s -= self.ramp
        return x + self.u1 * s, self.u1, 0.0

    @property
    def phases(self) -> tuple:
        """The times in a period where x'' changes."""
        return (self.tau + self.t5, self.tau + self.t5 + self.ramp)


def crawl(M: float, m: float, mu: float, L: float, r: float, kappa: float = 1.0,
          g: float = 9.81) -> Crawl:
    """The law of the class with the share r = u2/w and ramp kappa a_s over the range L."""
    nu = m / (M + m)
    rk = 1.0 / (2.0 * (1.0 + kappa))
    if r <= rk:
        w = math.sqrt(2 * kappa * mu * g * L / nu) / (1 - r)
    else:
        w = math.sqrt(mu * g * L / (nu * (r + r * r / (2 * kappa))))
    u2, u1 = r * w, (1 - r) * w
    tau = nu * w / (mu * g)
    t5 = tau * ((1 - 2 * r) / (2 * kappa * r) - 1) if r < rk else 0.0
    t4 = tau * (r - (1 - 2 * r) / (2 * kappa)) / (1 - r) if r > rk else 0.0
    ramp = tau / kappa
    period = tau + t5 + ramp + t4
    D = nu * nu * w * w / (2 * mu * g)
    return Crawl(u1=u1, u2=u2, a=kappa * mu * g / nu, tau=tau, t5=t5, ramp=ramp, t4=t4,
                 period=period, range=L, speed=D / period, nu=nu)


def optimum(M: float, m: float, mu: float, L: float | None = None, U: float | None = None,
            g: float = 9.81) -> float:
    """V* of the class (kappa = 1, u1 = 3 u2) under the bounds given."""
    nu = m / (M + m)
    out = math.inf
    if L is not None:
        out = min(out, math.sqrt(2 * nu * mu * g * L) / 3)
    if U is not None:
        out = min(out, nu * U / 3)
    return out


def _throw(M: float, m: float, mu: float, A: float | None, mu_s: float | None, g: float,
           kappa: float | None) -> tuple[float, float, float, float] | None:
    """The bounded classes' constants: (nu, a_k, beta = a_k/A (0 for the jump), kappa
    (default the sticking limit mu_s/mu)), or None when ``A`` cannot break the rest."""
    nu = m / (M + m)
    mu_s = mu if mu_s is None else mu_s
    a_k = mu * g / nu
    if A is not None and A <= mu_s * g / nu:
        return None
    return nu, a_k, 0.0 if A is None else a_k / A, mu_s / mu if kappa is None else kappa


def optimum_bounded(M: float, m: float, mu: float, L: float | None = None,
                    U: float | None = None, A: float | None = None,
                    mu_s: float | None = None, g: float = 9.81,
                    kappa: float | None = None) -> float:
    """V* of the class with the acceleration bounded by ``A`` (None: unbounded, the
    jump) and the static coefficient ``mu_s`` (default mu), at the sticking limit (or
    with the return at ``kappa a_k``, kappa <= mu_s/mu); 0 when ``A`` cannot break the
    rest."""
    throw = _throw(M, m, mu, A, mu_s, g, kappa)
    if throw is None:
        return 0.0
    nu, a_k, beta, kappa = throw
    r = (kappa * beta + 1) / (2 * (kappa + 1))
    w = math.inf
    if L is not None:
        w = min(w, math.sqrt(L * a_k / (r * (1 - beta) + r * r * (beta + 1 / kappa) / 2)))
    if U is not None:
        w = min(w, U / (1 - r))
    return nu * w * (1 - beta) * kappa / (2 * (kappa + 1))


def sawtooth_bounded(M: float, m: float, mu: float, L: float | None = None,
                     U: float | None = None, A: float | None = None,
                     mu_s: float | None = None, g: float = 9.81,
                     kappa: float | None = None) -> float:
    """V of the sawtooth (the return at ``kappa a_k`` at once after the throw, default the
    sticking limit mu_s/mu) under the bounds given; 0 when ``A`` cannot break the rest."""
    throw = _throw(M, m, mu, A, mu_s, g, kappa)
    if throw is None:
        return 0.0
    nu, a_k, beta, kappa = throw
    w = math.inf
    if L is not None:
        w = min(w, math.sqrt(8 * L * a_k / (beta + 1 / kappa)))
    if U is not None:
        w = min(w, 2 * U)
    return nu * w * (1 - beta) * (beta + (1 - beta) / (1 + kappa)) / (2 * (beta + 1 / kappa))


def brake_bounded(M: float, m: float, mu: float, A: float, L: float | None = None,
                  U: float | None = None, mu_s: float | None = None, g: float = 9.81,
                  samples: int = 2001) -> tuple[float, float]:
    """The brake class (the planner's find): the throw at ``-A`` for t1, a coast for t2
    while the body slides, a brake at ``+A`` for tb ending as the body stops, the return
    at the static limit ``mu_s g/nu`` with the body at rest.  Returns (V, rho): the best
    mean speed over the coast's share ``rho = t2/t_stop`` (t_stop: the coast to the
    body's own stop; rho = 1 is the rest class) on a grid of ``samples``, each shape
    scaled in time (the accelerations kept) until the stroke or the velocity bound is
    met.  In units t1 = 1: V1 = nu (A - a_k), tb = (V1 - nu a_k t2)/(nu (A + a_k)), the
    return lasts A (t1 - tb)/a_st, and the periodic position fixes u1 (the integral of
    x' is linear in it)."""
    nu = m / (M + m)
    mu_s = mu if mu_s is None else mu_s
    a_k, a = mu * g / nu, mu_s * g / nu
    if A <= a:
        return 0.0, 0.0
    best = (0.0, 0.0)
    for rho in [k / (samples - 1) for k in range(samples)]:
        t1 = 1.0
        V1 = nu * (A - a_k) * t1
        t2 = rho * V1 / (nu * a_k)
        V2 = V1 - nu * a_k * t2
        tb = V2 / (nu * (A + a_k))
        tr = A * (t1 - tb) / a
        P = t1 + t2 + tb + tr
        const = (-A * t1 * t1 / 2 - A * t1 * t2 - A * t1 * tb + A * tb * tb / 2
                 - A * (t1 - tb) * tr + a * tr * tr / 2)
        u1 = -const / P
        # x' at the breakpoints, linear between: the stroke from its zeros
        ts = [0.0, t1, t1 + t2, t1 + t2 + tb, P]
        vs = [u1, u1 - A * t1, u1 - A * t1, u1 - A * t1 + A * tb, u1]
        xs, x = [0.0], 0.0
        for i in range(4):
            h, v0, v1 = ts[i + 1] - ts[i], vs[i], vs[i + 1]
            if v0 * v1 < 0:                              # a turning point inside
                s0 = h * v0 / (v0 - v1)
                xs.append(x + v0 * s0 / 2)
            x += h * (v0 + v1) / 2
            xs.append(x)
        stroke = max(xs) - min(xs)
        D = V1 * t1 / 2 + (V1 + V2) * t2 / 2 + V2 * tb / 2
        c = math.inf
        if L is not None:
            c = math.sqrt(L / stroke)
        if U is not None:
            c = min(c, U / max(abs(v) for v in vs))
        V = c * D / P
        if V > best[0]:
            best = (V, rho)
    return best
