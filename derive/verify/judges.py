"""Verdicts: what the toolkit did with a case, judged against the README's contract.

* :func:`judge_api` and :func:`judge_cli`: a hostile scene through ``parse_scene`` (and
  the simulation) or through ``derive simulate``.  GOOD outcomes are ``ran-ok``,
  ``ran-status`` (accepted; ended max_steps, ... honestly) and ``refused`` (exit 2, one
  line, the field named, nothing written).  BAD ones: traceback, crash, hang,
  silent-accept (a scene the README says must be refused ran), wrong-field (refused, but
  blaming another field or none), multi-line, control-chars, wrong-exit, warning,
  wrong-answer (rows off the true trajectory, law values off the expression, a status
  that lies; from :mod:`derive.verify.oracle`), wrote-files (an output folder after a
  refusal), outside-files (anything created outside it), fuzzer-error.
* :func:`judge_run`: a random valid bouncing scene's run: ``ok``, or ``status``,
  ``nan``, ``fell``, ``orthonormality``, ``integral`` (|K| not constant in a flight,
  E1.9); on a rough plane also ``painleve`` (an honest stop: sliding friction can leave
  no consistent reaction there), ``cone`` (a contact row's reaction outside the friction
  cone), ``stop`` (a stick or a reversal where the slip, computed apart, had not stopped)
  and ``energy`` (friction doing positive work, or the energy gaining more than the
  point's drive gave).
* :func:`classify`: a hard scene's run against its reference: ``correct``, ``wrong``,
  ``missed events``, ``fell through the plane`` or a named status.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .. import abi
from ..runtime.events import contact_intervals, phases
from ..scene.errors import has_unprintable

if TYPE_CHECKING:
    from ..bench.routes import Run
    from .generators import Case

PARSE_LIMIT_S = 2.0        # validation must take milliseconds; this is the hang verdict
RUN_LIMIT_S = 20.0         # a 1 s scene runs in milliseconds
CLI_LIMIT_S = 60.0

BAD = ("traceback", "crash", "hang", "silent-accept", "wrong-field", "multi-line",
       "control-chars", "wrong-exit", "warning", "wrong-answer", "wrote-files",
       "outside-files", "fuzzer-error")
GOOD = ("ran-ok", "ran-status", "refused")

FIELD_RE = re.compile(r"^(\[[^\]\n]+\][^:\n]*|[^\W\d][\w.\\-]*\s?(\[\d+\])*)( \([^)]*\))?:")


@dataclass
class Outcome:
    """A hostile case's verdict (GOOD or BAD), why, and what the toolkit printed."""
    case: Case
    verdict: str
    detail: str = ""
    seconds: float = 0.0
    message: str = ""

    @property
    def bad(self) -> bool:
        return self.verdict in BAD


def _names_field(message: str) -> bool:
    return bool(FIELD_RE.match(message.strip()))


def judge_api(case: Case, res: dict, run_limit: float) -> Outcome:
    st = res.get("status")
    secs = res.get("seconds", 0.0) + res.get("run_seconds", 0.0)
    if st == "timeout":
        return Outcome(case, "hang", "no answer within the time limit", secs)
    if st == "crash":
        return Outcome(case, "crash", f"worker died (exit code {res.get('exitcode')})", secs)
    if st == "error":
        where = " while simulating" if res.get("stage") else ""
        last = [ln for ln in res.get("tb", "").strip().splitlines() if ln.strip()]
        return Outcome(case, "traceback", f"{res.get('type')}{where}: "
                       f"{(last[-1] if last else '')[:160]}", secs)
    if st == "refused":
        msg = res.get("message", "")
        if "\n" in msg.strip():
            return Outcome(case, "multi-line", msg[:200], secs, msg)
        if has_unprintable(msg.strip()):
            return Outcome(case, "control-chars", f"raw control characters: {msg[:160]!r}",
                           secs, msg)
        if res.get("seconds", 0.0) > PARSE_LIMIT_S:
            return Outcome(case, "hang", f"refused after {res['seconds']:.1f} s", secs, msg)
        if case.fields is not None and not _names_field(msg):
            return Outcome(case, "wrong-field", f"names no field: {msg[:160]}", secs, msg)
        if case.fields and not any(f in msg for f in case.fields):
            return Outcome(case, "wrong-field", f"wants {case.fields[0]}: {msg[:160]}",
                           secs, msg)
        return Outcome(case, "refused", "", secs, msg)
    # accepted
    problems = list(res.get("problems", []))
    if res.get("seconds", 0.0) > PARSE_LIMIT_S:
        return Outcome(case, "hang", f"accepted after {res['seconds']:.1f} s", secs)
    if case.expect == "refuse":
        return Outcome(case, "silent-accept", f"accepted (run: {res.get('run_status')}) "
                       + "; ".join(problems)[:200], secs)
    for p in problems:
        verdict = p.split(":", 1)[0]
        return Outcome(case, verdict if verdict in BAD else "wrong-answer", p[:300], secs)
    if res.get("warnings"):
        return Outcome(case, "warning", "; ".join(res["warnings"])[:200], secs)
    if res.get("run_seconds", 0.0) > run_limit:
        return Outcome(case, "hang", f"ran for {res['run_seconds']:.1f} s", secs)
    status = res.get("run_status", "done")
    return Outcome(case, "ran-ok" if status == "done" else "ran-status",
                   "" if status == "done" else status, secs)


def judge_cli(case, run, limit: float = CLI_LIMIT_S) -> Outcome:
    """``derive simulate`` on the case in the sandbox (a :class:`~derive.verify.sandbox.
    CliRun`): a refusal is exit 2 with one line ``derive simulate: <field>: <rule>`` and
    no output folder; a run is exit 0 (done) or 1 (another status) with its folder; no
    file anywhere else."""
    if run.returncode is None:
        return Outcome(case, "hang", f"no exit within {limit:.0f} s", limit)
    secs, err, so, rc = run.seconds, run.stderr, run.stdout, run.returncode
    lines = err.strip().splitlines()
    if "Traceback" in err:
        last = lines[-1] if lines else ""
        return Outcome(case, "traceback", f"exit {rc}: {last[:160]}", secs, err[-2000:])
    if run.outside:
        return Outcome(case, "outside-files", f"exit {rc}, created {run.outside[:3]}",
                       secs, err)
    if rc == 2:
        msg = lines[0] if lines else ""
        if len(lines) != 1:
            return Outcome(case, "multi-line", f"{len(lines)} lines on stderr: "
                           f"{err[:160]!r}", secs, err)
        if run.output:
            return Outcome(case, "wrote-files", f"out/ exists after a refusal: {msg}",
                           secs, msg)
        if not msg.startswith("derive simulate: "):
            return Outcome(case, "wrong-field", f"not 'derive simulate:': {msg[:160]}",
                           secs, msg)
        body = msg[len("derive simulate: "):]
        if has_unprintable(body):
            return Outcome(case, "control-chars", f"raw control characters: "
                           f"{msg[:160]!r}", secs, msg)
        if case.fields is not None and not _names_field(body):
            return Outcome(case, "wrong-field", f"names no field: {msg[:160]}", secs,
                           msg)
        if case.toml_level_ok and body.startswith("scene.toml: is nested too deeply"):
            return Outcome(case, "refused", "", secs, msg)
        if case.fields and not any(f in body for f in case.fields):
            return Outcome(case, "wrong-field", f"wants {case.fields[0]}: {msg[:160]}",
                           secs, msg)
        return Outcome(case, "refused", "", secs, msg)
    if rc in (0, 1):
        if case.expect == "refuse":
            return Outcome(case, "silent-accept", f"exit {rc}: {so.splitlines()[:1]}", secs,
                           err)
        if "Warning" in err:
            return Outcome(case, "warning", err.strip()[:200], secs, err)
        if not run.output:
            return Outcome(case, "wrong-exit", f"exit {rc} but no out/", secs, err)
        if secs > limit / 2:
            return Outcome(case, "hang", f"took {secs:.1f} s", secs, err)
        return Outcome(case, "ran-ok" if rc == 0 else "ran-status",
                       so.splitlines()[0][:120] if so else "", secs, err)
    return Outcome(case, "wrong-exit", f"exit {rc}: {err.strip()[-160:]!r}", secs, err)


# ---- a random valid bouncing scene's run ----------------------------------------------
ROUNDING = 1e-12          # the Lie methods: orthonormality and |K| in flight at round-off


def judge_run(result, size: float) -> tuple[str, str]:
    """The verdict on one run: ``ok`` or what is wrong."""
    scene = result.scene
    if result.rough and result.status == "painleve":
        return _judge_painleve(result)
    if result.status != "done":
        return "status", f"ended with {result.status} at t = {result.t[-1]:.6g}"
    if abs(result.t[-1] - (scene.t0 + scene.duration)) > 1e-9 * max(1.0, scene.duration):
        return "status", f"says done but ended at t = {result.t[-1]:.9g}"
    if not np.all(np.isfinite(result.model_q)):
        return "nan", "non-finite state"
    if result.min_height < -1e-9 * size:
        return "fell", f"S reached {result.min_height:.3g} below the plane"
    h = result.height
    if h is not None and np.min(h) < -1e-9 * size:
        k = int(np.argmin(h))
        return "fell", f"a row has S at {h[k]:.3g} (t = {result.t[k]:.6g})"
    g = result.general
    lie = scene.method in abi.LIE_METHODS
    contact_rows = np.zeros(len(result.t), dtype=bool)
    for a, b in contact_intervals(result):
        contact_rows |= (result.t >= a) & (result.t <= b)
    if g is not None:
        A = g[:, 9:18].reshape(-1, 3, 3)
        dev = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        # classical methods let A drift at the level of their tolerance per unit time
        # (RK4: of its step); the Lie-group methods keep it to round-off in flight (in
        # persistent contact the classical method of the same order runs)
        bound = 1e-9 + 1e4 * (scene.rtol if scene.method != "rk4" else 1e-8) \
            * max(1.0, scene.duration)
        # (a run in contact throughout, a body put on the plane at rest, has no flight:
        # only the classical bound below)
        err = float(dev[~contact_rows].max()) if (~contact_rows).any() else 0.0
        if lie and err > ROUNDING:
            return "orthonormality", f"A A^T - 1 reaches {err:.2e} in flight (Lie: round-off)"
        # RK4 has no error control: after impacts spin the body up, its fixed step no
        # longer resolves the rotation, and A's drift says so; not a fault of the runtime
        if scene.method != "rk4" and float(dev.max()) > bound:
            return "orthonormality", f"A A^T - 1 reaches {dev.max():.2e} (bound {bound:.1e})"
    # E1.9 within each flight: |K| constant between events (tolerance-dependent)
    K = result.momentum["K_norm"]
    worst = 0.0
    for a, b, _ in phases(result):
        if b - a > 2 and K[a] > 1e-9 and not contact_rows[a:b].any():
            worst = max(worst, float(np.max(np.abs(K[a:b] - K[a])) / K[a]))
    if worst > (ROUNDING if lie else 1e-4):
        return "integral", f"|K| drifts by {worst:.2e} within a flight"
    if result.rough:
        return judge_rough(result)
    return "ok", ""


# the rough plane: the cone to the tolerance's share of the weight (the rows at a
# transition are where the event function crosses 0, located to the tolerance); energy to
# this fraction of the largest energy of the run (the balance's residual is the
# integrator's: 1e-9 of E on smooth scenes at these tolerances, up to 1e-7 in long sticking
# phases at rtol 1e-7)
CONE_SLACK = 100.0
ENERGY_SLACK = 1e-6
STOP_SLACK = 2.0          # a stop of the slip: its speed before, in v_freeze (judge_reaction)


def _couples_painleve_ratio(result) -> float:
    """With couples: the largest share of G_ZZ that the reactions proportional to N can
    take from N's coefficient k at the last row, over every choice of held and turning
    channels and directions (the slip's and the rolling's on 72 angles each, the spin's
    two signs); 1 or more where some choice makes k vanish."""
    s = result.scene
    G, _, _ = result.session.contact_wrench(result.t[-1], result.model_q[-1])
    angles = np.linspace(0.0, 2.0 * math.pi, 72, endpoint=False)
    circle = np.c_[np.cos(angles), np.sin(angles)]
    worst = 0.0
    for slip_held in (False, True):
        for spin in ((None, 1.0, -1.0) if s.spin_friction > 0 else (0.0,)):
            for roll_held in ((False, True) if s.rolling_resistance > 0 else (True,)):
                held = ([0, 1] if slip_held else []) + ([5] if spin is None else []) \
                    + ([3, 4] if roll_held else [])
                for sl in (circle[:1] if slip_held else circle):
                    for rl in (circle[:1] if roll_held else circle):
                        b = np.zeros(6)
                        b[2] = 1.0
                        if not slip_held:
                            b[:2] = -s.friction * sl
                        if spin is not None:
                            b[5] = -s.spin_friction * spin
                        if not roll_held:
                            b[3:5] = -s.rolling_resistance * rl
                        Gb = G @ b
                        k = Gb[2]
                        if held:
                            H = G[np.ix_(held, held)]
                            k -= G[2, held] @ np.linalg.solve(H, Gb[held])
                        worst = max(worst, 1.0 - k / G[2, 2])
    return worst


def _judge_painleve(result) -> tuple[str, str]:
    """An honest painleve: at the last row sliding friction can make k_f = W_ZZ - mu_f
    (W_Zt, dir) vanish for some direction, mu_f |W_tn| >= W_ZZ (to 1%: the runtime stops
    where k_f falls below 1e-2 W_ZZ with N beyond 100 weights)."""
    W, _ = result.session.delassus(result.t[-1], result.model_q[-1])
    ratio = result.scene.friction * math.hypot(W[0, 2], W[1, 2]) / W[2, 2]
    if result.couples_on:
        ratio = max(ratio, _couples_painleve_ratio(result))
    what = "1 - k/W_ZZ at worst (with the couples)" if result.couples_on \
        else "mu_f |W_tn|/W_ZZ"
    if ratio >= 0.99:
        return "painleve", f"at t = {result.t[-1]:.6g}: {what} = {ratio:.3f}"
    return "status", (f"painleve at t = {result.t[-1]:.6g} where {what} = "
                      f"{ratio:.3f} < 1: no direction makes k_f vanish")


def couple_channels(s) -> list:
    """(bit, columns of the wrench, bound) of the couples a scene has on (the layout of
    abi.COUPLE_BITS, WRENCH_COLUMNS and COUPLE_COLUMNS)."""
    out = []
    for name, bit in abi.COUPLE_BITS:
        mu = float(getattr(s, abi.COUPLE_BOUNDS[name]))
        if mu > 0.0:
            out.append((bit, [abi.WRENCH_COLUMNS.index(c) for c in abi.COUPLE_COLUMNS[name]],
                        mu))
    return out


# the decisions at the events (reaction.row_modes): the row that holds the state the
# runtime decided on, ``before`` (1) or ``after`` (2) the event
_INSIDE = {"stick": 2, "contact": 2}                 # the cone holds (sticking after it)
_AT_THE_BOUND = {"slip": 1, "reversal": 2}          # the sticking reaction left the cone
_COUPLE_STOPS = {f"{name}_stop": bit for name, bit in abi.COUPLE_BITS}
_COUPLE_STARTS = {f"{name}_start": bit for name, bit in abi.COUPLE_BITS}


def judge_reaction(result, slack: float) -> tuple[str, str] | None:
    """The friction cone, the couples' bounds and N >= 0 on the contact rows, against the
    reaction computed apart from the runtime (:mod:`derive.verify.reaction`: Newton–Euler
    for the carrier, its points and rotors under each row's mode), and the decisions at
    the events:

    * every row between events (the steps', and those of an instant with one event):
      sticking inside the cone; sliding, where the slip says its direction, with N >= 0
      along it, and where it does not, along some direction; each held couple inside its
      bound;
    * at each event what it decided: a stick (or an entry into contact that sticks) only
      inside the cone, a couple's stop only inside its bound; a slip, and a reversal, only
      where the sticking reaction is on or outside the cone; a lift-off only where N has
      reached 0; a couple's start only where its held couple has reached its bound; a
      stick or a reversal (a stop of the slip) only where the slip of the row before it
      is below twice v_freeze (``Session.slip_band``: below v_freeze the runtime's
      friction keeps the reference of the step's start, and a stop removes what the
      step's lag leaves, the slip's growth in that step with it: 1.07 and 1.27 v_freeze
      at scenes #717 and #565 of ``verify robustness --plane rough -n 1000``; far above
      it removes a slip that had not stopped, 37 v_freeze at #204 before its fix:
      verdict ``stop``).  The
      rows of an instant with several events (a spin's stop whose held couple makes the
      slip begin at once) are held to their own event's decision alone: what it did not
      decide, the next event at that instant does.

    The reaction needs each turning couple's direction: rows where one turns below the
    resolution (along a reference these rows do not record) are not judged.  ``slack``:
    the tolerance's share of the weight.  None when all hold."""
    from ..runtime.choice import length_scale
    from .reaction import STICKING, contact_reactions
    s = result.scene
    rr = contact_reactions(result, 10.0 * math.sqrt(s.rtol))
    if not len(rr.rows):
        return None
    R, N, T = rr.reaction.R, rr.reaction.N, rr.reaction.T
    Rs, Ns = rr.sticking_reaction.R, rr.sticking_reaction.N
    mode = rr.modes.mode[rr.rows]
    held_bits = rr.modes.couples[rr.rows]
    sticking = mode == STICKING
    known, ck = rr.known, rr.couples_known
    steady = ~rr.modes.cascade[rr.rows]
    mu = s.friction
    channels = couple_channels(s)
    # (a couple's event function is scaled by mu F: located to 1e-6 of the bound at worst)
    couple_slack = {bit: max(slack * length_scale(s), 1e-6 * bound * _force(s))
                    for bit, _, bound in channels}
    excess = np.hypot(R[:, 0], R[:, 1]) - mu * N
    short = mu * Ns - np.hypot(Rs[:, 0], Rs[:, 1])      # > 0: inside the cone
    over = {bit: np.linalg.norm(T[:, [c - 3 for c in cols]], axis=1) - bound * N
            for bit, cols, bound in channels}

    def where(k: int) -> str:
        j = rr.rows[k]
        ev = rr.modes.event[j]
        side = {1: "before", 2: "after"}.get(int(rr.modes.side[j]), "")
        return (f"t = {result.t[j]:.6g} ({abi.MODES[mode[k]].name}"
                + (f", {side} {ev}" if ev else "") + ")")

    for k in np.flatnonzero(steady & known & (N < -slack))[:1]:
        return "cone", f"N = {N[k]:.3g} N < 0 at {where(k)} (independent reaction)"
    for k in np.flatnonzero(steady & known & sticking & (excess > slack))[:1]:
        return "cone", (f"|R_t| - mu_f N = {excess[k]:.3g} N, N = {N[k]:.3g} N at "
                        f"{where(k)} (independent reaction)")
    for k in np.flatnonzero(steady & (rr.min_sliding_N < -slack))[:1]:
        return "cone", (f"sliding with N < 0 along every direction (at most "
                        f"{rr.min_sliding_N[k]:.3g} N) at {where(k)}")
    for bit, _, _ in channels:
        held = (held_bits & bit) != 0
        for k in np.flatnonzero(steady & known & held & (over[bit] > couple_slack[bit]))[:1]:
            return "cone", (f"|T| - mu N = {over[bit][k]:.3g} N m (couple {bit}) at "
                            f"{where(k)} (independent reaction)")
    for k, j in enumerate(rr.rows):
        ev, side = rr.modes.event[j], int(rr.modes.side[j])
        if not ev or not ck[k]:
            continue
        if _INSIDE.get(ev) == side and sticking[k] and (ev == "stick" or not channels) \
                and excess[k] > slack:
            return "cone", (f"|R_t| - mu_f N = {excess[k]:.3g} N, N = {N[k]:.3g} N where "
                            f"the runtime decided to stick, at {where(k)}")
        if _AT_THE_BOUND.get(ev) == side and Ns[k] > 0.0 and short[k] > slack:
            return "cone", (f"a {ev} where the sticking reaction is inside the cone by "
                            f"{short[k]:.3g} N (N = {Ns[k]:.3g} N) at {where(k)}")
        if ev in ("stick", "reversal") and side == 1 and not sticking[k]:
            slip = math.hypot(rr.kin.v_S[k, 0], rr.kin.v_S[k, 1])
            freeze = result.session.slip_band(result.t[j], result.model_q[j])["freeze"]
            if slip > STOP_SLACK * freeze:
                return "stop", (f"a {ev} where the slip was {slip:.3g} m/s, "
                                f"{slip / freeze:.3g} v_freeze, at {where(k)}")
        if ev == "lift_off" and side == 1 and (sticking[k] or known[k]):
            n_here = Ns[k] if sticking[k] else N[k]
            if n_here > slack:
                return "cone", f"a lift-off with N = {n_here:.3g} N at {where(k)}"
        bit = _COUPLE_STOPS.get(ev) if side == 2 else _COUPLE_STARTS.get(ev)
        if bit in over and held_bits[k] & bit and known[k]:
            gap = over[bit][k] if side == 2 else -over[bit][k]
            if gap > couple_slack[bit]:
                return "cone", (f"a {ev} with the held couple "
                                + ("outside" if side == 2 else "inside")
                                + f" its bound by {gap:.3g} N m at {where(k)}")
    return None


def _force(s) -> float:
    return (s.M + s.m) * max(s.g, 1.0)


def judge_rough(result) -> tuple[str, str]:
    """The friction cone, the couples' bounds and N >= 0 on every contact row and at the
    events' decisions, against a reaction computed apart from the runtime
    (:func:`judge_reaction`), friction's work never positive, and no energy gain beyond
    the drive's work (runtime.motion.energy_balance)."""
    from ..runtime.motion import energy_balance, motion
    s = result.scene
    F = _force(s)
    # RK4 has no error control: its step, the user's, need not resolve a contact phase (a
    # step can cross the place where sliding friction leaves no consistent reaction, k_f
    # = 0, and come out with a reaction of the wrong sign): the cone is not judged there;
    # nor in a closed loop (its law is the controller's, not the scene's)
    rk4 = s.method == "rk4"
    slack = max(1e-9, CONE_SLACK * s.rtol) * F
    if not rk4 and result.min_normal < -slack:
        return "cone", f"the runtime's least normal reaction in contact: {result.min_normal:.3g} N"
    if not rk4 and s.control is None and s.disturbance is None:
        verdict = judge_reaction(result, slack)
        if verdict is not None:
            return verdict
    mo = motion(result)
    balance = energy_balance(result, mo)
    scale = max(float(np.max(np.abs(mo.E))), float(np.max(mo.T)), 1e-300)
    drive = (balance["drive_work_in_flight"] + balance["drive_work_in_contact"]
             + (balance["drive_work_at_impacts"] or 0.0))
    gain = balance["change"] - drive
    if balance["work_of_friction"] > ENERGY_SLACK * scale:
        return "energy", f"friction did {balance['work_of_friction']:.3g} J of positive work"
    if gain > ENERGY_SLACK * scale:
        return "energy", (f"the energy gained {gain:.3g} J beyond the drive's work "
                          f"({gain / scale:.1e} of E)")
    return "ok", ""


# ---- a hard scene's run against its reference -----------------------------------------
CORRECT = 1e-6


def classify(run: Run, ref: Run, scene_has_plane: bool) -> tuple[str, float]:
    """Accumulating impacts resolved as persistent contact give fewer impacts than the
    reference with the same states: an impact count alone does not make a miss; a miss
    is fewer impacts and a state that went wrong."""
    status = run.status
    if status.startswith("stopped"):
        return "stopped at a limit", math.nan
    if status.startswith("failed"):
        return status, math.nan
    if status != "done":
        return status, math.nan
    if scene_has_plane and run.min_height < -CORRECT:
        return "fell through the plane", math.nan
    from ..bench.routes import errors
    err, _ = errors(run, ref)
    if not np.isfinite(err):
        return "wrong (incomplete)", math.nan
    if err <= CORRECT:
        return "correct", err
    if len(run.impacts) < len(ref.impacts):
        return "missed events", err
    return "wrong", err


# ---- a body on its face (the base model) ---------------------------------------------------
FACE_STOPS = ("lift_off", "tipping", "face_lifting")
FACE_GRID = 400            # samples of N(t) over the run (N is the laws' alone)
FACE_MARGIN = 1e-8         # a stop's margin (N, the edge's or the kern's) within this of 0,
                           # of (M + m) g or of the face's size


def face_system(scene):
    """The scene as derive/base_reference.py's System (Newton-Euler of every body in the
    face frame, apart from the runtime's moments and crt_base_model.h): the laws read
    through derive/runtime/bodies.py (the NumPy twin of crt_law.h) and turned by Q."""
    from .. import base_reference as br
    from ..runtime import bodies as bm, choice
    face = choice.base_face(scene)
    Q = face.frame
    memo = {}

    def at(t):
        if t not in memo:
            memo.clear()
            memo[t] = bm.along(scene, [t])
        return memo[t]

    def point(j):
        return lambda t: tuple(Q @ x[j, 0] for x in (at(t).r, at(t).v, at(t).a))

    def rotor(k):
        return lambda t: (float(at(t).psi[k, 0, 1]), float(at(t).psi[k, 0, 2]))
    b = at(scene.t0)
    return br.System(M=scene.M, J=tuple(np.diag(Q @ np.diag(scene.J) @ Q.T)), face=face,
                     points=tuple(br.Point(float(m), point(j)) for j, m in enumerate(b.masses)),
                     rotors=tuple(br.Rotor(float(i), tuple(Q @ a), rotor(k))
                                  for k, (i, a) in enumerate(zip(b.inertias, b.axes))),
                     mu=scene.friction, mu_static=scene.static_friction,
                     pressure=scene.pressure or "uniform", g=scene.g)


def _face_balance(system, t: float, q):
    """N and the centre of pressure at (t, q) by the reference, of the mode the body is in:
    where it moves, the slip's (its friction over the face by adaptive quadrature, linear
    pressure's centre iterated); at rest, the rest's where the rest holds (the gauge of
    the wrench it needs at most 1 under mu_s), else the slip's that starts there (a slip
    from rest, a reversal at a stop) along the reference's start direction.  A rest that
    cannot hold has no reaction: its cp off the face is no tip (issue 33's trial: a
    runtime that tested it before the gauge stopped `tipping` at a reversal, and this
    judge, reading the rest's cp, agreed)."""
    from .. import base_reference as br
    q = np.asarray(q, dtype=float)
    integ = br.Integrator(system)
    if np.any(q[3:6]):
        return integ.rates(t, q)[1]
    rest = br.balance_stick(system, t)
    if rest.N <= 0.0:
        return rest
    gamma, xi = br.limit_gauge(system, rest.N, rest.cp, rest.wrench)
    if gamma <= 1.0 + 1e-9:
        return rest
    d = integ.start_direction(t, q, -xi)
    return rest if d is None else integ.rates(t, q, direction=d)[1]


def judge_face_run(result) -> tuple[str, str]:
    """A random body on its face: ``ok``, or ``status`` (not done nor an honest stop, or
    done before the end), ``nan``, ``lift_off`` (N reached 0 where no lift-off was
    reported, or one reported where N is not 0), ``stop`` (tipping or the face lifting
    reported where cp is not on the edge or the kern, or cp past them at the end)."""
    scene, status = result.scene, result.status
    if status not in ("done", *FACE_STOPS):
        return "status", f"ended with {status} at t = {result.t[-1]:.6g}"
    t_end = float(result.t[-1])
    if status == "done" and abs(t_end - (scene.t0 + scene.duration)) > 1e-9 * max(
            1.0, scene.duration):
        return "status", f"says done but ended at t = {t_end:.9g}"
    if not np.all(np.isfinite(result.model_q)):
        return "nan", "non-finite state"
    system = face_system(scene)
    weight = system.mass * system.g
    from .. import base_reference as br
    grid = np.linspace(scene.t0, t_end, FACE_GRID)
    N = np.array([br.balance_stick(system, float(t)).N for t in grid])
    before = N[:-1] if status == "lift_off" else N
    if before.min() <= 0.0:
        k = int(np.argmin(before))
        return "lift_off", f"N = {before[k]:.3g} N at t = {grid[k]:.6g} and no lift-off there"
    if status == "lift_off":               # (N is the laws' alone; the slip's balance is
        N_end = br.balance_stick(system, t_end).N   # singular where N = 0)
        if abs(N_end) > FACE_MARGIN * weight:
            return "lift_off", f"lift_off at t = {t_end:.9g} where N = {N_end:.3g} N"
        return "ok", status
    bal = _face_balance(system, t_end, result.model_q[-1])
    face = system.face
    edge, kern = face.edge_margin(bal.cp), face.kern_margin(bal.cp)
    if status in ("tipping", "face_lifting"):
        # on the edge or the kern; or past it where cp jumped (at the start, or at a
        # slip's onset, where the friction changes at once)
        margin = edge if status == "tipping" else kern
        if margin > FACE_MARGIN * face.size:
            return "stop", f"{status} at t = {t_end:.9g} where the margin is {margin:.3g} m"
        return "ok", status
    if edge < -FACE_MARGIN * face.size or (system.pressure == "linear"
                                           and kern < -FACE_MARGIN * face.size):
        return "stop", f"done, but cp at the end is past the {'edge' if edge < 0 else 'kern'}"
    return "ok", status


# the general model's honest ends after a hand-over (a flat landing: the C's stop, crt_collide)
FLIGHT_ENDS = ("done", "flat_landing", "surface_jump", "painleve")


def judge_handover(result) -> tuple[str, str]:
    """A face run that lifted off and went on in the general model
    (derive/runtime/handover.py): the base part as :func:`judge_face_run` judges it (its
    lift-off at N = 0); then ``handover`` where the rows on both sides of it differ
    beyond round-off or from the base state's C = O + A OC (derive.runtime.choice's
    base_c, against the general state handed over), ``status`` where the flight ends
    otherwise than done or an honest stop, ``landing`` where a flat landing's corners are
    not within the height resolution, or those of the first touch coming down of a
    flight that goes on are."""
    from ..runtime import handover as ho
    from ..runtime.choice import base_c
    h = result.handover
    verdict, detail = judge_face_run(h.base)
    if verdict != "ok" or h.base.status != "lift_off":
        return verdict if verdict != "ok" else "status", detail or h.base.status
    i = len(h.base.t)
    scale = max(float(np.max(np.abs(h.state[:6]))), 1.0)
    jump = float(np.max(np.abs(result.model_q[i] - result.model_q[i - 1])))
    r_C, v_C, _, _ = base_c(h.base.scene, h.base.start, h.base.t[-1:], h.base.model_q[-1:])
    off = float(np.max(np.abs(np.concatenate([r_C[0], v_C[0]]) - h.state[:6])))
    if jump > 1e-12 * scale or off > 1e-12 * scale:
        return "handover", f"at t = {h.t:.9g} the state jumps by {max(jump, off):.3g}"
    if result.status not in FLIGHT_ENDS:
        return "status", f"the flight ended with {result.status} at t = {result.t[-1]:.6g}"
    if not np.all(np.isfinite(result.model_q)):
        return "nan", "non-finite state in the flight"
    # the first touch coming down (v_n below minus the runtime's speed noise) after the
    # hand-over's instant (at that instant the face is on the plane with v_n = 0, and the
    # C may touch it; after it, grazes with v_n > 0 as the face hovers, and round-off
    # touches as it leaves): no other is a landing
    def coming_down(ev) -> bool:
        return ev["v_minus"] < -ho.noise(h.flight, int(np.searchsorted(h.flight.t,
                                                                       ev["t"])))[1]
    touch = next((ev for ev in h.flight.events
                  if ev["kind"] in ("impact", "contact", "graze", "flat_landing")
                  and ev["t"] > ho.at_once(h.t) and coming_down(ev)), None)
    if touch is not None:
        j = int(np.searchsorted(h.flight.t, touch["t"]))
        q = h.flight.model_q[j]
        spread = ho.flat_spread(result.scene, q[ho.G.A])
        res = ho.noise(h.flight, j)[0]
        if (touch["kind"] == "flat_landing") != (spread <= res):
            return "landing", (f"{touch['kind']} at t = {touch['t']:.9g} with the corners "
                               f"{spread:.3g} m apart (resolution {res:.3g} m)")
    return "ok", f"lift_off, then {result.status}"
