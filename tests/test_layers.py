"""The layers: the engine (core, cage, binding, deform, fileio, batching) never reaches into the window."""

import ast
from pathlib import Path

import pytest

import hybridedit

PACKAGE = Path(hybridedit.__file__).resolve().parent
ENGINE = ["core", "cage", "binding", "deform", "fileio", "batching"]
GUI = ("PySide6", "qtpy", "pyvista", "pyvistaqt", "vtk", "vtkmodules")


def _imports(path: Path) -> list[tuple[int, str]]:
    """(level, dotted name) of every import in a module (level > 0: relative)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(0, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.level, node.module or ""))
    return out


@pytest.mark.parametrize("layer", ENGINE + ["warmup.py", "defaults.py"])
def test_the_engine_imports_no_viewer_and_no_gui_toolkit(layer):
    files = sorted((PACKAGE / layer).rglob("*.py")) if (PACKAGE / layer).is_dir() else [PACKAGE / layer]
    assert files
    for f in files:
        depth = len(f.relative_to(PACKAGE).parts) - 1  # how many dots reach the package
        for level, name in _imports(f):
            if level == 0:
                assert not name.split(".")[0] in GUI, f"{f.relative_to(PACKAGE)} imports {name}"
                assert not name.startswith("hybridedit.viewer"), f"{f.relative_to(PACKAGE)} imports {name}"
            elif level == depth + 1:  # from the package root: ..viewer from a sub-package
                assert not name.startswith("viewer"), f"{f.relative_to(PACKAGE)} imports {'.' * level}{name}"
            elif level <= depth:  # inside its own sub-package
                pass


SORTED_KEYWORDS = {"return_index", "return_inverse", "return_counts", "axis"}
HASHING = ("union1d", "setdiff1d", "intersect1d")


@pytest.mark.parametrize("f", sorted(PACKAGE.rglob("*.py")), ids=lambda f: str(f.relative_to(PACKAGE)))
def test_sets_of_indices_come_from_index_sets(f):
    """A plain ``np.unique`` (and union1d, setdiff1d, intersect1d, which call it) hashes integers
    from numpy 2.3: 15-40x slower than a sort for millions of distinct indices. Sets of indices
    come from :mod:`hybridedit.core.index_sets`; np.unique stays only where it also gives
    indices, an inverse or counts (it sorts then)."""
    for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "np":
            name = node.func.attr
            where = f"{f.relative_to(PACKAGE)}:{node.lineno}"
            assert name not in HASHING, f"{where}: np.{name}; use hybridedit.core.index_sets"
            if name == "unique":
                assert {k.arg for k in node.keywords} & SORTED_KEYWORDS, \
                    f"{where}: plain np.unique; use index_sets.unique_sorted"
