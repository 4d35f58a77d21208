"""Where the project's data folders are: ``templates/`` (read by the emitters) and
``generated/`` (written by ``derive emit``, read by the runtime).  One place, so that the
runtime needs neither jinja2 nor the emitters to find its C.

Two layouts, one answer:

* a checkout (``pip install -e .``): the folders at the top of the repository, beside
  ``derive/`` and ``pyproject.toml``; ``derive emit`` rewrites ``generated/`` there;
* an installed wheel: the same folders are package data of ``derive`` (pyproject.toml
  maps the top-level ``templates/`` and ``generated/`` to ``derive/templates`` and
  ``derive/generated``), found through :mod:`importlib.resources`.  They are read only:
  ``derive emit -o DIR`` renders elsewhere.
"""
from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

_CHECKOUT_ROOT = Path(__file__).resolve().parents[1]


def _is_checkout(root: Path) -> bool:
    return ((root / "pyproject.toml").is_file() and (root / "templates").is_dir()
            and (root / "generated").is_dir())


def _package_data() -> Path:
    data = resources.files(__package__)
    if not isinstance(data, Path):
        raise RuntimeError(f"derive is installed as {data!r}, not as files: its templates "
                           "and generated C must be readable as files (install the wheel "
                           "unzipped, as pip does)")
    return data


CHECKOUT = _is_checkout(_CHECKOUT_ROOT)
ROOT = _CHECKOUT_ROOT if CHECKOUT else _package_data()
TEMPLATES = ROOT / "templates"
GENERATED = ROOT / "generated"


# The hand-written C of the runtime and of the controllers is read from generated/runtime
# and templates/control; ``$DERIVE_C_SOURCES`` names a folder holding ``runtime/`` and
# ``control/`` to read in their place (``derive verify mutants`` builds each mutant from
# a scratch copy there, never touching these folders).
C_SOURCES_ENV = "DERIVE_C_SOURCES"


def c_sources(part: str) -> Path:
    """The folder of the runtime's C (``part`` "runtime") or of the controllers'
    hand-written C ("control")."""
    home = {"runtime": GENERATED / "runtime", "control": TEMPLATES / "control"}[part]
    override = os.environ.get(C_SOURCES_ENV)
    return Path(override) / part if override else home
