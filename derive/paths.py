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
