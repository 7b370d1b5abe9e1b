"""The durable results of a grading run: a journal in OUT, and files written atomically.

Every graded submission is appended to ``OUT/results.jsonl`` (one JSON line, flushed and
fsynced) the moment it is graded, and ``grades.csv`` and ``report.json`` are rewritten
from the journal by write-and-rename. A run stopped at any moment (Ctrl-C, SIGKILL, a
power cut) leaves every finished row on disk and never a half-written file; a torn last
line of the journal (the run died while appending it) is ignored when it is read back.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from autograder.feedback import GRADER_ERROR

CSV_HEADER = ["student_id", "assignment_id", "score", "max_score", "status"]
JOURNAL = "results.jsonl"
_UMASK = os.umask(0o022)  # read once, at import (setting it is process-wide)
os.umask(_UMASK)


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``path`` so that a reader sees the old file or the new one, never a part."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.fchmod(fd, 0o666 & ~_UMASK)  # as open() would create it, not mkstemp's 0600
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def folder_digest(folder: Path) -> str:
    """sha256 over a submission folder's files (names and contents); "" when absent."""
    if not folder.is_dir():
        return ""
    digest = hashlib.sha256()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(folder)).encode() + b"\0")
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()


class Journal:
    """``OUT/results.jsonl``: the rows graded so far, the last one per submission wins."""

    def __init__(self, out: Path, keep: bool) -> None:
        """Open the journal; ``keep=False`` starts it afresh (a full regrade)."""
        self.path = out / JOURNAL
        self.entries: dict[tuple[str, str], dict[str, Any]] = {}
        if keep and self.path.exists():
            for line in self.path.read_bytes().splitlines():
                try:
                    entry = json.loads(line)
                    self.entries[(entry["student_id"], entry["assignment_id"])] = entry
                except (ValueError, KeyError, TypeError):
                    continue  # a torn last line: the run died while writing it
        out.mkdir(parents=True, exist_ok=True)
        # Rewritten compactly (atomically) so that a torn line is never appended to.
        write_atomic(self.path, "".join(json.dumps(e) + "\n" for e in self.entries.values()))
        self._file = open(self.path, "ab")  # noqa: SIM115 (open for the run, closed by close())

    def graded(self, student_id: str, assignment_id: str, digest: str) -> bool:
        entry = self.entries.get((student_id, assignment_id))
        # the grader's own failure is never a grade: graded again
        return (
            entry is not None
            and entry.get("digest") == digest
            and entry.get("status") != GRADER_ERROR
        )

    def append(self, entry: dict[str, Any]) -> None:
        self._file.write((json.dumps(entry) + "\n").encode())
        self._file.flush()
        os.fsync(self._file.fileno())
        self.entries[(entry["student_id"], entry["assignment_id"])] = entry

    def close(self) -> None:
        self._file.close()

    def rows(self) -> list[dict[str, Any]]:
        return sorted(self.entries.values(), key=lambda e: (e["student_id"], e["assignment_id"]))


def grades_csv(rows: Iterable[dict[str, Any]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    for r in rows:
        writer.writerow(
            [r["student_id"], r["assignment_id"], f"{r['score']:g}", f"{r['max_score']:g}"]
            + [r["status"]]
        )
    return buffer.getvalue()


def write_tables(journal: Journal, out: Path) -> None:
    """Rewrite ``grades.csv`` and ``report.json`` from the journal, atomically."""
    rows = journal.rows()
    write_atomic(out / "grades.csv", grades_csv(rows))
    write_atomic(out / "report.json", json.dumps(rows, indent=1))
