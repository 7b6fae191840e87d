"""Progress reports: stage lines on stdout, and a live status line on a terminal.

Stage notes (``note``: a stage starting, an optimizer run's outcome) are plain lines on
stdout, with the result summary, so a log (``> log``, a CI job) shows what happened and
stderr keeps only errors, each one line. When stderr is a terminal the optimizer's
``(done, total, best)`` calls also redraw a live status line there; otherwise they print
nothing (no control characters in logs). ``quiet`` silences both.
"""

from __future__ import annotations

import sys
import time


class TerminalProgress:
    """A ``progress(done, total, best)`` callback for optimizers, plus ``note`` for stages.

    Attributes:
        label: what the optimizer is doing, printed before its progress (set per run).
    """

    def __init__(self, label: str, *, quiet: bool = False, notes=None, status=None, min_interval_s: float = 0.1):
        self.notes = notes or sys.stdout
        self.status = status or sys.stderr
        self.enabled = not quiet
        self.live = self.enabled and hasattr(self.status, "isatty") and self.status.isatty()
        self.label = label
        self._last = -float("inf")  # the first count shows, however soon after boot (monotonic time)
        self._min_interval = min_interval_s
        self._open = False  # a status line drawn and not yet ended

    def __call__(self, done: int, total: int, best: float) -> None:
        """Show ``done`` of ``total`` iterations and the best objective so far on a live terminal, at most
        once per ``min_interval_s`` (the last iteration always)."""
        self.count(done, total, f"iterations, best objective {best:.6g}")

    def count(self, done: int, total: int, what: str) -> None:
        """Show ``{label}: done/total what`` on a live terminal, at most once per ``min_interval_s``
        (the last step always, ending the line)."""
        if not self.live:
            return
        now = time.monotonic()
        if done < total and now - self._last < self._min_interval:
            return
        self._last = now
        self._write(self.status, f"\r{self.label}: {done}/{total} {what}\033[K" + ("\n" if done >= total else ""))
        self._open = done < total

    def end_line(self) -> None:
        """Clear a status line left short of its total (a search the time limit stopped), so that what
        follows starts a line of its own."""
        if self.live and self._open:
            self._write(self.status, "\r\033[K")
        self._open = False

    def note(self, message: str) -> None:
        """A one-off line on stdout: a stage starting or ending (any open status line cleared first)."""
        self.end_line()
        if self.enabled:
            self._write(self.notes, f"{message}\n")

    def _write(self, stream, text: str) -> None:
        try:
            stream.write(text)
            stream.flush()
        except (OSError, ValueError):  # a closed or broken stream must not stop the work
            self.enabled = self.live = False
