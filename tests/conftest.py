import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


def pytest_configure(config):
    """Build every model of the runtime once, in the controller, before the test workers
    start (each would otherwise compile the same library at the same time)."""
    if hasattr(config, "workerinput"):
        return
    from derive.runtime.build import build_all
    build_all()
