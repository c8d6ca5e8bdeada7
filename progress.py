"""Progress on stderr for every wait of more than a moment (nothing on stdout).

`ProgressBar` draws a bar with the rate and the time left when the total is known, and a
spinner with the stage's name and the time so far when it is not. Short jobs print nothing
(the first redraw waits `DELAY`). `ticking` keeps it moving while a step with no progress of
its own runs (a compiler, a synthesis tool), so that long work is visible from its start.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time

DELAY = 0.5  # seconds before the bar first appears: short jobs print nothing
EVERY = 0.2  # seconds between redraws (a line per redraw when stderr is not a terminal: 2 s)
SPINNER = "|/-\\"
WIDTH = 30  # characters of the bar


def duration(seconds: float) -> str:
    """A time to read at a glance: 4.2 s, 42 s, 3 min 5 s, 1 h 20 min."""
    if seconds < 9.95:
        return f"{max(0.0, seconds):.1f} s"
    seconds = round(seconds)
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60} min"


def rate(count: float, seconds: float, unit: str = "") -> str:
    """Steps per second (of `unit`, e.g. "edges"), or seconds per step when steps are slow."""
    per_second = count / seconds
    unit = f" {unit}" if unit else ""
    if per_second >= 100:
        return f"{per_second:,.0f}{unit}/s"
    if per_second >= 1:
        return f"{per_second:.1f}{unit}/s"
    return f"{seconds / count:,.1f} s each"


class ProgressBar:
    """A progress bar on stderr for long jobs (nothing for short ones).

    Either called with the counts, `bar(done, total, stage)`, or stepped through a total
    given up front, `bar.step(stage)` (or `with bar.doing(stage):` around each step). A total
    of 0 means unknown: a spinner and the time so far. The rate counts from where the total
    was set: a job that resumes, or that waits for a build first, starts with `bar(done_before,
    total)` at the start of its work. `unit` names what is counted in the rate ("edges":
    1,234 edges/s). `clock` is for tests.
    """

    def __init__(
        self,
        label: str,
        total: int = 0,
        enabled: bool = True,
        stream=None,
        delay: float | None = None,
        unit: str = "",
        clock=time.perf_counter,
    ):
        self.label, self.total, self.enabled = label, total, enabled
        self.delay = DELAY if delay is None else delay
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.clock, self.unit = clock, unit
        self.start = clock()
        self.mark = (0.0, 0)  # (time, done) where this total was set: the rate's origin
        self.last = float("-inf")  # the first line comes at `delay`, on any stream
        self.shown = False
        self.stage = ""
        self.done = 0
        self.frame = 0
        self.lock = threading.Lock()  # `ticking` redraws from a second thread

    def step(self, stage: str | None = None, n: int = 1) -> None:
        """Count n more of `total` done (the stage kept unless given); the last step ends the
        bar's line."""
        self.done += n
        self(self.done, self.total, stage)
        if self.done >= self.total:
            self.close()

    def __call__(self, done: int, total: int, stage: str | None = None) -> None:
        with self.lock:
            now = self.clock() - self.start
            if total != self.total:  # a new stage with its own total: a new rate
                self.mark = (now, done)
            self.done, self.total = done, total
            if stage is not None:
                self.stage = stage
            if not self.enabled:
                return
            finished = total > 0 and done >= total
            every = EVERY if self.tty else 10 * EVERY
            if now < self.delay or (not finished and now - self.last < every):
                return
            self.last = now
            self.shown = True
            self._draw(self.text(now))

    def text(self, now: float) -> str:
        """The bar's line `now` seconds after its start."""
        stage = f"{self.stage} " if self.stage else ""
        if self.total <= 0:  # unknown length: a spinner and the time so far
            self.frame += 1
            return f"{self.label}: {stage}{SPINNER[self.frame % len(SPINNER)]} {duration(now)}"
        fraction = min(1.0, self.done / self.total)
        filled = round(WIDTH * fraction)
        bar = "#" * filled + "-" * (WIDTH - filled)
        counts = f"{self.done:,}/{self.total:,}, {duration(now)}"
        since, base = self.mark
        ran, spent = self.done - base, now - since
        if ran > 0 and spent > 0:
            counts += f", {rate(ran, spent, self.unit)}"
            if self.done < self.total:
                counts += f", {duration((self.total - self.done) * spent / ran)} left"
        return f"{self.label}: {stage}[{bar}] {100 * fraction:5.1f}% ({counts})"

    def _draw(self, text: str) -> None:
        if self.tty:
            self.stream.write("\r" + text + "\x1b[K")  # clear what a longer line left
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    @contextlib.contextmanager
    def ticking(self, stage: str):
        """Redraw the bar (its elapsed time) while a step with no progress of its own runs,
        such as a compiler or a synthesis tool: long work is visible from its start."""
        self(self.done, self.total, stage)
        stop = threading.Event()

        def tick():
            while not stop.wait(EVERY):
                self(self.done, self.total)

        thread = threading.Thread(target=tick, daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join()

    @contextlib.contextmanager
    def doing(self, stage: str):
        """One step of the total, named while it runs and counted when it ends."""
        with self.ticking(stage):
            yield
        self.step(stage)

    def close(self) -> None:
        """End the bar's line (on a terminal); a later call starts a new one."""
        if self.shown and self.tty:
            self.stream.write("\n")
            self.stream.flush()
        self.shown = False
