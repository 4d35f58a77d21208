"""Running a check by its catalogue ID: :func:`run` gives its :class:`Outcome`.

The runner imports the sections, whose checks register themselves in
:mod:`paper_checks.registry` as they are imported; the registry imports no section.
"""
from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field

from . import extensions, internal_motion, section1, section2, section3, section4
from .registry import CHECKS, CheckFailed, Erratum, Report

SECTIONS = (section1, section2, section3, section4, extensions, internal_motion)


@dataclass
class Outcome:
    id: str
    status: str                 # "pass", "erratum", "fail", "missing", "error"
    seconds: float = 0.0
    detail: str = ""
    errata: list[Erratum] = field(default_factory=list)
    shown: list = field(default_factory=list)    # (label, expression) for the report


def run(check_id: str) -> Outcome:
    """Run the check registered for ``check_id`` (by a module of :data:`SECTIONS`)."""
    fn = CHECKS.get(check_id)
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
