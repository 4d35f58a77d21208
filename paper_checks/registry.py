"""Registration of checks by catalogue ID and the outcome of running one."""
from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field
from typing import Callable


class CheckFailed(AssertionError):
    """A derived expression disagrees with the paper, or a claim does not hold."""


@dataclass
class Erratum:
    id: str
    printed: str
    correct: str
    consequence: str


@dataclass
class Outcome:
    id: str
    status: str                 # "pass", "erratum", "fail", "missing", "error"
    seconds: float = 0.0
    detail: str = ""
    errata: list[Erratum] = field(default_factory=list)
    shown: list = field(default_factory=list)    # (label, expression) for the report


class Report:
    """What a check hands back besides passing: errata and a one-line detail."""

    def __init__(self, check_id: str):
        self.id = check_id
        self.errata: list[Erratum] = []
        self.detail = ""
        self.shown: list = []

    def erratum(self, printed: str, correct: str, consequence: str) -> None:
        self.errata.append(Erratum(self.id, printed, correct, consequence))

    def show(self, label: str, expr) -> None:
        """A derived expression the report prints beside the verdict."""
        self.shown.append((label, expr))


CHECKS: dict[str, Callable[[Report], None]] = {}


def check(check_id: str):
    def register(fn: Callable[[Report], None]):
        if check_id in CHECKS:
            raise ValueError(f"two checks for {check_id}")
        CHECKS[check_id] = fn
        return fn
    return register


def load_all() -> dict[str, Callable[[Report], None]]:
    from . import (extensions, internal_motion, section1, section2, section3,  # noqa: F401
                   section4)  # (registration)
    return CHECKS


def run(check_id: str) -> Outcome:
    checks = load_all()
    fn = checks.get(check_id)
    if fn is None:
        return Outcome(check_id, "missing", 0.0, "no check registered for this ID")
    report = Report(check_id)
    start = time.perf_counter()
    try:
        fn(report)
    except CheckFailed as exc:
        return Outcome(check_id, "fail", time.perf_counter() - start, str(exc))
    except Exception as exc:  # a crash in a check is a failure, reported with its cause
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return Outcome(check_id, "error", time.perf_counter() - start, tb)
    status = "erratum" if report.errata else "pass"
    return Outcome(check_id, status, time.perf_counter() - start, report.detail,
                   report.errata, report.shown)
