"""Independent work spread over the machine's cores in forked worker processes.

The timing NLP's starts and the outputs' figure hold Python's global interpreter
lock while they run (CasADi's IPOPT calls, matplotlib), so threads do not run
them side by side; processes do. A forked child inherits everything already
built (a CasADi program, a trajectory), so only the items and the results
cross a pipe, pickled. Where the platform cannot fork, the process runs other
threads (forking then is unsafe, ``_fork_context``), or one worker is asked
for (the default: the core count), the work runs in the calling process, in
order: same results.

``WarmWorkers`` forks its children ahead of their work, so that each can prepare for
it (import its library) while the caller goes on; the work then crosses a pipe too.

A child's exception is raised again in the parent; an interruption of the
parent (Ctrl-C, SIGTERM, a time limit, an error in its own share) ends the children at once,
and on Linux a parent killed outright (SIGKILL) takes its children with it.
"""

from __future__ import annotations

import ctypes
import faulthandler
import multiprocessing
import os
import pickle
import signal
import tempfile
import threading
import time
from contextlib import contextmanager
from multiprocessing.connection import wait
from typing import Any, Callable, Iterator, Sequence, TypeVar

from .interrupts import check as check_interrupted
from .interrupts import deferred

Item = TypeVar("Item")
Result = TypeVar("Result")


class WorkerLost(RuntimeError):
    """A worker process ended without its results (killed by a signal, the out-of-memory killer, ...);
    ``said``: what it wrote on stderr, where that was kept (``call_in_child``), else empty."""

    said: str = ""


def core_count() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _fork_context():
    """The ``fork`` multiprocessing context, or None where the platform has none (Windows) or where this
    process runs other threads: a forked child holds only the thread that forked it, so a lock another
    thread held at that moment (the import lock, an allocator's, a library's) stays held in the child for
    good, and the child hangs at its first use (``planner.plan`` from several threads at once). The work
    then runs in the calling thread, in order: same results."""
    if threading.active_count() > 1 or "fork" not in multiprocessing.get_all_start_methods():
        return None
    return multiprocessing.get_context("fork")


def map_forked(function: Callable[[Item], Result], items: Sequence[Item], workers: int | None = None) -> list[Result]:
    """``[function(item) for item in items]`` over ``workers`` processes: the calling one and forked
    children, each taking the next item not yet taken until none is left (``_map``). ``workers``
    defaults to ``core_count()``; 1, one item, or no ``fork`` or shared counter on this platform
    (``_shared_counter``) runs everything here.
    """
    results = _map(function, items, workers)
    return [results[i] for i in range(len(items))]


def map_forked_until(function: Callable[[Item, Callable[[Result], None]], Result], items: Sequence[Item],
                     workers: int | None, deadline: float) -> list[Result | None]:
    """``[function(item, report) for item in items]`` over ``workers`` processes, stopped at ``deadline``
    (a ``time.monotonic()`` time [s]): every item runs in a child, each child taking the next item not yet
    taken (``map_forked``), and the caller only waits; children not done by then are ended (a library call
    cannot be stopped halfway in the calling process; a child can).

    ``report(partial)``, which ``function`` may call as it goes, sends a result it could already
    return (the best so far): an item not done by the deadline gets its last one, or None if it sent
    none. Without ``fork`` (``_fork_context``) or a shared counter (``_shared_counter``), everything runs
    here, ``report`` does nothing and the deadline is left to ``function`` (the timing NLP's IPOPT stops at
    the time limit by itself).
    """
    workers = min(workers or core_count(), len(items))
    context = _fork_context()
    taken = _shared_counter(context)
    if context is None or taken is None:
        return [function(item, _ignore) for item in items]
    results: dict[int, Result] = {}
    children: list = []
    try:
        waiting = {}
        for _ in range(workers):
            receive, send = context.Pipe(duplex=False)
            process = context.Process(target=_serve_reporting, args=(function, items, taken, send, os.getpid()),
                                      daemon=True)
            with _forking():  # started and listed in one step: the cleanup below ends every child
                process.start()
                children.append((process, receive))
            send.close()
            waiting[receive] = process
        while waiting and (left := deadline - time.monotonic()) > 0:
            for ready in wait(list(waiting), timeout=left):
                _, index, payload = _message(ready, waiting[ready])
                if index == _ALL_TAKEN:
                    del waiting[ready]
                else:
                    results[index] = payload
    finally:
        _end(children)
    return [results.get(i) for i in range(len(items))]


def _message(receive, process) -> tuple[bool, int, Any]:
    """The next ``(done, index, result)`` of a ``map_forked_until`` child (``_serve_reporting``), or its
    exception raised here."""
    try:
        done, index, payload = receive.recv()
    except EOFError:
        raise _lost(process, "without a result") from None
    if index is None:  # the child failed
        raise payload
    return done, index, payload


def _ignore(partial) -> None:
    """A ``report`` that keeps nothing (``map_forked_until`` without ``fork``)."""


#: The index a ``map_forked_until`` child sends once no item is left to take.
_ALL_TAKEN = -1


def _serve_reporting(function: Callable, items: Sequence, taken, send, parent: int) -> None:
    """A ``map_forked_until`` child's work: per item it takes (``_next_item``), ``(False, index, partial)``
    for each ``report`` and ``(True, index, result)`` at its end, then ``(True, _ALL_TAKEN, None)``, or
    ``(True, None, exception)`` at the first failure, down ``send``."""
    _become_child(parent)
    try:
        while (index := _next_item(taken, len(items))) is not None:
            def report(partial, index=index) -> None:
                send.send((False, index, partial))
            send.send((True, index, function(items[index], report)))
        send.send((True, _ALL_TAKEN, None))
    except BaseException as exc:  # noqa: BLE001 - every failure goes to the parent
        try:
            send.send((True, None, _crossing(exc)))
        except OSError:  # the parent has stopped listening: nobody needs the error
            pass
    send.close()


def _map(function: Callable[[Item], Result], items: Sequence[Item], workers: int | None) -> dict[int, Result]:
    """The results of ``map_forked`` by item index: each worker, the caller among them, takes the next item
    not yet taken until none is left (items of unequal cost, such as the timing NLP's windows, keep every
    core busy to the end; results do not depend on who computed them)."""
    workers = min(workers or core_count(), len(items))
    context = _fork_context()
    taken = _shared_counter(context) if workers > 1 else None
    if context is None or taken is None:
        return {i: function(item) for i, item in enumerate(items)}
    children: list = []
    results: dict[int, Result] = {}
    try:
        for _ in range(workers - 1):
            receive, send = context.Pipe(duplex=False)
            process = context.Process(target=_serve_taking, args=(function, items, taken, send, os.getpid()),
                                      daemon=True)
            with _forking():  # started and listed in one step: the cleanup below ends every child
                process.start()
                children.append((process, receive))
            send.close()
        results.update(_taking(function, items, taken))
        for process, receive in children:
            results.update(_received(receive, process))
    finally:
        _end(children)
    return results


def _taking(function: Callable[[Item], Result], items: Sequence[Item], taken) -> dict[int, Result]:
    """``function`` of each item this worker takes (``_map``), by index, until none is left."""
    done = {}
    while (index := _next_item(taken, len(items))) is not None:
        done[index] = function(items[index])
    return done


def _shared_counter(context):
    """A counter shared by the processes forked from here (``context``'s ``Value`` with its lock), at 0: the
    index of the next item to take; None without ``fork``, or where the platform has no working semaphores
    (``sem_open``: some containers and serverless hosts), so that the work runs in the calling process."""
    if context is None:
        return None
    try:
        return context.Value("q", 0)
    except (ImportError, OSError):
        return None


def _next_item(taken, count: int) -> int | None:
    """The index of the next of ``count`` items not yet taken by any worker (``taken``: a shared counter), or
    None where all are."""
    with taken.get_lock():
        index = taken.value
        taken.value = index + 1
    return index if index < count else None


def call_in_child(function: Callable[[Item], Result], item: Item) -> Result:
    """``function(item)`` in a forked child, its result or exception brought back through a pipe: a failure
    that kills a process outright (a native library's abort, such as a Rust panic in a decoder) ends the
    child, not the caller, and is raised here as ``WorkerLost`` carrying what the child wrote on stderr
    (``said``), which stays off the caller's. Without ``fork`` (``_fork_context``), ``function(item)``
    runs here."""
    context = _fork_context()
    if context is None:
        return function(item)
    children: list = []
    results: dict[int, Result] = {}
    with tempfile.TemporaryFile() as stderr:
        try:
            receive, send = context.Pipe(duplex=False)
            process = context.Process(target=_serve_quietly, args=(function, item, send, os.getpid(), stderr.fileno()),
                                      daemon=True)
            with _forking():  # started and listed in one step: the cleanup below ends the child
                process.start()
                children.append((process, receive))
            send.close()
            _collect(receive, [0], process, results)
        except WorkerLost as lost:
            stderr.seek(0)
            lost.said = stderr.read(16000).decode("utf-8", "replace")  # (a backtrace follows its cause)
            raise
        finally:
            _end(children)
    return results[0]


def _serve_quietly(function: Callable, item, send, parent: int, stderr: int) -> None:
    """``call_in_child``'s child: its stderr to the file ``stderr`` (and no ``faulthandler`` dump, which
    writes where it was enabled), then ``_serve`` of the one item."""
    os.dup2(stderr, 2)
    faulthandler.disable()
    _serve(function, [item], send, parent)


def _end(children: list) -> None:
    """Close each (process, pipe end) pair's pipe and end the process if it still runs."""
    for process, receive in children:
        receive.close()
        if process.is_alive():
            process.terminate()
        process.join()


#: The signals the command line handles (``cli._interrupt``), held back while a child is forked
#: (``_forking``).
_HANDLED = {signal.SIGINT, signal.SIGTERM}


@contextmanager
def _forking() -> Iterator[None]:
    """The ``with`` block forks a child: Ctrl-C and SIGTERM are held back in this thread, which the
    child inherits (it unblocks them once it has set its own handlers, ``_become_child``), and an
    interruption the parent's handler records meanwhile (another thread may take the signal) is
    raised when the block ends (``interrupts.deferred``). Otherwise a signal then ran the parent's
    handler in the child (a traceback beside the command's one line), or in the parent inside the
    fork's own hooks, which swallow its exception: the parent then took the child's death for an
    internal error (3 runs in 25 with SIGTERM to the process group 0.3 to 2 s after the start)."""
    if not hasattr(signal, "pthread_sigmask"):  # not POSIX: no fork either
        yield
        return
    with deferred():
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, _HANDLED)
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


#: ``prctl`` option: the signal the kernel sends a process when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1


def end_with(parent: int) -> None:
    """Have the kernel end this child when process ``parent`` dies (Linux ``prctl``; kept across ``exec``):
    a parent killed by SIGKILL cleans nothing up, and its output writers kept its folder locked for a
    second (its headless viewer ran on for good). Elsewhere nothing changes."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (AttributeError, OSError):
        return
    if prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0 and os.getppid() != parent:
        os._exit(1)  # the parent died before the request took effect


def _collect(receive, share: list[int], process, results: dict) -> None:
    """A child's results for the items ``share`` into ``results``, or its exception raised here."""
    results.update(zip(share, _received(receive, process)))


def _received(receive, process):
    """What a child sent down ``receive`` (``_run_and_send``), or its exception raised here."""
    try:
        failed, payload = receive.recv()
    except EOFError:
        raise _lost(process, "without a result") from None
    if failed:
        raise payload
    return payload


def _lost(process, when: str) -> WorkerLost:
    """The error of a child that ended ``when`` (its pipe closed): the parent's own interruption
    is raised instead where the same signal ended the child."""
    process.join()
    check_interrupted()
    return WorkerLost(f"a worker process ended {when} (exit code {process.exitcode})")


def _serve_taking(function: Callable, items: Sequence, taken, send, parent: int) -> None:
    """A ``_map`` child's work: the results of the items it takes (``_taking``), by index, down ``send``
    (``_run_and_send``)."""
    _become_child(parent)
    _run_and_send(lambda: _taking(function, items, taken), send)


def _serve(function: Callable, items: list, send, parent: int) -> None:
    """A child's work: ``(False, results)`` or ``(True, exception)`` down ``send``."""
    _become_child(parent)
    _run_and_send(lambda: [function(item) for item in items], send)


def _become_child(parent: int) -> None:
    """The parent alone answers Ctrl-C and SIGTERM (and then ends its children): a child ignores
    SIGINT and dies at once on SIGTERM, rather than running the handlers it inherited, which a
    library may swallow (IPOPT does) and which would leave it running after its parent has gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HANDLED)  # held back by the parent (``_forking``)
    end_with(parent)


def _run_and_send(work: Callable[[], object], send) -> None:
    """``(False, work())``, or ``(True, exception)`` where it fails, down ``send``."""
    message: tuple[bool, object]
    try:
        message = (False, work())
    except BaseException as exc:  # noqa: BLE001 - every failure goes to the parent
        message = (True, _crossing(exc))
    try:
        send.send(message)
        send.close()
    except OSError:  # the parent has stopped listening: nobody needs the result
        pass


def _crossing(exc: BaseException) -> BaseException:
    """``exc`` itself if it survives the pipe whole, else a ``RuntimeError`` naming it."""
    return exc if _picklable(exc) else RuntimeError(f"{type(exc).__name__}: {exc}")


def _picklable(exc: BaseException) -> bool:
    """``exc`` survives the pipe (an exception whose constructor takes other arguments may not)."""
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:  # noqa: BLE001 - any failure to round-trip means no
        return False
    return True


class WarmWorkers:
    """Processes forked ahead of their work, each to prepare for its share (import its library,
    say) while the caller goes on; ``map`` then hands them their shares. Use it as a context
    manager: leaving it ends whatever child is still running.

    The work and its results cross pipes pickled (``map_forked`` needs no pickling: its children
    are forked with the work in hand). Each child serves one share and ends, so ``map`` runs once.
    Where the platform cannot fork, or the work does not pickle, ``map`` is ``map_forked``.
    """

    def __init__(self, preparations: Sequence[Callable[[], None] | None]):
        """One child per preparation: child w runs ``preparations[w]()`` (None: nothing), then serves
        item w of ``map``'s items, the one it prepared for, and then, of the items after the first
        ``count``, the next one not yet taken by any child until none is left (items of unequal cost
        keep every core busy to the end; without a shared counter, ``_shared_counter``, child w
        serves items w, w + count, ... instead). A preparation's failure is ignored there: the work
        that needs it fails in turn, and says why."""
        self.preparations = list(preparations)
        self._children: list = []
        self._used = False
        self._taken = None

    def __enter__(self) -> "WarmWorkers":
        context = _fork_context()
        if context is None:
            return self
        self._taken = _shared_counter(context)
        try:
            for prepare in self.preparations:
                jobs, give = context.Pipe(duplex=False)
                receive, send = context.Pipe(duplex=False)
                process = context.Process(target=_serve_when_given,
                                          args=(prepare, jobs, send, os.getpid(), self._taken), daemon=True)
                with _forking():  # started and listed in one step: ``__exit__`` ends every child
                    process.start()
                    self._children.append((process, give, receive))
                jobs.close()
                send.close()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc_info) -> None:
        for process, give, receive in self._children:
            give.close()
            receive.close()
            if process.is_alive():
                process.terminate()
            process.join()
        self._children = []

    def map(self, function: Callable[[Item], Result], items: Sequence[Item]) -> list[Result]:
        """``[function(item) for item in items]``, child w serving item w and then the items after the
        first ``count`` that it takes (``__init__``) while the caller waits; ``map_forked`` over as many
        workers when there are no children (no ``fork``, or outside the context) or the work does not
        pickle."""
        if self._used:
            raise RuntimeError("WarmWorkers.map runs once: each child serves one share")
        self._used = True
        children = self._children[:len(items)]
        count = len(children)
        # (item indices served first, the index from which items are taken from the shared counter)
        shares = ([([w], count) for w in range(count)] if self._taken is not None else
                  [(list(range(w, len(items), count)), len(items)) for w in range(count)])
        try:
            jobs = [pickle.dumps((function, items, own, shared_from)) for own, shared_from in shares]
        except Exception:  # noqa: BLE001 - whatever stops pickling: fork with the work in hand instead
            jobs = []
        if not children or not jobs:
            return map_forked(function, items, len(self.preparations))
        results: dict[int, Result] = {}
        try:
            for (process, give, _), job in zip(children, jobs):
                try:
                    give.send_bytes(job)
                except OSError:  # the child has died (killed): say so, as when its result is missing
                    raise _lost(process, "before its work was handed over") from None
            for _, give, _ in self._children:
                give.close()  # a child without a share ends
            for process, _, receive in children:
                results.update(_received(receive, process))
        except BaseException:
            self.__exit__(None, None, None)  # every child ends before the caller cleans up (its folder, say)
            raise
        return [results[i] for i in range(len(items))]


def _serve_when_given(prepare: Callable[[], None] | None, jobs, send, parent: int, taken) -> None:
    """A warm child: ``prepare()``, then the share that comes down ``jobs`` (none: it ends): its own
    items, then those it takes with the shared counter ``taken`` (``WarmWorkers.map``), their results
    by index down ``send``."""
    _become_child(parent)
    if prepare is not None:
        try:
            prepare()
        except Exception:  # noqa: BLE001, S110 - the work that needs it fails in turn and says why
            pass
    try:
        job = jobs.recv_bytes()
    except EOFError:
        return
    try:
        function, items, own, shared_from = pickle.loads(job)
    except Exception as exc:  # noqa: BLE001 - a share that cannot be read is that share's failure
        function, items, own, shared_from = _raise, [exc], [0], 1

    def serve() -> dict:
        done = {index: function(items[index]) for index in own}
        if shared_from < len(items):  # (never without a shared counter)
            while (index := _next_item(taken, len(items) - shared_from)) is not None:
                done[shared_from + index] = function(items[shared_from + index])
        return done
    _run_and_send(serve, send)


def _raise(exc: BaseException) -> None:
    raise exc
