import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


def pytest_configure(config):
    """Build every model of the runtime once, in the controller, before the test workers
    start (each would otherwise compile the same library at the same time).  One process
    (-n 0) builds each model when a test first uses it (derive verify mutants runs its
    tests so: a mutant is built only into the models its tests load)."""
    if hasattr(config, "workerinput"):
        return
    if not getattr(config.option, "numprocesses", None):
        return
    from derive.runtime.build import build_all
    build_all()
