"""The generated C library from Python, through ctypes.

:func:`load_generated` compiles ``generated/c`` (cached, see :mod:`derive.cbuild`) and
returns typed wrappers of the convenience functions ``carrier_<name>`` that take and
return NumPy arrays, in the order of the specifications' inputs and outputs.
"""
from __future__ import annotations

import ctypes
from pathlib import Path
from typing import Callable

import numpy as np

from .base import base_specs
from .cbuild import build_shared, generated_sources
from .models import FunctionSpec
from .models_moments import emitted_specs

DOUBLE_P = ctypes.POINTER(ctypes.c_double)


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(DOUBLE_P)


def wrap(lib: ctypes.CDLL, spec: FunctionSpec, prefix: str = "carrier_") -> Callable:
    fn = getattr(lib, prefix + spec.name)
    argtypes = [ctypes.c_double if len(v.entries) == 1 else DOUBLE_P for v in spec.inputs]
    argtypes += [DOUBLE_P for _ in spec.outputs]
    fn.argtypes, fn.restype = argtypes, None
    sizes_in = [len(v.entries) for v in spec.inputs]
    sizes_out = [len(v.entries) for v in spec.outputs]

    def call(*inputs):
        args = []
        keep = []
        for x, n in zip(inputs, sizes_in):
            arr = np.ascontiguousarray(x, dtype=float).reshape(-1)
            if arr.size != n:
                raise ValueError(f"{spec.name}: an input has {arr.size} entries, needs {n}")
            if n == 1:
                args.append(float(arr[0]))
            else:
                keep.append(arr)
                args.append(_ptr(arr))
        outs = [np.empty(n) for n in sizes_out]
        fn(*args, *[_ptr(o) for o in outs])
        return tuple(outs)

    call.__name__ = spec.name
    return call


def generated_library(folder: Path | None = None, flags: tuple = ("-O2",)) -> Path:
    from .emit.render import GENERATED
    return build_shared(generated_sources(folder or GENERATED / "c"), flags=flags,
                        name="libcarrier")


def load_generated(folder: Path | None = None) -> dict[str, Callable]:
    lib = ctypes.CDLL(str(generated_library(folder)))
    return {spec.name: wrap(lib, spec) for spec in emitted_specs() + base_specs()}
