"""generated/ is byte-for-byte what a fresh render gives, under any PYTHONHASHSEED: one
render under seed 4242 and ``derive emit --check`` under seed 1 both equal the committed
bytes (two renders, each about 30 s, prove all three the same)."""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys

HASHES = """
import hashlib, json
from derive.emit.driver import render_all
print(json.dumps({k: hashlib.sha256(v).hexdigest() for k, v in render_all().items()}))
"""


def _render(seed: str) -> dict:
    env = dict(os.environ, PYTHONHASHSEED=seed)
    out = subprocess.run([sys.executable, "-c", HASHES], capture_output=True, text=True,
                         env=env, check=True, timeout=600)
    return json.loads(out.stdout)


def _committed() -> dict:
    from derive.emit.driver import existing
    from derive.paths import GENERATED
    return {k: hashlib.sha256(v).hexdigest() for k, v in existing(GENERATED).items()}


def test_a_render_under_another_hash_seed_equals_the_committed_bytes():
    fresh, committed = _render("4242"), _committed()
    assert fresh == committed, sorted(set(fresh) ^ set(committed)) + sorted(
        k for k in fresh if fresh[k] != committed.get(k))


def test_committed_generated_matches_a_fresh_render():
    proc = subprocess.run([sys.executable, "-m", "derive", "emit", "--check"],
                          capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, PYTHONHASHSEED="1"))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr


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
    assert plain == ["crt_bodies.h", "crt_call.h", "crt_contact.h", "crt_control.h",
                     "crt_core.h", "crt_dk.h", "crt_events.h",
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
