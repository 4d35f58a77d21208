"""Subcommands declared once: the commands of ``derive bench`` and ``derive verify``.

A :class:`Command` names a subcommand, its help, its arguments and the module that runs
it (``derive/bench/__init__.py`` and ``derive/verify/__init__.py`` list them).
:mod:`derive.cli` builds each subcommand's parser from its own arguments only (one
subcommand, one parser: an option of one command is refused by another) and runs every
command the same way::

    result = module.run(**arguments, progress=...)    # measure, or check
    print(module.report(result))                      # the table; each target PASS or FAIL
    ok = module.passed(result)                        # True: every target passed

and exits 0 when ``ok`` and 1 otherwise.  Each module builds its report's verdict lines
and its ``passed`` from one list of :class:`Target`, so a command that prints FAIL exits
non-zero and one that prints only PASS exits 0.  A module is imported when its command
runs, not when the parser is built (``derive --help`` stays fast).
"""
from __future__ import annotations

import argparse
import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Target:
    """One verdict of a report: what is required, with the measured value, and whether
    it holds."""
    what: str
    ok: bool

    def __post_init__(self):
        object.__setattr__(self, "ok", bool(self.ok))      # NumPy's bool_ too

    @property
    def mark(self) -> str:
        return "PASS" if self.ok else "FAIL"

    def __str__(self) -> str:
        return f"{self.what}: {self.mark}"


def all_pass(targets) -> bool:
    return all(t.ok for t in targets)


@dataclass(frozen=True)
class Arg:
    """An argument of a command: argparse's flags and options.  ``dest`` names the
    keyword argument of the module's ``run`` that receives it."""
    flags: tuple
    options: dict

    @classmethod
    def of(cls, *flags: str, **options) -> "Arg":
        return cls(tuple(flags), options)


@dataclass(frozen=True)
class Command:
    """A subcommand: ``module`` holds ``run``, ``report`` and ``passed``; any of the
    three may be given as ``"module:function"`` elsewhere instead."""
    name: str
    help: str
    module: str
    arguments: tuple = ()
    run: str = "run"
    report: str = "report"
    passed: str = "passed"

    def function(self, role: str):
        """The function playing ``role`` (run, report or passed), imported now."""
        ref = getattr(self, role)
        module, _, attr = ref.rpartition(":")
        return getattr(importlib.import_module(module or self.module), attr)


# ---- argument types: bad values are refused by the parser (exit 2) ---------------------
def count(lo: int, hi: int):
    """An integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, not {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi:,}] (got {value})")
        return value
    parse.__name__ = "count"
    return parse


def positive_float(text: str) -> float:
    """A finite float > 0."""
    import math
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, not {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be finite and > 0 (got {text})")
    return value

