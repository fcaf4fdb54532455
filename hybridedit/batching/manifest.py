"""The batch's bookkeeping: ``OUTDIR/manifest.parquet``, a row per output, kept as results arrive.

A row says where an output came from (the input's path and SHA-256, the seed and pose index, the
settings' key), what it is (the output and its edit file, relative to the output folder, with their
SHA-256; with ``--pack``, the pack file holding it and the pack's SHA-256), how it went (``status``
"done" or "failed", a one-line ``message``, the ARAP pose's relative RMS ``edge_error`` and its
``max_stretch``, both in percent, how far it ``moved`` the shape, in percent of its diagonal, the
draws it took) and what it cost (seconds reading, binding, posing, writing, packing; the worker).
One row per output: a later attempt replaces an earlier one. A packed pose made and waiting for its
pack is ``status`` "posed": its positions are staged (``output_sha256`` is the staged file's hash)
until the pack task writes the pack and makes its row "done".

Rows are safe as soon as they arrive: each is appended (and fsynced) to a journal,
``OUTDIR/.manifest.journal.jsonl``, and the Parquet file is rewritten atomically from time to time
and at the end, after which the journal is emptied. Reading a manifest merges both, so a batch killed
at any point loses no row it had received. :meth:`Manifest.done` tells a re-run which outputs need not
be made again: a done row with the same settings and input hash whose output (or pack) and edit
files still have the hashes it records.

Examples
--------
>>> row = new_row(input="/data/cat.obj", output="cat-pose000.obj", status="done")
>>> sorted(set(COLUMNS) - set(row)), row["edge_error"] is None
([], True)
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Iterable

__all__ = ["COLUMNS", "MANIFEST", "JOURNAL", "new_row", "Manifest", "schema", "to_table", "verified", "row_files",
           "file_sha256"]

MANIFEST = "manifest.parquet"
JOURNAL = ".manifest.journal.jsonl"

#: the columns, in order, with their Arrow types
COLUMNS: dict[str, str] = {
    "input": "string",           # the mesh file, absolute
    "input_sha256": "string",    # its content hash
    "output": "string",          # the output mesh, relative to the output folder (packed: PACK#TARGET)
    "output_sha256": "string",   # (a posed pose waiting for its pack: the staged file's)
    "edit": "string",            # its edit file (replays it with hybridedit deform), relative
    "edit_sha256": "string",
    "pack": "string",            # the file of poses holding it (--pack), relative
    "pack_sha256": "string",
    "seed": "int64",             # the batch's seed (poses mode)
    "pose": "int64",             # the pose index (poses mode)
    "status": "string",          # "done" or "failed" ("posed": made, its pack not written yet)
    "message": "string",         # why it failed, or the writer's notes
    "draws": "int64",            # poses drawn to find one within --max-stretch
    "edge_error": "float64",     # relative RMS edge-length error, percent
    "max_stretch": "float64",    # largest |l' - l| / l over the edges, percent
    "moved": "float64",          # largest vertex displacement, percent of the bounding-box diagonal
    "read_seconds": "float64",
    "bind_seconds": "float64",   # the cage and binding (shared by an input's poses)
    "pose_seconds": "float64",   # drawing, solving and judging the pose
    "write_seconds": "float64",
    "pack_seconds": "float64",   # writing the pack (shared by an input's poses)
    "cache_hit": "bool",         # the cage and binding came from the cache
    "worker": "string",          # the Dask worker that made it
    "settings": "string",        # the key of the arguments that make it (BatchSettings.key)
    "finished": "timestamp",     # when the row was made (UTC)
}


def new_row(**fields) -> dict:
    """A manifest row: every column, the ones not given None (``finished``: now).

    Raises
    ------
    KeyError
        A field that is not a column.
    """
    unknown = set(fields) - set(COLUMNS)
    if unknown:
        raise KeyError(f"not manifest columns: {sorted(unknown)}")
    row = dict.fromkeys(COLUMNS)
    row["finished"] = datetime.now(timezone.utc).isoformat()
    row.update(fields)
    return row


def schema():
    """The manifest's ``pyarrow.Schema``."""
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(), "bool": pa.bool_(),
             "timestamp": pa.timestamp("us", tz="UTC")}
    return pa.schema([(name, types[kind]) for name, kind in COLUMNS.items()])


def _arrow_value(kind: str, value):
    if value is None:
        return None
    if kind == "timestamp":
        return datetime.fromisoformat(value) if isinstance(value, str) else value
    if kind == "float64":
        return float(value)
    if kind == "int64":
        return int(value)
    if kind == "bool":
        return bool(value)
    return str(value)


def to_table(rows: Iterable[dict]):
    """Rows as a ``pyarrow.Table`` with the manifest's :func:`schema`."""
    import pyarrow as pa

    rows = list(rows)
    data = {name: [_arrow_value(kind, r.get(name)) for r in rows] for name, kind in COLUMNS.items()}
    return pa.Table.from_pydict(data, schema=schema())


def _plain(value):
    """A value read from Parquet as the rows keep it (timestamps as ISO text)."""
    return value.isoformat() if isinstance(value, datetime) else value


class Manifest:
    """The manifest of one output folder: its rows by output, kept on disk as they arrive.

    Parameters
    ----------
    folder : str or path-like
        The output folder (created if missing).
    flush_seconds : float
        Rewrite the Parquet file at most this often (the journal holds the rows between).
    """

    def __init__(self, folder: str | os.PathLike[str], *, flush_seconds: float = 2.0) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.path = self.folder / MANIFEST
        self.journal = self.folder / JOURNAL
        self.flush_seconds = float(flush_seconds)
        self.rows: dict[str, dict] = {}
        self._read()
        self._journal = None
        self._flushed = time.monotonic()
        self._dirty = False

    def _read(self) -> None:
        """The rows on disk: the Parquet file's, then the journal's (later rows win)."""
        if self.path.is_file():
            import pyarrow.parquet as pq

            for r in pq.read_table(self.path).to_pylist():
                self.rows[r["output"]] = {k: _plain(r.get(k)) for k in COLUMNS}
        if self.journal.is_file():
            for line in self.journal.read_text(encoding="utf-8").splitlines():
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:  # the last line of a killed write
                    continue
                if isinstance(r, dict) and "output" in r:
                    self.rows[r["output"]] = {k: r.get(k) for k in COLUMNS}
            self._dirty = True

    def add(self, row: dict) -> None:
        """Keep ``row`` (replacing the output's earlier row): journaled at once, in the Parquet file by
        the next :meth:`flush` (at most ``flush_seconds`` later while rows arrive)."""
        row = {k: row.get(k) for k in COLUMNS}
        self.rows[row["output"]] = row
        if self._journal is None:
            self._journal = open(self.journal, "a", encoding="utf-8")
        self._journal.write(json.dumps(row) + "\n")
        self._journal.flush()
        os.fsync(self._journal.fileno())
        self._dirty = True
        if time.monotonic() - self._flushed >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        """Rewrite the Parquet file atomically with every row, then empty the journal."""
        if not self._dirty and self.path.exists():
            return
        import pyarrow.parquet as pq

        from ..fileio.atomic import atomic_write

        with atomic_write(self.path, "wb") as f:
            pq.write_table(self.table(), f)
        if self._journal is not None:
            self._journal.close()
            self._journal = None
        try:
            os.unlink(self.journal)
        except FileNotFoundError:
            pass
        self._flushed = time.monotonic()
        self._dirty = False

    def close(self) -> None:
        """:meth:`flush` and close the journal."""
        self.flush()

    def table(self, outputs: Iterable[str] | None = None):
        """The rows (of ``outputs``, in that order, when given) as a ``pyarrow.Table``."""
        if outputs is None:
            return to_table(self.rows[k] for k in sorted(self.rows))
        return to_table(self.rows[k] for k in outputs if k in self.rows)

    def claimed_done(self, output: str, *, settings: str, input_sha256: str | None,
                     posed: bool = False) -> dict | None:
        """The row of ``output`` when it says done with these settings and input hash (its files are
        not checked here: see :func:`verified`), else None; with ``posed``, a "posed" row too."""
        r = self.rows.get(output)
        if r is None or r.get("status") not in (("done", "posed") if posed else ("done",)) \
                or r.get("settings") != settings:
            return None
        if input_sha256 is None or r.get("input_sha256") != input_sha256:
            return None
        return r


def row_files(row: dict) -> list[tuple[str, str | None]]:
    """The files a done (or posed) row stands for, relative to the output folder, with the hashes it
    records: its edit file, and its output, its pack (a packed pose) or its staged positions (a
    posed one, :func:`hybridedit.batching.plan.staged_path`)."""
    from .plan import staged_path

    if row.get("status") == "posed":
        made = (staged_path(row["output"]), row.get("output_sha256"))
    elif row.get("pack") is not None:
        made = (row["pack"], row.get("pack_sha256"))
    else:
        made = (row["output"], row.get("output_sha256"))
    return [made, (row["edit"], row.get("edit_sha256"))]


def verified(row: dict, folder: str | os.PathLike[str]) -> bool:
    """Whether a done row's files (:func:`row_files`) are in ``folder`` with the hashes it records."""
    f = Path(folder)
    return all(sha is not None and file_sha256(f / name) == sha for name, sha in row_files(row))


def file_sha256(path: str | Path) -> str | None:
    """The SHA-256 (hex) of a file's bytes, or None when it cannot be read.

    Parameters
    ----------
    path : str or Path
    """
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()
