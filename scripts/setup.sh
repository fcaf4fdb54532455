#!/usr/bin/env bash
# Installs everything hybridedit needs into ./.venv on a Debian or Ubuntu machine.
#   bash scripts/setup.sh          the editor
#   bash scripts/setup.sh test     the editor and what the tests need (Xvfb, pytest-qt, Chromium, ...)
#   bash scripts/setup.sh web      the editor and hybridedit web (the editor in a browser)
# Safe to run again: it only installs what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
extras="${1:-}"

# --- system packages -------------------------------------------------------
# libsuitesparse-dev: CHOLMOD, which scikit-sparse compiles against. (A plain pip install needs
# none of this for solving: cholespy, a required dependency, brings CHOLMOD in its wheel; the
# scikit-sparse built here is used instead where present, its supernodal factor being faster.)
# The libraries Qt 6 (PySide6) and VTK load for a window.
# xvfb: a virtual screen for the GUI tests; nodejs and npm (where there is no npm yet): the Khronos
# glTF Validator, which the tests run on the .glb files he.save_poses writes; chromium and its
# driver: the browser tests of hybridedit web (tests/web, through selenium).
apt_pkgs=(libsuitesparse-dev libgl1 libegl1 libopengl0 libglib2.0-0 libdbus-1-3 libfontconfig1
          libxkbcommon0 libxkbcommon-x11-0 libxrender1 libxcb-cursor0 libxcb-icccm4 libxcb-image0
          libxcb-keysyms1 libxcb-randr0 libxcb-render-util0 libxcb-shape0 libxcb-xinerama0 libxcb-xkb1)
[[ ",$extras," == *",test,"* ]] && apt_pkgs+=(xvfb xauth chromium chromium-driver)
[[ ",$extras," == *",test,"* ]] && ! command -v npm >/dev/null 2>&1 && apt_pkgs+=(nodejs npm)
missing=()
if command -v dpkg-query >/dev/null 2>&1; then
  for p in "${apt_pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
fi
if ((${#missing[@]})); then
  if [[ $(id -u) == 0 ]]; then sudo=(); elif command -v sudo >/dev/null; then sudo=(sudo); else
    echo "setup: please install these system packages first: ${missing[*]}" >&2; exit 1; fi
  echo "setup: installing system packages: ${missing[*]}" >&2
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- Python environment ----------------------------------------------------
py=${PYTHON:-python3}
[[ -x .venv/bin/python ]] || "$py" -m venv .venv
pip=(.venv/bin/python -m pip -q --disable-pip-version-check)

# scikit-sparse (pyproject's "cholmod" extra; source only, so built here against the system's
# SuiteSparse) is the fastest backend: hybridedit uses it first, cholespy otherwise.
# scikit-sparse 0.5 needs SuiteSparse >= 7; older systems (Debian 12 ships 5.12) build 0.4.16.
hdr=$(ls /usr/include/suitesparse/SuiteSparse_config.h /usr/include/SuiteSparse_config.h 2>/dev/null | head -n1 || true)
ss_major=$( [[ -n "$hdr" ]] && awk '/define SUITESPARSE_MAIN_VERSION/ {print $3; exit}' "$hdr" || echo 7)
if [[ "${ss_major:-7}" -lt 7 ]]; then sks="scikit-sparse==0.4.16"; else sks="scikit-sparse>=0.5"; fi
if ! .venv/bin/python -c "import sksparse.cholmod" 2>/dev/null; then
  echo "setup: building $sks against SuiteSparse ${ss_major}" >&2
  "${pip[@]}" install "numpy>=2" "cython>=3" setuptools wheel
  "${pip[@]}" install --no-build-isolation "$sks"
fi

# the browser tests need the web editor: the test extra brings the web extra with it
[[ ",$extras," == *",test,"* && ",$extras," != *",web,"* ]] && extras="$extras,web"
spec="."
[[ -n "$extras" ]] && spec=".[$extras]"
"${pip[@]}" install -e "$spec"
# the glTF Validator for the tests (scripts/gltf-validator: its version pinned in package-lock.json)
if [[ ",$extras," == *",test,"* && ! -d scripts/gltf-validator/node_modules/gltf-validator ]]; then
  if command -v npm >/dev/null 2>&1; then
    echo "setup: installing the glTF Validator (npm)" >&2
    npm ci --prefix scripts/gltf-validator --no-audit --no-fund --loglevel=error >/dev/null
  else
    echo "setup: no npm: the tests that run the glTF Validator will be skipped" >&2
  fi
fi
# compile every kernel now (cached on disk), so the first window and the first deform do not wait on it
echo "setup: compiling the kernels (once; about a minute or two)" >&2
.venv/bin/python -m hybridedit.warmup -q
# and build the default mesh's cage and binding into the user cache, so that the
# first launch opens it as fast as every later one
echo "setup: preparing the default mesh (once)" >&2
.venv/bin/python -c "import hybridedit as he; from hybridedit.cli import DEFAULT_MESH; \
he.build_rig(he.read_mesh(DEFAULT_MESH), cage_size=0.05, cache=True)"
echo "setup: ready (.venv)" >&2
