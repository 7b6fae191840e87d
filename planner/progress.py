"""Progress lines on a terminal; silent when not a TTY or when asked to be quiet."""

from __future__ import annotations

import sys
import time


class TerminalProgress:
    """A ``progress(done, total, best)`` callback that redraws one status line on stderr."""

    def __init__(self, label: str, *, quiet: bool = False, stream=None, min_interval_s: float = 0.1):
        self.stream = stream or sys.stderr
        self.enabled = not quiet and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.label = label
        self._last = 0.0
        self._min_interval = min_interval_s

    def __call__(self, done: int, total: int, best: float) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if done < total and now - self._last < self._min_interval:
            return
        self._last = now
        self.stream.write(f"\r{self.label}: {done}/{total}  best {best:.6g}\033[K")
        if done >= total:
            self.stream.write("\n")
        self.stream.flush()

    def note(self, message: str) -> None:
        """A one-off status line (a stage starting or ending)."""
        if self.enabled:
            self.stream.write(f"{message}\n")
            self.stream.flush()
