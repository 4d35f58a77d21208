"""Running cases where they can do no harm.

* :class:`Worker`: a forked process that evaluates jobs one at a time under an
  address-space limit (memory bombs) and a time limit per job; killed and restarted on
  a hang or a crash, which become answers (``timeout``, ``crash``) instead of the
  caller's.
* :func:`lay_out`: a case's files (tables, symlinks, FIFOs, folders) and its scene file
  in a private folder.
* :func:`run_cli`: ``python -m derive ...`` on a laid-out case in a subprocess: a private
  HOME and working folder at ``<tmp>/a/b/c/home`` (so that ``../../`` escapes stay inside
  ``<tmp>`` and are seen), a private runtime cache and matplotlib folder, its own session
  (killed whole at the time limit), the memory limit; it returns what the command
  printed, its exit status and every file it created outside its output folder.
"""
from __future__ import annotations

import copy
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from .generators import Case, csv_text, table_rows
from ..scene import toml

MEMORY_LIMIT = 3 << 30     # address space of a worker / CLI run (memory bombs)


# ---- the worker: evaluate jobs in a forked process with time and memory limits ----------
def limit_memory():
    """Cap the address space of this process (a worker, or a CLI run before exec)."""
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    except (ImportError, ValueError, OSError):
        pass


def _serve(conn, evaluate):
    limit_memory()
    sys.setrecursionlimit(10_000)
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        try:
            out = evaluate(job)
        except BaseException as exc:      # the evaluation itself failed
            out = {"status": "error", "type": type(exc).__name__,
                   "tb": traceback.format_exc()[-3000:]}
        try:
            conn.send(out)
        except Exception as exc:
            conn.send({"status": "error", "type": "unpicklable", "tb": repr(exc)})


class Worker:
    """A forked process that evaluates jobs one at a time with ``evaluate(job) -> dict``;
    killed and restarted on a hang or a crash.  Fork it after the imports and builds the
    jobs need, so that each job pays only for itself."""

    def __init__(self, evaluate):
        self.evaluate = evaluate
        self.ctx = multiprocessing.get_context("fork")
        self.proc = None
        self._start()

    def _start(self):
        self.conn, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_serve, args=(child, self.evaluate), daemon=True)
        self.proc.start()
        child.close()

    def _restart(self):
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.join(5)
        self.conn.close()
        self._start()

    def call(self, job: dict, timeout: float) -> dict:
        start = time.perf_counter()
        self.conn.send(job)
        if not self.conn.poll(timeout):
            self._restart()
            return {"status": "timeout", "seconds": time.perf_counter() - start}
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            code = self.proc.exitcode
            self._restart()
            return {"status": "crash", "exitcode": code,
                    "seconds": time.perf_counter() - start}

    def close(self):
        try:
            self.conn.send(None)
        except (OSError, BrokenPipeError):
            pass
        self.proc.join(2)
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.join(2)


# ---- a case's files in a private folder --------------------------------------------------
def has_table(doc) -> bool:
    pt = doc.get("point") if isinstance(doc, dict) else None
    return isinstance(pt, dict) and "table" in pt


def case_doc(case: Case, outside: Path) -> dict | None:
    """A copy of the case's scene dict, its ``OUTSIDE`` table path pointed at
    ``outside`` (a good table outside the case's folder); None for a text case."""
    if case.doc is None:
        return None
    doc = copy.deepcopy(case.doc)
    pt = doc.get("point") if isinstance(doc, dict) else None
    if isinstance(pt, dict) and pt.get("table") == "OUTSIDE":
        pt["table"] = str(outside)
    return doc


def _materialise(case: Case, folder: Path, outside: Path) -> Path | None:
    """Write the case's files (tables, symlinks, FIFOs, folders) below folder."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in case.files.items():
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, tuple):
            if content[0] == "symlink":
                target = str(outside) if content[1] == "OUTSIDE" else content[1]
                os.symlink(target, p)
            elif content[0] == "fifo":
                os.mkfifo(p)
            elif content[0] == "dir":
                p.mkdir()
        else:
            p.write_bytes(content)
    return folder


def lay_out(case: Case, folder: Path, outside: Path) -> Path:
    """The case's files and ``scene.toml`` (its dict serialised, or its text as it is)
    below ``folder``; the scene file's path."""
    _materialise(case, folder, outside)
    doc = case_doc(case, outside)
    if doc is not None:
        sys.setrecursionlimit(max(sys.getrecursionlimit(), 20000))   # the deep hostile lists
        text = toml.dumps(doc).encode("utf-8")
    elif isinstance(case.text, bytes):
        text = case.text
    else:
        text = case.text.encode("utf-8", errors="surrogatepass")
    path = folder / "scene.toml"
    path.write_bytes(text)
    return path


def write_outside(path: Path) -> Path:
    """The good table that escaping paths of the cases point at."""
    path.write_text(csv_text(table_rows()))
    return path


# ---- the command line in a subprocess --------------------------------------------------
def snapshot(root: Path) -> set:
    """Every file and folder below root (symlinks not followed)."""
    found = set()
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for n in dirnames + filenames:
            found.add(os.path.join(dirpath, n))
    return found


def cli_env(home: Path, cache: Path) -> dict:
    """The environment of a sandboxed command: HOME, the runtime cache and matplotlib's
    folder private, this checkout first on the path, nothing else of the caller's."""
    env = {k: v for k, v in os.environ.items()
           if k in ("PATH", "LANG", "LC_ALL", "VIRTUAL_ENV", "SYSTEMROOT", "TMPDIR")}
    env.update(HOME=str(home), DERIVE_CACHE=str(cache), PYTHONDONTWRITEBYTECODE="1",
               MPLCONFIGDIR=str(home / ".mpl"), PYTHONPATH=str(Path(__file__).parents[2]))
    return env


@dataclass
class CliRun:
    """What a sandboxed command did."""
    returncode: int | None            # None: killed at the time limit
    stdout: str = ""
    stderr: str = ""
    seconds: float = 0.0
    outside: list = field(default_factory=list)   # created outside the output folder
    output: bool = False              # the output folder exists afterwards


def run_cli(case: Case, argv: list, cache: Path, limit: float, output: str = "out",
            keep: bool = False) -> CliRun:
    """``python -m derive *argv`` in the case's private folder (the working folder and
    HOME, holding its files and ``scene.toml``); ``output`` is the folder the command
    may write."""
    tmp = Path(tempfile.mkdtemp(prefix="derive-fuzz-cli-"))
    try:
        root = tmp / "a" / "b" / "c" / "home"
        root.mkdir(parents=True)
        (root / ".mpl").mkdir()
        lay_out(case, root, write_outside(tmp / "outside.csv"))
        before = snapshot(tmp)
        start = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "derive", *argv], cwd=root,
                                env=cli_env(root, cache), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                                start_new_session=True, preexec_fn=limit_memory)
        try:
            so, se = proc.communicate(timeout=limit)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            return CliRun(None, seconds=limit)
        secs = time.perf_counter() - start
        out_dir = root / output
        new = sorted(snapshot(tmp) - before)
        outside = [p for p in new if not p.startswith(str(out_dir) + os.sep)
                   and p != str(out_dir)]
        return CliRun(proc.returncode, so.decode(errors="replace"),
                      se.decode("utf-8", errors="replace"), secs, outside, out_dir.exists())
    finally:
        if not keep:
            shutil.rmtree(tmp, ignore_errors=True)
