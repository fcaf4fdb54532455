"""The files beside an OBJ: its material libraries (``.mtl``) and the images they name.

Reading a library's colours and diffuse image (:func:`read_mtl`), writing one for a document
converted to OBJ with its images (:func:`converted_companions`), and finding what must be
copied when an OBJ is saved into another folder (:func:`companions`).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..document import Document, Material

def read_mtl(path: Path) -> dict[str, Material]:
    """The materials of a ``.mtl`` file by name ({} if it cannot be read)."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return {}
    out: dict[str, Material] = {}
    current = None
    for line in text.splitlines():
        words = line.split()
        if not words:
            continue
        key = words[0].lower()
        if key == "newmtl":
            current = out.setdefault(" ".join(words[1:]), Material(" ".join(words[1:])))
        elif current is None:
            continue
        elif key == "kd" and len(words) >= 4:
            current.color = (*[float(x) for x in words[1:4]], current.color[3])
        elif key in ("d", "tr") and len(words) >= 2:
            alpha = float(words[1]) if key == "d" else 1.0 - float(words[1])
            current.color = (*current.color[:3], alpha)
        elif key == "map_kd" and len(words) >= 2:
            image = path.parent / words[-1].replace("\\", "/")
            current.image_name = image.name  # (named even when missing: the look says it is not there)
            if image.is_file():
                current.image = image.read_bytes()
    return out


def image_names(materials: list[Material]) -> list[str | None]:
    """A distinct plain file name for each material's image (None for none)."""
    names, used = [], set()
    for k, m in enumerate(materials):
        if m.image is None:
            names.append(None)
            continue
        base = Path((m.image_name or f"texture_{k}.png").replace("\\", "/")).name or f"texture_{k}.png"
        name = base if base not in used else f"{k}_{base}"
        used.add(name)
        names.append(name)
    return names


def converted_companions(doc: Document, target: Path) -> list[tuple[Path, bytes]]:
    """The material library (``target``'s name with ``.mtl``) and the texture images of a
    converted document, to be written beside ``target``."""
    tex = doc.textures()
    if tex is None or not tex.materials:
        return []
    names = image_names(tex.materials)
    lines = [f"# materials of {target.name}"]
    files = []
    for m, image in zip(tex.materials, names):
        r, g, b, a = m.color
        lines += ["", f"newmtl {m.name}", f"Kd {r:.6g} {g:.6g} {b:.6g}", f"d {a:.6g}"]
        if image is not None:
            lines.append(f"map_Kd {image}")
            files.append((target.parent / image, m.image))
    mtl = (target.parent / (target.stem + ".mtl"), ("\n".join(lines) + "\n").encode("utf-8"))
    return [mtl, *files]


# --------------------------------------------------------------------------- companions

_MAP_STATEMENTS = {"bump", "disp", "decal", "refl", "norm"}


def _material_libraries(doc: Document) -> list[str]:
    names: list[str] = []
    if doc.format == "obj":  # (its native is the file's lines: an ObjNative; mtllib is a statement)
        for line in doc.native.statements()[1]:
            s = line.strip()
            if s[:7] in (b"mtllib ", b"mtllib\t"):
                names += [w.decode("utf-8", "replace") for w in s.split()[1:]]
    return names


def _texture_references(mtl: Path) -> list[str]:
    """Image files a material library refers to (the last word of each map statement)."""
    refs = []
    try:
        text = mtl.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return refs
    for line in text.splitlines():
        words = line.split()
        if len(words) >= 2 and (words[0].lower().startswith("map_") or words[0].lower() in _MAP_STATEMENTS):
            refs.append(words[-1])
    return refs


def _inside(ref: str) -> bool:
    p = Path(ref.replace("\\", "/"))
    return not p.is_absolute() and ".." not in p.parts


def companions(doc: Document, source: Path | None, target: Path) -> tuple[list[tuple[Path, Path]], list[str]]:
    """Files an OBJ written to ``target`` refers to and that must travel with it.

    Returns
    -------
    copies : list of (from, to) paths
        Each material library the file names and each image a library names,
        to be copied into ``target``'s folder at the same relative place, when
        ``target`` is in another folder than ``source``.
    notes : list of str
        References that are not copied (missing, or outside the source folder).
    """
    if source is None:
        return [], []
    src_dir, dst_dir = source.resolve().parent, target.resolve().parent
    if src_dir == dst_dir:
        return [], []
    copies, notes = [], []
    for name in _material_libraries(doc):
        if not _inside(name):
            notes.append(f"material library {name} is outside the mesh's folder; not copied")
            continue
        mtl = src_dir / name
        if not mtl.is_file():
            notes.append(f"material library {name} not found next to {source.name}; not copied")
            continue
        copies.append((mtl, dst_dir / name))
        for ref in _texture_references(mtl):
            img = mtl.parent / ref.replace("\\", "/")
            if not _inside(ref):
                if not Path(ref).is_absolute():
                    notes.append(f"texture {ref} is outside the material's folder; not copied")
                continue
            if not img.is_file():
                notes.append(f"texture {ref} named in {name} not found; not copied")
                continue
            copies.append((img, (dst_dir / name).parent / ref.replace("\\", "/")))
    return copies, notes


def same_content(a: Path, b: Path) -> bool:
    """``b`` exists and holds the same bytes as ``a``."""
    try:
        return b.is_file() and os.path.getsize(a) == os.path.getsize(b) and a.read_bytes() == b.read_bytes()
    except OSError:
        return False

