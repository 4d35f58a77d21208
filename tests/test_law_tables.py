"""The law tables the parser builds, held to the record of the parser before its tape
(tests/law_corpus.py: the examples' laws, the tests' law strings, the robustness
generators' draws one by one and together, random and hostile laws): the same bytes for
crt_set_law, the same refusals word for word."""
from __future__ import annotations

import json

import law_corpus


def test_every_recorded_law_builds_the_recorded_table_or_refusal():
    record = json.loads(law_corpus.RECORD.read_text())
    assert len(record) > 900
    assert sum(":" in r for *_, r in record) > 100          # refusals among them
    assert sum(k == "outputs" for k, *_ in record) > 40     # several bodies' programs
    wrong = [(kind, texts, want, got) for kind, texts, want in record
             if (got := law_corpus.table(kind, tuple(texts))) != want]
    assert not wrong, f"{len(wrong)} differ, first: {wrong[0]}"
