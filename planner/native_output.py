"""Output that C++ libraries write straight to file descriptor 2 (the URDF parser's logging,
CasADi's warnings), kept off the user's terminal: the command line's stderr holds one line per error."""

from __future__ import annotations

import os
import sys
import tempfile
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def stderr_captured() -> Iterator[list[str]]:
    """Point file descriptor 2 at a temporary file for the ``with`` block (C++ libraries log there);
    the list yielded receives what was written, once the block ends. Restored in any case."""
    sys.stderr.flush()
    captured: list[str] = []
    saved = os.dup(2)
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 2)
            try:
                yield captured
            finally:
                sys.stderr.flush()
                os.dup2(saved, 2)
                sink.seek(0)
                captured.append(sink.read(4096).decode("utf-8", "replace"))
    finally:
        os.close(saved)
