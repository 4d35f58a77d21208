"""pytest entry: one test per catalogue ID; a catalogue ID without a check fails."""
from __future__ import annotations

import pytest

from paper_checks.catalogue import entries
from paper_checks.runner import run

IDS = [e.id for e in entries()]


@pytest.mark.parametrize("claim_id", IDS)
def test_claim(claim_id):
    outcome = run(claim_id)
    assert outcome.status in ("pass", "erratum"), \
        f"{claim_id}: {outcome.status}: {outcome.detail}"


def test_catalogue_is_read():
    ids = [e.id for e in entries()]
    assert "E1.8a" in ids and "E3.3" in ids and "E4.5" in ids and "O4" in ids
    assert len(ids) == len(set(ids))
