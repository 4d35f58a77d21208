"""Deleting paper_checks/ leaves a working derivation: derive never imports it."""
from __future__ import annotations

import subprocess
import sys

CODE = """
import sys
sys.modules['paper_checks'] = None          # any import of paper_checks now fails
from derive.equations import BUILDERS, derived
for eid in BUILDERS:
    derived(eid)
from derive.models import all_specs
assert len(all_specs()) >= 9
from derive.cli import main
raise SystemExit(main(['prove']))
"""


def test_derivation_runs_without_paper_checks():
    proc = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                          timeout=600)
    # the derivation succeeded; `prove` alone reports that it has nothing to run
    assert proc.returncode == 2, proc.stderr
    assert "paper_checks/ folder is not importable" in proc.stderr
    assert "Traceback" not in proc.stderr
