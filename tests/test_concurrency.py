import functools
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from planner import InfeasibleError, UnknownRobotError
from planner.concurrency import WarmWorkers, WorkerLost, call_in_child, core_count, map_forked, map_forked_until


def square_with_pid(x):
    return x * x, os.getpid()


def test_every_item_in_order_and_shared_over_processes():
    results = map_forked(square_with_pid, list(range(7)), workers=3)
    assert [value for value, _ in results] == [x * x for x in range(7)]


def square_with_pid_slowly_at_zero(x, seconds=1.0):
    """``square_with_pid``, after ``seconds`` for item 0: while one worker does it, another takes the rest."""
    if x == 0:
        time.sleep(seconds)
    return square_with_pid(x)


def test_a_slow_item_does_not_hold_back_the_others():
    """Each worker takes the next item not yet taken: while one works through a slow item, the other does
    every other item (dealt out in fixed shares, it waited for the slow one's worker to do half of them)."""
    results = map_forked(square_with_pid_slowly_at_zero, list(range(9)), workers=2)
    assert [value for value, _ in results] == [x * x for x in range(9)]
    slow, others = results[0][1], {pid for _, pid in results[1:]}
    assert others.isdisjoint({slow}) and len(others) == 1 and os.getpid() in others | {slow}


def test_one_worker_or_one_item_runs_here():
    assert {pid for _, pid in map_forked(square_with_pid, [1, 2, 3], workers=1)} == {os.getpid()}
    assert map_forked(square_with_pid, [4]) == [(16, os.getpid())]
    assert map_forked(square_with_pid, []) == []
    assert core_count() >= 1


def test_with_other_threads_running_everything_runs_in_the_calling_thread():
    """A child forked beside another thread keeps any lock that thread held, for good (``planner.plan``
    from several threads at once hung in a forked NLP start until its time limit): with a second thread
    alive, every map runs here, in order, to the same results, and a deadline is left to the work."""
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert map_forked(square_with_pid, list(range(5)), workers=3) == [(x * x, os.getpid()) for x in range(5)]
        reported = map_forked_until(lambda x, report: square_with_pid(x), [2, 3], 2, time.monotonic() + 60)
        assert reported == [(4, os.getpid()), (9, os.getpid())]
        with WarmWorkers([None, None]) as workers:
            assert workers.map(square_with_pid, [5, 6]) == [(25, os.getpid()), (36, os.getpid())]
    finally:
        stop.set()
        other.join()
    alone_again = map_forked(functools.partial(square_with_pid_slowly_at_zero, seconds=0.3), [0, 1], workers=2)
    assert len({pid for _, pid in alone_again}) == 2


def abort_after_saying(text):
    os.write(2, text.encode())
    os.abort()


def test_a_call_in_a_child_returns_raises_or_names_the_crash_that_ended_it(capfd):
    """A native library's abort (a Rust panic) kills its process: in a child, the caller gets ``WorkerLost``
    with what the child said on stderr, none of which reaches the caller's; results and the planner's
    errors come back whole."""
    assert call_in_child(square_with_pid, 7)[0] == 49 and call_in_child(square_with_pid, 7)[1] != os.getpid()
    with pytest.raises(InfeasibleError, match="item 3 is odd") as raised:
        call_in_child(fail_on_odd, 3)
    assert (raised.value.joint, raised.value.joint_index) == ("joint4", 3)
    with pytest.raises(WorkerLost, match="exit code -6") as lost:
        call_in_child(abort_after_saying, "thread panicked at here:\nthe cause\n")
    assert lost.value.said.startswith("thread panicked at here:\nthe cause")
    assert "panicked" not in capfd.readouterr().err


def fail_on_odd(x):
    if x % 2:
        raise InfeasibleError(f"item {x} is odd", joint=f"joint{x + 1}", joint_index=x, quantity="velocity",
                               value=2.0, limit=1.0)
    return x


def test_a_childs_error_is_raised_in_the_parent_with_its_fields():
    with pytest.raises(InfeasibleError, match="item 1 is odd") as caught:
        map_forked(fail_on_odd, [0, 1], workers=2)
    assert (caught.value.joint, caught.value.joint_index, caught.value.quantity, caught.value.value) == (
        "joint2", 1, "velocity", 2.0)


def unknown_robot(x):
    if x == "puma":  # the child's item: the parent's share succeeds
        raise UnknownRobotError(f"no robot {x!r}", name=x, known=("ur5", "panda"))
    return x


def test_errors_whose_constructors_take_fields_cross_whole():
    with pytest.raises(UnknownRobotError, match="no robot 'puma'") as caught:
        map_forked(unknown_robot, ["ok", "puma"], workers=2)
    assert caught.value.name == "puma" and caught.value.known == ("ur5", "panda")


def die_in_a_child(caller):
    """Wait in the caller (so that a child takes an item), end a child with exit code 3."""
    if os.getpid() == caller:
        time.sleep(0.3)
        return caller
    os._exit(3)


def test_a_child_that_dies_is_an_error_not_a_hang():
    with pytest.raises(RuntimeError, match="exit code 3"):
        map_forked(die_in_a_child, [os.getpid()] * 2, workers=2)


class Stop(BaseException):
    """An interruption, as the command line's signal handler raises one."""


def stop_on_signal(signum, frame):
    """The command line's handler (``cli._interrupt``), raising ``Stop``."""
    from planner import interrupts
    interrupts.request(Stop(signum))


def blocked_signals(_):
    import signal
    return sorted(int(s) for s in signal.pthread_sigmask(signal.SIG_BLOCK, []))


def test_a_signal_during_a_fork_reaches_the_parent_after_it_and_never_the_child():
    """A SIGTERM that lands while a child is forked used to run the parent's handler in the child (a
    traceback on the shared stderr) or inside the fork's own hooks in the parent (swallowed). It is
    held back until the child is started and listed, then raised in the parent; children run with
    nothing held back."""
    import signal
    import threading
    import time

    from planner import concurrency, interrupts

    interrupts.reset()
    previous = signal.signal(signal.SIGTERM, stop_on_signal)
    reached = False
    other = threading.Event()
    waiting = threading.Thread(target=other.wait)  # the kernel gives the signal to this thread instead
    waiting.start()
    try:
        with pytest.raises(Stop):
            with concurrency._forking():
                os.kill(os.getpid(), signal.SIGTERM)
                deadline = time.monotonic() + 10
                while interrupts._pending is None and time.monotonic() < deadline:
                    time.sleep(0.001)  # the other thread takes it; the handler runs here, and records it
                reached = interrupts._pending is not None
        assert reached
        interrupts.reset()
        with WarmWorkers([None]) as workers:
            assert workers.map(blocked_signals, [0]) == [[]]
        assert map_forked(blocked_signals, [0, 1], workers=2) == [[], []]
    finally:
        other.set()
        waiting.join()
        signal.signal(signal.SIGTERM, previous)
        interrupts.reset()


def test_a_child_ended_by_the_parents_own_interruption_raises_that_interruption():
    """SIGTERM to the process group kills a child (it dies at once) as the parent's handler records
    the interruption: the parent raises the interruption, not 'a worker process ended without a
    result' (an internal error, exit 1, where 143 is due)."""
    from planner import interrupts

    interrupts.reset()  # a command run earlier in this process leaves it finished
    with pytest.raises(Stop):
        interrupts.request(Stop())
    try:
        with pytest.raises(Stop):
            map_forked(die_in_a_child, [os.getpid()] * 2, workers=2)
    finally:
        interrupts.reset()


def slow_unless_first(x):
    if x:
        import time
        time.sleep(60)
    raise KeyError("the parent's own share fails")


def sleep_or_die(x):
    import time
    if x == 0:
        os.kill(os.getpid(), 9)
    time.sleep(60)


def test_warm_workers_name_a_killed_child_and_end_the_others_before_raising():
    """A writer killed from outside (SIGKILL, the out-of-memory killer) was 'Broken pipe' (taken for the
    folder's fault) or an internal error, and the surviving writers still wrote into the staging folder
    that the failure's cleanup removed, leaving a half-written one behind. Now it is ``WorkerLost``, and
    every child has ended when ``map`` raises."""
    import multiprocessing
    import signal

    from planner.concurrency import WorkerLost

    with WarmWorkers([None, None]) as workers:
        os.kill(workers._children[0][0].pid, signal.SIGKILL)
        workers._children[0][0].join()
        with pytest.raises(WorkerLost, match=r"before its work was handed over \(exit code -9\)"):
            workers.map(square_with_pid, [1, 2])
        assert multiprocessing.active_children() == []
    with WarmWorkers([None, None]) as workers:
        with pytest.raises(WorkerLost, match=r"ended without a result \(exit code -9\)"):
            workers.map(sleep_or_die, [0, 1])  # the second child sleeps on: it must be ended first
        assert multiprocessing.active_children() == []


def test_the_parents_failure_ends_its_children():
    import multiprocessing
    with pytest.raises(KeyError):
        map_forked(slow_unless_first, [0, 1], workers=2)
    assert multiprocessing.active_children() == []


def mark_prepared(folder):
    def prepare():
        (folder / str(os.getpid())).write_text("prepared")
    return prepare


def fail_to_prepare():
    raise ImportError("no such library")


def test_warm_workers_prepare_first_then_serve_their_own_item_then_take_the_rest_as_they_are_free(tmp_path):
    """Each child runs its preparation before any work is handed over (the output writers import their
    libraries while the plan runs), then serves the item it prepared for (the recording, the figure), then
    the items after the children's own to whichever is free (the CSV's pieces): a child busy with a slow
    own item takes none of them. Results come back in the items' order."""
    import multiprocessing
    with WarmWorkers([mark_prepared(tmp_path), fail_to_prepare, None]) as workers:
        results = workers.map(square_with_pid_slowly_at_zero, list(range(7)))
        with pytest.raises(RuntimeError, match="runs once"):
            workers.map(square_with_pid, [1])
    assert [value for value, _ in results] == [x * x for x in range(7)]
    pids = [pid for _, pid in results]
    assert os.getpid() not in pids and len(set(pids[:3])) == 3
    assert [int(p.name) for p in tmp_path.iterdir()] == [pids[0]]  # child 0 prepared, and served item 0
    assert set(pids[3:]) <= {pids[1], pids[2]}  # taken while child 0 slept through item 0
    assert multiprocessing.active_children() == []


def test_warm_workers_without_a_shared_counter_serve_fixed_shares(monkeypatch):
    """Where the platform has no working semaphores, child w serves items w, w + count, ..."""
    import planner.concurrency as concurrency
    monkeypatch.setattr(concurrency, "_shared_counter", lambda context: None)
    with WarmWorkers([None, None, None]) as workers:
        results = workers.map(square_with_pid, list(range(8)))
    assert [value for value, _ in results] == [x * x for x in range(8)]
    pids = [pid for _, pid in results]
    assert len(set(pids)) == 3 and all(pids[w::3] == [pids[w]] * len(pids[w::3]) for w in range(3))


def test_warm_workers_raise_a_childs_error_and_end_unused_children():
    import multiprocessing
    with pytest.raises(InfeasibleError, match="item 1 is odd"):
        with WarmWorkers([None, None]) as workers:
            workers.map(fail_on_odd, [0, 1])
    with WarmWorkers([None, None, None]):
        pass  # never handed work (the plan failed): the children end with the context
    assert multiprocessing.active_children() == []


def test_warm_workers_fork_with_the_work_in_hand_when_it_does_not_pickle():
    offset = 10
    with WarmWorkers([None, None]) as workers:
        results = workers.map(lambda x: (x + offset, square_with_pid_slowly_at_zero(x, 0.3)[1]), [0, 1, 2])
    assert [value for value, _ in results] == [10, 11, 12]
    assert os.getpid() in {pid for _, pid in results} and len({pid for _, pid in results}) == 2  # map_forked


def test_concurrent_nlp_starts_match_serial_ones(monkeypatch):
    from planner import paper
    from planner.timing import TimingProblem, nlp, optimize

    via = np.deg2rad(np.cumsum(np.random.default_rng(3).uniform(-40, 40, (70, 6)), axis=0))
    problem = TimingProblem(via, "cubic", paper.paper_limits())
    monkeypatch.setattr(nlp, "CONCURRENT_SEGMENTS", 10**9)
    serial = optimize(problem, "nlp")
    monkeypatch.setattr(nlp, "CONCURRENT_SEGMENTS", 1)
    concurrent = optimize(problem, "nlp")
    assert serial.feasible and len(serial.starts) == 2
    assert (serial.settings["nlp"]["processes"], concurrent.settings["nlp"]["processes"]) == (1, 2)
    assert serial.settings["starts"] == ["cruise", "stop-at-turns"]
    assert serial.settings["nlp"]["ipopt"]["tol"] == nlp.IPOPT_OPTIONS["ipopt.tol"]
    np.testing.assert_array_equal(serial.durations, concurrent.durations)
    assert [(s.label, s.objective, s.iterations, s.status) for s in serial.starts] == \
        [(s.label, s.objective, s.iterations, s.status) for s in concurrent.starts]


def test_cut_families_solve_their_starts_side_by_side_from_few_segments(monkeypatch):
    """hermite7 and quintic take rounds of cuts per start: theirs run in processes from 2 segments, with
    the results of a serial run."""
    from planner import paper
    from planner.timing import TimingProblem, nlp, optimize

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG[:4]), "quintic", paper.paper_limits())
    concurrent = optimize(problem, "nlp")
    monkeypatch.setattr(nlp, "CUT_CONCURRENT_SEGMENTS", 10**9)
    serial = optimize(problem, "nlp")
    assert (serial.settings["nlp"]["processes"], concurrent.settings["nlp"]["processes"]) == (1, 2)
    np.testing.assert_array_equal(serial.durations, concurrent.durations)
    assert [(s.label, s.objective, s.iterations) for s in serial.starts] == \
        [(s.label, s.objective, s.iterations) for s in concurrent.starts]


def sleep_then_pid(seconds, report):
    import time
    time.sleep(seconds)
    return os.getpid()


def report_then_sleep(seconds, report):
    import time
    report(("first", os.getpid()))
    report(("second", os.getpid()))
    time.sleep(seconds)
    return ("done", os.getpid())


def test_a_deadline_ends_the_children_still_working():
    """Every item runs in a child; results of items not done by the deadline are None, and the children
    still working are ended (not left running)."""
    import time

    from planner.concurrency import map_forked_until

    def live_children() -> set[int]:
        """This process's children not yet ended (zombies are ended), read from /proc: asked through pgrep and
        ps, the shell os.popen starts for them is a live child itself, now and then still running (a fresh
        clone's suite failed on it once in four runs)."""
        found = set()
        for entry in filter(str.isdigit, os.listdir("/proc")):
            try:
                state, parent = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[:2]
            except OSError:  # ended meanwhile
                continue
            if int(parent) == os.getpid() and state != "Z":
                found.add(int(entry))
        return found
    before = live_children()  # what earlier tests left running (a headless viewer shutting down, say) is not ours
    start = time.monotonic()
    results = map_forked_until(sleep_then_pid, [0.0, 60.0, 0.0, 60.0], 2, start + 2.0)
    assert time.monotonic() - start < 30  # not the 60 s a child would sleep
    assert results[1] is None and results[3] is None
    assert os.getpid() not in {results[0], results[2]} and None not in {results[0], results[2]}
    assert live_children() - before == set()
    assert all(pid != os.getpid() for pid in map_forked_until(sleep_then_pid, [0.0, 0.0], 2, time.monotonic() + 30))


def test_a_deadline_keeps_the_last_result_each_unfinished_child_reported():
    """What a child reports as it goes stands in for its result if the deadline ends it first; a
    finished item's own result replaces its reports."""
    import time

    from planner.concurrency import map_forked_until
    results = map_forked_until(report_then_sleep, [60.0, 0.0, 60.0], 3, time.monotonic() + 3.0)
    assert [r[0] for r in results] == ["second", "done", "second"]
    assert results[0][1] != results[2][1] and os.getpid() not in {r[1] for r in results}


def test_the_time_limit_ends_nlp_starts_that_run_over(monkeypatch):
    """From CONCURRENT_SEGMENTS segments the starts run in processes; at the time limit those still
    solving are ended and reported so, and the result is the best repaired start (feasible)."""
    import time

    from planner import paper
    from planner.timing import TimingProblem, nlp, optimize

    def endless(self, start, report=None):
        time.sleep(600)
    via = np.deg2rad(np.cumsum(np.random.default_rng(3).uniform(-40, 40, (70, 6)), axis=0))
    problem = TimingProblem(via, "cubic", paper.paper_limits())
    monkeypatch.setattr(nlp.TimingNLP, "solve", endless)
    started = time.monotonic()
    result = optimize(problem, "nlp", time_limit_s=2.0)
    assert time.monotonic() - started < 60
    assert result.stop_reason == ("time limit of 2 s reached; it stopped the NLP from cruise before it solved a "
                                  "round, from stop-at-turns before it solved a round") and result.feasible
    assert problem.evaluate_durations(result.durations[None]).feasible[0]


def test_children_end_when_their_parent_is_killed_outright(tmp_path):
    """SIGKILL runs no cleanup in the parent: its children (output writers holding the folder's lock)
    outlived it by a second or more. The kernel now ends them with it (Linux)."""
    import signal
    import subprocess
    import sys
    import time

    script = tmp_path / "parent.py"
    script.write_text(
        "import os, sys, time\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "from planner.concurrency import map_forked\n"
        "def work(item):\n"
        "    if item:\n"
        "        open(sys.argv[2], 'w').write(str(os.getpid()))\n"
        "    time.sleep(60)\n"
        "map_forked(work, [0, 1], 2)\n")
    pid_file = tmp_path / "child.pid"
    parent = subprocess.Popen([sys.executable, str(script), str(Path(__file__).resolve().parents[1]), str(pid_file)])
    deadline = time.monotonic() + 30
    while not (pid_file.exists() and pid_file.read_text()) and time.monotonic() < deadline:
        time.sleep(0.02)
    child = int(pid_file.read_text())
    parent.send_signal(signal.SIGKILL)
    parent.wait(timeout=10)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        status = Path(f"/proc/{child}/stat").read_text().split()[2] if Path(f"/proc/{child}/stat").exists() else "X"
        if status == "Z":  # ended; waiting for init to reap it
            break
        time.sleep(0.05)
    else:
        os.kill(child, signal.SIGKILL)
        raise AssertionError("the child outlived its killed parent by 5 s")


def sleep_at_zero_then_pid(x, report):
    if x == 0:
        time.sleep(1.0)
    return os.getpid()


def test_under_a_deadline_a_slow_item_does_not_hold_back_the_others():
    """As ``map_forked``: while one child works through a slow item, the other takes every other one."""
    results = map_forked_until(sleep_at_zero_then_pid, list(range(7)), 2, time.monotonic() + 60)
    assert None not in results and os.getpid() not in results
    assert len(set(results[1:])) == 1 and results[0] not in results[1:]


def test_without_semaphores_the_work_runs_here(monkeypatch):
    """Where the platform has no working ``sem_open`` (some containers and serverless hosts), a shared
    counter cannot be made: the work runs in the calling process, to the same results, rather than failing."""
    import multiprocessing.context

    def no_semaphores(*args, **kwargs):
        raise ImportError("This platform lacks a functioning sem_open implementation")
    monkeypatch.setattr(multiprocessing.context.BaseContext, "Value", no_semaphores)
    assert map_forked(square_with_pid, [1, 2, 3], workers=2) == [(x * x, os.getpid()) for x in (1, 2, 3)]
    assert map_forked_until(sleep_at_zero_then_pid, [1, 2], 2, time.monotonic() + 60) == [os.getpid()] * 2
