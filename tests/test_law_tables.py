"""The law tables the parser builds, held to the record of the parser before its tape
(tests/law_corpus.py: the examples' laws, the tests' law strings, the robustness
generators' draws one by one and together, random and hostile laws): the same bytes for
crt_set_law, the same refusals word for word."""
from __future__ import annotations

import json
import random

import law_corpus
import numpy as np

from derive import abi
from derive.scene.law import parse as P


def test_every_recorded_law_builds_the_recorded_table_or_refusal():
    record = json.loads(law_corpus.RECORD.read_text())
    assert len(record) > 900
    assert sum(":" in r for *_, r in record) > 100          # refusals among them
    assert sum(k == "outputs" for k, *_ in record) > 40     # several bodies' programs
    wrong = [(kind, texts, want, got) for kind, texts, want in record
             if (got := law_corpus.table(kind, tuple(texts))) != want]
    assert not wrong, f"{len(wrong)} differ, first: {wrong[0]}"


def _program(texts: tuple, limit: int, parse):
    """The program of ``texts`` parsed into one builder by ``parse`` (P.parse_one: straight
    in, no tape; P.parse_into: through the recorded calls), or the refusal (which string,
    the message)."""
    b = P._Builder(limit)
    outs = []
    for k, text in enumerate(texts):
        try:
            outs.append(parse(text, b))
        except P.LawError as exc:
            return k, str(exc)
    return b.program(tuple(outs), texts).arrays()


def _direct(texts: tuple, limit: int):
    return _program(texts, limit, P.parse_one)


def _taped(texts: tuple, limit: int):
    return _program(texts, limit, P.parse_into)


def _same(x, y) -> bool:
    if isinstance(x, tuple) or isinstance(y, tuple):
        return x == y
    return all(np.array_equal(x[k], y[k]) for k in ("code", "consts", "outputs")) and \
        x["n_const"] == y["n_const"]


def test_a_replayed_tape_builds_what_the_parser_builds_into_the_same_builder():
    """The tape of each string, replayed into a builder that already holds other strings'
    nodes (several bodies' program, in random orders and under a small node limit),
    builds what parsing the strings straight into it builds, and refuses where it
    refuses: a value's refusal before a later syntax error, the limit before either."""
    record = json.loads(law_corpus.RECORD.read_text())
    strings = sorted({t for _, texts, _ in record for t in texts})
    rng = random.Random(3)
    cases = [tuple(rng.sample(strings, rng.randint(2, 9))) for _ in range(300)]
    cases += [("1/0 + (", "t"), ("t", "sin(t)*(1/0) + )"), ("t*" * 40 + "t", "0.1*(")]
    refused = 0
    for texts in cases:
        for limit in (abi.LAW_MAX_NODES, 12):
            want, got = _direct(texts, limit), _taped(texts, limit)
            assert _same(want, got), (texts, limit, want, got)
            refused += isinstance(want, tuple)
    assert refused > 100                     # the limit and the refusals reached
    assert _taped(("1/0 + (",), 99) == (0, "divides by zero in '1/0'")
