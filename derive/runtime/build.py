"""Render a scene's model and the runtime into one C file, compile it (cached) and load
it with ctypes."""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from functools import lru_cache

from ..cbuild import build_shared, runtime_flags
from ..emit.c_backend import body
from ..emit.program import build as build_program
from ..emit.render import environment, versions
from . import tableaus as T
from .scene_models import SceneModel, generic_reference


def _c(x) -> str:
    return repr(float(x))


def _pairs(values) -> list:
    """(index, C literal) for the nonzero coefficients."""
    return [(j, _c(v)) for j, v in enumerate(values) if float(v) != 0.0]


@lru_cache(maxsize=None)
def tableau_context() -> dict:
    def dense_rows(rows, n):
        out = []
        for i in range(n):
            row = [0.0] * i
            for j, v in rows[i] if i < len(rows) else ():
                row[j] = float(v)
            out.append([_c(v) for v in row])
        return out
    return {
        "dopri5": {"a": dense_rows(T.DOPRI5_A, 7), "c": [_c(v) for v in T.DOPRI5_C],
                   "e": [_c(v) for v in T.DOPRI5_E], "d": [_c(v) for v in T.DOPRI5_D]},
        "dop853": {"a_pairs": [[(j, _c(v)) for j, v in row if float(v) != 0.0]
                               for row in T.DOP853_A],
                   "c": [_c(v) for v in T.DOP853_C], "b_pairs": _pairs(T.DOP853_B),
                   "e3_pairs": _pairs(T.DOP853_E3), "e5_pairs": _pairs(T.DOP853_E5),
                   "d_pairs": [_pairs(row) for row in T.DOP853_D]},
    }


@dataclass
class Rendered:
    source: str
    rhs_ops: int
    generic_ops: int


def render(model: SceneModel, scene_name: str, params: tuple = ()) -> Rendered:
    """``params``: symbols left in the model, read at run time from ``env->prm``
    (set with ``crt_set_params``): one compiled library for a whole parameter sweep."""
    env = environment()
    bodies = {name: body(spec, params=params) for name, spec in model.specs.items()}
    generic = generic_reference(model.kind)
    generic_ops = build_program(generic).ops
    ctx = {"template": "templates/runtime/scene_model.c.jinja", "versions": versions(),
           "scene_name": scene_name, "kind": model.kind, "nq": len(model.labels),
           "labels": model.labels, "plane": model.has_plane, "z_index": model.z_index,
           "zd_index": model.zd_index, "normalize": model.normalize,
           "rhs_ops": bodies["rhs"]["ops"], "generic_ops": generic_ops,
           "params": [str(p) for p in params],
           "generic_name": generic.name, **bodies}
    source = env.get_template("runtime/scene_model.c.jinja").render(**ctx)
    source += env.get_template("runtime/runtime.c.jinja").render(**tableau_context())
    return Rendered(source=source, rhs_ops=bodies["rhs"]["ops"], generic_ops=generic_ops)


class Library:
    """The compiled runtime of one scene, through ctypes."""

    def __init__(self, path):
        self.path = path
        lib = ctypes.CDLL(str(path))
        d = ctypes.POINTER(ctypes.c_double)
        i = ctypes.POINTER(ctypes.c_int)
        lib.crt_sizeof.restype = ctypes.c_int
        lib.crt_nq.restype = ctypes.c_int
        lib.crt_init.argtypes = [ctypes.c_void_p, d, ctypes.c_double, d]
        lib.crt_init.restype = ctypes.c_int
        lib.crt_advance.argtypes = [ctypes.c_void_p, ctypes.c_double, d, d, i, ctypes.c_int, i,
                                    d, ctypes.c_int, i]
        lib.crt_advance.restype = ctypes.c_int
        lib.crt_stats.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_long)]
        lib.crt_time.argtypes = [ctypes.c_void_p]
        lib.crt_time.restype = ctypes.c_double
        lib.crt_phase.argtypes = [ctypes.c_void_p]
        lib.crt_phase.restype = ctypes.c_int
        lib.crt_set_params.argtypes = [ctypes.c_void_p, d]
        lib.crt_n_params.restype = ctypes.c_int
        self.lib = lib
        self.nq = lib.crt_nq()
        self.session_size = lib.crt_sizeof()
        self.n_params = lib.crt_n_params()


def compile_scene(rendered: Rendered, flags: tuple | None = None) -> Library:
    flags = runtime_flags() if flags is None else flags
    path = build_shared({"scene_runtime.c": rendered.source}, flags=flags, name="scene")
    library = Library(path)
    library.flags = flags
    return library
