"""Laws of the internal bodies given as formulas: a point's ``x(t), y(t), z(t)``, a
rotor's ``psi(t)``.  Parsed by a whitelist, proved twice differentiable over the whole
run, and compiled into a program the C runtime interprets (``crt_law.h``: value, first
and second derivative of every output in one forward pass).

* :mod:`.ops`: the opcodes (jets, interval enclosures, SymPy forms), one object each;
* :mod:`.program`: :class:`Program`, the compiled law, for C, NumPy and SymPy;
* :mod:`.parse`: the whitelist parser and the builder (constant folding, harmonics,
  shared subexpressions): :func:`compile_law`, each string parsed once and its builder
  calls replayed;
* :mod:`.proof`: the interval proof over a run (:func:`find_singularity`) and a point
  law's :class:`LawSummary`;

"""
from __future__ import annotations

from ..errors import LawError
from .ops import FUNCTIONS, OPS
from .parse import (MAX_DEPTH, MAX_LENGTH, MAX_NODES, MAX_POWER, CoordinateError, compile_law,
                    parse_law)
from .program import Program
from .proof import SAMPLES, LawSummary, Singularity, find_singularity, summarise

__all__ = ["FUNCTIONS", "MAX_DEPTH", "MAX_LENGTH", "MAX_NODES", "MAX_POWER", "OPS",
           "CoordinateError", "LawError", "LawSummary", "Program", "SAMPLES", "Singularity",
           "compile_law", "find_singularity", "parse_law", "summarise"]
