"""Build the installable Blender extension: one zip per platform (Edit > Preferences > Get Extensions >
Install from Disk), each holding the add-on, hybridedit's own wheel and its engine's dependency wheels
for the Pythons of the Blender versions the manifest admits (:data:`BUNDLED`: Python 3.11, Blender
4.2 LTS, 4.5 LTS and 5.0, the versions tested), downloaded unmodified from the package index with
``pip download --only-binary=:all: --platform ... --python-version ...``.

Never bundled: numpy (Blender ships its own), and nothing Qt, VTK or file-format related (the
extension uses hybridedit's engine only: hybridedit's wheel goes in with ``--no-deps``).

    python blender/build_extension.py                     # all four platforms into blender/dist/
    python blender/build_extension.py --platform linux-x64 --out /tmp/dist
    python blender/build_extension.py --requirements cp311 # the pins, one per line (run_tests.sh)

Each zip's blender_manifest.toml lists its wheels; the build checks it with Blender's own
extension validator when a bpy install provides one (``--validate-with PATH/blender_ext.py``).

The zip of the platform the build runs on (linux-x64, with a CPython of a bundled version and numpy
1.x as Blender ships it: the bpy venv of run_tests.sh) also holds the engine's kernels compiled for
any CPU of the platform (``kernels/``, :mod:`hybridedit_blender.portable_kernels`): the background
compile's rehearsal run on the zip's own wheels with numba's CPU set to ``generic``, a few minutes
once per build. ``--no-kernels`` leaves them out.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform as host
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
ADDON = HERE / "hybridedit_blender"
sys.path.insert(0, str(HERE))
from hybridedit_blender.portable_kernels import CPU, INFO, numba_folder_name  # noqa: E402 -- (no bpy)

#: what hybridedit's engine imports (hybridedit/editor.py, rig.py, cage.py, binding.py, linsolve.py,
#: bindcache.py), pinned per Python: scipy for 3.11 accepts numpy >= 1.23.5 (Blender 4.2-5.0 ship
#: numpy 1.24-1.26); numba 0.68 accepts numpy >= 1.22 and 2.x (Blender 5.1+: numpy 2.3).
PINS = {
    "cp311": ["scipy==1.15.3", "numba==0.68.1", "llvmlite==0.50.0", "cholespy==2.2.0",
              "fast-simplification==0.2.0", "platformdirs==4.14.8"],
    "cp313": ["scipy==1.17.1", "numba==0.68.1", "llvmlite==0.50.0", "cholespy==2.2.0",
              "fast-simplification==0.2.0", "platformdirs==4.14.8"],
}
#: where the index has no wheel of the pin for a platform: numba stopped publishing macOS x86_64
#: wheels after 0.62 (0.62.1 takes numpy < 2.4, Blender 5.1's 2.3 included)
OVERRIDES = {"macos-x64": {"numba": "numba==0.62.1", "llvmlite": "llvmlite==0.45.1"}}
PYTHONS = {"cp311": "3.11", "cp313": "3.13"}
#: the Pythons whose wheels go into the zips: those of the manifest's blender_version_min..max
#: (4.2-5.0: 3.11). Blender 5.1+ (3.13, the cp313 pins) is not on the package index as bpy to be
#: tested yet; raising the manifest's max to it adds "cp313" here
BUNDLED = ("cp311",)
#: Blender's platform names -> pip platform tags (pip also takes the older manylinux / macOS tags)
PLATFORMS = {
    "linux-x64": ["manylinux_2_28_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64"],
    "macos-arm64": ["macosx_12_0_arm64", "macosx_11_0_arm64"],
    "macos-x64": ["macosx_12_0_x86_64", "macosx_10_15_x86_64"],
    "windows-x64": ["win_amd64"],
}


def run(cmd: list[str]) -> None:
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stdout[-2000:]}{r.stderr[-3000:]}")


def hybridedit_wheel(folder: Path) -> Path:
    """hybridedit's wheel built from the committed tree (git archive HEAD) in a folder of its own, so
    that nothing is built inside the working tree (setuptools' build/ is shared with others)."""
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hybridedit-src-") as src:
        if (REPO / ".git").exists():
            archive = subprocess.run(["git", "-C", str(REPO), "archive", "HEAD"], capture_output=True, check=True)
            subprocess.run(["tar", "-x", "-C", src], input=archive.stdout, check=True)
        else:
            shutil.copytree(REPO, src, dirs_exist_ok=True, ignore=shutil.ignore_patterns(".venv*", "build", "dist"))
        run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(folder), src])
    return next(folder.glob("hybridedit-*.whl"))


def download(platform: str, py: str, folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "-q", "--disable-pip-version-check", "--no-deps",
           "--only-binary=:all:", "--implementation", "cp", "--python-version", PYTHONS[py], "-d", str(folder)]
    for tag in PLATFORMS[platform]:
        cmd += ["--platform", tag]
    over = OVERRIDES.get(platform, {})
    run(cmd + [over.get(p.split("==")[0], p) for p in PINS[py]])
    return sorted(folder.glob("*.whl"))


def manifest_with(wheels: list[str], platform: str) -> str:
    text = (ADDON / "blender_manifest.toml").read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith("platforms")]
    out, done = [], False
    for ln in lines:
        out.append(ln)
        if ln.startswith("license") and not done:
            out.append(f'platforms = ["{platform}"]')
            out.append("wheels = [")
            out += [f'  "./wheels/{w}",' for w in wheels]
            out.append("]")
            done = True
    return "\n".join(out) + "\n"


#: the platform the build can compile portable kernels for (the one it runs on), or None
HOST_PLATFORM = {("linux", "x86_64"): "linux-x64"}.get((sys.platform, host.machine().lower()))


def kernels_unavailable() -> str | None:
    """Why this Python cannot compile the zip's portable kernels (None: it can)."""
    py = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    if HOST_PLATFORM is None:
        return f"no portable kernels are built on {sys.platform} {host.machine()}"
    if py not in BUNDLED or sys.implementation.name != "cpython":
        return f"the build runs on {sys.implementation.name} {py}, the zip bundles {', '.join(BUNDLED)}"
    try:
        import numpy
    except ImportError:
        return "no numpy in the build's Python"
    if not numpy.__version__.startswith("1."):
        return f"the build's numpy is {numpy.__version__}; Blender 4.2-5.0 ship 1.x (run it with the bpy venv)"
    return None


def kernels_by_source(cache: Path, package_dir: Path) -> dict[str, list[Path]]:
    """The kernel files numba wrote into ``cache`` for the package at ``package_dir``, by source
    folder relative to the package's parent (``hybridedit/binding``); a folder of numba's that is no
    folder of the package is an error (a kernel of another package would be shipped nameless)."""
    names = {numba_folder_name(str(d)): d.relative_to(package_dir.parent).as_posix()
             for d in [package_dir, *sorted(p for p in package_dir.rglob("*") if p.is_dir())]
             if d.name != "__pycache__"}
    found: dict[str, list[Path]] = {}
    for folder in sorted(p for p in cache.iterdir() if p.is_dir()):
        files = sorted(f for f in folder.iterdir() if f.suffix in (".nbi", ".nbc"))
        if not files:
            continue
        if folder.name not in names:
            raise SystemExit(f"portable kernels: {folder.name} in {cache} is no folder of {package_dir}")
        found[names[folder.name]] = files
    return found


def portable_kernels(wheels: list[Path], work: Path) -> tuple[dict[str, list[Path]], dict]:
    """The background compile's rehearsal (hybridedit_blender/precompile.py) run on these wheels,
    unpacked, with numba's CPU ``generic``: the kernel files by source folder and their description."""
    site, cache = work / "site", work / "cache"
    shutil.rmtree(work, ignore_errors=True)
    for w in wheels:
        with zipfile.ZipFile(w) as z:
            z.extractall(site)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON", "_HYBRIDEDIT"))}
    env.update(NUMBA_CACHE_DIR=str(cache), NUMBA_CPU_NAME=CPU, PYTHONPATH=str(site))
    log = work / "precompile.log"
    with open(log, "w") as err:
        # (precompile.py ends when its stdin closes: it is held open until the rehearsal is done)
        p = subprocess.Popen([sys.executable, "-s", str(ADDON / "precompile.py")], stdin=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, stderr=err, env=env)
        code = p.wait()
        p.stdin.close()
    if code:
        sys.exit(f"portable kernels: the rehearsal failed (exit code {code}):\n{log.read_text()[-3000:]}")
    found = kernels_by_source(cache, site / "hybridedit")
    h = hashlib.sha256()
    for rel, files in sorted(found.items()):
        for f in files:
            h.update(f"{rel}/{f.name}\0".encode() + f.read_bytes())
    import numpy

    numba = next(d.name[len("numba-"):-len(".dist-info")] for d in site.glob("numba-*.dist-info"))
    meta = {"id": h.hexdigest()[:16], "cpu": CPU, "platform": sys.platform, "machine": host.machine().lower(),
            "python": f"{sys.version_info[0]}.{sys.version_info[1]}", "numba": numba, "numpy": numpy.__version__,
            "kernel_files": sum(len(f) for f in found.values())}
    return found, meta


def build(platform: str, out: Path, work: Path, he_wheel: Path, *, kernels: bool = True) -> Path:
    wheels: dict[str, Path] = {he_wheel.name: he_wheel}
    per_python = {py: download(platform, py, work / platform / py) for py in BUNDLED}
    for ws in per_python.values():
        for w in ws:
            wheels.setdefault(w.name, w)  # pure-Python wheels are shared by both Pythons
    compiled: tuple[dict[str, list[Path]], dict] | None = None
    if kernels and platform == HOST_PLATFORM:
        why = kernels_unavailable()
        if why is None:
            py = f"cp{sys.version_info[0]}{sys.version_info[1]}"
            compiled = portable_kernels([he_wheel, *per_python[py]], work / platform / "kernels")
        else:
            print(f"{platform}: no portable kernels in the zip: {why}")
    version = next(ln.split('"')[1] for ln in (ADDON / "blender_manifest.toml").read_text().splitlines()
                   if ln.startswith("version"))
    path = out / f"hybridedit_blender-{version}-{platform}.zip"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(ADDON.glob("*.py")):
            z.write(f, f.name)
        z.writestr("blender_manifest.toml", manifest_with(sorted(wheels), platform))
        for name, w in sorted(wheels.items()):
            z.write(w, f"wheels/{name}", compress_type=zipfile.ZIP_STORED)  # wheels are zips already
        if compiled is not None:
            found, meta = compiled
            for rel, files in sorted(found.items()):
                for f in files:
                    z.write(f, f"kernels/{rel}/{f.name}")
            z.writestr(f"kernels/{INFO}", json.dumps(meta, indent=1) + "\n")
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platform", action="append", choices=sorted(PLATFORMS), help="default: all four")
    ap.add_argument("--out", type=Path, default=HERE / "dist")
    ap.add_argument("--requirements", choices=sorted(PINS), help="print the pins for this Python and exit")
    ap.add_argument("--hybridedit-wheel", type=Path, metavar="DIR", help="only build hybridedit's wheel into DIR")
    ap.add_argument("--validate-with", type=Path, help="Blender's blender_ext.py (from a bpy install)")
    ap.add_argument("--no-kernels", action="store_true", help="no portable kernels in the zip")
    args = ap.parse_args(argv)
    if args.requirements:
        print(" ".join(PINS[args.requirements]))
        return 0
    if args.hybridedit_wheel:
        print(hybridedit_wheel(args.hybridedit_wheel))
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hybridedit-ext-") as tmp:
        work = Path(tmp)
        he_wheel = hybridedit_wheel(work / "own")
        for platform in args.platform or list(PLATFORMS):
            path = build(platform, args.out, work, he_wheel, kernels=not args.no_kernels)
            with zipfile.ZipFile(path) as z:
                names = [i for i in z.infolist() if i.filename.startswith("wheels/")]
                kernel_bytes = sum(i.file_size for i in z.infolist() if i.filename.startswith("kernels/"))
            digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
            print(f"{path.name}: {path.stat().st_size / 2**20:.1f} MiB, sha256 {digest}..., {len(names)} wheels"
                  + (f", portable kernels {kernel_bytes / 2**20:.1f} MiB" if kernel_bytes else ""))
            for i in names:
                print(f"    {i.filename[7:]}  ({i.file_size / 2**20:.1f} MiB)")
            if args.validate_with:
                r = subprocess.run([sys.executable, str(args.validate_with), "validate", str(path)],
                                   capture_output=True, text=True)
                print("    Blender's validator:", (r.stdout + r.stderr).strip().splitlines()[-1:] or "ok")
                if r.returncode:
                    return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
