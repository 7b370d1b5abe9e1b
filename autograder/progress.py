"""What a grading run tells the instructor while it runs.

On a terminal: one line, rewritten in place (done / total, failures so far, time left),
and a line of its own for each submission that did not end ``ok``. Elsewhere (a CI
log, a file): one plain line per graded submission.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def duration(seconds: float) -> str:
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes} min {seconds:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


class Progress:
    def __init__(
        self,
        total: int,
        skipped: int = 0,
        stream: TextIO | None = None,
        at_once: int | None = None,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.live = self.stream.isatty()
        self.total = total  # submissions to grade in this run
        self.done = 0
        self.failed = 0
        self.started = time.monotonic()
        if skipped:
            self._say(f"{skipped} submission(s) already graded and unchanged: kept")
        self._say(f"grading {total} submission(s)" + (f", {at_once} at a time" if at_once else ""))

    def _say(self, line: str) -> None:
        if self.live:
            self.stream.write("\r\x1b[K")
        self.stream.write(line + "\n")
        self.stream.flush()

    def status(self) -> str:
        elapsed = time.monotonic() - self.started
        left = (
            f"about {duration(elapsed / self.done * (self.total - self.done))} left"
            if self.done
            else "time left: estimating"
        )
        return f"[{self.done}/{self.total}] {self.failed} not ok, {left}"

    def update(self, student_id: str, assignment_id: str, score: str, status: str) -> None:
        """One more submission graded."""
        self.done += 1
        self.failed += status != "ok"
        what = f"{student_id} {assignment_id}: {score} {status}"
        if not self.live:
            self._say(f"{self.status()}  {what}")
            return
        if status != "ok":
            self._say(what)
        self.stream.write("\r\x1b[K" + self.status())
        self.stream.flush()

    def close(self) -> None:
        if self.live:
            self.stream.write("\n")
            self.stream.flush()
