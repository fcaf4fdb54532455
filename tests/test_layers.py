"""The layers: every module imports only from its own floor or the floors below it.

The floors, lowest first (as the comment on ``hybridedit._WHERE`` states them):

0. ``defaults`` -- the settings several floors share (plain Python);
1. ``core`` -- meshes, topology, normals, the shared small rules (the cache folder, shape
   fingerprints, one-line messages), and beside it ``kernel_cache`` (the folder numba caches the
   kernels in, chosen by the package's ``__init__`` before numba loads);
2. ``fileio`` -- mesh files, edit files, atomic writes;
3. ``cage`` -- the QEM cage;
4. ``binding`` -- mean value coordinates, the rig (cage and binding assembled) and its cache;
5. ``deform`` -- ARAP, propagation, the editor, the limb skeleton;
6. ``batching`` -- ``hybridedit batch``;
7. the top: ``cli``, ``viewer``, ``warmup`` (it runs the whole pipeline), ``__main__`` and the
   package's own ``__init__`` (the lazy public names of ``_WHERE`` point into every floor).

Every import counts: at module level or inside a function, relative or absolute
(``hybridedit.X``), ``from hybridedit import Name`` (resolved through ``_WHERE``), and
``importlib.import_module`` with a string literal. The package root's own constants
(``__version__``) are importable from anywhere: the root is loaded before any floor.
"""

import ast
from pathlib import Path

import pytest

import hybridedit

PACKAGE = Path(hybridedit.__file__).resolve().parent
FLOORS = {"defaults": 0, "core": 1, "kernel_cache": 1, "fileio": 2, "cage": 3, "binding": 4, "deform": 5, "batching": 6,
          "cli": 7, "viewer": 7, "web": 7, "warmup": 7, "__main__": 7, "__init__": 7}
ENGINE = ["core", "cage", "binding", "deform", "fileio", "batching"]
GUI = ("PySide6", "qtpy", "pyvista", "pyvistaqt", "vtk", "vtkmodules")
SOURCES = sorted(PACKAGE.rglob("*.py"))


def _where_table() -> dict[str, str]:
    """The package's ``_WHERE`` (public name -> module), read from its source, not imported."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "_WHERE" for t in node.targets):
            return ast.literal_eval(node.value)
    raise AssertionError("hybridedit/__init__.py has no _WHERE table")


def _root_constants() -> set[str]:
    """Names the package's ``__init__`` assigns at module level (``__version__``)."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    return {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
            if isinstance(t, ast.Name)}


WHERE = _where_table()
ROOT_CONSTANTS = _root_constants() - {"_WHERE", "_RENAMED", "__all__"}


def _module_name(path: Path, package: Path) -> list[str]:
    """``hybridedit/binding/rig.py`` -> ``["binding", "rig"]``; a package's ``__init__`` -> the package."""
    parts = list(path.relative_to(package).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def _resolve(path: Path, level: int, module: str, package: Path) -> list[str] | None:
    """The imported module, as parts below the package; None when it is outside hybridedit."""
    if level == 0:
        parts = module.split(".")
        return parts[1:] if parts[0] == "hybridedit" else None
    here = _module_name(path, package)
    inside = here if path.name == "__init__.py" else here[:-1]  # the sub-package the module sits in
    assert level - 1 <= len(inside), f"{path}: relative import beyond the package"
    return inside[: len(inside) - (level - 1)] + (module.split(".") if module else [])


def _under_type_checking(tree: ast.AST) -> set[ast.AST]:
    """The nodes inside ``if TYPE_CHECKING:`` blocks (imports for annotations only)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", getattr(node.test, "attr", None)) == "TYPE_CHECKING":
            out |= {n for child in node.body for n in ast.walk(child)}
    return out


def _imports(path: Path, package: Path = PACKAGE, runtime: bool = False) -> list[tuple[int, list[str], str]]:
    """(line, imported module as parts below the package, the import as written) of every import of
    hybridedit in a module: ``from X import name`` gives ``X.name`` when ``name`` is a submodule,
    and a public name of the root resolves through ``_WHERE``. ``runtime``: leave out the imports
    under ``if TYPE_CHECKING:``."""
    out = []
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing_only = _under_type_checking(tree)
    for node in ast.walk(tree):
        if runtime and node in typing_only:
            continue
        if isinstance(node, ast.Import):
            out += [(node.lineno, parts, f"import {a.name}") for a in node.names
                    if (parts := _resolve(path, 0, a.name, package)) is not None]
        elif isinstance(node, ast.ImportFrom):
            parts = _resolve(path, node.level, node.module or "", package)
            if parts is None:
                continue
            written = f"from {'.' * node.level}{node.module or ''} import"
            for a in node.names:
                sub = parts + [a.name]
                if not parts and a.name in ROOT_CONSTANTS:
                    continue  # the root's own constant (the root is loaded before every floor)
                if not parts and a.name in WHERE:  # a public name of the root: where it lives
                    out.append((node.lineno, WHERE[a.name].split("."), f"{written} {a.name}"))
                elif package.joinpath(*sub).with_suffix(".py").exists() or package.joinpath(*sub).is_dir():
                    out.append((node.lineno, sub, f"{written} {a.name}"))
                else:
                    out.append((node.lineno, parts, f"{written} {a.name}"))
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if name in ("import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant) \
                    and isinstance(node.args[0].value, str):
                target = node.args[0].value
                level = len(target) - len(target.lstrip("."))
                parts = _resolve(path, level, target.lstrip(".") if level else target, package)
                if parts is not None:
                    out.append((node.lineno, parts, f"{name}({target!r})"))
    return out


def violations(package: Path = PACKAGE) -> list[str]:
    """Every import in the package against the order of the floors, one line each."""
    out = []
    for f in sorted(package.rglob("*.py")):
        here = _module_name(f, package)[:1] or ["__init__"]
        here = here[0]
        for line, parts, written in _imports(f, package):
            there = parts[0] if parts else "__init__"  # the bare root (``import hybridedit``): every public name
            where = f"{f.relative_to(package)}:{line}"
            assert here in FLOORS and there in FLOORS, f"{where}: {written}: {here} or {there} has no floor"
            if FLOORS[there] > FLOORS[here]:
                out.append(f"{where}: {written} -- {here} (floor {FLOORS[here]}) imports from {there} "
                           f"(floor {FLOORS[there]}), a higher floor")
    return out


def test_every_module_has_a_floor():
    floors = {(_module_name(f, PACKAGE)[:1] or ["__init__"])[0] for f in SOURCES}
    assert floors <= set(FLOORS), f"modules with no floor in FLOORS: {sorted(floors - set(FLOORS))}"


def test_imports_point_down_the_floors():
    found = violations()
    assert not found, "imports against core < fileio < cage < binding < deform < batching < (cli, viewer):\n" \
        + "\n".join(found)


def _module_of(parts: list[str]) -> str:
    """The module an import names (``binding.rig.Rig`` -> ``binding.rig``; the root -> ``__init__``)."""
    while parts and not (PACKAGE.joinpath(*parts).with_suffix(".py").exists() or PACKAGE.joinpath(*parts).is_dir()):
        parts = parts[:-1]
    return ".".join(parts) or "__init__"


def test_no_two_modules_import_each_other():
    """A pair that imports each other (even inside functions) is one module in two files, or a rule
    in the wrong one: the shared part moves down. Imports for annotations only do not count."""
    imports = {}
    for f in SOURCES:
        here = ".".join(_module_name(f, PACKAGE)) or "__init__"
        imports[here] = {_module_of(parts) for _, parts, _ in _imports(f, runtime=True)} - {here}
    pairs = sorted(f"{a} <-> {b}" for a in imports for b in imports[a] if a < b and a in imports.get(b, ()))
    assert not pairs, "modules that import each other:\n" + "\n".join(pairs)


UPWARD = """\
from ..deform.arap import x
import hybridedit.deform.arap
def f():
    from hybridedit.deform import arap
    from .. import deform
    from hybridedit import HybridEditor
    import importlib
    importlib.import_module("hybridedit.deform.arap")
    from .. import __version__
    from . import mesh
    from ..defaults import CAGE_SIZE
    import numpy
"""


def test_the_check_sees_every_kind_of_import(tmp_path):
    """The scan itself: each way of writing an upward import is caught (lines 1-8), while the
    root's constant, its own floor, a lower floor and outside packages are not."""
    fake = tmp_path / "hybridedit"
    for d in (fake / "core", fake / "deform"):
        d.mkdir(parents=True)
        (d / "__init__.py").write_text("")
    (fake / "__init__.py").write_text("")
    (fake / "defaults.py").write_text("")
    (fake / "deform" / "arap.py").write_text("from ..core import up\nimport hybridedit.core.up\n")
    (fake / "core" / "up.py").write_text(UPWARD)
    found = violations(fake)
    assert [line.split(":")[1] for line in found] == ["1", "2", "4", "5", "6", "8"], found
    assert all(line.startswith("core/up.py:") and "core (floor 1) imports from deform (floor 5)" in line
               for line in found), found


@pytest.mark.parametrize("layer", ENGINE + ["warmup.py", "defaults.py"])
def test_the_engine_imports_no_viewer_and_no_gui_toolkit(layer):
    files = sorted((PACKAGE / layer).rglob("*.py")) if (PACKAGE / layer).is_dir() else [PACKAGE / layer]
    assert files
    for f in files:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else []
            for name in names:
                assert name.split(".")[0] not in GUI, f"{f.relative_to(PACKAGE)}:{node.lineno} imports {name}"
        assert not [p for _, p, _ in _imports(f) if p[:1] == ["viewer"]], f"{f.relative_to(PACKAGE)} imports the viewer"
        assert not [p for _, p, _ in _imports(f) if p[:1] == ["web"]], f"{f.relative_to(PACKAGE)} imports the web editor"


QT = ("PySide6", "qtpy", "pyvistaqt")


@pytest.mark.parametrize("f", sorted((PACKAGE / "web").rglob("*.py")), ids=lambda f: f.name)
def test_the_web_editor_imports_no_qt(f):
    """``hybridedit web`` runs on a machine with no Qt: it uses the viewer's Qt-free model and scene only."""
    for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
            [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else []
        for name in names:
            assert name.split(".")[0] not in QT, f"{f.relative_to(PACKAGE)}:{node.lineno} imports {name}"
    for _, parts, written in _imports(f):
        if parts[:1] == ["viewer"]:
            assert parts[1:2] in (["model"], ["render"], ["app"]), \
                f"{f.relative_to(PACKAGE)}: {written} -- the web editor uses the viewer's model and render only"


def test_the_web_editor_loads_no_qt():
    """Importing the web editor (and what it imports, the scene included) loads no Qt module."""
    import subprocess
    import sys

    pytest.importorskip("trame")
    code = ("import sys, hybridedit.web.editor_app, hybridedit.viewer.render.scene; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('PySide6', 'qtpy', 'pyvistaqt')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**__import__("os").environ, "PYTHONPATH": str(PACKAGE.parent)})
    assert out.stdout.strip() == "[]", out.stdout


SORTED_KEYWORDS = {"return_index", "return_inverse", "return_counts", "axis"}
HASHING = ("union1d", "setdiff1d", "intersect1d")


@pytest.mark.parametrize("f", SOURCES, ids=lambda f: str(f.relative_to(PACKAGE)))
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
