"""Compile C into a shared library, cached by a hash of the sources and the compiler.

Nothing recompiles when nothing changed: the cache key covers every source's name and
bytes, the flags and the compiler's own version line.  The cache lives in
``$DERIVE_CACHE`` (default ``~/.cache/markeev-carrier``); a library is built in a
temporary folder and renamed into place, so concurrent builds cannot see half a file.
"""
from __future__ import annotations

import hashlib
import os
import threading
import shutil
import subprocess
import tempfile
from functools import lru_cache
from pathlib import Path

WARNINGS = ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror")
OPTIMISE = ("-O2",)
# the runtime libraries derive builds for its own runs: for this machine, with fused
# multiply-adds (the generated C itself is compiled by its users with their flags)
RUNTIME_FLAGS = ("-O3", "-march=native", "-ffp-contract=fast")


def runtime_flags() -> tuple:
    """``$DERIVE_CFLAGS`` (split on spaces) or :data:`RUNTIME_FLAGS`."""
    env = os.environ.get("DERIVE_CFLAGS")
    return tuple(env.split()) if env else RUNTIME_FLAGS


class BuildError(RuntimeError):
    """The C compiler rejected generated code (a bug in derive, not in the input)."""


def compiler() -> str:
    return os.environ.get("CC", "cc")


def _ask_compiler_id(cc: str) -> str:
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        raise BuildError(f"no working C compiler {cc!r} ({exc}); set CC") from None
    return out.stdout.splitlines()[0] if out.stdout else cc


def _ask_native_target(cc: str) -> str:
    try:
        out = subprocess.run([cc, "-march=native", "-Q", "--help=target"], capture_output=True,
                             text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        out = ""
    for line in out.splitlines():
        if line.strip().startswith("-march="):
            return line.split()[-1]
    import platform
    return platform.machine() + " " + platform.processor()


def _fingerprint(cc: str) -> str | None:
    """The compiler's executable (path, size, time) and the machine: a cheap stand-in for
    its identity, under which its version and native target are remembered."""
    path = shutil.which(cc)
    if path is None:
        return None
    real = os.path.realpath(path)
    st = os.stat(real)
    import platform
    return f"{cc}|{real}|{st.st_size}|{st.st_mtime_ns}|{platform.node()}"


@lru_cache(maxsize=None)
def _compiler_facts(cc: str) -> tuple:
    """(version line, -march=native target) of ``cc``: asked once per compiler binary and
    machine, then read from ``<cache>/compilers.json`` (two subprocesses would otherwise
    cost every process 0.1 s before it may load a cached library)."""
    import json
    key = _fingerprint(cc)
    memo = cache_dir() / "compilers.json"
    known = {}
    if key is not None and memo.is_file():
        try:
            known = json.loads(memo.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            known = {}
        if isinstance(known, dict) and isinstance(known.get(key), list):
            return tuple(known[key])
    facts = (_ask_compiler_id(cc), _ask_native_target(cc))
    if key is not None:
        known = known if isinstance(known, dict) else {}
        known[key] = list(facts)
        try:
            memo.parent.mkdir(parents=True, exist_ok=True)
            tmp = memo.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
            tmp.write_text(json.dumps(known), encoding="utf-8")
            os.replace(tmp, memo)
        except OSError:
            pass
    return facts


def compiler_id(cc: str) -> str:
    return _compiler_facts(cc)[0]


def native_target(cc: str) -> str:
    """What ``-march=native`` resolves to, so that a cache shared between machines never
    hands one machine another's instructions."""
    return _compiler_facts(cc)[1]


def cache_dir() -> Path:
    root = os.environ.get("DERIVE_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "markeev-carrier"


def build_shared(sources: dict[str, str | bytes], *, flags: tuple = OPTIMISE,
                 name: str = "lib") -> Path:
    """Compile ``{file name: text}`` (``.c`` compiled, ``.h`` available to include)
    into ``<cache>/<hash>/<name>.so`` and return its path."""
    cc = compiler()
    h = hashlib.sha256()
    parts = [compiler_id(cc), cc, " ".join(WARNINGS), " ".join(flags)]
    if "-march=native" in flags:
        parts.append(native_target(cc))
    for part in parts:
        h.update(part.encode() + b"\0")
    for fname in sorted(sources):
        data = sources[fname]
        h.update(fname.encode() + b"\0")
        h.update(data.encode() if isinstance(data, str) else data)
        h.update(b"\0")
    target_dir = cache_dir() / h.hexdigest()[:24]
    lib = target_dir / f"{name}.so"
    if lib.is_file():
        return lib
    target_dir.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target_dir.parent) as tmp:
        tmp_path = Path(tmp)
        for fname, data in sources.items():
            path = tmp_path / fname
            if isinstance(data, str):
                path.write_text(data, encoding="utf-8")
            else:
                path.write_bytes(data)
        c_files = sorted(f for f in sources if f.endswith(".c"))
        cmd = [cc, *WARNINGS, *flags, "-fPIC", "-shared", "-I", str(tmp_path),
               "-o", str(tmp_path / f"{name}.so"), *[str(tmp_path / f) for f in c_files], "-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise BuildError("the C compiler rejected the generated code:\n"
                             + proc.stderr[-4000:])
        try:
            os.replace(tmp_path, target_dir)
        except OSError:
            # another process finished the same build first: use it; or the folder holds
            # the same sources built under another name: add this library beside it
            if not lib.is_file():
                os.replace(tmp_path / f"{name}.so", lib)
        else:
            # os.replace moved the folder; recreate tmp so TemporaryDirectory can remove it
            Path(tmp).mkdir(exist_ok=True)
    return lib


def generated_sources(folder: Path) -> dict[str, bytes]:
    """Every ``.c`` and ``.h`` of a folder, for :func:`build_shared`."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.suffix in (".c", ".h")}


def clear_cache() -> None:
    shutil.rmtree(cache_dir(), ignore_errors=True)
