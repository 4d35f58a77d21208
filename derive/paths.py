"""Where the project's data folders are: ``templates/`` (read by the emitters) and
``generated/`` (written by ``derive emit``, read by the runtime).  One place, so that the
runtime needs neither jinja2 nor the emitters to find its C."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ROOT / "templates"
GENERATED = ROOT / "generated"
