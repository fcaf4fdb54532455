"""The compiled kernels are cached per version of the kernel sources (hybridedit.kernel_cache)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import hybridedit
from hybridedit import kernel_cache

# region_metrics._rows_box inlines core.bounds.grow_box: a kernel of another file
RUN_THE_BOX = """
import json, os
import numpy as np
import hybridedit
from hybridedit.core.region_metrics import _rows_box
box = np.array([[np.inf] * 3, [-np.inf] * 3])
_rows_box(np.array([[1.0, 2.0, 3.0]]), np.array([0]), box)
print(json.dumps({"hi": box[1].tolist(), "loaded": sum(_rows_box._cache_hits.values()),
                  "compiled": sum(_rows_box._cache_misses.values()), "folder": os.environ["NUMBA_CACHE_DIR"],
                  "package": hybridedit.__file__}))
"""


def _run(copy_parent: Path, code: str, **env) -> dict:
    full = {**os.environ, "PYTHONPATH": str(copy_parent), **env}  # (inherits this process's NUMBA_CACHE_DIR)
    r = subprocess.run([sys.executable, "-c", code], cwd=copy_parent, env=full, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_a_kernel_runs_the_new_code_of_a_kernel_it_inlines_from_another_file(tmp_path):
    pkg = tmp_path / "hybridedit"
    shutil.copytree(Path(hybridedit.__file__).parent, pkg, ignore=shutil.ignore_patterns("__pycache__"))

    first = _run(tmp_path, RUN_THE_BOX)
    assert Path(first["package"]).parent == pkg
    assert Path(first["folder"]).is_relative_to(pkg)  # its own folder, not the one this process inherited
    assert (first["hi"], first["compiled"]) == ([1.0, 2.0, 3.0], 1)
    again = _run(tmp_path, RUN_THE_BOX)
    assert (again["hi"], again["loaded"], again["compiled"], again["folder"]) == ([1.0, 2.0, 3.0], 1, 0,
                                                                                  first["folder"])

    bounds = pkg / "core" / "bounds.py"
    text = bounds.read_text()
    assert text.count("            box[1, d] = x\n") == 2
    bounds.write_text(text.replace("            box[1, d] = x\n", "            box[1, d] = x + 1.0\n", 1))

    edited = _run(tmp_path, RUN_THE_BOX)  # region_metrics.py itself is unchanged
    assert (edited["hi"], edited["compiled"]) == ([2.0, 3.0, 4.0], 1)
    assert edited["folder"] != first["folder"] and not Path(first["folder"]).exists()  # the stale one removed


def test_a_numba_cache_dir_the_user_set_is_kept(tmp_path):
    code = "import os, hybridedit; print(os.environ['NUMBA_CACHE_DIR'])"
    env = {k: v for k, v in os.environ.items() if k != kernel_cache.CHOSEN}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert r.stdout.strip() == str(tmp_path / "mine")


def test_the_stamp_follows_every_kernel_source_and_nothing_else(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "plain.py").write_text("x = 1\n")
    (pkg / "sub" / "k.py").write_text("from numba import njit\n\n\n@njit(cache=True)\ndef f():\n    return 1\n")
    (pkg / "mention.py").write_text('"""Not a kernel: the text @njit inside a line."""\n')
    assert kernel_cache.kernel_files(pkg) == [pkg / "sub" / "k.py"]
    stamp = kernel_cache.sources_stamp(pkg)
    (pkg / "plain.py").write_text("x = 2\n")
    assert kernel_cache.sources_stamp(pkg) == stamp
    (pkg / "sub" / "k.py").write_text((pkg / "sub" / "k.py").read_text().replace("return 1", "return 2"))
    assert kernel_cache.sources_stamp(pkg) != stamp
