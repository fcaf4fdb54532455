import json

import numpy as np
import pytest

from hybridedit.cli import main, parse_cage_size
from hybridedit.fileio.meshfiles import read_mesh, write_mesh

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def mesh_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("cli") / "blob.obj"
    write_mesh(p, bumpy_blob(3))
    return p


def write_edit(path, **kw):
    path.write_text(json.dumps(kw))
    return path


def test_deform_end_to_end(tmp_path, mesh_file):
    m = read_mesh(mesh_file)
    x = m.vertices[:, 0]
    handle = np.flatnonzero(x > x.max() - 0.4).tolist()
    roi = np.flatnonzero(x > 0).tolist()
    edit = write_edit(tmp_path / "e.json", handle=handle, roi=roi, translate=[0, 0.5, 0],
                      rotate={"axis": [0, 0, 1], "degrees": 20})
    out = tmp_path / "out.ply"
    stats = tmp_path / "s.json"
    rc = main(["deform", str(mesh_file), "-o", str(out), "--edit", str(edit), "--cage", "120",
               "--frames", "5", "--stats", str(stats), "-q"])
    assert rc == 0
    d = read_mesh(out)
    assert np.array_equal(d.faces, m.faces)
    s = json.loads(stats.read_text())
    for k in ("n_vertices", "cage_vertices", "cage_seconds", "bind_seconds", "frame_ms_median", "nnz_per_row"):
        assert k in s
    assert s["n_vertices"] == m.n_vertices and s["frames"] == 5
    assert s["max_stretch_percent"] >= s["rrms_edge_error_percent"] > 0
    # the handle went up, the far side did not move
    assert (d.vertices[handle, 1] - m.vertices[handle, 1]).mean() > 0.2
    far = np.flatnonzero(x < x.min() + 0.3)
    assert np.abs(d.vertices[far] - m.vertices[far]).max() < 0.05


def test_info(capsys, mesh_file):
    assert main(["info", str(mesh_file)]) == 0
    out = capsys.readouterr().out
    assert "blob.obj" in out
    assert main(["info", str(mesh_file), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["vertices"] == 642 and rep["components"] == 1 and rep["boundary_edges"] == 0


def test_errors_exit_2_with_one_line(tmp_path, mesh_file, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{oops")
    rc = main(["deform", str(mesh_file), "-o", str(tmp_path / "o.obj"), "--edit", str(bad)])
    err = capsys.readouterr().err
    assert rc == 2 and "bad.json" in err and "Traceback" not in err
    edit = write_edit(tmp_path / "e.json", handle=[0], fixed=[1])
    rc = main(["deform", str(mesh_file), "-o", str(mesh_file), "--edit", str(edit)])
    assert rc == 2 and "refusing to overwrite" in capsys.readouterr().err
    rc = main(["deform", str(tmp_path / "missing.obj"), "-o", str(tmp_path / "o.obj"), "--edit", str(edit)])
    assert rc == 2 and "missing.obj" in capsys.readouterr().err
    edit = write_edit(tmp_path / "e2.json", handle=[10 ** 6], fixed=[1])
    rc = main(["deform", str(mesh_file), "-o", str(tmp_path / "o.obj"), "--edit", str(edit), "--cage", "60", "-q"])
    assert rc == 2 and "out of range" in capsys.readouterr().err


def test_cage_size_parsing():
    assert parse_cage_size("2000") == 2000
    assert parse_cage_size("0.05") == 0.05
    assert parse_cage_size("5%") == 0.05
    for bad in ("abc", "0", "1.5", "-3%"):
        with pytest.raises(Exception):
            parse_cage_size(bad)


def test_info_and_deform_report_repairs(tmp_path, capsys):
    import trimesh

    from hybridedit.core.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=3)
    f = np.asarray(s.faces)[:, ::-1]  # inside out
    v = np.vstack([s.vertices, [[3.0, 3.0, 3.0]]])
    p = tmp_path / "inv.obj"
    write_mesh(p, Mesh(v, f))
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "the cage is built from a repaired copy (the mesh itself is kept as is):" in out
    assert f"    - re-oriented {len(f):,} faces" in out
    assert "    - ignored 1 unreferenced vertex for the cage (they still follow the deformation)" in out
    e = write_edit(tmp_path / "e.json", handle=[0], roi=[0, 1, 2])
    o = tmp_path / "o.obj"
    assert main(["deform", str(p), "-o", str(o), "--edit", str(e), "--cage", "60", "--frames", "2", "-q"]) == 0
    err = capsys.readouterr().err
    assert f"hybridedit: note: inv.obj: re-oriented {len(f):,} faces" in err
    d = read_mesh(o)
    assert np.array_equal(d.faces, f) and d.n_vertices == len(v)


def test_deform_with_polish_and_progress(tmp_path, mesh_file, capsys):
    m = read_mesh(mesh_file)
    x = m.vertices[:, 0]
    edit = write_edit(tmp_path / "e.json", handle=np.flatnonzero(x > x.max() - 0.4).tolist(),
                      roi=np.flatnonzero(x > -0.3).tolist(), translate=[0, 0.6, 0.2])
    plain, polished = tmp_path / "a.ply", tmp_path / "b.ply"
    sa, sb = tmp_path / "a.json", tmp_path / "b.json"
    common = ["--edit", str(edit), "--cage", "100", "--frames", "5", "--no-cache"]
    assert main(["deform", str(mesh_file), "-o", str(plain), "--stats", str(sa), *common]) == 0
    capsys.readouterr()
    assert main(["deform", str(mesh_file), "-o", str(polished), "--stats", str(sb), "--polish", "5", *common]) == 0
    err = capsys.readouterr().err
    # progress of each slow step: a start line and a done line (stderr is not a terminal here)
    for step in ("building the cage", "binding", "polishing"):
        assert f"hybridedit: {step} ..." in err and f"hybridedit: {step} done (" in err
    a, b = json.loads(sa.read_text()), json.loads(sb.read_text())
    assert "polish_iterations" not in a and b["polish_iterations"] >= 1
    assert b["rrms_edge_error_before_polish_percent"] == pytest.approx(a["rrms_edge_error_percent"])
    assert b["rrms_edge_error_percent"] < a["rrms_edge_error_percent"]
    assert not np.array_equal(read_mesh(plain).vertices, read_mesh(polished).vertices)
    assert main(["deform", str(mesh_file), "-o", str(polished), "--polish", "-1", *common]) == 2


def test_progress_on_a_terminal_updates_in_place():
    import io

    from hybridedit.cli import _progress

    class Tty(io.StringIO):
        def isatty(self):
            return True

    out = Tty()
    say = _progress(False, out)
    for f in (0.0, 0.5, 1.0):
        say("binding", f)
    text = out.getvalue()
    assert "\rhybridedit: binding   0%" in text and text.endswith("\rhybridedit: binding 100%\n")


@pytest.mark.parametrize(
    "text, words",
    [
        ('{"handle": [1180591620717411303424], "fixed": [1]}', "far beyond any mesh"),
        ('{"handle": [2.5]}', "integer vertex indices"),
        ("[" * 100000 + "]" * 100000, "nested too deeply"),
        ('{"handles": [{"indices": [0, 1]}, {"indices": [1]}]}', "share 1 vertices"),
        ('{"handles": [{"indices": [0]}], "symmetry": "x", "roi": [0, 1]}', "not symmetric"),
        ('{"handles": [{"indices": [0]}], "mesh": {"vertices": 5, "faces": 6, "topology": "ab"}}',
         "made for a mesh of 5 vertices"),
    ],
)
def test_every_edit_file_error_names_the_edit_file_and_exits_2(tmp_path, mesh_file, capsys, text, words):
    bad = tmp_path / "edit.json"
    bad.write_text(text)
    rc = main(["deform", str(mesh_file), "-o", str(tmp_path / "o.obj"), "--edit", str(bad), "--cage", "60", "-q"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.count("\n") == 0, err
    assert err.startswith(f"hybridedit: error: {bad}: ") and words in err, err
    assert not (tmp_path / "o.obj").exists()


def test_a_byte_order_mark_in_the_edit_file_is_accepted(tmp_path, mesh_file):
    e = tmp_path / "bom.json"
    e.write_bytes(b"\xef\xbb\xbf" + json.dumps({"handle": [0], "fixed": [5], "translate": [0, 0.1, 0]}).encode())
    assert main(["deform", str(mesh_file), "-o", str(tmp_path / "o.obj"), "--edit", str(e), "--cage", "60",
                 "--frames", "2", "-q"]) == 0


def test_deform_holds_constraints_exactly_with_several_groups(tmp_path, mesh_file):
    m = read_mesh(mesh_file)
    x = m.vertices
    a, b = np.flatnonzero(x[:, 0] < x[:, 0].min() + 0.3), np.flatnonzero(x[:, 0] > x[:, 0].max() - 0.3)
    mid = np.flatnonzero(np.abs(x[:, 0]) < 0.2)
    e = write_edit(tmp_path / "e.json", format="hybridedit-edit", version=2, fixed=mid.tolist(),
                   handles=[{"indices": a.tolist(), "translate": [0, 0.3, 0]},
                            {"indices": b.tolist(), "rotate": {"axis": [0, 0, 1], "degrees": 25}}])
    out = tmp_path / "o.ply"
    assert main(["deform", str(mesh_file), "-o", str(out), "--edit", str(e), "--cage", "100", "-q"]) == 0
    d = read_mesh(out).vertices
    from hybridedit.core.transforms import rigid_transform, apply_transform

    diag = m.bbox_diagonal()
    assert np.abs(d[mid] - x[mid]).max() <= 1e-9 * diag
    assert np.abs(d[a] - (x[a] + [0, 0.3, 0])).max() <= 1e-9 * diag
    Tb = rigid_transform(axis=(0, 0, 1), degrees=25, center=x[b].mean(0))
    assert np.abs(d[b] - apply_transform(Tb, x[b])).max() <= 1e-9 * diag


def test_file_progress_is_shown_only_for_steps_over_a_second():
    from hybridedit.cli import _SlowSteps

    t = [0.0]
    said = []
    slow = _SlowSteps(lambda step, f: said.append((step, f)), clock=lambda: t[0])
    slow("reading a.obj", 0.0)
    t[0] = 0.5
    slow("reading a.obj", 1.0)  # done in half a second: its summary line is enough
    slow("writing b.obj", 0.0)
    t[0] = 1.2
    slow("writing b.obj", 0.3)  # 0.7 s in: not yet
    t[0] = 1.6
    slow("writing b.obj", 0.6)  # 1.1 s in: shown from now on, to the end
    t[0] = 1.7
    slow("writing b.obj", 1.0)
    assert said == [("writing b.obj", 0.6), ("writing b.obj", 1.0)]


def test_an_error_in_the_middle_of_a_step_is_printed_on_a_line_of_its_own(tmp_path, mesh_file, monkeypatch):
    """On a terminal a step's progress line is rewritten in place; an error that stops the step
    ends that line first, so the error is a line of its own."""
    import io
    import sys

    from hybridedit import cli

    class Tty(io.StringIO):
        def isatty(self):
            return True

    def broken_read(path, progress=None):
        progress(f"reading {path.name}", 0.0)
        raise cli.CLIError(f"{path}: line 7: not a number")

    err = Tty()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(cli, "SHOW_AFTER_SECONDS", 0.0)
    monkeypatch.setattr(cli, "read_document", broken_read)
    e = write_edit(tmp_path / "e.json", handle=[0], translate=[0, 0.1, 0])
    assert main(["deform", str(mesh_file), "-o", str(tmp_path / "o.obj"), "--edit", str(e)]) == 2
    text = err.getvalue()
    assert text.endswith(f"\rhybridedit: reading blob.obj   0%\nhybridedit: error: {mesh_file}: line 7: not a number\n"), \
        repr(text)


def test_version_names_the_solver_backend(capsys, monkeypatch):
    import hybridedit

    monkeypatch.delenv("HYBRIDEDIT_SOLVER", raising=False)
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    from hybridedit.core.linsolve import available_backends, backend_name

    assert out.startswith(f"hybridedit {hybridedit.__version__} (Python ")
    assert f"solver: {backend_name()} (" in out and "installed: " + ", ".join(available_backends()) in out
    monkeypatch.setenv("HYBRIDEDIT_SOLVER", "cholespy")
    with pytest.raises(SystemExit):
        main(["--version"])
    assert "solver: cholespy (CHOLMOD via cholespy" in capsys.readouterr().out


def test_the_default_mesh_is_found_in_a_checkout_and_in_an_installed_package(tmp_path):
    from pathlib import Path

    from hybridedit import cli

    from shapes import REPO

    here = Path(cli.__file__).resolve().parent
    if here == REPO / "hybridedit":  # a checkout (or an editable install): data/creature.ply beside the package
        assert cli.DEFAULT_MESH == REPO / "data" / "creature.ply"
    else:  # run against an installed wheel (.ci/run's wheels-only venv): the packaged copy
        assert cli.DEFAULT_MESH == here / "data" / "creature.ply"
    assert cli.DEFAULT_MESH.is_file()
    assert read_mesh(cli.DEFAULT_MESH).n_vertices == 100_576
    # an installed wheel: the copy inside the package comes first
    pkg = tmp_path / "site-packages" / "hybridedit"
    (pkg / "data").mkdir(parents=True)
    (pkg / "data" / "creature.ply").write_bytes(b"ply")
    assert cli._default_mesh(pkg) == pkg / "data" / "creature.ply"
    assert cli._default_mesh(tmp_path / "elsewhere" / "hybridedit") == tmp_path / "elsewhere" / "data" / "creature.ply"


@pytest.mark.slow
def test_info_into_a_closed_pipe_exits_quietly(mesh_file):
    """`hybridedit info FILE | head -1`: the reader may go away before the report is written."""
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-m", "hybridedit", "info", str(mesh_file)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    p.stdout.close()  # the reader has gone before the child writes anything
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0 and err == ""


def test_web_errors_exit_2_with_one_line(tmp_path, mesh_file, capsys):
    """``hybridedit web`` says a missing file, a bad port, a port in use or a bad edit file in one line,
    before any build."""
    import importlib.util
    import socket

    assert main(["web", str(tmp_path / "missing.ply")]) == 2
    assert main(["web", str(mesh_file), "--port", "0"]) == 2
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        assert main(["web", str(mesh_file), "--port", str(busy.getsockname()[1])]) == 2
    bad_edit = tmp_path / "bad-edit.json"
    bad_edit.write_text("{not json")
    assert main(["web", str(mesh_file), "--edit", str(bad_edit)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("hybridedit: error: ") for line in err), err
    assert "bad-edit.json" in err[3]
    assert "no such file" in err[0] and "not a port number" in err[1]
    # without the web extra (the wheels-only venv's [test] install) the port is never reached
    web_installed = all(importlib.util.find_spec(m) for m in ("trame", "trame_vtk", "trame_vuetify"))
    assert ("cannot listen" if web_installed else "pip install 'hybridedit[web]'") in err[2], err[2]
