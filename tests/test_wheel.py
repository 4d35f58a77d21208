"""Issue 15: the built wheel works outside the checkout.

The wheel is built from a copy of the project's sources (`pip wheel --no-deps`, build
isolation as a user gets it), installed into a fresh virtual environment in a temporary
folder (its dependencies from the package index, pip's cache allowed; not byte-compiled
at install) and used from a temporary working directory:

* the wheel carries every module, template and generated file of the checkout;
* `derive simulate -o out -q` (the README's main job) compiles the runtime from the
  installed `generated/runtime` into an empty cache and writes the same trajectory and
  impacts as the checkout;
* `derive emit -o DIR` renders, from the installed templates, exactly the checkout's
  committed `generated/` (and without -o it refuses to rewrite the installation);
* the C++ embedding test (tests/c) builds with CMake against DIR installed as a package
  (shared library, `find_package(carrier)`, rpath) and passes.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("pyproject.toml", "README.md", "derive", "templates", "generated", "paper_checks")
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
CMAKE = shutil.which("cmake")

pytestmark = pytest.mark.slow


def _run(cmd, **kwargs) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kwargs)
    assert proc.returncode == 0, (f"{cmd}\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}")
    return proc


def _clean_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME", "DERIVE_CACHE")}
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    env.update(extra)
    return env


def _checkout_files() -> set:
    """What the wheel must hold, as paths inside it."""
    want = {p.relative_to(ROOT).as_posix() for p in (ROOT / "derive").rglob("*.py")
            if "__pycache__" not in p.parts}
    want |= {f"derive/{p.relative_to(ROOT).as_posix()}"
             for p in (ROOT / "templates").rglob("*") if p.is_file()}   # *.jinja and *.h
    want |= {f"derive/generated/{rel}" for rel in _generated()}
    want |= {p.relative_to(ROOT).as_posix() for p in (ROOT / "derive" / "docs").rglob("*")
             if p.suffix in (".md", ".png")}                     # the reference pages
    want |= {p.relative_to(ROOT).as_posix() for p in (ROOT / "derive").glob("*/examples/*.toml")}
    return want


def _generated() -> dict:
    """The checkout's generated/ as derive emit owns it (no build folders, no dotfiles)."""
    from derive.emit.driver import existing
    return existing(ROOT / "generated")


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv bin folder, environment, wheel path): the wheel installed in a fresh venv."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=IGNORE)
        else:
            shutil.copy2(path, src / name)
    env = _clean_env(DERIVE_CACHE=str(tmp / "cache"))
    # -v: pip shows setuptools' own output, where a folder of data missing from pyproject's
    # packages is warned of (one warning a folder, at every install)
    built = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-v", "-w", tmp / "dist",
                  src], env=env, cwd=tmp)
    unlisted = [line for line in (built.stdout + built.stderr).splitlines()
                if "absent from the `packages` configuration" in line]
    assert not unlisted, unlisted
    (wheel,) = (tmp / "dist").glob("markeev_carrier-*.whl")
    _run([sys.executable, "-m", "venv", tmp / "venv"], env=env)
    bin_dir = tmp / "venv" / "bin"
    # --no-compile: pip would byte-compile every module of every dependency (sympy's,
    # scipy's, matplotlib's: 12 of the install's 20 s of CPU); the modules the tests
    # import are compiled as they are imported, as from any source tree
    _run([bin_dir / "python", "-m", "pip", "install", "-q", "--no-compile", wheel], env=env,
         cwd=tmp)
    work = tmp / "work"
    work.mkdir()
    print(f"wheel {wheel.name}: {wheel.stat().st_size / 1e3:.0f} kB")
    return bin_dir, env, wheel, work


def test_wheel_carries_modules_templates_and_generated(installed):
    _, _, wheel, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(_checkout_files() - names)
    assert not missing, missing[:20]
    assert "paper_checks/CLAIMS.md" in names


def test_simulate_from_the_wheel(installed, tmp_path):
    """The README's main job from the installed wheel: same trajectory as the checkout."""
    bin_dir, env, _, work = installed
    _run([bin_dir / "derive", "simulate", "-o", "out", "-q"], env=env, cwd=work)
    out = work / "out"
    for name in ("trajectory.csv", "impacts.csv", "summary.json", "overview.png", "motion.gif"):
        assert (out / name).is_file(), name
    # the library was compiled from the installed sources, not the checkout's
    site = _run([bin_dir / "python", "-c", "import derive.paths as p; print(p.GENERATED)"],
                env=env, cwd=work).stdout.strip()
    assert not Path(site).is_relative_to(ROOT) and "site-packages" in site
    assert any(Path(env["DERIVE_CACHE"]).rglob("*.so"))
    # the checkout, same scene, same C: the same numbers
    _run([sys.executable, "-m", "derive", "simulate", "-o", tmp_path / "ref", "-q",
          "--no-plots"], cwd=ROOT)
    for name in ("trajectory.csv", "impacts.csv"):
        assert (out / name).read_bytes() == (tmp_path / "ref" / name).read_bytes(), name


def test_emit_from_the_wheel(installed):
    """derive emit -o DIR renders the committed generated/ byte for byte, under another
    PYTHONHASHSEED than the one it was rendered under (the suite's one whole render: it
    proves the wheel renders what the checkout holds and that no hash order reaches the
    output; tests/test_reproducible.py); without -o an installation is not rewritten
    (exit 2)."""
    bin_dir, env, _, work = installed
    refused = subprocess.run([bin_dir / "derive", "emit"], capture_output=True, text=True,
                             env=env, cwd=work)
    assert refused.returncode == 2 and "-o DIR" in refused.stderr
    proc = _run([bin_dir / "derive", "emit", "-o", "emitted"],
                env=dict(env, PYTHONHASHSEED="4242"), cwd=work)
    emitted = work / "emitted"
    got = {p.relative_to(emitted).as_posix(): p.read_bytes()
           for p in emitted.rglob("*") if p.is_file()}
    want = _generated()
    assert sorted(got) == sorted(want)
    differ = sorted(k for k in want if got[k] != want[k])
    assert not differ, differ
    # its progress on stderr (half a minute had been silent): through every C function
    # and every runtime model it wrote
    n_c = sum(1 for k in got if re.fullmatch(r"c/\w+\.c", k))
    n_models = sum(1 for k in got if re.fullmatch(r"runtime/model_\w+\.c", k))
    assert "emit: deriving the functions ..." in proc.stderr
    assert f"emit: the C functions: 100%  {n_c}/{n_c} " in proc.stderr, proc.stderr
    assert f"emit: the runtime's models: 100%  {n_models}/{n_models} " in proc.stderr


@pytest.mark.skipif(CMAKE is None, reason="no cmake")
def test_cpp_embedding_against_the_emitted_folder(installed, tmp_path):
    """What derive emit -o DIR wrote, built as a shared library and installed with
    CMake, found by tests/c/CMakeLists.txt with find_package(carrier); embed runs
    through the rpath CMake records."""
    bin_dir, env, _, work = installed
    emitted = work / "emitted"
    if not (emitted / "CMakeLists.txt").is_file():
        _run([bin_dir / "derive", "emit", "-o", emitted], env=env, cwd=work)
    lib_build, prefix, app_build = tmp_path / "lib", tmp_path / "prefix", tmp_path / "app"
    _run([CMAKE, "-S", emitted, "-B", lib_build, "-DBUILD_SHARED_LIBS=ON",
          "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS=-Werror"])
    _run([CMAKE, "--build", lib_build, "--parallel", "2"])
    _run([CMAKE, "--install", lib_build, "--prefix", prefix])
    assert (prefix / "include" / "carrier.h").is_file()
    _run([CMAKE, "-S", ROOT / "tests" / "c", "-B", app_build, f"-DCMAKE_PREFIX_PATH={prefix}",
          "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON"])
    _run([CMAKE, "--build", app_build])
    # what the embedding guide says: an imported target's header folder is a system one
    import json
    commands = json.loads((app_build / "compile_commands.json").read_text())
    embed = next(c["command"] for c in commands if c["file"].endswith("embed.cpp"))
    assert f"-isystem {prefix / 'include'}" in embed, embed
    env_run = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    run = _run([app_build / "embed"], env=env_run, timeout=120)
    print(run.stdout)
