"""``derive bench rough``: what a rough plane costs, against the smooth plane and against
a SciPy route with the same laws, measured in one run, targets marked PASS or FAIL.

Scenes: the rough built-in scene (the ball with its moving point, mu_f = 0.3: impacts
that slip in 3-D, stick inside the impact, accumulate into contact that sticks), the
spherical robot and the hopper of ``derive/scene/examples/`` (rolling; landing, hopping,
sliding and sticking).  For each:

* **cost against the smooth plane** (issue 25: at most 2x, the kernel and end to end):
  the same scene with ``friction = 0`` run by the general model (the smooth twin of the
  rough model: same state, same methods), and by the model ``derive.simulate`` would
  choose for it; the C run alone (crt_run through a Session), and ``derive.simulate``
  end to end with other initial numbers on every call;
* **work-precision against SciPy**: the runtime (methods lie and dop853) and
  :class:`ScipyRough` (``solve_ivp`` DOP853 on the NumPy evaluation of the same derived
  functions: the flight RHS, the Darboux-Keller impact of derive/darboux_keller.py with
  the scene's restitution law, sliding and sticking contact with the same transitions)
  at rtol 1e-6 to 1e-12; the error is the largest state difference on a common output
  grid against the runtime at 1e-13 (itself compared with SciPy at 1e-12).

The times are minima over repetitions after a warm-up.
"""
from __future__ import annotations

import copy

import numpy as np
from scipy.integrate import solve_ivp

from .. import layout
from ..scene import builtin_doc
from .routes import GRID_DT, Run, Runtime, _timed, errors, grid_of
from .timing import AT_MOST, SPREAD_NOTE, Spread, interleaved, judge, ratios

GOAL = 2.0                 # a rough run costs at most this many smooth runs
G = layout.GENERAL
TOLERANCES = (1e-6, 1e-8, 1e-10, 1e-12)


def rough_builtin() -> dict:
    doc = builtin_doc()
    doc["name"] = "rough built-in"
    doc["plane"]["friction"] = 0.3
    doc["run"]["duration"] = 3.0
    return doc


def example(name: str) -> dict:
    import tomllib
    from importlib import resources
    text = resources.files("derive.scene").joinpath(f"examples/{name}.toml").read_text()
    return tomllib.loads(text)


def robot_with_couples() -> dict:
    """The spherical robot with spin friction and rolling resistance (the contact solved
    as a wrench: crt_rough_modes.h, crt_rough_wrench)."""
    doc = example("spherical-robot")
    doc["name"] = "spherical-robot with couples"
    doc["plane"].update(spin_friction=0.005, rolling_resistance=0.002)
    return doc


def has_couples(doc: dict) -> bool:
    plane = doc.get("plane", {})
    return bool(plane.get("spin_friction") or plane.get("rolling_resistance"))


def scenes() -> list:
    return [rough_builtin(), example("spherical-robot"), example("hopper"),
            robot_with_couples()]


# ---- SciPy with the same laws -----------------------------------------------------------------
class ScipyRough:
    """The rough plane event by event in SciPy: the NumPy evaluation of the derived
    functions (derive.friction_models, derive.models), ``solve_ivp`` between events.

    * flight: ``general_flight_rhs``; a terminal event on the gap;
    * an impact (S approaching): derive/darboux_keller.py (SciPy's DOP853 in the normal
      impulse) with the scene's mu_f, e and restitution law; S then rests on the plane
      when its rebound rises less than 1e-9 of the body (accumulation);
    * sliding: ``general_sliding_rhs`` along the slip (fixed along the reference while a
      slip restarting from rest is below 1e-8 of the speeds); events N = 0 and the slip
      along the segment's starting direction reaching 0;
    * sticking: ``general_sticking_rhs``; the event |R_t| = mu_f R_Z (or R_Z = 0);
    * at a stopped slip: stick if the sticking reaction is inside the cone, else slide
      from rest along the runtime's direction (the same scan of sigma x a_t(sigma)).
    """

    def __init__(self, doc: dict, rtol: float, dt: float = GRID_DT, budget: int = 2000):
        from ..emit.numpy_backend import compile_spec, numpy_function
        from ..models import flight_rhs, gap, lowest_point, lowest_point_rate
        from ..runtime import choice
        from ..scene import parse_scene
        self.scene = s = parse_scene(doc)
        self.rtol, self.budget = rtol, budget
        self.label = "scipy DOP853 (rough)"
        self.rhs = compile_spec(flight_rhs("general"))
        self.gap_f = compile_spec(gap("general"))
        self.lp = compile_spec(lowest_point(s.shape))
        self.lpr = compile_spec(lowest_point_rate(s.shape))
        self.slide = numpy_function("general_sliding_rhs")
        self.stick = numpy_function("general_sticking_rhs")
        self.vel = numpy_function("general_contact_velocity")
        self.dl = numpy_function("general_delassus")
        self.axes = list(s.size)
        self.p = np.array(s.p)
        self.mu_f, self.e = s.friction, s.e
        self.grid = grid_of(s, dt)
        self.q0 = choice.start(s, "general").q0
        self.F = (s.M + s.m) * max(s.g, 1.0)
        self.L = choice.length_scale(s)
        self.log = []             # (t, what, mode) of each event, for a reader

    # -- the derived functions at (t, q)
    def u(self, t):
        return layout.u_of_jets(self.scene.law.jets(np.array([t]))[:, 0])

    def s_of(self, q):
        n = q[G.n]
        return (self.lp(n, self.scene.center, self.axes)[0],
                self.lpr(n, q[G.omega], self.axes)[0])

    def v_S(self, t, q):
        return self.vel(q, self.u(t), self.s_of(q)[0], self.p)[0]

    def f_flight(self, t, q):
        return self.rhs(q, self.u(t), self.p)[0]

    def sliding(self, t, q, direction):
        s, sd = self.s_of(q)
        dq, N, _, _ = self.slide(q, self.u(t), s, sd, self.p, [self.mu_f], direction)
        return dq, float(N[0])

    def sticking(self, t, q):
        s, sd = self.s_of(q)
        dq, R = self.stick(q, self.u(t), s, sd, self.p)
        return dq, np.asarray(R)

    def project(self, t, q, slip_too=False):
        q = q.copy()
        for _ in range(2):
            s = self.s_of(q)[0]
            h, vn = self.gap_f(q, self.u(t), s, self.p)
            q[G.Z] -= h[0]
            q[G.Zd] -= vn[0]
        if slip_too:
            v = self.v_S(t, q)
            q[G.horizontal_velocity] -= v[:2]
        return q

    # -- the direction a slip takes from rest (crt_rough.h, crt_rough_onset)
    def onset(self, t, q, R):
        w6, _ = self.dl(q, self.u(t), self.s_of(q)[0], self.p)
        a, b, c, d, e, f = w6
        W = np.array([[a, b, c], [b, d, e], [c, e, f]])
        WR = W @ R
        d0 = -R[:2] / np.hypot(R[0], R[1])

        def at(th):
            sg = np.array([np.cos(th), np.sin(th)])
            k_f = W[2, 2] - self.mu_f * W[2, :2] @ sg
            N = WR[2] / k_f
            if not (k_f > 0 and N > 0):
                return np.nan, np.nan
            a_t = (W @ np.array([-N * self.mu_f * sg[0] - R[0], -N * self.mu_f * sg[1] - R[1],
                                 N - R[2]]))[:2]
            return sg[0] * a_t[1] - sg[1] * a_t[0], sg @ a_t
        ths = np.linspace(0.0, 2 * np.pi, 73)
        gs = [at(th)[0] for th in ths]
        best, out = -2.0, d0
        for k in range(1, 73):
            g0, g1 = gs[k - 1], gs[k]
            if not (np.isfinite(g0) and np.isfinite(g1)) or (g0 > 0) == (g1 > 0):
                continue
            lo, hi = ths[k - 1], ths[k]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if (at(mid)[0] > 0) == (g0 > 0):
                    lo = mid
                else:
                    hi = mid
            th = 0.5 * (lo + hi)
            sg = np.array([np.cos(th), np.sin(th)])
            score = (4.0 if g1 < g0 else 0.0) + sg @ d0
            if at(th)[1] > 0 and score > best:
                best, out = score, sg
        return out

    def result(self) -> Run:
        from .. import darboux_keller as dk
        s = self.scene
        t, q = s.t0, self.q0.copy()
        t_end = s.t0 + s.duration
        mode, direction, armed = "flight", np.array([1.0, 0.0]), True
        left = False
        rows_t, rows_q, impacts, events = [t], [q.copy()], [], 0
        calls = [0]
        v_scale = float(np.abs(q[G.com_velocity]).max()) + 1.0

        def record(sol):
            for tt, qq in zip(sol.t, np.asarray(sol.y).reshape(18, -1).T):
                rows_t.append(tt)
                rows_q.append(qq)

        def after_flight(tt, qq):
            s_, _ = self.s_of(qq)
            h, vn = self.gap_f(qq, self.u(tt), s_, self.p)
            return h[0], vn[0]

        while t < t_end - 1e-12 and events < self.budget:
            grid = np.minimum(self.grid[(self.grid > t + 1e-12) & (self.grid <= t_end + 1e-12)],
                              t_end)
            if mode == "flight":
                def gap_ev(tt, qq):
                    return after_flight(tt, qq)[0]
                gap_ev.terminal, gap_ev.direction = True, -1
                h0, vn0 = after_flight(t, q)
                if left or not (h0 <= 1e-12 * self.L and vn0 <= 1e-9 * v_scale):
                    left = False         # (S just lifted off: it rises, no touchdown now)
                    sol = solve_ivp(self.f_flight, (t, t_end), q, method="DOP853",
                                    rtol=self.rtol, atol=self.rtol * 1e-2, events=[gap_ev],
                                    t_eval=grid, dense_output=False)
                    record(sol)
                    calls[0] += sol.nfev
                    if sol.status != 1:
                        t = t_end
                        break
                    t, q = float(sol.t_events[0][0]), np.asarray(sol.y_events[0][0])
                # S on the plane, its normal velocity kept
                q[G.Z] -= after_flight(t, q)[0]
                _, vn = after_flight(t, q)
                if vn < -1e-9 * v_scale:
                    s_, _ = self.s_of(q)
                    imp = dk.impact(q.copy(), self.u(t), s_, self.p, self.mu_f, self.e,
                                    s.restitution_model, rtol=max(self.rtol, 1e-12))
                    q = imp.q_plus
                    impacts.append(t)
                    events += 1
                    v_plus = imp.v_plus[2]
                    self.log.append((t, "impact", v_plus))
                else:
                    v_plus = 0.0
                # accumulation: the rebound rises less than 1e-9 of the body
                if v_plus * v_plus / (2 * s.g) <= 1e-9 * self.L:
                    q = self.project(t, q)
                    v = self.v_S(t, q)
                    if np.hypot(v[0], v[1]) > 1e-8 * v_scale:
                        mode, direction, armed = "sliding", v[:2] / np.hypot(*v[:2]), True
                    else:
                        mode, direction, armed = self.at_rest(t, q)
                    self.log.append((t, "contact", mode))
                    if mode != "sliding" or not armed:
                        q = self.project(t, q, slip_too=True)
                        if mode == "flight":     # not pressed onto the plane: it leaves
                            step = solve_ivp(self.f_flight, (t, min(t + 1e-9, t_end)), q,
                                             method="DOP853", rtol=self.rtol,
                                             atol=self.rtol * 1e-2)
                            t, q = step.t[-1], step.y[:, -1]
                else:
                    # leave the plane before looking for the next impact
                    step = solve_ivp(self.f_flight, (t, min(t + 1e-9, t_end)), q,
                                     method="DOP853", rtol=self.rtol, atol=self.rtol * 1e-2)
                    t, q = step.t[-1], step.y[:, -1]
                continue
            if mode == "sticking":
                def f(tt, qq):
                    return self.sticking(tt, qq)[0]

                def cone(tt, qq):
                    R = self.sticking(tt, qq)[1]
                    return (self.mu_f * R[2] - np.hypot(R[0], R[1])) / self.F
                cone.terminal, cone.direction = True, -1
                sol = solve_ivp(f, (t, t_end), q, method="DOP853", rtol=self.rtol,
                                atol=self.rtol * 1e-2, events=[cone], t_eval=grid)
                record(sol)
                calls[0] += sol.nfev
                if sol.status != 1:
                    t = t_end if sol.status == 0 else t
                    break
                t, q = float(sol.t_events[0][0]), np.asarray(sol.y_events[0][0])
                events += 1
                R = self.sticking(t, q)[1]
                self.log.append((t, "slip", R[2]))
                if R[2] <= 0:
                    mode, left = "flight", True
                    q = self.project(t, q)
                    continue
                mode, direction, armed = "sliding", -R[:2] / np.hypot(R[0], R[1]), False
                continue
            # sliding
            d_ref = direction.copy()
            frozen = not armed

            def f(tt, qq):
                v = self.v_S(tt, qq)
                rho = np.hypot(v[0], v[1])
                d = d_ref if (frozen or rho == 0.0) else v[:2] / rho * np.sign(v[:2] @ d_ref)
                return self.sliding(tt, qq, d)[0]

            def normal(tt, qq):
                v = self.v_S(tt, qq)
                rho = np.hypot(v[0], v[1])
                d = d_ref if (frozen or rho == 0.0) else v[:2] / rho * np.sign(v[:2] @ d_ref)
                return self.sliding(tt, qq, d)[1] / self.F

            def slip(tt, qq):
                v = self.v_S(tt, qq)
                return v[:2] @ d_ref / v_scale + (1e-12 if frozen else 0.0)

            def resolved(tt, qq):
                v = self.v_S(tt, qq)
                return np.hypot(v[0], v[1]) - 1e-8 * v_scale
            normal.terminal, normal.direction = True, -1
            slip.terminal, slip.direction = True, -1
            resolved.terminal, resolved.direction = True, 1
            evs = [normal, slip] + ([resolved] if frozen else [])
            sol = solve_ivp(f, (t, t_end), q, method="DOP853", rtol=self.rtol,
                            atol=self.rtol * 1e-2, events=evs, t_eval=grid)
            record(sol)
            calls[0] += sol.nfev
            if sol.status != 1:
                t = t_end if sol.status == 0 else t
                break
            which = min((k for k in range(len(evs)) if len(sol.t_events[k])),
                        key=lambda k: sol.t_events[k][0])
            t, q = float(sol.t_events[which][0]), np.asarray(sol.y_events[which][0])
            q = self.project(t, q)
            events += 1
            if which == 0:
                mode, left = "flight", True
                self.log.append((t, "lift_off", None))
                continue
            if which == 2:               # the restarted slip is resolved: follow it
                v = self.v_S(t, q)
                direction, armed = v[:2] / np.hypot(v[0], v[1]), True
                continue
            v = self.v_S(t, q)
            if np.hypot(v[0], v[1]) > 1e-6 * v_scale:     # the slip turned: a new segment
                direction, armed = v[:2] / np.hypot(v[0], v[1]), True
                continue
            mode, direction, armed = self.at_rest(t, q)
            q = self.project(t, q, slip_too=True)
            self.log.append((t, "settle", mode))
        st = np.array(rows_q) if rows_q else np.empty((0, 18))
        tt = np.array(rows_t)
        keep = np.searchsorted(tt, self.grid - 1e-12)
        ok = len(tt) and np.all(np.abs(tt[np.clip(keep, 0, len(tt) - 1)] - self.grid) < 1e-9)
        states = st[np.clip(keep, 0, len(tt) - 1)] if ok else st
        status = "done" if ok and t >= t_end - 1e-9 else f"stopped at t = {t:.4g}"
        return Run(states, np.array(impacts), calls[0], status)

    def at_rest(self, t, q):
        q0 = self.project(t, q, slip_too=True)
        R = self.sticking(t, q0)[1]
        if R[2] > 0 and np.hypot(R[0], R[1]) <= self.mu_f * R[2]:
            return "sticking", np.array([1.0, 0.0]), True
        if R[2] <= 0:
            return "flight", np.array([1.0, 0.0]), True
        return "sliding", self.onset(t, q0, R), False

    def timed(self, repeats: int) -> float:
        return _timed(self.result, repeats)


# ---- the measurements ---------------------------------------------------------------------------
def _smooth(doc: dict) -> dict:
    d = copy.deepcopy(doc)
    d["plane"]["friction"] = 0.0
    for key in ("spin_friction", "rolling_resistance"):
        d["plane"].pop(key, None)
    return d


def _renumbered(doc: dict, k: int) -> dict:
    """Other initial numbers on every call, the same physics (C moved by 1e-13 of itself
    in X: nothing a cache keys on a number can be reused)."""
    d = copy.deepcopy(doc)
    init = d.setdefault("initial", {})
    com = list(init.get("com", [0.0, 0.0, 0.0]))
    com[0] = float(com[0]) + 1e-13 * k
    init["com"] = com
    return d


FAST = 20          # each sample of a run the least of this many


def cost_rows(doc: dict, repeats: int) -> dict:
    """The rough scene against its smooth twin (friction 0): the C run alone and
    derive.simulate end to end, sampled in interleaved rounds (a burst of load hits every
    route alike; each sample the least of FAST calls)."""
    import derive
    from ..runtime.driver import prepare, run_prepared
    from ..runtime.session import session_for
    out, fns = {}, {}
    samples = max(5, repeats)
    for label, d, model in (("rough", doc, None), ("smooth, general model", _smooth(doc),
                                                    "general"),
                            ("smooth, model chosen", _smooth(doc), None)):
        dd = copy.deepcopy(d)
        if model:
            dd.setdefault("run", {})["model"] = model
        prep = prepare(dd)
        session = session_for(prep.kind)
        res = run_prepared(prep, session)

        def c_run(p=prep, s=session):
            s.set_law(p.scene.law)
            s.run(p.scene.t0, p.scene.duration, p.start.q0, p.options, p.parameters)
        docs = iter([_renumbered(dd, k) for k in range(1, FAST * samples + 3)])
        fns[(label, "kernel")] = c_run
        fns[(label, "end")] = lambda docs=docs: derive.simulate(next(docs))
        out[label] = {"model": prep.kind, "events": len(res.events),
                      "steps": res.stats["steps"]}
    got = interleaved(fns, samples, FAST)
    for label in out:
        out[label].update({"kernel": got[(label, "kernel")], "end_to_end": got[(label, "end")],
                           "kernel_s": Spread.of(got[(label, "kernel")]).median,
                           "end_to_end_s": Spread.of(got[(label, "end")]).median})
    return out


def precision_rows(doc: dict, repeats: int, progress) -> dict:
    progress(f"{doc['name']}: reference at 1e-13, checked against SciPy at 1e-12")
    ref = Runtime(doc, "dop853", 1e-13, model="rough").result()
    peer = ScipyRough(doc, 1e-12)
    agreement = errors(peer.result(), ref)
    rows = []
    for tol in TOLERANCES:
        for name, make in (("runtime LIE", lambda t: Runtime(doc, "lie", t, model="rough")),
                           ("runtime DOP853", lambda t: Runtime(doc, "dop853", t,
                                                                model="rough")),
                           ("scipy DOP853 (rough)", lambda t: ScipyRough(doc, t))):
            progress(f"{doc['name']}: {name} at {tol:g}")
            route = make(tol)
            res = route.result()
            err = errors(res, ref)
            sec = _timed(route.run_raw if hasattr(route, "run_raw") else route.result,
                         (20 if name.startswith("runtime") else 1) * repeats)
            rows.append({"route": name, "rtol": tol, "seconds": sec, "error": err[0],
                         "impact_error": err[1], "status": res.status})
    return {"agreement": agreement, "rows": rows}


def run(progress=lambda m: None, repeats: int = 3, quick: bool = False) -> dict:
    out = []
    for doc in scenes():
        progress(f"{doc['name']}: rough against smooth")
        item = {"scene": doc["name"], "duration": doc["run"]["duration"],
                "cost": cost_rows(doc, repeats)}
        if not quick and not has_couples(doc):     # (the SciPy route has no couples)
            item["precision"] = precision_rows(doc, repeats, progress)
        out.append(item)
    return {"scenes": out}


def _cost_targets(item: dict) -> list:
    c = item["cost"]
    r, s = c["rough"], c["smooth, general model"]
    return [judge(f"{item['scene']}: the rough C run over the smooth one (general model)",
                  ratios(r["kernel"], s["kernel"]), AT_MOST, GOAL, ".2f"),
            judge(f"{item['scene']}: derive.simulate end to end, rough over smooth",
                  ratios(r["end_to_end"], s["end_to_end"]), AT_MOST, GOAL, ".2f")]


def targets(out: dict) -> list:
    return [t for item in out["scenes"] for t in _cost_targets(item)]


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))


def report(out: dict) -> str:
    lines = []
    for item in out["scenes"]:
        lines.append(f"scene {item['scene']} ({item['duration']:g} s)")
        lines.append(f"  {'run':<26}{'model':>9}{'C run [ms]':>12}{'simulate [ms]':>15}"
                     f"{'events':>8}{'steps':>7}")
        for label, r in item["cost"].items():
            lines.append(f"  {label:<26}{r['model']:>9}{1e3 * r['kernel_s']:>12.3f}"
                         f"{1e3 * r['end_to_end_s']:>15.3f}{r['events']:>8d}{r['steps']:>7d}")
        lines += [f"  {t}" for t in _cost_targets(item)]
        if "precision" in item:
            p = item["precision"]
            lines.append(f"  work-precision (error: largest state difference on a {GRID_DT:g} s "
                         f"grid against the runtime at 1e-13; that reference against SciPy "
                         f"at 1e-12: state {p['agreement'][0]:.1e}, impact times "
                         f"{p['agreement'][1]:.1e})")
            lines.append(f"  {'route':<24}{'rtol':>8}{'time [ms]':>12}{'error':>10}"
                         f"{'impacts':>10}  status")
            for r in p["rows"]:
                lines.append(f"  {r['route']:<24}{r['rtol']:>8.0e}{1e3 * r['seconds']:>12.3f}"
                             f"{r['error']:>10.1e}{r['impact_error']:>10.1e}  {r['status']}")
    lines.append("goal: " + "; ".join(str(t) for t in targets(out)))
    lines.append(SPREAD_NOTE)
    return "\n".join(lines)

