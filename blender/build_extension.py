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
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
ADDON = HERE / "hybridedit_blender"

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


def build(platform: str, out: Path, work: Path, he_wheel: Path) -> Path:
    wheels: dict[str, Path] = {he_wheel.name: he_wheel}
    for py in BUNDLED:
        for w in download(platform, py, work / platform / py):
            wheels.setdefault(w.name, w)  # pure-Python wheels are shared by both Pythons
    version = next(ln.split('"')[1] for ln in (ADDON / "blender_manifest.toml").read_text().splitlines()
                   if ln.startswith("version"))
    path = out / f"hybridedit_blender-{version}-{platform}.zip"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(ADDON.glob("*.py")):
            z.write(f, f.name)
        z.writestr("blender_manifest.toml", manifest_with(sorted(wheels), platform))
        for name, w in sorted(wheels.items()):
            z.write(w, f"wheels/{name}", compress_type=zipfile.ZIP_STORED)  # wheels are zips already
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platform", action="append", choices=sorted(PLATFORMS), help="default: all four")
    ap.add_argument("--out", type=Path, default=HERE / "dist")
    ap.add_argument("--requirements", choices=sorted(PINS), help="print the pins for this Python and exit")
    ap.add_argument("--hybridedit-wheel", type=Path, metavar="DIR", help="only build hybridedit's wheel into DIR")
    ap.add_argument("--validate-with", type=Path, help="Blender's blender_ext.py (from a bpy install)")
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
            path = build(platform, args.out, work, he_wheel)
            with zipfile.ZipFile(path) as z:
                names = [i for i in z.infolist() if i.filename.startswith("wheels/")]
            digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
            print(f"{path.name}: {path.stat().st_size / 2**20:.1f} MiB, sha256 {digest}..., {len(names)} wheels")
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
