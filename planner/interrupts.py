"""Interruptions (Ctrl-C, SIGTERM) that no library may swallow.

IPOPT, through CasADi, catches the ``KeyboardInterrupt`` a signal handler
raises inside its callbacks, prints a warning and carries on. So the command
line's handlers also *record* the interruption here, and the long-running
loops (after every IPOPT solve, every optimizer iteration, and just before
outputs are published) call ``check``, which raises it
again. Only the first interruption is raised: later ones would cut its cleanup
short. Once the outputs are published the work is done: ``finish`` makes later
signals change nothing.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

_pending: BaseException | None = None
_finished = False
_deferring = 0
_publishing = False


def request(interruption: BaseException) -> None:
    """Record ``interruption`` (an exception instance) and raise it, unless the work is already
    finished or an earlier interruption is on its way: a second signal (Ctrl-C then ``kill``, a
    second Ctrl-C) raised inside the first one's cleanup would cut it short and leave a lock or a
    staging folder behind, so it changes nothing."""
    global _pending
    if _finished or _pending is not None:
        return
    _pending = interruption
    if not _deferring:
        raise interruption


def check() -> None:
    """Raise the recorded interruption, if any (call it where a swallowed one must surface)."""
    if _pending is not None and not _finished and not _publishing:
        raise _pending


@contextmanager
def deferred() -> Iterator[None]:
    """An interruption requested in the ``with`` block is recorded there and raised when the block
    ends: for code that must not be cut halfway, or that would swallow it (a fork runs hooks,
    ``os.register_at_fork``, in which an exception is printed and dropped)."""
    global _deferring
    _deferring += 1
    try:
        yield
    finally:
        _deferring -= 1
    check()


@contextmanager
def publishing() -> Iterator[None]:
    """The step that publishes the outputs (renames that must all happen, or none): an interruption requested
    before it is raised at its start; one requested in it waits for its end. Once it has published, the work
    is done (``finish``): the interruption changes nothing. If it fails, the interruption is raised instead.
    Only renames belong in it: ``check`` raises nothing there (a second file's check would stop the pair half
    published)."""
    global _deferring, _publishing
    check()
    _deferring += 1
    _publishing = True
    try:
        yield
    except BaseException:
        _deferring -= 1
        _publishing = False
        check()
        raise
    _deferring -= 1
    _publishing = False
    finish()


def finish() -> None:
    """The outputs are published: ignore interruptions from now on."""
    global _finished
    _finished = True


def reset() -> None:
    """Forget any interruption (a new command starts)."""
    global _pending, _finished, _publishing
    _pending, _finished, _publishing = None, False, False
