"""The zip's portable kernels (hybridedit_blender.portable_kernels, build_extension.py's kernels/):
filed where numba looks for them wherever hybridedit is installed, loaded without a compile, and
compiled again where a source differs; the session's choice between them and the native ones."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import ZIP
from hybridedit_blender import kernels, portable_kernels

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
import build_extension  # noqa: E402

KERNEL = textwrap.dedent("""\
    import numba

    @numba.njit(cache=True)
    def twice(x):
        return 2.0 * x
    """)

RUN = textwrap.dedent("""\
    import json, sys
    from numba.core import event

    class Count(event.Listener):
        n = 0
        def on_start(self, ev):
            pass
        def on_end(self, ev):
            Count.n += 1

    event.register("numba:compile", Count())
    from hybridedit.core.k import twice
    from numba.core.registry import cpu_target
    print(json.dumps({"value": twice(21.0), "compiled": Count.n,
                      "cpu": cpu_target.target_context.codegen()._get_host_cpu_name()}))
    """)


def _package(root: Path, source: str = KERNEL) -> Path:
    pkg = root / "hybridedit"
    (pkg / "core").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "core" / "__init__.py").write_text("")
    (pkg / "core" / "k.py").write_text(source)
    return pkg


def _run(site: Path, cache: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "_HYBRIDEDIT"))}
    env.update(PYTHONPATH=str(site), NUMBA_CACHE_DIR=cache, NUMBA_CPU_NAME=portable_kernels.CPU)
    r = subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_the_folder_names_are_numbas():
    from numba.core.caching import UserProvidedCacheLocator

    for src in ("/opt/blender/4.2/extensions/.local/lib/python3.11/site-packages/hybridedit/binding/kernels.py",
                str(HERE / "x.py")):
        assert portable_kernels.numba_folder_name(os.path.dirname(src)) == \
            UserProvidedCacheLocator.get_suitable_cache_subpath(src)


def test_kernels_compiled_in_one_place_load_in_another_without_a_compile(tmp_path):
    """Compiled for the generic CPU where the build unpacked the package, filed by source folder,
    installed for a copy of the package elsewhere: loaded with no compile; a changed source is
    compiled again (numba checks each kernel against its source's content)."""
    built = _package(tmp_path / "build" / "site")
    first = _run(built.parent, str(tmp_path / "build" / "cache"))
    assert first == {"value": 42.0, "compiled": 1, "cpu": "generic"}
    found = build_extension.kernels_by_source(tmp_path / "build" / "cache", built)
    assert list(found) == ["hybridedit/core"] and {f.suffix for f in found["hybridedit/core"]} == {".nbi", ".nbc"}
    shipped = tmp_path / "ext" / "kernels"
    for rel, files in found.items():
        (shipped / rel).mkdir(parents=True)
        for f in files:
            shutil.copy(f, shipped / rel / f.name)
    meta = {"id": "abc123"}
    here = _package(tmp_path / "user" / "site")
    folder = portable_kernels.install(meta, str(tmp_path / "user" / "portable"), folder=str(shipped),
                                      package_dir=str(here))
    assert folder == str(tmp_path / "user" / "portable" / "abc123")
    assert sorted(os.listdir(folder)) == [".complete", portable_kernels.numba_folder_name(str(here / "core"))]
    assert _run(here.parent, folder) == {"value": 42.0, "compiled": 0, "cpu": "generic"}
    assert portable_kernels.install(meta, str(tmp_path / "user" / "portable"), folder=str(shipped),
                                    package_dir="/nowhere") == folder  # (copied once)
    changed = _package(tmp_path / "user2" / "site", KERNEL.replace("2.0 * x", "3.0 * x"))
    folder2 = portable_kernels.install(meta, str(tmp_path / "user2" / "portable"), folder=str(shipped),
                                       package_dir=str(changed))
    assert _run(changed.parent, folder2) == {"value": 63.0, "compiled": 1, "cpu": "generic"}


def test_a_foreign_kernel_folder_stops_the_build(tmp_path):
    pkg = _package(tmp_path / "site")
    (tmp_path / "cache" / "other_0123").mkdir(parents=True)
    (tmp_path / "cache" / "other_0123" / "f-1.py311.nbi").write_bytes(b"")
    with pytest.raises(SystemExit, match="no folder of"):
        build_extension.kernels_by_source(tmp_path / "cache", pkg)


def test_the_choice(tmp_path, monkeypatch):
    """Unusable kernels are not used (another numba, Python, platform or numpy major; a CPU the user
    chose); once the native kernels are ready the copy is removed and the session uses those."""
    from importlib.metadata import version

    import platform

    good = {"id": "x", "cpu": "generic", "platform": sys.platform, "machine": platform.machine().lower(),
            "python": f"{sys.version_info[0]}.{sys.version_info[1]}", "numba": version("numba"),
            "numpy": version("numpy")}
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    monkeypatch.delenv("NUMBA_CPU_FEATURES", raising=False)
    if "_toplevel_target_context" not in vars(__import__("numba.core.registry").core.registry.cpu_target):
        assert portable_kernels.why_not(good) is None
    else:  # (this process compiled a kernel already: its CPU is chosen)
        assert "compiled a kernel" in portable_kernels.why_not(good)
    assert "none are shipped" in portable_kernels.why_not(None)
    for key, value in (("numba", "0.1.0"), ("python", "3.99"), ("platform", "plan9"), ("machine", "vax"),
                       ("numpy", "99.0")):
        assert value in portable_kernels.why_not({**good, key: value})
    monkeypatch.setenv("NUMBA_CPU_NAME", "skylake")
    assert "NUMBA_CPU_NAME" in portable_kernels.why_not(good)
    into = tmp_path / "numba-portable"
    (into / "x").mkdir(parents=True)
    monkeypatch.setattr(portable_kernels, "IN_USE", None)
    assert portable_kernels.choose(str(into), native_ready=True) is None
    assert not into.exists() and portable_kernels.IN_USE is None


def test_a_bind_does_not_wait_for_the_compile_while_portable_kernels_serve(monkeypatch):
    monkeypatch.setattr(portable_kernels, "IN_USE", "/some/folder")
    assert kernels.ready()
    assert not kernels.must_wait()
    assert portable_kernels.child_environment({"NUMBA_CPU_NAME": "generic", "A": "1"}) == {"A": "1"}
    monkeypatch.setattr(portable_kernels, "IN_USE", None)
    assert portable_kernels.child_environment({"NUMBA_CPU_NAME": "znver3"}) == {"NUMBA_CPU_NAME": "znver3"}


@pytest.mark.skipif(not ZIP, reason="the zip's kernels: run_tests.sh --zip")
def test_the_zip_ships_portable_kernels_for_this_platform(monkeypatch):
    """The Linux zip holds them, made for this Blender; they serve this suite's session unless a run
    before left the kernels compiled for this CPU in its user folder (the fresh-install test checks
    a fresh one)."""
    import zipfile

    with zipfile.ZipFile(ZIP) as z:
        names = z.namelist()
        meta = json.loads(z.read("kernels/info.json")) if "kernels/info.json" in names else None
    assert meta is not None, f"{ZIP} has no portable kernels"
    if portable_kernels.IN_USE is None:
        assert kernels.native_ready()
    else:
        assert os.environ.get("NUMBA_CPU_NAME") == portable_kernels.CPU
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)  # (their own setting: the rest of the match)
    assert portable_kernels.why_not(meta) in (None, "numba compiled a kernel in this Blender already")
    assert meta["kernel_files"] == sum(1 for n in names if n.startswith("kernels/hybridedit/")) > 100
