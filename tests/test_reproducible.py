"""generated/ is byte-for-byte what a fresh render gives, under any PYTHONHASHSEED.

A whole render costs about a minute of CPU, so the suite renders once for this:
tests/test_wheel.py::test_emit_from_the_wheel renders the committed tree from the installed
wheel under PYTHONHASHSEED=4242 and compares every byte (proving at once that a wheel
renders what the checkout holds and that no hash order reaches the output; the committed
tree was rendered under another seed).  Here: ``derive emit --check``'s own path (its
verdicts and exit codes on a render it is given), the diff it prints, and the plain
headers' verbatim copies.
"""
from __future__ import annotations


def test_emit_check_says_match_or_differ_and_exits_so(monkeypatch, tmp_path, capsys):
    """``derive emit --check`` on a render equal to the tree: exit 0 and "matches"; on a
    render one byte off: exit 1, the unified diff on stdout and the hint on stderr."""
    import argparse

    from derive import cli
    from derive.emit import driver
    from derive.paths import GENERATED
    files = driver.existing(GENERATED)
    monkeypatch.setattr(driver, "render_all", lambda progress=None: dict(files))
    args = argparse.Namespace(output=None, check=True, quiet=True)
    assert cli.cmd_emit(args) == 0
    assert "matches a fresh render" in capsys.readouterr().out
    edited = dict(files)
    name = "c/general_flight_rhs.c"
    edited[name] = files[name].replace(b"dq[0] =", b"dq[0] = 1.0 +", 1)
    monkeypatch.setattr(driver, "render_all", lambda progress=None: edited)
    assert cli.cmd_emit(args) == 1
    out = capsys.readouterr()
    assert "+++ " in out.out and "dq[0] = 1.0 +" in out.out
    assert "differs from a fresh render: run `derive emit`" in out.err


def test_check_reports_a_diff_and_exit_1(tmp_path, monkeypatch):
    from derive.emit import driver
    from derive.paths import GENERATED
    files = driver.existing(GENERATED)       # the committed tree (equal to a fresh render)
    name = "c/general_flight_rhs.c"
    (tmp_path / "c").mkdir()
    for rel, data in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    edited = files[name].replace(b"dq[0] =", b"dq[0] = 1.0 +", 1)
    (tmp_path / name).write_bytes(edited)
    (tmp_path / "c" / "stale.c").write_text("/* left over */\n")
    delta = driver.diff(files, tmp_path)
    assert "--- generated/c/general_flight_rhs.c" in delta and "-  dq[0] = 1.0 +" in delta
    assert "generated/c/stale.c" in delta


def test_the_plain_runtime_headers_are_copied_byte_for_byte(monkeypatch, tmp_path):
    """templates/runtime/*.h are hand-written C (no template syntax), copied verbatim by
    derive emit: the render holds them byte for byte, so --check compares the copies."""
    from derive.emit import driver, runtime_backend
    from derive.paths import GENERATED, TEMPLATES
    monkeypatch.setattr(runtime_backend, "render_model", lambda m: "")   # not needed here
    files = runtime_backend.render_runtime()
    plain = sorted(p.name for pattern in ("*.h", "*.c")
                   for p in (TEMPLATES / "runtime").glob(pattern))
    assert plain == ["crt_base.h", "crt_base_flow.h", "crt_base_model.h", "crt_bodies.h",
                     "crt_call.h",
                     "crt_contact.h", "crt_control.h",
                     "crt_core.h", "crt_dk.h", "crt_events.h", "crt_face.h",
                     "crt_friction_state.h", "crt_integrators.h",
                     "crt_law.h", "crt_lie.h", "crt_loop.h", "crt_math.h",
                     "crt_plane.h", "crt_rhs.h", "crt_rough.h",
                     "crt_rough_api.h", "crt_rough_modes.h",
                     "crt_session.h", "crt_smooth.h", "crt_step.h"]
    for name in plain:
        source = (TEMPLATES / "runtime" / name).read_bytes()
        assert files[f"runtime/{name}"].encode("utf-8") == source
        assert (GENERATED / "runtime" / name).read_bytes() == source
        text = source.decode("utf-8")
        assert not any(tag in text for tag in ("{{", "{%", "{#")), name
        assert f"templates/runtime/{name}, copied verbatim" in " ".join(
            line.lstrip(" *") for line in text[:800].splitlines()), name
    # the per-hop controller in C: templates/control/ into generated/control/, as they are
    for rel, text in runtime_backend.render_controllers().items():
        source = (TEMPLATES / rel).read_bytes()
        assert text.encode("utf-8") == source and (GENERATED / rel).read_bytes() == source
    # an edited copy is a difference for --check
    committed = driver.existing(GENERATED)
    for rel, data in committed.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    edited = committed["runtime/crt_events.h"].replace(b"CRT_MAX_SUB 32", b"CRT_MAX_SUB 33")
    (tmp_path / "runtime" / "crt_events.h").write_bytes(edited)
    delta = driver.diff(committed, tmp_path)
    assert delta.startswith("--- generated/runtime/crt_events.h") and "CRT_MAX_SUB 33" in delta
