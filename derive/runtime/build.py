"""The compiled runtime of each model: built once per machine from ``generated/runtime``,
cached, and loaded with ctypes.

``library(kind)`` compiles ``generated/runtime/model_<kind>.c`` (with the runtime headers
beside it) the first time it is asked for on a machine; the build is cached by a hash of
the sources, the flags and the compiler (:mod:`derive.cbuild`), so later calls, in this
process or any other, only load it.  No SymPy, no code generation and no compiler run on
the path of a simulation once the library exists.
"""
from __future__ import annotations

import ctypes
import time
from functools import lru_cache
from pathlib import Path

from ..cbuild import build_shared, runtime_flags
from .. import abi

KINDS = ("general", "rough", "vertical", "attitude", "translational", "planar",
         "axisymmetric", "variational", "moments", "moments_rough", "base")

DP = ctypes.POINTER(ctypes.c_double)
IP = ctypes.POINTER(ctypes.c_int)


def runtime_dir() -> Path:
    """generated/runtime (or the folder $DERIVE_C_SOURCES puts in its place)."""
    from ..paths import c_sources
    return c_sources("runtime")


def sources(kind: str) -> dict[str, bytes]:
    """``model_<kind>.c`` and the runtime's headers (every ``crt_*.h`` that ``derive emit``
    wrote beside it: each model's file includes them through crt_core.h)."""
    folder = runtime_dir()
    if kind not in KINDS:
        raise KeyError(kind)
    names = [*sorted(p.name for p in folder.glob("crt_*.h")), f"model_{kind}.c"]
    missing = [n for n in ("crt_core.h", f"model_{kind}.c") if not (folder / n).is_file()]
    if missing:
        raise FileNotFoundError(f"{folder} lacks {', '.join(missing)}: run `derive emit`")
    return {n: (folder / n).read_bytes() for n in names}


class Library:
    """One model's runtime through ctypes; checks its name tables against
    :mod:`derive.abi` when loaded."""

    def __init__(self, path: Path, kind: str, build_seconds: float = 0.0):
        self.path, self.kind, self.build_seconds = Path(path), kind, build_seconds
        lib = ctypes.CDLL(str(path))
        c = ctypes
        for name, res, args in (
                ("crt_sizeof", c.c_int, []), ("crt_nq", c.c_int, []),
                ("crt_has_plane", c.c_int, []), ("crt_has_friction", c.c_int, []),
                ("crt_model_name", c.c_char_p, []),
                ("crt_count", c.c_int, [c.c_int]),
                ("crt_state_name", c.c_char_p, [c.c_int]),
                ("crt_set_law_program", c.c_int, [c.c_void_p, c.c_int, c.c_int, IP, DP,
                                                  c.c_int, IP]),
                ("crt_set_law_table", c.c_int, [c.c_void_p, c.c_int, DP, DP, c.c_int]),
                ("crt_set_law_bodies", c.c_int, [c.c_void_p, c.c_int, c.c_int, IP, c.c_int,
                                                 c.c_int, IP, DP, c.c_int, c.c_int, c.c_int,
                                                 DP, DP, c.c_int]),
                ("crt_law_width", c.c_int, [c.c_void_p]),
                ("crt_law_at", None, [c.c_void_p, c.c_double, DP]),
                ("crt_law_rows", None, [c.c_void_p, c.c_int, DP, DP]),
                ("crt_init", c.c_int, [c.c_void_p, DP, DP, c.c_double, DP]),
                ("crt_bad_option", c.c_int, [c.c_void_p]),
                ("crt_bad_parameter", c.c_int, [c.c_void_p]),
                ("crt_advance", c.c_int, [c.c_void_p, c.c_double, DP, DP, IP, c.c_int, IP,
                                          DP, c.c_int, IP]),
                ("crt_run", c.c_int, [c.c_void_p, DP, DP, c.c_double, DP, c.c_double, DP, DP,
                                      IP, c.c_int, IP, DP, c.c_int, IP, c.POINTER(c.c_long),
                                      DP, IP]),
                ("crt_run_many", None, [c.c_void_p, c.c_int, DP, DP, DP, DP, DP, DP, DP, IP,
                                         c.c_int, DP, c.c_int, IP, IP, c.POINTER(c.c_long),
                                         DP, DP, DP]),
                ("crt_stats", None, [c.c_void_p, c.POINTER(c.c_long)]),
                ("crt_summary", None, [c.c_void_p, DP]),
                ("crt_time", c.c_double, [c.c_void_p]),
                ("crt_phase", c.c_int, [c.c_void_p]),
                ("crt_state", None, [c.c_void_p, DP]),
                ("crt_eval_rhs", None, [c.c_void_p, c.c_double, DP, DP]),
                ("crt_eval_rhs_rows", None, [c.c_void_p, c.c_int, DP, DP, DP]),
                ("crt_u_width", c.c_int, []),
                ("crt_eval_u_rows", None, [c.c_void_p, c.c_int, DP, DP]),
                ("crt_eval_contact", None, [c.c_void_p, c.c_double, DP, DP, DP, DP]),
                ("crt_eval_gap", None, [c.c_void_p, c.c_double, DP, DP, DP]),
                ("crt_eval_noise", None, [c.c_void_p, c.c_double, DP, DP]),
                ("crt_eval_contact_rows", None, [c.c_void_p, c.c_int, DP, DP, DP, DP, DP]),
                ("crt_control_sizeof", c.c_int, []),
                ("crt_control_setup", c.c_int, [c.c_void_p, c.c_void_p, c.c_void_p,
                                                c.c_double, DP, c.c_double, DP, c.c_int, DP,
                                                c.c_int]),
                ("crt_control_channels", c.c_int, [c.c_void_p, c.c_int, IP]),
                ("crt_set_control", c.c_int, [c.c_void_p, c.c_void_p]),
                ("crt_control_log_count", c.c_int, [c.c_void_p]),
                ("crt_control_log_taken", None, [c.c_void_p]),
                ("crt_control_fault", c.c_int, [c.c_void_p])):
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = res, args
        for name in ("option", "parameter", "method", "status", "event", "stat", "summary",
                     "opcode"):
            fn = getattr(lib, f"crt_{name}_name")
            fn.restype, fn.argtypes = c.c_char_p, [c.c_int]
        self.has_friction = bool(lib.crt_has_friction())
        if self.has_friction:       # crt_rough_api.h's functions
            for name, res, args in (
                    ("crt_contact_mode", c.c_int, [c.c_void_p]),
                    ("crt_set_contact_mode", c.c_int, [c.c_void_p, c.c_int, DP]),
                    ("crt_eval_rough_rows", None, [c.c_void_p, c.c_int, DP, DP, IP, DP, DP,
                                                   DP, DP]),
                    ("crt_eval_wrench_rows", None, [c.c_void_p, c.c_int, DP, DP, IP, DP, IP,
                                                    DP, DP, DP, DP]),
                    ("crt_eval_delassus", None, [c.c_void_p, c.c_double, DP, DP, DP]),
                    ("crt_eval_slip_band", None, [c.c_void_p, c.c_double, DP, DP]),
                    ("crt_eval_contact_wrench", None, [c.c_void_p, c.c_double, DP, DP, DP, DP]),
                    ("crt_eval_impact", c.c_int, [c.c_void_p, DP, DP, DP])):
                fn = getattr(lib, name)
                fn.restype, fn.argtypes = res, args
        self.lib = lib
        self.nq = lib.crt_nq()
        self.session_size = lib.crt_sizeof()
        self.has_plane = bool(lib.crt_has_plane())
        self.moments = lib.crt_u_width() != 9      # u: the bodies' moments (crt_bodies.h)
        self.labels = tuple(lib.crt_state_name(i).decode() for i in range(self.nq))
        self._check_names()

    def _names(self, fn: str, count: int) -> tuple:
        getter = getattr(self.lib, fn)
        return tuple(getter(i).decode() for i in range(count))

    def _check_names(self) -> None:
        """The library and abi.py must agree on every name, position, return code and
        size."""
        tables = (("crt_option_name", abi.OPTIONS), ("crt_parameter_name", abi.PARAMETERS),
                  ("crt_method_name", abi.METHODS), ("crt_event_name", abi.EVENT_KINDS),
                  ("crt_stat_name", abi.STATS), ("crt_summary_name", abi.SUMMARY),
                  ("crt_opcode_name", abi.OPCODES))
        for fn, table in tables:
            got = self._names(fn, len(table))
            if got != abi.names(table):
                raise RuntimeError(f"{self.path}: {fn} disagrees with derive/abi.py "
                                   "(run `derive emit`)")
        # return codes by code, negative ones included; the codes next to them unnamed
        codes = [s.code for s in abi.STATUSES]
        got = {code: self.lib.crt_status_name(code).decode()
               for code in range(min(codes) - 1, max(codes) + 2)}
        if got != {code: abi.status_name(code) if code in codes else "" for code in got}:
            raise RuntimeError(f"{self.path}: crt_status_name disagrees with "
                               "derive/abi.py (run `derive emit`)")
        counts = [self.lib.crt_count(k) for k in range(len(abi.COUNTS))]
        want = [value for _, value in abi.COUNTS]
        if counts != want:
            raise RuntimeError(f"{self.path}: table sizes {counts} differ from abi.py {want}")


@lru_cache(maxsize=None)
def library(kind: str, flags: tuple | None = None) -> Library:
    """The compiled runtime of a model (built on first use on this machine, then cached)."""
    flags = runtime_flags() if flags is None else flags
    start = time.perf_counter()
    path = build_shared(sources(kind), flags=flags, name=f"crt_{kind}")
    return Library(path, kind, time.perf_counter() - start)


def build_all(progress=None) -> dict[str, float]:
    """Compile every model (``derive build``): seconds per model."""
    out = {}
    for kind in KINDS:
        if progress:
            progress(kind)
        out[kind] = library(kind).build_seconds
    return out
