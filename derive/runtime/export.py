"""``derive export SCENE -o DIR``: a scene as a standalone C project, no Python at run time.

The folder holds the runtime ``derive simulate`` runs (``model_<kind>.c`` of the model the
scene chooses, and the ``crt_*.h`` headers it includes, copied byte for byte from
``generated/runtime``: no other model), the scene's numbers as C (``scene.h``,
``scene.c``: the option and parameter vectors, the initial state and the law's arrays,
each number rebuilt from the parsed :class:`~derive.scene.Scene` through
:func:`derive.runtime.driver.prepare`, the same path a run takes), an example program
(``main.c``: crt_init, crt_advance to the end through every pause, trajectory.csv and
events.csv), a Makefile, a CMakeLists.txt and a README.  Rendered from
``templates/export/``: the same scene gives the same files, byte for byte.

Nothing of the scene file's text reaches the C: numbers are printed from floats
(``repr``, which C reads back to the same double), integers from ints, and every name in
the files (states, events, statuses) is the runtime's own.  What the export cannot carry
is refused by name (:func:`refusal`): ``[control]`` (a controller runs in Python or in a
compiled library the loop calls), ``[disturbance]`` (pushes need a loop closed by
Python) and, on a base run, the keys only its hand-over to the flight reads.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from .. import abi
from ..cbuild import RUNTIME_FLAGS, BuildError, compiler
from ..scene import SceneError, load_scene
from . import law_c
from .build import runtime_dir
from .driver import prepare

TEMPLATE_DIR = "export"
# the session's memory the caller gives (scene_memory): the runtime's crt_session of this
# model fits in it on LP64 machines with a quarter to spare; scene.c checks it at compile
# time
SESSION_QUANTUM = 4096
ROWS, EVENTS = 64, 16            # the example program's buffers (crt_advance pauses on them)


def refusal(scene) -> str | None:
    """What of ``scene`` the export cannot carry, by name (None: it carries it all)."""
    if scene.control is not None:
        return ("[control]: a closed loop's controller runs in Python or in a library the "
                "loop loads (derive.control); the export runs the scene's own law (drop "
                "[control], or run it with derive simulate)")
    if scene.disturbance is not None:
        return ("[disturbance]: pushes and noise are applied by a loop Python closes "
                "around the run; the export runs the plain scene (drop [disturbance], or "
                "run it with derive simulate)")
    python_only = [o for o in scene.outputs if o in _PYTHON_COLUMNS]
    if "[run].outputs" in scene.given and python_only:
        return (f"[run].outputs: {', '.join(python_only)} are columns derive simulate "
                "computes in Python from the state; the exported program writes the state "
                "(drop them from [run].outputs, or compute them from the state)")
    handover = [k for k in _HANDOVER_KEYS if k in scene.given]
    if handover:
        from .choice import choose
        if choose(scene)[0] == "base":
            return (f"{handover[0]}: a base run reads it only in derive simulate's hand-over "
                    "(the flight after a lift-off and its landing), and the exported program "
                    "has no hand-over: it stops where the body lifts off (status lift_off); "
                    "remove it, or run the scene with derive simulate")
    return None


# the keys a base run reads only in the hand-over (derive/runtime/handover.py)
_HANDOVER_KEYS = ("[plane].restitution", "[plane].restitution_model", "[run].zeno_dt")


# [run].outputs the exported program cannot write (derive simulate's Python columns)
_PYTHON_COLUMNS = ("omega", "height", "momentum")


def _c_double(value: float, where: str) -> str:
    """A double as C source that reads back to the same double (finite: Python's shortest
    repr; infinite: HUGE_VAL)."""
    v = float(value)
    if math.isnan(v):
        raise SceneError(where, "is NaN: the export writes numbers only")
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "-HUGE_VAL"
    text = repr(v)
    if not re.fullmatch(r"-?[0-9]+(\.[0-9]+)?(e[-+]?[0-9]+)?", text):
        raise AssertionError(f"unexpected float text {text!r}")     # (never: a float)
    return text if ("." in text or "e" in text) else text + ".0"


def _doubles(values, where: str) -> list[str]:
    return [_c_double(v, where) for v in np.asarray(values, dtype=float).reshape(-1)]


def _ints(values) -> list[str]:
    return [str(int(v)) for v in np.asarray(values).reshape(-1)]


def included(kind: str) -> list[str]:
    """``model_<kind>.c`` and the headers the preprocessor includes into it (``cc -E -H``:
    the branches of ``#if`` the model takes, not every ``#include`` written): the runtime
    files the scene's model needs, no more."""
    folder = runtime_dir()
    first = f"model_{kind}.c"
    if not (folder / first).is_file():
        raise FileNotFoundError(f"{folder} lacks {first}: run `derive emit`")
    proc = subprocess.run([compiler(), "-std=c99", "-E", "-H", "-I", str(folder),
                           str(folder / first)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"the C preprocessor failed on {first}:\n{proc.stderr[-2000:]}")
    names = set()
    for line in proc.stderr.splitlines():
        m = re.match(r"^\.+ (.+)$", line)
        if m and Path(m.group(1)).parent.resolve() == folder.resolve():
            names.add(Path(m.group(1)).name)
    return [first, *sorted(names)]


def _law(law) -> dict:
    """The law's arrays for scene.c and the call that hands them to the runtime."""
    arrays = law.arrays()
    kind = getattr(law, "kind", "")
    if kind == "bodies":
        a = arrays
        return {"kind": "bodies", "n_points": int(a["n_points"]),
                "n_rotors": int(a["n_rotors"]), "out": _ints(a["out"]),
                "n_nodes": int(a["n_nodes"]), "n_const": int(a["n_const"]),
                "code": _ints(a["code"]), "consts": _doubles(a["consts"], "law"),
                "n_knots": int(a["n_knots"]), "n_columns": int(a["n_columns"]),
                "knots": _doubles(a["knots"], "law"), "coef": _doubles(a["coef"], "law"),
                "periodic": int(a["periodic"])}
    if kind == "table":
        return {"kind": "table", "knots": _doubles(arrays["knots"], "law"),
                "coef": _doubles(arrays["coef"], "law"),
                "periodic": 1 if law.periodic else 0}
    return {"kind": "program", "code": _ints(arrays["code"]), "n_nodes": len(arrays["code"]),
            "n_const": int(arrays["n_const"]), "consts": _doubles(arrays["consts"], "law"),
            "out": _ints(arrays["outputs"])}


def law_width(law) -> int:
    """The numbers of the law's u at a time (crt_law_width): 9 for one point, 9 per point
    and 3 per rotor for a law of bodies."""
    return int(law.width) if getattr(law, "kind", "") == "bodies" else 9


def context(scene) -> dict:
    """Everything the templates render for ``scene`` (a path, a dict or a Scene)."""
    from .build import library
    scene = load_scene(scene)
    why = refusal(scene)
    if why is not None:
        table, rule = why.split(": ", 1)
        raise SceneError(table, rule)
    prep = prepare(scene)
    sc = prep.scene
    lib = library(prep.kind)
    labels = lib.labels
    size = lib.session_size
    options = [(e.name, v) for e, v in zip(abi.OPTIONS, _doubles(prep.options, "options"))]
    params = [(e.name, v) for e, v in zip(abi.PARAMETERS,
                                          _doubles(prep.parameters, "parameters"))]
    q0 = list(zip(labels, _doubles(prep.start.q0, "initial")))
    from ..emit.render import versions
    return {
        "kind": prep.kind, "nq": len(labels), "labels": labels,
        "options": options, "parameters": params, "q0": q0,
        "t0": _c_double(sc.t0, "[run].t0"),
        "t_end": _c_double(sc.t0 + sc.duration, "[run].duration"),
        "law": _law(sc.runtime_law), "law_width": law_width(sc.runtime_law),
        "law_jets": law_c.function(sc.runtime_law, lambda v: _c_double(v, "law")),
        "runtime": included(prep.kind),
        "session_bytes": -(-(size + size // 4) // SESSION_QUANTUM) * SESSION_QUANTUM,
        "statuses": abi.STATUSES, "row_kinds": abi.ROW_KINDS, "stats": abi.STATS,
        "event_columns": abi.EVENT_COLUMNS, "summary": abi.SUMMARY,
        "event_column_width": 1 + max(len(c) for c in abi.EVENT_COLUMNS),
        "min_rows": abi.MIN_ROWS, "min_events": abi.MIN_EVENTS,
        "rows": ROWS, "events": EVENTS, "versions": versions(),
        "flags": " ".join(RUNTIME_FLAGS),
    }


RENDERED = ("scene.h", "scene.c", "main.c", "Makefile", "CMakeLists.txt", "README.md")


def files(scene) -> dict[str, bytes]:
    """The project's files, name -> bytes (the runtime's copied, the rest rendered)."""
    from ..emit.render import environment
    ctx = context(scene)
    env = environment()
    out = {name: env.get_template(f"{TEMPLATE_DIR}/{name}.jinja").render(**ctx).encode()
           for name in RENDERED}
    folder = runtime_dir()
    for name in ctx["runtime"]:
        out[name] = (folder / name).read_bytes()
    return dict(sorted(out.items()))


# the names an export wrote into its folder, one a line (what a later --force may remove)
MANIFEST = ".derive-export"


def written_before(path: Path) -> set[str]:
    """The files a previous export recorded in ``path``'s manifest: plain names in the
    folder itself (a line naming another folder's file, or none, is not one of ours)."""
    try:
        lines = (path / MANIFEST).read_text(encoding="utf-8").splitlines()
    except (FileNotFoundError, UnicodeDecodeError):
        return set()
    return {n for n in lines if n and not n.startswith("#") and n not in (".", "..")
            and "/" not in n and "\\" not in n and n != MANIFEST}


def write(project: dict[str, bytes], folder, force: bool = False) -> Path:
    """Write the project into ``folder`` with its manifest (:data:`MANIFEST`, the names
    written): refused (FileExistsError, nothing written) when it exists, unless
    ``force``; then its files of these names are replaced and the files the previous
    export's manifest names that this project does not have (a model's runtime it no
    longer needs) are removed, so that the folder holds exactly the project's files
    besides the user's own, which are left.  Written into a hidden folder beside it and
    moved into place."""
    path = Path(folder)
    if path.exists() and not force:
        raise FileExistsError(f"{folder} exists (--force writes into it)")
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"{folder} is a file, not a folder")
    path.parent.mkdir(parents=True, exist_ok=True)
    manifest = ("# written by derive export: derive export --force replaces these files "
                "and removes those a new export does not write\n"
                + "".join(f"{name}\n" for name in sorted(project))).encode()
    stage = Path(tempfile.mkdtemp(prefix=".export-", dir=path.parent))
    try:
        for name, data in {**project, MANIFEST: manifest}.items():
            (stage / name).write_bytes(data)
        if not path.exists():
            os.replace(stage, path)
            return path
        stale = written_before(path) - set(project)
        for name in (*project, MANIFEST):
            os.replace(stage / name, path / name)
        for name in sorted(stale):
            if (path / name).is_file() and not (path / name).is_symlink():
                (path / name).unlink()
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)
    return path
