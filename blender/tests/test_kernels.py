"""The engine's kernels compiled in the background from the moment the extension is enabled
(hybridedit_blender/kernels.py, precompile.py): the first Bind after a fresh install compiles
nothing in Blender's process, a Bind started meanwhile waits with the compile's progress, and a
compile that fails or is killed leaves Bind to compile the engine itself, said in one line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import bpy
import numpy as np
import pytest
from conftest import ZIP
from test_blender import icosphere, positions, rig_up

from hybridedit_blender import kernels, live, portable_kernels, precompile
from hybridedit_blender.bind import BindJob, session_of

HERE = Path(__file__).resolve().parent


@pytest.mark.slow
def test_the_first_bind_after_a_fresh_install_compiles_nothing_in_blender(tmp_path):
    """A fresh process, an empty kernel cache and user folder (installed from the zip by Blender's
    own installer under run_tests.sh --zip): the Bind started right after enabling loads the zip's
    portable kernels at once (the zip's platform), or else waits for the background compile with
    its progress, then loads every kernel; neither it nor the live frame, settle, Apply and
    animation frame after it compiles one in Blender's process. The compile for this CPU ends well
    either way (the next start uses it)."""
    out = tmp_path / "result.json"
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "NUMBA_CPU_NAME", "_HYBRIDEDIT_KERNEL_FOLDER")}  # (a fresh Blender's)
    if ZIP:  # the extension's own user folder, in a fresh BLENDER_USER_RESOURCES
        env.pop("HYBRIDEDIT_BLENDER_CACHE", None)
    else:
        env["HYBRIDEDIT_BLENDER_CACHE"] = str(tmp_path / "user")
    cmd = [sys.executable, str(HERE / "fresh_install.py"), str(out)] + ([ZIP] if ZIP else [])
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=1800)
    assert out.is_file(), r.stdout[-2000:] + r.stderr[-4000:]
    res = json.loads(out.read_text())
    how = ("with the zip's portable kernels, not waiting" if res["portable"] else
           f"waiting for it ({res['waited_polls']} polls, progress {res['wait_fractions'][:1]} to "
           f"{res['wait_fractions'][-1:]})")
    print(f"\nfresh install: the background compile took {res['compile_seconds']:.1f} s; the Bind started "
          f"at once, {how}, was done {res['seconds_since_enable']:.1f} s after enabling; "
          f"kernel versions compiled in Blender's process: {res['compiled_during_bind']} during Bind, "
          f"{res['compiled_in_all']} after the live frame, settle, Apply and an animation frame")
    assert res["compiling_at_enable"] and not res["ready_at_enable"]
    assert res["compile_ok"] and res["ready_after"]
    assert res["bind_kind"] == ["INFO"], res["bind_report"]
    if ZIP and sys.platform.startswith("linux"):  # (the Linux zip ships them: build_extension.py)
        assert res["portable"], "the Linux zip's portable kernels did not serve the first Bind"
    if res["portable"]:
        assert res["waited_polls"] == 0
    else:
        assert res["waited_polls"] > 0 and "%" in res["wait_status"] and "Esc to cancel" in res["wait_status"]
        assert len(res["wait_fractions"]) > 1 and 0.0 <= min(res["wait_fractions"]) < max(res["wait_fractions"]) <= 1.0
    assert res["compiled_during_bind"] == 0
    assert res["compiled_in_all"] == 0
    assert res["moved"] > 0.2


def test_the_suites_own_background_compile_ran_with_this_blenders_python(registered):
    """Registering the extension (conftest) started the background compile, unless a run before
    left its stamp: it ran with this Blender's Python to the end and left the stamp."""
    c = kernels.CURRENT
    if c is not None:
        c.wait()  # (kernels.wait() returns at once while the zip's portable kernels serve)
    assert c is None or c.ok, c.outcome() if c is not None else ""
    assert kernels.native_ready()
    if c is not None:
        print(f"\nthe suite's background compile: {c.seconds:.1f} s, {c.outcome()[1]}")


def _fake_compile(script: str) -> kernels.Compile:
    """A stand-in for precompile.py (its progress protocol), started as register starts the real one."""
    kernels.wait()  # (the suite's own background compile, if it still runs)
    c = kernels.start(command=[sys.executable, "-c", script])
    assert c is not None and c is kernels.CURRENT
    return c


@pytest.fixture
def restore_current(monkeypatch):
    """(Also: no portable kernels, as on a platform the zip has none for: a Bind waits.)"""
    saved = kernels.CURRENT
    monkeypatch.setattr(portable_kernels, "IN_USE", None)
    yield
    if kernels.CURRENT is not None and kernels.CURRENT.running:
        kernels.CURRENT.kill()
    kernels.CURRENT = saved
    live.LAST_PROBLEMS.clear()


def _bind_in_background(obj) -> tuple[BindJob, threading.Thread]:
    job = BindJob(obj)
    t = threading.Thread(target=job.run)
    t.start()
    return job, t


def test_a_bind_waits_for_the_compile_with_its_progress_and_goes_on_when_it_is_killed(scene, restore_current):
    """While the compile runs the Bind waits (it never starts the engine beside it) and shows the
    compile's progress; killed, the compile is said in one line, and the Bind binds by itself."""
    c = _fake_compile("import sys; print('progress 0.420 serial kernels: bind', flush=True); sys.stdin.read()")
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1)
    job, t = _bind_in_background(obj)
    for _ in range(400):  # (the Bind reads the compile's progress every 0.1 s)
        if job.fraction > 0 and job.stage.startswith("waiting"):
            break
        t.join(0.05)
    assert t.is_alive() and job.stage.startswith("waiting for the engine's kernels")
    assert job.fraction == pytest.approx(0.42)
    assert "42%" in job.status() and "Esc to cancel" in job.status()
    assert "42%" in c.status() and "background" in c.status()
    assert c.waiting == 1  # (the status bar then shows the Bind's line, which holds the compile's)
    t.join(0.3)
    assert t.is_alive()  # still waiting
    c.kill()
    t.join(300)
    assert not t.is_alive()
    kind, line = job.install(bpy.context)
    assert kind == {"INFO"} and session_of(obj) is not None, line
    level, said = c.outcome()
    assert level == "WARNING" and "killed" in said and "the first Bind compiles it instead" in said
    assert "\n" not in said and c.log_path in said
    assert kernels._tick() is None  # the timer's last turn: the line goes to the status bar's report
    assert ("WARNING", said) in live.LAST_PROBLEMS


def test_a_failed_compile_is_said_in_one_line_and_bind_compiles_itself(scene, restore_current):
    c = _fake_compile("import sys; print('progress 0.1 serial kernels: bind', flush=True); "
                      "sys.stderr.write('Traceback: something broke\\n'); sys.exit(3)")
    c.done.wait(60)
    assert not c.running and not c.ok and c.returncode == 3
    level, said = c.outcome()
    assert level == "WARNING" and "failed (exit code 3)" in said and "\n" not in said
    assert "something broke" in Path(c.log_path).read_text()  # its output kept for a bug report
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}  # nothing to wait for: it binds at once
    assert session_of(obj) is not None


def test_a_bind_cancelled_while_it_waits_for_the_compile(scene, restore_current):
    c = _fake_compile("import sys; print('progress 0.3 x', flush=True); sys.stdin.read()")
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1)
    job, t = _bind_in_background(obj)
    for _ in range(200):
        if job.stage.startswith("waiting"):
            break
        t.join(0.05)
    job.cancel.set()  # Esc
    t.join(10)
    assert not t.is_alive() and job.error == "cancelled"
    assert c.running  # the compile goes on (the next Bind loads what it compiles)


def test_the_stamp_follows_the_engine_sources(tmp_path, monkeypatch):
    """The stamp that says the kernels are compiled names the sources: a changed file of hybridedit
    (its size or time) or another place gives another stamp, so the compile runs again."""
    pkg = tmp_path / "site" / "hybridedit"
    (pkg / "core").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "core" / "k.py").write_text("x = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    import importlib

    importlib.invalidate_caches()
    real = sys.modules.pop("hybridedit", None)  # (find_spec then looks on the path, where the stand-in is first)
    try:
        first = precompile.stamp_path(str(tmp_path))
        assert first == precompile.stamp_path(str(tmp_path))
        assert not kernels.native_ready(str(tmp_path))
        precompile.write_stamp(str(tmp_path), 1.0)
        assert kernels.native_ready(str(tmp_path))
        (pkg / "core" / "k.py").write_text("x = 22\n")
        assert precompile.stamp_path(str(tmp_path)) != first and not kernels.native_ready(str(tmp_path))
    finally:
        sys.modules.pop("hybridedit", None)
        if real is not None:
            sys.modules["hybridedit"] = real


def test_the_rehearsal_shapes_are_what_bind_reads():
    """The background compile's shapes have Bind's array types (float32 rest, int64 triangles), so
    the kernels it compiles are the ones Bind loads."""
    rest32, tris = precompile.bumpy_sphere()
    assert rest32.dtype == np.float32 and tris.dtype == np.int64 and tris.shape[1] == 3
    assert tris.min() == 0 and tris.max() == len(rest32) // 3 - 1
    bad32, bad_tris = precompile.needs_repair(rest32, tris)
    assert bad32.dtype == np.float32 and bad_tris.dtype == np.int64 and len(bad_tris) == len(tris) - 2


def test_a_compile_that_hangs_is_killed_and_the_bind_goes_on(scene, restore_current, monkeypatch):
    """A compile silent for STALL_SECONDS is taken as hung: the waiting Bind kills it and binds."""
    c = _fake_compile("import sys; print('progress 0.2 x', flush=True); sys.stdin.read()")
    monkeypatch.setattr(kernels, "STALL_SECONDS", 1.0)
    obj = icosphere(3)
    Z = positions(obj.data)[:, 2]
    rig_up(obj, Z > 0.75, Z > -0.1)
    assert bpy.ops.hybrid_arap.bind() == {"FINISHED"}  # (waited about a second, then bound)
    assert not c.running and c.returncode is not None and c.returncode < 0
    assert "killed" in c.outcome()[1] and session_of(obj) is not None
