"""A progress bar on stderr for long renders (nothing on stdout, nothing for short ones)."""

from __future__ import annotations

import sys
import time

DELAY = 0.5  # seconds before the bar first appears: short renders print nothing
EVERY = 0.2  # seconds between redraws (a line per redraw when stderr is not a terminal: 2 s)


class ProgressBar:
    def __init__(self, label: str, enabled: bool = True, stream=None):
        self.label, self.enabled = label, enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.last = -1.0
        self.shown = False
        self.stage = ""

    def __call__(self, done: int, total: int, stage: str | None = None) -> None:
        if stage is not None:
            self.stage = stage
        if not self.enabled:
            return
        now = time.perf_counter() - self.start
        finished = done >= total
        every = EVERY if self.tty else 10 * EVERY
        if now < DELAY or (not finished and now - self.last < every):
            return
        self.last = now
        self.shown = True
        fraction = done / total if total else 1.0
        width = 30
        bar = "#" * round(width * fraction) + "-" * (width - round(width * fraction))
        text = (
            f"{self.label}: {self.stage:<12} [{bar}] {100 * fraction:5.1f}% "
            f"({done}/{total}, {now:.1f} s)"
        )
        if self.tty:
            self.stream.write("\r" + text)
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.shown and self.tty:
            self.stream.write("\n")
            self.stream.flush()
