"""``derive emit``: render everything under ``generated/``, or compare with it."""
from __future__ import annotations

import difflib
from pathlib import Path

from ..base import base_specs
from ..models import layout_doc
from ..models_moments import emitted_specs
from .c_backend import render_c
from .casadi_backend import render_casadi
from .render import GENERATED
from .runtime_backend import render_controllers, render_runtime

MANAGED = ("c", "casadi", "cmake", "control", "runtime")   # folders of generated/ owned by emit
MANAGED_FILES = ("CMakeLists.txt", "Makefile")   # and files at its top


def render_all(progress=None) -> dict[str, bytes]:
    """Every file ``derive emit`` writes, path -> bytes.  ``progress``: told ``(stage,
    done, total, name)`` as the work goes: the derivations (one step), the C functions,
    the runtime's models (their CSE and printing: most of the time)."""
    def stage(label):
        return None if progress is None else \
            (lambda done, total, name: progress(label, done, total, name))
    if progress is not None:
        progress("deriving the functions", 0, 1, "")
    specs = emitted_specs() + base_specs()      # the paper's, the moments', the base model's
    if progress is not None:
        progress("deriving the functions", 1, 1, f"{len(specs)} functions")
    files = {k: v.encode("utf-8") for k, v in
             render_c(specs, GENERATED, layout_doc(), stage("the C functions")).items()}
    files.update({k: v.encode("utf-8")
                  for k, v in render_runtime(stage("the runtime's models")).items()})
    files.update({k: v.encode("utf-8") for k, v in render_controllers().items()})
    files.update(render_casadi(specs))
    return dict(sorted(files.items()))


def existing(root: Path) -> dict[str, bytes]:
    found: dict[str, bytes] = {}
    for folder in MANAGED:
        base = root / folder
        if base.is_dir():
            for path in sorted(base.rglob("*")):
                if path.is_file():
                    found[path.relative_to(root).as_posix()] = path.read_bytes()
    for name in MANAGED_FILES:
        path = root / name
        if path.is_file():
            found[name] = path.read_bytes()
    return dict(sorted(found.items()))


def write(files: dict[str, bytes], root: Path = GENERATED) -> list[str]:
    """Write ``files`` and delete managed files that are no longer produced."""
    changed = []
    old = existing(root)
    for rel, data in files.items():
        path = root / rel
        if old.get(rel) != data:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
            changed.append(rel)
    for rel in sorted(set(old) - set(files)):
        (root / rel).unlink()
        changed.append(rel)
    return changed


def diff(files: dict[str, bytes], root: Path = GENERATED) -> str:
    """Unified diff from what is in ``root`` to a fresh render (empty if identical)."""
    old = existing(root)
    chunks: list[str] = []
    for rel in sorted(set(old) | set(files)):
        a, b = old.get(rel), files.get(rel)
        if a == b:
            continue
        if rel.endswith(".casadi"):
            state = "missing" if a is None else ("stale" if b is None else "differs")
            chunks.append(f"--- generated/{rel}\n+++ fresh render\n(binary-safe file {state})\n")
            continue
        a_lines = [] if a is None else a.decode("utf-8").splitlines(keepends=True)
        b_lines = [] if b is None else b.decode("utf-8").splitlines(keepends=True)
        chunks.append("".join(difflib.unified_diff(
            a_lines, b_lines, fromfile=f"generated/{rel}", tofile=f"fresh/{rel}")))
    return "".join(chunks)
