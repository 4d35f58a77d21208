"""The laws whose compiled tables ``tests/test_law_tables.py`` holds to the ones recorded in
``tests/data/law_tables.json`` (by the parser before the tape of derive/scene/law/parse.py):
every law in the examples, every string and triple of strings in the tests that the parser
reads, the robustness generators' draws (smooth, rough, face: each scene's laws one by one
and all together, as the runtime gets them), random laws of the grammar and the hostile
ones (refused with the same message).  ``python tests/law_corpus.py`` rewrites the record
(only when the parser is meant to change what it builds)."""
from __future__ import annotations

import ast
import hashlib
import json
import random
import re
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "tests" / "data" / "law_tables.json"
DRAWS = 60                       # scenes per generator
NAMES = {"t", "pi", "e", "sin", "cos", "tan", "exp", "log", "sqrt", "sinh", "cosh", "tanh",
         "asin", "acos", "atan"}


def _toml_laws(doc: dict) -> list:
    out = []
    points = doc.get("point")
    for p in points if isinstance(points, list) else [points] if points else []:
        if isinstance(p, dict) and isinstance(p.get("law"), list):
            out.append(("law", tuple(p["law"])))
    for r in doc.get("rotor", []) or []:
        if isinstance(r, dict) and isinstance(r.get("law"), str):
            out.append(("angle", (r["law"],)))
    return out


def _scene_items(doc: dict) -> list:
    """A scene's laws one by one, and together (compile_outputs: the runtime's program)."""
    items = _toml_laws(doc)
    together = tuple(x for _, texts in items for x in texts)
    if len(items) > 1:
        items.append(("outputs", together))
    return items


def _law_like(text: str) -> bool:
    """A string of the tests that may be meant as a law: short, without letters beyond the
    grammar's names (most of the tests' strings are prose, names and paths)."""
    return len(text) <= 300 and re.fullmatch(r"[0-9a-z.+\-*/^() \t]*", text) is not None and \
        set(re.findall(r"[a-z]+", text)) <= NAMES


def _test_strings() -> list:
    """The law-like string literals of the tests, and every list or tuple of three."""
    out = []
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and _law_like(node.value):
                out.append(("angle", (node.value,)))
            elif isinstance(node, (ast.List, ast.Tuple)) and len(node.elts) == 3 and all(
                    isinstance(e, ast.Constant) and isinstance(e.value, str)
                    and _law_like(e.value) for e in node.elts):
                out.append(("law", tuple(e.value for e in node.elts)))
    return out


def corpus() -> list:
    """(kind, texts): kind law (three strings), angle (one) or outputs (several)."""
    from derive.verify import generators as g, laws as L
    items = []
    for path in sorted((ROOT / "derive").rglob("examples/*.toml")):
        items += _scene_items(tomllib.loads(path.read_text()))
    items += _test_strings()
    for k in range(DRAWS):
        for make in (lambda r: g.random_scene(r, 60.0), lambda r: g.random_rough_scene(r, 20.0),
                     lambda r: g.random_face_scene(r, 3.0)):
            items += _scene_items(make(np.random.default_rng(1000 + k)))
    rng = random.Random(5)
    for _ in range(200):
        items.append(("angle", (L.law_text(L.random_law(rng, rng.randint(1, 4))),)))
    for _ in range(40):
        items.append(("angle", (L.law_text(L.planted_law(rng, (0.2, 0.8))[1]),)))
    items += [("angle", (s,)) for s in [*L.HOSTILE_LAWS, *L.EITHER_LAWS] if len(s) <= 300]
    seen, out = set(), []
    for item in items:
        if item not in seen:
            seen.add(item)
            out.append(item)
    return out


def table(kind: str, texts: tuple) -> str:
    """The digest of the law's table (crt_set_law's arrays and the texts), or its refusal."""
    from derive import abi
    from derive.scene.law import parse as P
    try:
        prog = (P.compile_law(texts) if kind == "law" else P.compile_angle(texts[0])
                if kind == "angle" else P.compile_outputs(texts, abi.LAW_MAX_NODES))
    except P.LawError as exc:
        return f"{type(exc).__name__} {getattr(exc, 'k', '')}: {exc}"
    a = prog.arrays()
    h = hashlib.sha256()
    for x in (a["code"], a["consts"], a["outputs"], np.array([a["n_const"]])):
        h.update(np.ascontiguousarray(x).tobytes())
    h.update(repr(prog.text).encode())
    return h.hexdigest()[:20]


def record() -> list:
    return [[kind, list(texts), table(kind, texts)] for kind, texts in corpus()]


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    RECORD.parent.mkdir(exist_ok=True)
    RECORD.write_text("[\n" + ",\n".join(json.dumps(r) for r in record()) + "\n]\n")
    print(f"{RECORD}: {len(json.loads(RECORD.read_text()))} laws")
