"""What an optimizer returns, and the bookkeeping every optimizer shares."""

from __future__ import annotations

import time
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from ..errors import SettingError
from ..interrupts import check as check_interrupted
from ..read_only import ReadOnlyArrays, freeze_arrays
from .problem import Evaluation, TimingProblem

#: progress(done, total, best_objective) -> None, called once per iteration.
Progress = Callable[[int, int, float], None]


#: Starts whose repaired objectives are within this relative gap of the best agree.
AGREEMENT = 1e-4
#: IPOPT statuses after which a solution is used (a round's, in the NLP) and a start has converged.
SOLVED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


@dataclass(frozen=True)
class StartReport:
    """One start of a local refinement (the sparse NLP) and where it ended.

    Attributes:
        label: where the start came from (``nest 1``, ``rest-to-rest``, ...).
        objective: objective of the refined, repaired durations (total time [s] for ``time``).
        feasible: the repaired result passed the exact check.
        iterations: solver iterations over all rounds; rounds: solves made.
        status: the solver's last return status.
        certificates: certificates the last round needed.
    """

    label: str
    objective: float
    feasible: bool
    iterations: int
    rounds: int
    status: str
    certificates: int


@dataclass(frozen=True)
class OptimizationResult(ReadOnlyArrays):
    """Outcome of one optimizer run on a ``TimingProblem``.

    Attributes:
        algorithm: optimizer name (``nlp``, ``cuckoo``, ``cuckoo-paper``, ``pso``, ``de``, ``slsqp``).
        durations: (S,) best segment durations [s].
        total_time: sum of the durations [s].
        objective: objective value of the best durations.
        ratios: (3, J) exact constraint ratios of the best durations.
        feasible: every limit and bound holds (exact check, 1e-9 relative tolerance).
        evaluations: candidate evaluations spent.
        wall_time_s: wall-clock time of the run [s].
        history: best objective after each iteration (convergence history).
        stop_reason: why the run ended.
        seed: the seed of its random generator (None when deterministic).
        settings: the algorithm's settings.
        starts: the refinement's starts, when it ran the sparse NLP.
        knot_states: (n, J, 3) velocity, acceleration and jerk at each (merged) via-point, where the
            family's are free and the NLP chose them (``TimingProblem.trajectory``); None: the
            family's own rule.
    """

    algorithm: str
    durations: np.ndarray
    total_time: float
    objective: float
    ratios: np.ndarray
    feasible: bool
    evaluations: int
    wall_time_s: float
    history: list[float]
    stop_reason: str
    seed: int | None
    settings: dict = field(default_factory=dict)
    starts: list[StartReport] = field(default_factory=list)
    knot_states: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)

    @property
    def out_of_time(self) -> bool:
        """The time limit ended the run: the result is the best timing found by then."""
        return self.stop_reason.startswith(TIME_LIMIT_REASON)

    @property
    def max_ratio(self) -> float:
        """The largest constraint ratio r_{j,d} of the result."""
        return float(self.ratios.max())

    @property
    def starts_agree(self) -> bool | None:
        """Every refinement start converged (``SOLVED``) to a feasible result within ``AGREEMENT`` of the
        best (None without starts): starts stopped at IPOPT's iteration cap at one point do not agree."""
        if not self.starts:
            return None
        values = np.array([s.objective if s.feasible and s.status in SOLVED else np.inf for s in self.starts])
        return bool(np.isfinite(values).all() and np.all(values <= values.min() * (1 + AGREEMENT)))

    @property
    def solver_iterations(self) -> int:
        """Solver iterations over all refinement starts."""
        return sum(s.iterations for s in self.starts)


#: Most spline coefficients one evaluation holds at once (candidates x segments x joints x 8, 32 MB of
#: floats, and a few times that in work arrays): ``SearchTracker`` evaluates larger batches in chunks
#: (10,000 nests of 999 segments made one 915 MB array, then a MemoryError).
CHUNK_COEFFICIENTS = 2**22
#: Under a time limit, a chunk holds at most the candidates that take this fraction of the time left, at the
#: cost per candidate the tracker last measured; its first chunk holds ``PROBE_CANDIDATES``, to measure it.
#: Without that, a population's first evaluation ran whole past the limit (PSO with 10,000 particles of
#: 99 hermite7 segments: a chunk of 882 took 7.8 s for a time limit of 2 s).
CHUNK_TIME_SHARE = 0.1
PROBE_CANDIDATES = 8
#: Most numbers a search population may hold (members x segments, 160 MB of floats): ``check_population``.
MAX_POPULATION_NUMBERS = 2 * 10**7
#: How the stop reason of a run the time limit ended begins (``OptimizationResult.out_of_time``).
TIME_LIMIT_REASON = "time limit of"
#: Monotonic time [s] by which the running optimization must stop, or None (``time_limit``).
_deadline: ContextVar[float | None] = ContextVar("timing_deadline", default=None)


class OutOfTime(Exception):
    """The time limit passed: carries the tracker, whose best candidate becomes the result."""

    def __init__(self, tracker: "SearchTracker"):
        super().__init__("time limit reached")
        self.tracker = tracker


@contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Within the block, trackers stop the search (``OutOfTime``) once ``seconds`` [s] have passed, or
    earlier where an enclosing block's limit ends first (nested limits: the earliest deadline holds)."""
    outer = _deadline.get()
    own = None if seconds is None else time.monotonic() + seconds
    token = _deadline.set(own if outer is None else outer if own is None else min(outer, own))
    try:
        yield
    finally:
        _deadline.reset(token)


def remaining_time() -> float | None:
    """Seconds left before the time limit (at least 0), or None without one."""
    deadline = _deadline.get()
    return None if deadline is None else max(deadline - time.monotonic(), 0.0)


def check_population(problem: TimingProblem, setting: str, value: int, members: int) -> None:
    """Refuse a search population of ``members`` candidates, which ``setting`` = ``value`` makes (members
    in proportion to it), if its array of durations would hold more than ``MAX_POPULATION_NUMBERS``.

    Raises:
        SettingError: naming ``setting``, the population's size and the most this problem allows.
    """
    segments = problem.segment_count
    numbers = members * segments
    if numbers > MAX_POPULATION_NUMBERS:
        raise SettingError(setting, f"{value} makes a population of {members:,} candidates of {segments} durations "
                                    f"({numbers:,} numbers), above the {MAX_POPULATION_NUMBERS:,} a search holds: at "
                                    f"most {value * MAX_POPULATION_NUMBERS // numbers} for {segments} segments")


class SearchTracker:
    """Counts evaluations, keeps the best candidate seen and the per-iteration history; stops the
    search (``OutOfTime``) once a best candidate exists and the time limit has passed."""

    def __init__(self, problem: TimingProblem, progress: Progress | None = None, total_iterations: int = 0,
                 settings: dict | None = None):
        """``settings``: every setting of the search, defaults included (``OptimizationResult.settings``), known
        from its start: a run the time limit ends records them too."""
        self.problem = problem
        self.settings = dict(settings or {})
        self.evaluations = 0
        self.best_durations: np.ndarray | None = None
        self.best_objective = np.inf
        self.best_feasible = False
        self.best_states: np.ndarray | None = None
        self.history: list[float] = []
        self.starts: list[StartReport] = []
        self._progress = progress
        self._total = total_iterations
        self._start = time.perf_counter()
        self._candidate_seconds: float | None = None  # an evaluation's wall time per candidate [s], last measured

    def evaluate(self, candidates: np.ndarray, repair: bool = True) -> Evaluation:
        """Evaluate a batch (repaired from the search box, or as durations) and track the best."""
        return self._track(self.problem.evaluate if repair else self.problem.evaluate_durations, candidates)

    def _track(self, evaluate: Callable[[np.ndarray], Evaluation], candidates) -> Evaluation:
        """``evaluate(candidates)`` (B rows) in chunks of ``CHUNK_COEFFICIENTS`` at most, and under a
        time limit of ``CHUNK_TIME_SHARE`` of the time left (``_chunk_rows``): each chunk's candidates offered
        as the best and counted, the time limit checked after each."""
        count = len(candidates) if np.ndim(candidates) == 2 else 0  # (a malformed batch is refused whole)
        parts: list[Evaluation] = []
        begin = 0
        while begin < count or not parts:
            rows = count if count == 0 else self._chunk_rows()
            started = time.perf_counter()
            parts.append(evaluate(candidates[begin:begin + rows] if count else candidates))
            self._candidate_seconds = (time.perf_counter() - started) / max(len(parts[-1].objective), 1)
            begin += rows
            self.offer(parts[-1])
            self.check_time()
        if len(parts) == 1:
            return parts[0]
        def joined(name: str) -> np.ndarray:
            return np.concatenate([getattr(part, name) for part in parts])
        return Evaluation(joined("durations"), joined("objective"), joined("ratios"), joined("position_excess"),
                          joined("feasible"))  # (no states: ``evaluate`` and ``evaluate_durations`` return none)

    def _chunk_rows(self) -> int:
        """Candidates of the next chunk (``_track``): within ``CHUNK_COEFFICIENTS``, and under a time limit,
        ``PROBE_CANDIDATES`` at first, then what takes ``CHUNK_TIME_SHARE`` of the time left at the cost per
        candidate last measured."""
        most = max(1, CHUNK_COEFFICIENTS // (self.problem.segment_count * self.problem.joint_count * 8))
        left = remaining_time()
        if left is None:
            return most
        if self._candidate_seconds is None:
            return min(most, PROBE_CANDIDATES)
        return int(np.clip(CHUNK_TIME_SHARE * left / max(self._candidate_seconds, 1e-9), 1, most))

    def count(self, evaluations: int) -> None:
        """Count ``evaluations`` that offer no candidate (a finite-difference Jacobian's points) and stop
        at the time limit: a local solver between two offered candidates can take far longer than it."""
        self.evaluations += evaluations
        self.check_time()

    def check_time(self) -> None:
        """Stop the search (``OutOfTime``) if the time limit has passed and a best candidate exists."""
        if self.best_durations is not None and remaining_time() == 0.0:
            raise OutOfTime(self)

    def offer(self, evaluation: Evaluation) -> None:
        """Count ``evaluation``'s candidates and keep the best, feasible ones first (a penalised objective
        guides a search, but an infeasible candidate with a small penalty must not displace a feasible
        one), without stopping at the time limit (``check_time``): several results of work the limit
        ended go in before the search stops."""
        self.evaluations += len(evaluation.objective)
        feasible = np.asarray(evaluation.feasible, dtype=bool)
        pool = np.flatnonzero(feasible) if feasible.any() else np.arange(len(feasible))
        i = int(pool[np.argmin(evaluation.objective[pool])])
        if (feasible[i], -evaluation.objective[i]) > (self.best_feasible, -self.best_objective):
            self.best_objective = float(evaluation.objective[i])
            self.best_durations = evaluation.durations[i].copy()
            self.best_feasible = bool(feasible[i])
            self.best_states = None if evaluation.states is None else evaluation.states[i].copy()

    def end_iteration(self) -> None:
        """Close one iteration: record the best objective, report progress, check interruption and time."""
        check_interrupted()
        self.history.append(self.best_objective)
        if self._progress is not None:
            self._progress(len(self.history), self._total, self.best_objective)
        self.check_time()

    def result(self, algorithm: str, stop_reason: str, seed: int | None) -> OptimizationResult:
        """The result for the best candidate, re-checked exactly as durations (no repair), with the search's
        ``settings``."""
        states = None if self.best_states is None else self.best_states[None]
        final = self.problem.evaluate_durations(self.best_durations, states)
        return OptimizationResult(
            algorithm=algorithm, durations=final.durations[0], total_time=float(final.durations[0].sum()),
            objective=float(final.objective[0]), ratios=final.ratios[0], feasible=bool(final.feasible[0]),
            evaluations=self.evaluations, wall_time_s=time.perf_counter() - self._start,
            history=list(self.history), stop_reason=stop_reason, seed=seed, settings=self.settings,
            starts=list(self.starts), knot_states=self.best_states)
