#!/usr/bin/env bash
# The Blender extension's tests, in Blender itself: a venv (blender/.venv-bpy, reused between runs)
# with Blender as a Python module (bpy 4.2 LTS, Python 3.11, numpy<2 as Blender 4.2-5.0 ship it), the
# X client libraries bpy loads (apt, as root), hybridedit's own wheel and the wheels the extension
# bundles (wheels only: nothing compiled). Prints pytest's summary line last; arguments after the
# options go to pytest (e.g. -m "not slow", -k NAME, -s).
#   BPY_VERSION=4.2.* (default, venv blender/.venv-bpy), 4.5.* or 5.0.* (venv blender/.venv-bpy-4.5,
#   -5.0): the versions blender_manifest.toml admits (.ci/run runs all three)
#   PYTHON=python3.11 (default python3)
#   --zip (first argument): build the Linux zip and run the tests on it, installed through Blender's
#   own extension installer (HYBRIDEDIT_BLENDER_ZIP, see tests/conftest.py)
set -euo pipefail
cd "$(dirname "$0")"
HERE=$PWD
PY=${PYTHON:-python3}
BPY=${BPY_VERSION:-4.2.*}
# one venv per bpy series: .venv-bpy for the default (4.2), .venv-bpy-4.5 for BPY_VERSION=4.5.* ...
SERIES=$(printf '%s' "$BPY" | sed -E 's/^([0-9]+\.[0-9]+).*/\1/')
if [[ $BPY == "4.2.*" ]]; then VENV=$HERE/.venv-bpy; else VENV=$HERE/.venv-bpy-$SERIES; fi
"$PY" -c 'import sys; assert sys.version_info[:2] == (3, 11), "bpy 4.2-5.0 need Python 3.11, got " + sys.version' || exit 2

if [[ $(id -u) == 0 ]] && command -v apt-get >/dev/null; then
  need=()
  for p in libx11-6 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6 libgl1 libegl1 libgomp1; do
    dpkg -s "$p" >/dev/null 2>&1 || need+=("$p")
  done
  if (( ${#need[@]} )); then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
  fi
fi

[[ -x $VENV/bin/python ]] || "$PY" -m venv "$VENV"
PIP=("$VENV/bin/python" -m pip -q --disable-pip-version-check)
INSTALL=("${PIP[@]}" install --no-warn-conflicts)
# pip's own cache keeps the 350 MB bpy wheel between runs on this machine
"$VENV/bin/python" -c 'import bpy, sys; v = bpy.app.version_string; sys.exit(0 if v.startswith(sys.argv[1]) else 1)' "$SERIES" 2>/dev/null \
  || "${PIP[@]}" install "bpy==$BPY" "numpy<2" pytest
WHEELS=$(mktemp -d)
trap 'rm -rf "$WHEELS"' EXIT
# hybridedit's own wheel (no Qt, VTK or file-format dependencies: the extension uses the engine only)
"$VENV/bin/python" "$HERE/build_extension.py" --hybridedit-wheel "$WHEELS" >/dev/null
"${INSTALL[@]}" --force-reinstall --no-deps "$WHEELS"/hybridedit-*.whl
# the engine's dependencies as the extension bundles them (build_extension.py's list), wheels only
"${INSTALL[@]}" --only-binary=:all: "numpy<2" $("$VENV/bin/python" "$HERE/build_extension.py" --requirements cp311)
"$VENV/bin/python" -c 'import bpy, numpy, hybridedit; print("bpy", bpy.app.version_string, "numpy", numpy.__version__)'
if [[ ${1:-} == --zip ]]; then
  shift
  "$VENV/bin/python" "$HERE/build_extension.py" --platform linux-x64 --out "$WHEELS/zip" >/dev/null
  export HYBRIDEDIT_BLENDER_ZIP=$(ls "$WHEELS"/zip/*.zip)
fi
cd "$HERE"
"$VENV/bin/python" -m pytest -q -p no:cacheprovider tests "$@"
