"""Writing outputs without ever losing a user's file: one file, or a whole output folder.

The rules for an output folder ``DIR`` (``planner plan --out DIR``,
``PlanResult.save(DIR)``, ``planner reproduce --out DIR``), all checked
before any work is done:

* An empty path is refused: an unset shell variable must not mean "here".
* ``DIR`` is an existing file, lies under one, is an existing folder that is not
  writable, or is absent and its nearest existing ancestor is not a writable
  folder: refused.
* ``DIR`` may be absent (it and its parents are created), empty, or a folder
  the planner wrote: it holds the marker ``.planner-output``, which lists the
  files published there with the size and modification time each had then,
  and nothing else. A listed file that has changed since (edited, replaced,
  or a marker copied or written by hand beside other files) is not the
  planner's; nor, to a run that names the files it writes, is a listed file
  of another name (a plan's outputs where a reproduction goes: replacing the
  folder whole would delete them). Any other folder is refused unless
  ``force`` is given: then the outputs are moved into it one file at a time
  (each move atomic), replacing files of the same names and keeping every
  other file; a folder where an output file goes is refused (checked before
  the work when the caller names its files, and before the first move).
* Otherwise publishing is one atomic step: the files are written to a staging
  folder beside ``DIR`` (same parent, hence the same filesystem) and the
  staging folder is swapped with ``DIR`` in one ``renameat2(RENAME_EXCHANGE)``
  call (Linux); where the system cannot exchange, ``DIR`` is renamed aside and
  the staging folder renamed in its place, so ``DIR`` never holds a mix of old
  and new files. The current working folder, mount points and a folder whose
  parent is not writable (a container's bind mount) cannot be renamed: outputs
  go into them one file at a time.
* While a plan runs, ``DIR`` is locked (``flock`` on ``.DIR.lock`` beside it, or
  on ``INSIDE_LOCK`` in it where its parent is not writable):
  a second writer fails at once instead of interleaving. The lock file is the
  planner's only while empty: one holding data is refused, not taken over. Staging
  folders of a killed run are removed by the next run that takes the lock: only
  folders named ``.DIR.staging-`` and 8 hex digits, matched literally, that hold the
  file ``.planner-staging`` every staging folder gets when it is made.
* On any failure or interruption (an exception, Ctrl-C, SIGTERM turned into an
  exception by the CLI) the staging folder, and any parent folder made for the
  run, is deleted and ``DIR`` is left as it was.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import glob
import json
import os
import re
import secrets
import shutil
import stat
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from .errors import OutputError, path_encoding_advice, shown
from .interrupts import check as check_interrupted
from .interrupts import publishing

MARKER = ".planner-output"
#: In every staging folder from its creation until publishing: a later run removes only folders holding it.
STAGING_MARKER = ".planner-staging"
#: The lock file of an output folder whose parent is not writable, in the folder itself (``_Lock``).
INSIDE_LOCK = ".planner-output.lock"
#: The largest marker read [bytes]: it lists a folder's published files, a few hundred bytes.
MAX_MARKER_BYTES = 2**20
#: How a refusal of a folder names the way past it: the command's flag, and save's parameter.
FORCE = "--force (force=True from Python)"
#: A staging folder is named ``.DIR.staging-`` and this many random hex digits.
_STAGING_DIGITS = 8
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def absolute_path(path, what: str) -> Path:
    """``path`` as an absolute path with symbolic links resolved, as the system resolves it: a ``..`` after a
    symbolic link leaves the link's target, not the link's folder (``os.path.abspath`` first, which drops
    ``link/..`` as text, wrote where the system's ``link/../x`` does not lead); an empty path is refused.

    Raises:
        OutputError: an empty path, one that is not text or a path-like, holds a NUL or bytes that are not
            UTF-8, or cannot be resolved.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise OutputError(f"{what} must be a path (text or path-like), not {type(path).__name__}")
    text = os.fspath(path)
    if not isinstance(text, str):
        raise OutputError(f"{what} must be a path given as text, not {type(text).__name__}")
    if text.strip() == "":
        raise OutputError(f"{what} is empty (an unset shell variable?); give a path")
    if "\0" in text:
        raise OutputError(f"{what} {shown(text)} holds a NUL character")
    try:
        absolute = Path(text).absolute().resolve()
    except (OSError, RuntimeError) as exc:  # a symlink loop, a name too long
        raise OutputError(f"{what} {shown(text)}: {getattr(exc, 'strerror', None) or exc}") from None
    if not utf8_path(absolute):
        raise OutputError(f"{what} {shown(str(absolute))}: "
                          + not_utf8(absolute, "the planner writes at UTF-8 paths only (Rerun, which writes its "
                                               "recordings and screenshots, takes no others): choose another"))
    return absolute


def utf8_path(path: Path) -> bool:
    """Whether ``path`` is text that encodes as UTF-8 (a name read from bytes that are not UTF-8 holds
    surrogates, which Rerun, taking paths as UTF-8 strings, refuses)."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def not_utf8(path: Path, remedy: str) -> str:
    """Why ``path`` (not ``utf8_path``) cannot be used: its bytes are not UTF-8 (then ``remedy``), or
    they are and the filesystem encoding cannot show them (``path_encoding_advice``)."""
    try:
        os.fsencode(path).decode("utf-8")
    except UnicodeDecodeError:
        return f"the path holds bytes that are not UTF-8 (shown as \\udcXX); {remedy}"
    return f"the path is UTF-8{path_encoding_advice(str(path))}"


def _check_force(force) -> None:
    """``force`` is True or False: any other value (``force="no"``, truthy) would replace a user's files.

    Raises:
        OutputError: anything else, naming it.
    """
    if not isinstance(force, bool):
        raise OutputError(f"force must be True or False, not {shown(force)}")


def check_writable_location(path: Path, what: str) -> None:
    """The nearest existing ancestor of ``path`` is a folder this process may write in.

    Raises:
        OutputError: an ancestor is a file, or the folder is not writable.
    """
    for ancestor in path.parents:
        if ancestor.exists():
            if not ancestor.is_dir():
                raise OutputError(f"{what} {path} lies under {ancestor}, which is a file, not a folder")
            if not os.access(ancestor, os.W_OK | os.X_OK):
                raise OutputError(f"{what} {path}: cannot write in {ancestor} (permission denied)")
            return


def _listing(folder: Path) -> set[str]:
    """The names in output folder ``folder`` but the planner's own working entries there: a lock
    (``INSIDE_LOCK``) and staging folders (``_stale_staging``: a run's writing in place, or a killed one's)."""
    try:
        names = {entry.name for entry in folder.iterdir()}
    except OSError as exc:
        raise OutputError(f"output folder {folder}: cannot list it ({exc.strerror})") from None
    return names - {INSIDE_LOCK} - {entry.name for entry in _stale_staging(folder, folder.name)}


def _signature(path: Path) -> list[int] | None:
    """[size in bytes, modification time in ns] of the file ``path`` (not following a symbolic link), or
    None where it is absent (or its name cannot be, being too long)."""
    try:
        found = path.lstat()
    except OSError:
        return None
    return [found.st_size, found.st_mtime_ns]


def _marker(folder: Path) -> dict:
    """``folder``'s marker (a planner's holds an object); empty where there is none or it cannot be read, and
    where it is not a regular file of at most ``MAX_MARKER_BYTES`` (a pipe there hung the run, a link to
    /dev/zero read until memory ran out): opened without following a symbolic link or waiting on a pipe."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        descriptor = os.open(folder / MARKER, flags)
    except (OSError, ValueError):
        return {}
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            return {}
        raw = os.read(descriptor, MAX_MARKER_BYTES + 1)
        marker = json.loads(raw) if len(raw) <= MAX_MARKER_BYTES else None
    except (OSError, ValueError):
        return {}
    finally:
        os.close(descriptor)
    return marker if isinstance(marker, dict) else {}


def _planner_files(folder: Path) -> set[str] | None:
    """The files the marker says the planner published in ``folder`` that are still as published (or
    gone), or None without a valid marker."""
    files = _marker(folder).get("files")
    if not isinstance(files, dict) or not all(
            _plain_name(name) and isinstance(sign, list) and len(sign) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) for n in sign) for name, sign in files.items()):
        return None  # a marker naming anything else is not the planner's
    return {name for name, sign in files.items() if _signature(folder / name) in (sign, None)}


def _older_marker(folder: Path) -> bool:
    """Whether ``folder``'s marker is one an older planner wrote: its files a list of names, without the
    sizes and times that tell the planner's files from a user's."""
    marker = _marker(folder)
    files = marker.get("files")
    return marker.get("written_by") == "planner" and isinstance(files, list) and all(
        isinstance(name, str) and _plain_name(name) for name in files)


def _plain_name(name: str) -> bool:
    """A file name of a folder's own: no separator, not '.' or '..', not hidden, printable."""
    return (name not in ("", ".", "..") and "/" not in name and "\\" not in name and not name.startswith(".")
            and name.isprintable())


def check_output_folder(path, *, force: bool = False, files: Iterable[str] = ()) -> tuple[Path, bool]:
    """Check ``path`` as an output folder before any work (the rules in the module docstring).
    ``files``: the names this run writes, where known: the planner's files of other names there (another
    command's outputs, a reproduction's beside a plan's) are then kept, as if a user's.

    Returns:
        The absolute folder, and whether the outputs must be merged into it file by file.

    Raises:
        OutputError: the path is empty, a file, under a file, not writable, or a
            non-empty folder the planner did not write (without ``force``).
    """
    folder = absolute_path(path, "output folder")
    _check_force(force)
    try:
        return _check_folder(folder, force, set(files))
    except OSError as exc:  # a name too long, an unreadable ancestor
        raise OutputError(f"output folder {shown(str(folder))}: {exc.strerror or exc}") from None


def _own_files(planner: set[str] | None, files: set[str]) -> set[str] | None:
    """Of a folder's ``_planner_files`` (``planner``), those this run writes (all, where ``files`` is
    empty: not known)."""
    return planner & files if planner is not None and files else planner


def _check_folder(folder: Path, force: bool, files: set[str]) -> tuple[Path, bool]:
    """``check_output_folder`` for an absolute ``folder``."""
    if folder == Path(folder.anchor):
        raise OutputError(f"output folder {folder} is the filesystem's root; give a folder of its own")
    if not folder.exists():
        check_writable_location(folder, "output folder")
        return folder, False
    if not folder.is_dir():
        raise OutputError(f"output folder {folder} is an existing file; give a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"output folder {folder} is not writable")
    present = _listing(folder)
    planner = _planner_files(folder)  # None: no marker, or a marker that is not the planner's (a folder, say)
    owned = _own_files(planner, files)
    foreign = present - (owned or set()) - ({MARKER} if owned is not None else set())
    if foreign and not force:
        other = (planner or set()) & foreign
        if other:
            names = ", ".join(sorted(other)[:5]) + (", ..." if len(other) > 5 else "")
            raise OutputError(f"output folder {folder} holds outputs the planner wrote that this run does not write "
                              f"({shown(names)}: another command's, a plan's or a reproduction's), which it would "
                              f"replace; give another folder, or add {FORCE} to write beside them (files of the same "
                              f"names are replaced, others kept)")
        if owned is None and _older_marker(folder):
            raise OutputError(f"output folder {folder} was written by an older version of the planner, whose marker "
                              f"({MARKER}) does not record what it wrote; give a new folder, or add {FORCE} to write "
                              f"into it (files of the same names are replaced, others kept)")
        names = ", ".join(sorted(foreign)[:5]) + (", ..." if len(foreign) > 5 else "")
        raise OutputError(f"output folder {folder} holds files the planner did not write ({shown(names)}); "
                          f"give an empty or new folder, or add {FORCE} to write into it (files of the same "
                          f"names are replaced, others kept)")
    cwd = Path.cwd().resolve()
    in_place = (bool(foreign) or folder == cwd or folder in cwd.parents or os.path.ismount(folder)
                or not _writable_parent(folder))
    return folder, in_place


def _writable_parent(folder: Path) -> bool:
    """Whether this process may make and rename entries in ``folder``'s parent."""
    return os.access(folder.parent, os.W_OK | os.X_OK)


def _longer_names_hint(exc: OSError) -> str:
    """Where a name was too long: the planner's names beside (or in) an output folder NAME, which a
    name the file system takes may still exceed, and how short NAME must be; else ""."""
    if exc.errno != errno.ENAMETOOLONG:
        return ""
    extra = len(".staging-") + 1 + _STAGING_DIGITS  # the longest: the lock's .NAME.lock is shorter
    return (f"; the planner locks it as .NAME.lock and stages its outputs as .NAME.staging-XXXXXXXX, up to {extra} "
            f"bytes longer than its name: shorten it to at most {255 - extra} bytes")


class _Lock:
    """An exclusive ``flock`` on ``.NAME.lock`` beside a folder (``INSIDE_LOCK`` in it, where it exists and its
    parent is not writable), removed when released."""

    def __init__(self, folder: Path):
        inside = folder.is_dir() and not _writable_parent(folder)
        self.folder = folder
        self.path = folder / INSIDE_LOCK if inside else folder.parent / f".{folder.name}.lock"
        self.handle: int | None = None

    def acquire(self) -> None:
        while True:
            handle = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(handle)
                raise OutputError(f"output folder {self.folder} is being written by another planner process; wait "
                                  f"for it or choose another folder") from None
            try:  # the previous holder may have removed the file between our open and our lock
                same = os.stat(self.path).st_ino == os.fstat(handle).st_ino
            except FileNotFoundError:
                same = False
            if same:
                held = os.fstat(handle)
                if not stat.S_ISREG(held.st_mode) or held.st_size:  # a planner's lock file is always empty
                    os.close(handle)
                    raise OutputError(f"{shown(str(self.path))} is not a planner lock file (it holds data); "
                                      f"move it away or choose another output folder")
                self.handle = handle
                return
            os.close(handle)

    def release(self) -> str | None:
        """Unlock and remove the lock file; the reason it could not be removed (a folder made read-only
        during the run), else None."""
        left = None
        if self.handle is not None:
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
            except OSError as exc:
                left = exc.strerror or str(exc)
            os.close(self.handle)
            self.handle = None
        return left


def _exchange(first: Path, second: Path) -> bool:
    """Swap two paths in one atomic step (Linux ``renameat2``); False where the system cannot."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    if renameat2(_AT_FDCWD, os.fsencode(first), _AT_FDCWD, os.fsencode(second), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(second))


def _publish_whole(staging: Path, folder: Path) -> None:
    """Make ``staging`` be ``folder`` in one step; the old ``folder`` (if any) is deleted after."""
    if not folder.exists():
        os.rename(staging, folder)
        return
    if _exchange(staging, folder):
        shutil.rmtree(staging, ignore_errors=True)  # now the old contents
        return
    aside = folder.parent / f".{folder.name}.old-{secrets.token_hex(4)}"
    os.rename(folder, aside)
    try:
        os.rename(staging, folder)
    except BaseException:  # the old folder back, whatever stopped it
        os.rename(aside, folder)
        raise
    shutil.rmtree(aside, ignore_errors=True)


def _check_no_folder_in_the_way(folder: Path, names: Iterable[str]) -> None:
    """Refuse to merge into ``folder`` where one of the file ``names`` is a folder there (a file cannot
    replace it: the merge would stop half done)."""
    blocking = sorted(name for name in names if (folder / name).is_dir() and not (folder / name).is_symlink())
    if blocking:
        raise OutputError(f"output folder {folder} holds a folder named {shown(', '.join(blocking))}, where the "
                          f"planner writes a file; move it away, or give another output folder")


def _publish_in_place(staging: Path, folder: Path, stale: set[str]) -> None:
    """Move each file of ``staging`` into ``folder`` (each move atomic); remove ``stale`` planner files.
    Checked first, so that it cannot stop half done."""
    _check_no_folder_in_the_way(folder, (item.name for item in staging.iterdir()))
    for item in staging.iterdir():
        if item.name != MARKER:
            os.replace(item, folder / item.name)
    for name in stale:
        (folder / name).unlink(missing_ok=True)
    os.replace(staging / MARKER, folder / MARKER)


def _stale_staging(place: Path, name: str) -> list[Path]:
    """The staging folders of output folder ``name`` in ``place`` (a running run's, or one a killed run left): named
    ``.NAME.staging-`` and ``_STAGING_DIGITS`` hex digits (compared literally: ``name`` may hold glob
    characters), real folders, holding ``STAGING_MARKER`` or nothing (a run whose folder was made read-only
    removed the marker and the outputs, not the folder)."""
    prefix = f".{name}.staging-"
    try:
        entries = list(place.iterdir())
    except OSError:
        return []
    return [entry for entry in entries
            if entry.name.startswith(prefix) and len(entry.name) == len(prefix) + _STAGING_DIGITS
            and all(c in "0123456789abcdef" for c in entry.name[len(prefix):])
            and entry.is_dir() and not entry.is_symlink()
            and ((entry / STAGING_MARKER).is_file() or _empty(entry))]


def _empty(folder: Path) -> bool:
    """Whether ``folder`` can be listed and holds nothing."""
    try:
        return not any(folder.iterdir())
    except OSError:
        return False


def _write_marker(staging: Path, kept: dict[str, list[int]] | None = None) -> set[str]:
    """Write the marker listing every file in ``staging`` with its ``_signature`` (moves keep both), and
    the ``kept`` entries of the marker of the folder written into (the planner's files there that this
    run does not write); returns the names written."""
    files = {entry.name: _signature(entry) for entry in sorted(staging.iterdir())}
    document = {"written_by": "planner", "files": {**(kept or {}), **files}}
    (staging / MARKER).write_text(json.dumps(document) + "\n")
    return set(files)


def _other_entries(folder: Path, files: tuple[str, ...]) -> dict[str, list[int]]:
    """The marker entries of ``folder``'s files the planner wrote, still as written, that a run writing
    ``files`` does not write (another command's outputs, kept where it writes beside them)."""
    if not files or not folder.is_dir():
        return {}
    others = (_planner_files(folder) or set()) - set(files)
    entries = _marker(folder).get("files", {})
    return {name: entries[name] for name in sorted(others) if (folder / name).is_file()}


@contextmanager
def output_folder(path, *, force: bool = False, files: Iterable[str] = ()) -> Iterator[Path]:
    """Check and lock ``path``, yield an empty staging folder, and publish it when the block succeeds.

    ``files``: the names the block will write, if known, so that a folder of one of these names in
    a folder written into with ``force`` is refused before the work rather than at publishing, and
    the planner's files of other names there (another command's outputs) are kept, as if a user's.

    Enter it before the work that produces the outputs: a bad path fails before
    any computation, and the lock covers the whole run. On any exception
    (including ``KeyboardInterrupt``) the staging folder is removed and the
    destination is left as it was.

    Raises:
        OutputError: ``check_output_folder``'s errors, another process writing the same folder, or the
            system refusing to write the outputs (a full disk, a quota).
    """
    files = tuple(files)
    folder, in_place = check_output_folder(path, force=force, files=files)
    created = _missing_parents(folder)
    lock = _Lock(folder)
    try:
        _make_folders(created)
        lock.acquire()
    except OSError as exc:  # /proc, a name too long, a full disk: the path cannot take outputs
        _remove_empty(created)
        raise OutputError(f"output folder {folder}: cannot write there ({exc.strerror or exc})"
                          f"{_longer_names_hint(exc)}") from None
    staging, published = None, False
    try:
        stale_places = [folder.parent] + ([folder] if folder.is_dir() else [])  # beside it, or inside (--force)
        for stale in (found for place in stale_places for found in _stale_staging(place, folder.name)):
            shutil.rmtree(stale, ignore_errors=True)
        folder, in_place = check_output_folder(folder, force=force, files=files)  # again, now that we hold the lock
        if in_place and folder.exists():
            _check_no_folder_in_the_way(folder, files)
        base = folder if in_place and folder.exists() else folder.parent
        staging = base / f".{folder.name}.staging-{secrets.token_hex(_STAGING_DIGITS // 2)}"
        try:
            os.mkdir(staging, 0o777)  # the umask applies, as to any folder the user makes
        except OSError as exc:
            staging = None
            raise OutputError(f"output folder {folder}: cannot write there ({exc.strerror or exc})"
                              f"{_longer_names_hint(exc)}") from None
        (staging / STAGING_MARKER).touch()
        yield staging
        # Again: while this run worked, another may have written into DIR (its own --out DIR/sub, say);
        # swapping DIR out whole would delete that. Refused now, or (--force) merged file by file.
        in_place = in_place or check_output_folder(folder, force=force, files=files)[1]
        (staging / STAGING_MARKER).unlink()
        written = _write_marker(staging, _other_entries(folder, files) if in_place else None)
        with publishing():  # an interruption a library swallowed stops it first; one in it waits: no half run
            if in_place:
                folder.mkdir(exist_ok=True)
                _publish_in_place(staging, folder,
                                  (_own_files(_planner_files(folder), set(files)) or set()) - written)
            else:
                _publish_whole(staging, folder)
            published = True
    except OSError as exc:  # a full disk, a quota: the outputs could not be written (the folder is as it was)
        raise OutputError(f"output folder {shown(str(folder))}: cannot write the outputs "
                          f"({exc.strerror or exc})") from None
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        reason = lock.release()
        if not published:  # parents made for this run go too: a failed run leaves no trace
            _remove_empty(created)
        left = [str(place) for place, stays in ((staging, staging is not None and os.path.lexists(staging)),
                                                (lock.path, reason is not None)) if stays]
        failure = sys.exc_info()[1]
        if left and isinstance(failure, OutputError):  # a folder made read-only during the run, say
            raise OutputError(f"{failure}; the run's {' and '.join(map(shown, left))} could not be removed"
                              f"{f' ({reason})' if reason else ''}: remove {'them' if len(left) > 1 else 'it'} "
                              f"once the folder is writable again") from None


def _missing_parents(path: Path) -> list[Path]:
    """The ancestors of ``path`` that do not exist yet, deepest first (what a run will create)."""
    return [ancestor for ancestor in path.parents if not ancestor.exists()]


def _make_folders(missing: list[Path]) -> None:
    """Create the folders ``missing`` (``_missing_parents``: deepest first), shallowest first, one by one:
    ``Path.mkdir(parents=True)`` recurses once per level, and a path some 1500 folders deep (legal on Linux)
    ran out of Python's recursion limit (a ``RecursionError`` reported as an internal error)."""
    for folder in reversed(missing):
        try:
            folder.mkdir()
        except FileExistsError:  # made meanwhile by another process; a file there fails at the next level
            if not folder.is_dir():
                raise


def _remove_empty(folders: list[Path]) -> None:
    """Remove ``folders`` (deepest first) while they are empty: the parents a failed run made."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            break


def check_output_file(path, *, force: bool = False) -> Path:
    """``path`` as an absolute file path that can be written, checked before any work.

    Raises:
        OutputError: an empty path, a path that is a folder (or ends with a separator) or lies under a
            file, an unwritable folder, or (without ``force``) an existing file: a user's file is never
            replaced unasked.
    """
    target = absolute_path(path, "output file")
    _check_force(force)
    if os.fspath(path).endswith(tuple(filter(None, (os.sep, os.altsep)))):
        raise OutputError(f"output file {shown(os.fspath(path))} ends with a path separator, which names a folder; "
                          f"give a file name")
    try:
        return _check_file(target, force)
    except OSError as exc:
        raise OutputError(f"output file {shown(str(target))}: {exc.strerror or exc}") from None


def _check_file(target: Path, force: bool) -> Path:
    """``check_output_file`` for an absolute ``target``."""
    if target.is_dir():
        raise OutputError(f"output file {target} is an existing folder; give a file name")
    if target.exists() and not target.is_file():
        raise OutputError(f"output file {target} exists and is not a regular file (a device, pipe or socket); "
                          f"give a file name")
    if target.exists() and not force:
        raise OutputError(f"output file {target} exists; add --force to replace it, or give another name")
    check_writable_location(target, "output file")
    return target


#: The part of a temporary output file's name (``.NAME.XXXXXXXX.tmp``) after ``.NAME.``.
_STALE_TEMPORARY = re.compile(r"[0-9a-f]{8}\.tmp")
#: A file a run holds locked is left alone for this long [s] after it was last changed, however it looks:
#: between its creation and its lock another run could otherwise take it for abandoned.
ABANDONED_AFTER_S = 60.0


def abandoned(path: Path) -> bool:
    """Whether the file at ``path`` was left by a run that ended without removing it (killed outright): no
    process holds its ``flock`` and it has not changed for ``ABANDONED_AFTER_S``."""
    try:
        if time.time() - path.lstat().st_mtime < ABANDONED_AFTER_S or not path.is_file():
            return False
        handle = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except OSError:
        return False
    finally:
        os.close(handle)


@contextmanager
def atomic_file(path, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``, else delete it
    (and the parent folders made for it).

    The file gets the permissions any new file of the user gets (0666 less the umask).

    Raises:
        OutputError: as ``check_output_file``; or the system refused to make, write or rename the
            file (a full disk, a place such as /proc that takes no new files), naming it.
    """
    target = check_output_file(path, force=force)
    created = _missing_parents(target)
    published = False
    try:
        _make_folders(created)
        for stale in target.parent.glob(f".{glob.escape(target.name)}.*.tmp"):  # a run killed outright left it
            if _STALE_TEMPORARY.fullmatch(stale.name[len(target.name) + 2:]) and abandoned(stale):
                stale.unlink(missing_ok=True)
        temporary = target.parent / f".{target.name}.{secrets.token_hex(4)}.tmp"
        held = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        try:
            fcntl.flock(held, fcntl.LOCK_EX)  # held while the file is ours: ``abandoned`` once we are gone
            yield temporary
            check_interrupted()  # one a library swallowed (an import's weakref callback) must not publish the file
            os.replace(temporary, target)
            published = True
        finally:
            os.close(held)
            temporary.unlink(missing_ok=True)
    except OSError as exc:
        raise OutputError(f"output file {shown(str(target))}: cannot write it ({exc.strerror or exc})") from None
    finally:
        if not published:
            _remove_empty(created)
