"""The jinja2 environment over ``templates/`` and the tool versions for preambles."""
from __future__ import annotations

from functools import lru_cache
from importlib import metadata
import jinja2

from ..paths import GENERATED, ROOT, TEMPLATES  # noqa: F401  (re-exported)


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "absent"


@lru_cache(maxsize=None)
def versions() -> dict[str, str]:
    """Versions written into every generated file (no Python patch level, no paths)."""
    return {"derive": _version("markeev-carrier"), "sympy": _version("sympy"),
            "casadi": _version("casadi"), "jinja2": _version("jinja2")}


@lru_cache(maxsize=None)
def environment() -> jinja2.Environment:
    if not TEMPLATES.is_dir():
        raise FileNotFoundError(
            f"templates/ not found at {TEMPLATES}: neither a checkout nor an installation "
            "with its package data (derive/paths.py)")
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATES)),
        undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
        keep_trailing_newline=True, autoescape=False)
