"""The resumable store of a sweep: one Parquet part per finished chunk, written atomically, so
an interrupted sweep resumes where it stopped (:class:`SweepStore`)."""

from __future__ import annotations

import io
import json
from collections.abc import Iterable
from pathlib import Path

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.outputs import output_dir, write_bytes_atomic, write_json_atomic
from acc_fusion.sweep.columns import COUNT_COLUMNS, SUM_COLUMNS
from acc_fusion.sweep.config import SweepConfig
from acc_fusion.sweep.points import Chunk, _column_kinds


def _schema(cfg: SweepConfig):
    import pyarrow as pa

    types = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
    kinds = _column_kinds(cfg.axes)
    return pa.schema(
        [
            ("run_id", pa.string()),
            ("point_id", pa.string()),
            ("chunk_id", pa.string()),
            ("seed", pa.int64()),
            ("run", pa.int64()),
            *((a.key, types.get(kinds[a.key], pa.string())) for a in cfg.axes),
            ("fault", pa.string()),
            ("method", pa.string()),
            *((c, pa.int64()) for c in COUNT_COLUMNS),
            *((c, pa.float64()) for c in SUM_COLUMNS),
            ("steps", pa.int64()),
        ]
    )


def _rows_part(config: dict) -> dict:
    """What decides a sweep's rows: its config without ``report`` (which may change)."""
    return {k: v for k, v in config.items() if k != "report"}


def _json(path: Path) -> dict | None:
    """The JSON object in ``path``, or ``None`` if it holds none (cut short, not JSON)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _parquet_bytes(table) -> bytes:
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


class SweepStore:
    """The output folder of a sweep: ``sweep.json``, ``parts/`` and the consolidated results.

    Opening a folder whose ``sweep.json`` holds another sweep is refused (only the
    ``report`` settings may change between runs into the same folder).  Damaged state is
    recovered, losing nothing intact: a ``sweep.json`` that is not valid JSON is rewritten,
    and a part that cannot be read, or does not hold the runs of its chunk in this sweep's
    columns, is removed so that its chunk runs again; :attr:`damaged` says what was, one
    entry per file.
    """

    def __init__(self, out: str | Path, config: SweepConfig) -> None:

        self.out = output_dir(out)
        self.parts = output_dir(self.out / "parts")
        self.config = config
        self.schema = _schema(config)
        meta = self.out / "sweep.json"
        want = config.as_dict()
        columns = self.schema.names
        self.damaged: list[str] = []
        have = _json(meta) if meta.exists() else None
        if meta.exists() and have is None:
            self.damaged.append("sweep.json (not valid JSON: rewritten)")
        elif have is not None:
            config = have.get("config")
            if not isinstance(config, dict) or _rows_part(config) != _rows_part(want):
                raise ConfigError(
                    f"output folder {str(self.out)!r} holds a different sweep (see its "
                    "sweep.json); use another --out or remove that folder"
                )
            if have.get("columns") != columns:
                raise ConfigError(
                    f"output folder {str(self.out)!r} holds the rows of an older version of "
                    "acc_fusion, with other columns; use another --out or remove that folder"
                )
        write_json_atomic(meta, {"config": want, "columns": columns})
        for stale in self.parts.glob(".*.tmp"):  # a write cut short by a kill
            stale.unlink(missing_ok=True)

    def done(self, chunks: Iterable[Chunk]) -> set[str]:
        """Ids of the ``chunks`` whose part is written and intact; a damaged part is removed
        (its chunk runs again) and noted in :attr:`damaged`."""
        wanted = {c.id: c for c in chunks}
        done = set()
        for path in sorted(self.parts.glob("*.parquet")):
            chunk = wanted.get(path.stem)
            if chunk is None:
                continue
            problem = self._check_part(path, chunk)
            if problem:
                path.unlink()
                self.damaged.append(f"parts/{path.name} ({problem}: recomputed)")
            else:
                done.add(chunk.id)
        return done

    def _check_part(self, path: Path, chunk: Chunk) -> str:
        """What is wrong with the part of ``chunk`` at ``path``, or ``""``."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(path, columns=["chunk_id", "run"])
            schema = pq.read_schema(path)
        except (OSError, pa.ArrowException):
            return "unreadable"
        if schema.names != self.schema.names:
            return "other columns"
        runs = set(table.column("run").to_pylist())
        ids = set(table.column("chunk_id").to_pylist())
        if ids != {chunk.id} or runs != set(range(chunk.first, chunk.first + chunk.n_runs)):
            return "not the runs of its chunk"
        return ""

    def write_part(self, chunk: Chunk, columns: dict) -> None:
        """Store a finished chunk's rows atomically (the unit of completion)."""
        import pyarrow as pa

        table = pa.table(columns, schema=self.schema)
        write_bytes_atomic(self.parts / f"{chunk.id}.parquet", _parquet_bytes(table))

    def consolidate(self, chunk_ids: Iterable[str]):
        """All rows of ``chunk_ids`` as one table sorted by point, seed, run and method, also
        written atomically to ``runs.parquet``."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = [pq.read_table(self.parts / f"{c}.parquet") for c in chunk_ids]
        table = pa.concat_tables(tables) if tables else self.schema.empty_table()
        table = table.sort_by(
            [
                ("point_id", "ascending"),
                ("seed", "ascending"),
                ("run", "ascending"),
                ("method", "ascending"),
            ]
        )
        write_bytes_atomic(self.out / "runs.parquet", _parquet_bytes(table))
        return table
