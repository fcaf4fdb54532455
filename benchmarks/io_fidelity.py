"""What survives a deform, and how fast a refused output path is refused.

For spot (a textured quad OBJ, given a material and per-vertex normals here) and a
generated coloured PLY: the lines / properties of the input kept unchanged in the
output, the rewritten ones, and the angle between the written normals and the
deformed surface's (ours, angle-weighted, and trimesh's vertex normals as a
second opinion). Then the wall time of ``hybridedit deform`` refusing an output path on
the armadillo Loop-subdivided twice (690K vertices; ``--smoke``: the 43K one), and
the seconds it takes to read that OBJ and write it back (in its own structure and plain).

    python benchmarks/io_fidelity.py [--smoke]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import plyfile
import trimesh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hybridedit import HybridEditor  # noqa: E402
from hybridedit.core.normals import vertex_normals  # noqa: E402
from hybridedit.fileio.meshfiles import read_document, write_document, write_mesh  # noqa: E402

SHARED = ROOT.parent / "shared" / "meshes"


def angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def edit(doc, cage: int) -> np.ndarray:
    """Pull the top 15% (along the longest axis) of the shape sideways; (n, 3) positions."""
    V = doc.mesh.vertices
    axis = int(np.argmax(np.ptp(V, axis=0)))
    t = V[:, axis]
    span = t.max() - t.min()
    ed = HybridEditor(doc.mesh, cage, cache=False)
    ed.set_selection(np.flatnonzero(t > t.max() - 0.15 * span), roi=np.flatnonzero(t > t.max() - 0.5 * span))
    move = np.zeros(3)
    move[(axis + 1) % 3] = 0.2 * span
    for _ in range(10):
        out = ed.drag(translate=move)
    return out


def normal_errors(normals: np.ndarray, V: np.ndarray, F: np.ndarray, rows: np.ndarray) -> str:
    ours = angles(normals, vertex_normals(V, F)[rows])
    tm = angles(normals, np.asarray(trimesh.Trimesh(V, F, process=False).vertex_normals)[rows])
    length = np.abs(np.linalg.norm(normals, axis=1) - 1).max()
    return (f"max {ours.max():.4f} deg, mean {ours.mean():.4f} deg (angle-weighted); "
            f"trimesh's vertex normals: max {tm.max():.2f}, mean {tm.mean():.2f} deg; |n|-1 <= {length:.1e}")


def spot_case(work: Path) -> list[str]:
    src = SHARED / "spot" / "spot_quadrangulated.obj"
    if not src.exists():
        return [f"spot: {src} not available"]
    folder = work / "spot_in"
    folder.mkdir()
    base = read_document(src)
    n = vertex_normals(base.mesh.vertices, base.mesh.faces)
    lines = src.read_text().splitlines()
    out = ["# spot with a material and smooth normals", "mtllib spot.mtl", "o spot", "usemtl spot"]
    out += [line for line in lines if line.startswith("v ")]
    out += [line for line in lines if line.startswith("vt ")]
    out += ["vn %.6f %.6f %.6f" % tuple(r) for r in n.tolist()]
    out.append("s 1")
    for line in lines:
        if line.startswith("f "):
            out.append("f " + " ".join(f"{c}/{c.split('/')[0]}" for c in line.split()[1:]))
    (folder / "spot.obj").write_text("\n".join(out) + "\n")
    (folder / "spot.mtl").write_text("newmtl spot\nKd 1 1 1\nmap_Kd spot_texture.png\n")
    shutil.copy(SHARED / "spot" / "spot_texture.png", folder)
    doc = read_document(folder / "spot.obj")
    V = edit(doc, 150)
    dst = work / "spot_out"
    dst.mkdir()
    write_document(dst / "spot.obj", doc.with_vertices(V))
    a = (folder / "spot.obj").read_text().splitlines()
    b = (dst / "spot.obj").read_text().splitlines()
    kinds = {}
    for la, lb in zip(a, b):
        k = la.split()[0] if la.split() else ""
        kept, total = kinds.get(k, (0, 0))
        kinds[k] = (kept + (la == lb), total + 1)
    rows = [f"spot ({doc.mesh.n_vertices} vertices, {len(doc.polygons[0])} quads), "
            f"{int(np.any(V != doc.mesh.vertices, axis=1).sum())} vertices moved by the edit:"]
    rows += [f"  {k:8s} lines kept unchanged: {kept:5d} of {total:5d}" for k, (kept, total) in kinds.items()]
    rows.append(f"  line count: input {len(a)}, output {len(b)}; files in the output folder: "
                + ", ".join(sorted(p.name for p in dst.iterdir())))
    normals = np.array([[float(x) for x in line.split()[1:]] for line in b if line.startswith("vn ")])
    touched = np.zeros(len(V), dtype=bool)
    moved = np.any(V != doc.mesh.vertices, axis=1)
    touched[doc.mesh.faces[moved[doc.mesh.faces].any(axis=1)].ravel()] = True
    rows.append(f"  normals of the {touched.sum()} touched vertices: "
                + normal_errors(normals[touched], V, doc.mesh.faces, np.flatnonzero(touched)))
    return rows


def ply_case(work: Path, fmt: str) -> list[str]:
    s = trimesh.creation.icosphere(subdivisions=4)
    V0 = np.asarray(s.vertices) * [2.0, 1.0, 1.0]
    F = np.asarray(s.faces)
    n0 = vertex_normals(V0, F)
    vertex = np.empty(len(V0), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("nx", "f4"), ("ny", "f4"),
                                      ("nz", "f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1"),
                                      ("alpha", "u1"), ("confidence", "f4")])
    rng = np.random.default_rng(0)
    for k, c in enumerate("xyz"):
        vertex[c], vertex["n" + c] = V0[:, k], n0[:, k]
    for c in ("red", "green", "blue", "alpha"):
        vertex[c] = rng.integers(0, 256, len(V0))
    vertex["confidence"] = rng.random(len(V0))
    faces = np.empty(len(F), dtype=[("vertex_indices", "i4", (3,)), ("segment", "u1")])
    faces["vertex_indices"], faces["segment"] = F, np.arange(len(F)) % 5
    cam = np.array([(0.0, 0.0, 5.0)], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    order = {"ascii": "=", "binary_little_endian": "<", "binary_big_endian": ">"}[fmt]
    src = work / f"coloured_{fmt}.ply"
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                     plyfile.PlyElement.describe(faces, "face", len_types={"vertex_indices": "u1"}),
                     plyfile.PlyElement.describe(cam, "camera")],
                    text=fmt == "ascii", byte_order=order, comments=["scan", "units m"],
                    obj_info=["generated"]).write(str(src))
    doc = read_document(src)
    V = edit(doc, 120)
    dst = work / f"coloured_{fmt}_out.ply"
    write_document(dst, doc.with_vertices(V))
    a, b = plyfile.PlyData.read(str(src)), plyfile.PlyData.read(str(dst))
    same, total, changed = 0, 0, []
    for ea, eb in zip(a.elements, b.elements):
        for p in ea.properties:
            total += 1
            x, y = ea.data[p.name], eb.data[p.name]
            eq = all(np.array_equal(u, v) for u, v in zip(x, y)) if x.dtype == object else np.array_equal(x, y)
            same += eq
            if not eq:
                changed.append(f"{ea.name}.{p.name}")
    header_same = (a.text, a.byte_order, a.comments, a.obj_info) == (b.text, b.byte_order, b.comments, b.obj_info) \
        and all(str(ea.header) == str(eb.header) for ea, eb in zip(a.elements, b.elements))
    moved = np.any(V != doc.mesh.vertices, axis=1)
    touched = np.zeros(len(V), dtype=bool)
    touched[F[moved[F].any(axis=1)].ravel()] = True
    vb = b["vertex"].data
    normals = np.column_stack([vb["nx"], vb["ny"], vb["nz"]]).astype(np.float64)[touched]
    return [f"coloured PLY, {fmt} ({len(V0)} vertices, {moved.sum()} moved): properties identical "
            f"{same} of {total}; changed: {', '.join(changed)}; header (types, comments, obj_info, "
            f"format) identical: {header_same}",
            f"  normals of the {touched.sum()} touched vertices: "
            + normal_errors(normals, V.astype(np.float32).astype(np.float64), F, np.flatnonzero(touched))]


def big_mesh(smoke: bool) -> Path:
    src = SHARED / "armadillo43k.obj"
    if smoke:
        return src
    out = Path(tempfile.gettempdir()) / "armadillo_loop2_690k.obj"
    if not out.exists():
        from hybridedit.fileio.meshfiles import read_mesh

        m = read_mesh(src)
        v, f = trimesh.remesh.subdivide_loop(m.vertices, m.faces, iterations=2)
        from hybridedit import Mesh

        write_mesh(out, Mesh(v, f))
    return out


def refusal_case(work: Path, smoke: bool) -> list[str]:
    mesh = big_mesh(smoke)
    if not mesh.exists():
        return [f"refused paths: {mesh} not available"]
    edit_file = work / "edit.json"
    edit_file.write_text(json.dumps({"handle": [0], "translate": [0, 1, 0]}))
    exe = [sys.executable, "-m", "hybridedit.cli"]
    cases = {
        "unknown extension (-o out.xyz)": ["-o", str(work / "out.xyz")],
        "missing folder (-o nowhere/out.obj)": ["-o", str(work / "nowhere" / "out.obj")],
        "--stats onto the input": ["-o", str(work / "o.obj"), "--stats", str(mesh)],
        "-o onto the input (no --force)": ["-o", str(mesh)],
        "--stats onto the edit file": ["-o", str(work / "o.obj"), "--stats", str(edit_file)],
    }
    size = mesh.stat().st_size / 1e6
    rows = [f"refused output paths on {mesh.name} ({size:.0f} MB), wall time of the whole command:"]
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import hybridedit.cli"], check=True)
    startup = time.perf_counter() - t0
    for what, args in cases.items():
        t0 = time.perf_counter()
        r = subprocess.run([*exe, "deform", str(mesh), "--edit", str(edit_file), *args],
                           capture_output=True, text=True, cwd=ROOT)
        dt = time.perf_counter() - t0
        rows.append(f"  {what:38s} exit {r.returncode} in {dt:5.2f} s: {r.stderr.strip()[:110]}")
    from hybridedit import cli

    t0 = time.perf_counter()
    rc = cli.main(["deform", str(mesh), "--edit", str(edit_file), "-o", str(work / "out.xyz")])
    inproc = time.perf_counter() - t0
    rows.append(f"  (python start-up and imports alone: {startup:.2f} s; the refusal itself, in "
                f"process after the imports: exit {rc} in {inproc * 1e3:.1f} ms)")
    return rows


def obj_speed_case(work: Path, smoke: bool) -> list[str]:
    """Seconds to read the big OBJ, write it back in its own structure with every vertex moved,
    and write it as a plain OBJ (from a document that was not read from an OBJ)."""
    from hybridedit.fileio.document import Document

    mesh = big_mesh(smoke)
    if not mesh.exists():
        return [f"OBJ speed: {mesh} not available"]
    t0 = time.perf_counter()
    doc = read_document(mesh)
    t1 = time.perf_counter()
    write_document(work / "own.obj", doc.with_vertices(doc.mesh.vertices * 1.01))
    t2 = time.perf_counter()
    write_document(work / "plain.obj", Document.from_mesh(doc.mesh))
    t3 = time.perf_counter()
    size = mesh.stat().st_size / 1e6
    return [f"OBJ speed on {mesh.name} ({size:.0f} MB, {doc.mesh.n_vertices:,} vertices): read {t1 - t0:.2f} s, "
            f"written in its own structure (every vertex moved) {t2 - t1:.2f} s, as a plain OBJ {t3 - t2:.2f} s"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="43K armadillo for the refusals; quick")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        rows = spot_case(work)
        for fmt in (["binary_little_endian"] if args.smoke else
                    ["ascii", "binary_little_endian", "binary_big_endian"]):
            rows += ply_case(work, fmt)
        rows += refusal_case(work, args.smoke)
        rows += obj_speed_case(work, args.smoke)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
