"""plan.json: what a plan reports, as dataclasses.

``Summary.to_json()`` writes the keys the README describes, with their meanings
(readers of plan.json rely on them): ``goal``, ``objective``, ``solver``,
``stability_attempts`` (a hop whose first orbit was checked), then for a solved plan
``law``, ``nlp_estimate``, ``achieved``, ``stability`` (a hop), and always ``status``,
``message``, ``blocking`` (a plan that failed) and ``total_seconds``.  The goal's own
figures (``achieved``, ``nlp_estimate``, ``stability``, ``blocking``) are dicts made by
the goal object (:mod:`derive.planner.goals`) and the diagnosis
(:mod:`derive.planner.diagnose`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field


from .. import json_text


@dataclass
class SolverStats:
    ipopt_and_defect_correction_seconds: float
    nlp_build_seconds: float
    solves: list                 # per IPOPT run kept: round, status, iterations, seconds
    iterations: int
    intervals: int
    rk4_substeps: int
    variables: int
    constraints: int
    continuity_with_exact_flow: float   # max |Q_{k+1} - flow(Q_k)| at the end

    @classmethod
    def of(cls, report) -> "SolverStats":
        tr = report.tr
        return cls(report.solver_seconds, report.build_seconds, report.rounds,
                   int(sum(r["iterations"] for r in report.rounds)), tr.N, tr.m,
                   int(tr.w.shape[0]), int(tr.g.shape[0]), report.continuity_exact)


@dataclass
class LawStats:
    kind: str                    # cartesian | circle
    pieces: int
    duration: float              # T
    ends: str                    # periodic | rest | free
    table_rows: int
    table_reproduction_error: float
    max_acceleration: float      # max |OP''| on a fine grid
    max_distance_from_region_center: float
    effort: float                # integral of |OP''|^2


@dataclass
class BodiesLawStats:
    """The law of a task of several bodies (derive.planner.bodies): per decided body
    (``bodies``: name, effort, and a point's max_acceleration and
    max_distance_from_region_center, a rotor's max_rate, max_acceleration and turn,
    psi(T) - psi(0)); ``effort`` the objective's: the integral of each decided body's
    (acceleration / its bound)^2."""
    kind: str                    # bodies
    pieces: int
    duration: float
    ends: str                    # rest | free
    decided: list                # "point 1", "rotor 2", ...
    table_rows: int              # of each table
    table_reproduction_error: float
    bodies: list
    effort: float

    unit = "s (integral of each decided body's (acceleration / bound)^2)"


@dataclass
class Objective:
    kind: str                    # effort | time
    value: float | None = None
    unit: str | None = None

    @classmethod
    def of(cls, kind: str, law) -> "Objective":
        if kind == "effort":
            return cls("effort", law.effort, getattr(law, "unit",
                                                     "m^2/s^3 (integral of |OP''|^2)"))
        return cls("time", law.duration, "s")

    def to_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass
class Summary:
    goal: str
    objective: Objective
    solver: SolverStats
    status: str = ""             # solved | infeasible | failed
    message: str = ""
    total_seconds: float = math.nan
    stability_attempts: list = field(default_factory=list)
    blocking: dict | None = None     # a plan that failed: the diagnosis
    law: LawStats | BodiesLawStats | None = None
    nlp_estimate: dict | None = None
    achieved: dict | None = None     # per re-simulation: scipy, runtime
    stability: dict | None = None    # a hop: multipliers and their checks

    @property
    def ok(self) -> bool:
        return self.status == "solved"

    def to_dict(self) -> dict:
        out = {"goal": self.goal, "objective": self.objective.to_dict(),
               "solver": asdict(self.solver)}
        if self.stability_attempts:
            out["stability_attempts"] = self.stability_attempts
        if self.law is not None:
            out["law"] = asdict(self.law)
            out["nlp_estimate"] = self.nlp_estimate
            out["achieved"] = self.achieved
            if self.stability is not None:
                out["stability"] = self.stability
        out.update(status=self.status, message=self.message)
        if not self.ok:
            out["blocking"] = self.blocking
        out["total_seconds"] = self.total_seconds
        return out

    def to_json(self) -> str:
        return json_text.dumps(self.to_dict())
