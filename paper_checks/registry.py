"""Registration of checks by catalogue ID: ``@check("E1.7")`` files a check under its ID.

The sections (``section1`` ... ``section4``, ``extensions``) import this module and
register their checks; :mod:`paper_checks.runner` imports the sections and runs a check
by its ID.  Nothing here imports a section.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


class CheckFailed(AssertionError):
    """A derived expression disagrees with the paper, or a claim does not hold."""


@dataclass
class Erratum:
    id: str
    printed: str
    correct: str
    consequence: str


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
