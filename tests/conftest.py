import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

# The files whose tests take longest one after another on one worker (--dist loadfile keeps
# a file on one worker): the planner's NLP solves and diagnoses; a wheel installed in a
# fresh venv, then all of generated/ rendered from it; the controller built and run under
# the sanitizers and CMake; a scratch copy rendered whole; the runtime and the generated C
# built and run under the sanitizers.  xdist hands out files in the collection's order
# (--no-loadscope-reorder in pyproject.toml): these go first, longest first (their sums of
# `pytest --durations=0` at 13:00 on 29 Nov 2026), so that no worker runs one of them alone
# at the end while the other has finished; the other files follow, most tests first (what
# xdist's own reorder did).  A new long file belongs here.
FIRST = ("tests/test_plan.py", "tests/test_wheel.py", "tests/test_control_replan.py",
         "tests/test_regenerate.py", "tests/test_runtime_c.py", "tests/test_c_build.py",
         "tests/test_friction_emit.py", "tests/test_base_runtime.py",
         "tests/test_stability_chart.py")


def pytest_configure(config):
    """Build every model of the runtime once, in the controller, before the test workers
    start (each would otherwise compile the same library at the same time), one per core
    at a time.  One process (-n 0) builds each model when a test first uses it (derive
    verify mutants runs its tests so: a mutant is built only into the models its tests
    load)."""
    if hasattr(config, "workerinput"):
        return
    if not getattr(config.option, "numprocesses", None):
        return
    import os
    from concurrent.futures import ThreadPoolExecutor
    from derive.cbuild import compiler, compiler_id
    from derive.runtime.build import KINDS, library, runtime_dir
    compiler_id(compiler())         # the compiler asked once, before the threads
    size = {k: (runtime_dir() / f"model_{k}.c").stat().st_size for k in KINDS}
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        list(pool.map(library, sorted(KINDS, key=lambda k: -size[k])))   # largest first


def pytest_collection_modifyitems(config, items):
    """Under xdist, the files of FIRST first, then the others by their number of tests;
    a file's tests keep their order."""
    if not hasattr(config, "workerinput"):
        return
    files = [item.nodeid.split("::", 1)[0] for item in items]
    count, first_seen = Counter(files), {}
    for f in files:
        first_seen.setdefault(f, len(first_seen))
    rank = {f: k for k, f in enumerate(FIRST)}
    order = {f: (rank.get(f, len(FIRST)), -count[f], first_seen[f]) for f in first_seen}
    keyed = sorted(zip(files, range(len(items)), items), key=lambda x: (order[x[0]], x[1]))
    items[:] = [item for _, _, item in keyed]
