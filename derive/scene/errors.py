"""The one error a scene, a task or an override raises: :class:`SceneError`, naming the
field (``[body].mass``, ``[plan].region.radius``, ``initial.com[2]``) and the rule."""
from __future__ import annotations

import re

# the characters a message never shows raw: C0 and C1 controls (tab and newline
# included), DEL, the line and paragraph separators and the bidi embeddings, overrides
# and isolates.  The one definition: the scene's messages escape them (printable) and the
# fuzzers' judges (derive/verify) look for them (has_unprintable).
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def printable(text: str) -> str:
    """Control, line-break and bidi characters of a scene escaped (\\x1b, \\n, ...): a
    message is one line and cannot drive the terminal."""
    return _UNPRINTABLE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"),
                            str(text))


def has_unprintable(text: str) -> bool:
    """True when ``text`` holds a character that :func:`printable` would escape."""
    return _UNPRINTABLE.search(str(text)) is not None


class SceneError(ValueError):
    """A scene that breaks a rule: ``where`` names the field, ``rule`` says what."""

    def __init__(self, where: str, rule: str):
        where, rule = printable(where), printable(rule)
        if len(where) > 120:                  # a stranger's 5000-character key or index
            where = where[:117] + "..."
        super().__init__(f"{where}: {rule}")
        self.where, self.rule = where, rule


def type_name(value) -> str:
    """How a message calls the type of a value a scene gave."""
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a table"}.get(type(value), type(value).__name__)


class LawError(ValueError):
    """A law that is malformed, unsafe, or not twice differentiable on the run (the law
    modules raise it; the rules turn it into a :class:`SceneError` naming the field)."""
