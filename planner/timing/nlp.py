"""The timing problem as a sparse NLP with exact derivatives, solved by IPOPT through CasADi.

Decision variables: the segment durations h and the family's knot states
(``formulations.py``); every continuity condition involves one segment, so
the Jacobians are banded and the problem grows linearly with n.

    minimise    sum_k h_k                       (objective ``time``), or
                K_t sum_k h_k + K_j sum_j int q_j'''(t)^2 dt    (``time-jerk``; on each segment
                the integral is h^-5 int_0^1 P'''(s)^2 ds, a polynomial in the knot states)
    subject to  the family's continuity conditions (equalities),
                its exact limits: knot values (variable bounds), constant jerks, virtual knots,
                certificates for the extremes inside segments (below),
                h_min <= h_k <= h_max, or h_k >= 1e-6 of the time scale when unbounded
                (bounds on the log-durations, below).

Log-durations. The solver's duration variables are u_k = log(h_k / time scale),
not h_k. In h the objective is linear and the knot states are v ~ D / h, so at a
slow start (every limit slack but one) IPOPT's first Newton step, which sees no
curvature in h and a linearised v, shrinks durations 50-fold in one step; the
knot states then lie far from the spline of the new durations and the solve
sinks into the restoration phase (clipped random walks: 500 iterations
without progress). In u the objective sum exp(u_k) has its own curvature, which
bounds the step, and a step in u changes every duration by a factor, the way
the limits scale (velocity by exp(-du), acceleration by exp(-2 du), ...).

Certificates. Inside a segment a limited quantity f(s) = q^(d)(s h) (the
velocity of a cubic, the jerk of a quintic, a position, ...) must stay within
its bound for every s in [0, 1]: p(s) = side (bound - f(s)) / scale >= 0 there.
By Lukacs' theorem such a polynomial is a sum of squares weighted by s and
1 - s, which gives exact, smooth constraints with one or two extra variables:

* f quadratic, p = p0 + p1 s + p2 s^2: p >= 0 on [0, 1] if and only if some
  lambda >= 0 makes p(s) - lambda s (1 - s) a square, i.e. the matrix
  [[p0, (p1 - lambda) / 2], [(p1 - lambda) / 2, p2 + lambda]] is positive semidefinite:
  p0 >= 0, p2 + lambda >= 0 and 4 p0 (p2 + lambda) - (p1 - lambda)^2 >= 0.
* f cubic: p >= 0 on [0, 1] if and only if p = s A(s) + (1 - s) B(s) with A, B
  non-negative quadratics. Matching coefficients leaves two free numbers
  a0, a2 >= 0: A = (a0, p(1) - a0 - a2, a2), B = (p0, p0 + p1 - a0, a2 - p3),
  and each is non-negative when p0 >= 0, a2 - p3 >= 0, 4 a0 a2 >= (p(1) - a0 - a2)^2
  and 4 p0 (a2 - p3) >= (p0 + p1 - a0)^2.
* f cubic, a position next to a via-point on the same bound (a "touch"): the
  joint rests there (its knot velocity is fixed at 0, ``resting_sides`` in
  formulations.py), so p has a double root at that end and the general
  certificate degenerates (4 p0 (a2 - p3) >= (p0 + p1 - a0)^2 with p0 = p1 = 0
  forces a0 = 0 through a constraint whose gradient vanishes, and a2 likewise;
  IPOPT then stalls). Dividing the double root out leaves a linear factor,
  non-negative on [0, 1] iff at both ends: at s = 0, p = p0 + s^2 (p2 + p3 s):
  p0, p2, p2 + p3 >= 0; at s = 1, p = p(1) + (1-s)^2 (q2 + q3 (1-s)) with
  q2 = p2 + 3 p3, q3 = -p3: p(1), p2 + 3 p3, p2 + 2 p3 >= 0. Linear rows, no
  extra variable, exact on the bound; for a via-point just inside it (within
  ``RESTING_DISTANCE``, where it rests too) p0 > 0 and the rows are sufficient.
* f of higher degree (the quintic's velocity and position, hermite7's
  position): a cut, the bound imposed at the extreme s_c the exact check found,
  p(s_c) >= 0 (no extra variable). Cuts only ever relax the true constraint, so
  they never make the NLP infeasible where the problem is not; each round adds
  cuts at the extremes that moved, and the remaining violation shrinks with the
  square of the move.
* f of degree 4 to 7 where the via-point states are free (hermite7's velocity,
  acceleration and jerk): Lukacs' form with the Gram matrices' triangular
  factors as variables (``sos.py``: 9 to 16 per certificate, d + 1 equality
  rows), exact. trigonometric's velocity, acceleration and jerk likewise: no
  polynomial in s, but (1 + t^2)^4 f is one of degree 8 in u, t = tan(phi / 2)
  (``trigonometric.half_angle_map``; 25 variables per form), with the bound
  times that positive factor. The first round puts one on every side of every such quantity
  that its start's extremes lie on (both sides where none lies inside): cut
  rounds re-placed cuts at the moving extremes for 12 rounds on the paper's
  case (317-338 iterations per start) and ended 1e-7 above the optimum; with
  these one round of 49-53 iterations reaches it (16.4720805 s; trigonometric:
  12 rounds of cuts, 427 and 443 iterations, 8 s; with forms one round of 70
  and 77, 1.3 s, ``FORM_IPOPT_OPTIONS``). Not beside the robot rows (cuts
  there, ``_certify``).

Rounds. Certificates are added only where needed: a round solves, checks the
trajectory with the project's exact kinematics (``segment_extrema``), and
certifies every extreme inside a segment within 5 % of its bound; it stops
when the exact check passes (to 1e-9 relative), nothing new is needed, IPOPT
does not solve a round (its solution is then discarded), or after
``MAX_ROUNDS``. The caller then applies the time-scaling lemma
(``TimingProblem.evaluate``), which makes the result exactly feasible and
tight; nothing is reported feasible that the exact check did not pass.
"""

from __future__ import annotations

import ctypes
import functools
import itertools
import logging
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import trigonometric
from ..concurrency import map_forked, map_forked_until
from ..interrupts import check as check_interrupted
from ..kinematics import batch_scale_factors, jerk_energy, max_abs, position_range, segment_extrema
from ..limits import FEASIBILITY_TOLERANCE, range_exceeded, ratio_exceeded
from ..native_output import stderr_captured
from ..read_only import ReadOnlyArrays, freeze_arrays
from .formulations import FORMULATIONS, Scales, SegmentBlock
from .problem import TimingProblem
from .result import SOLVED, SearchTracker, StartReport, remaining_time
from .robot_rows import (
    MODEL_TOLERANCE,
    SAMPLES_PER_SEGMENT,
    FrozenModel,
    RobotConstraints,
    freeze,
    model_error,
    parameters,
    point_derivatives,
    point_rows,
    row_bounds,
    sample_points,
    spline_states,
)
from .sos import SOS_DEGREES, factor_count, factor_lower_bounds, sos_residuals, sos_start
from .starts import recombination

log = logging.getLogger(__name__)

MAX_ROUNDS = 12
#: The robot model's trust region in position (``TimingNLP.solve``): a round whose model ends this far
#: off the truth (a fraction of a limit), and not half as far as the round before, halves the region.
TRUST_SHRINK_GAP = 5e-2
#: A family with free via-point states is held this fraction below h_max in the NLP: where its limits are cut
#: (positions; every limit beside robot rows; before Lukacs' forms, all), the last round leaves them exceeded by
#: about 1e-7 of themselves, and the repair (``evaluate_states``) scales every duration up by that much, which
#: took a segment on h_max past it (by 1.7e-7 to 4.8e-7: refused).
FREE_STATES_H_MAX_MARGIN = 2e-6
#: Extremes inside a segment beyond (1 - FLAG_MARGIN) of their bound get a certificate.
FLAG_MARGIN = 0.05
#: Where the first round cuts a quantity with no extreme inside a segment (normalised time): both sides.
FLAT_CUTS = (0.25, 0.5, 0.75)
#: A cut closer than this (normalised time) to an extreme already covers it.
CUT_SPACING = 1e-6
#: A position cut placed where the position was beyond its range holds it this far inside [rad]. Cuts
#: close in on an extreme linearly (quintic, ranges: 7.5e-9 rad beyond after 10 rounds), and time scaling
#: cannot mend a position, so without a margin the last round's result can stay a hair outside.
POSITION_CUT_MARGIN = 1e-6
#: Unbounded problems keep every duration above this fraction of the time scale.
DURATION_FLOOR = 1e-6
#: ``mumps_mem_percent``: IPOPT's default (1000) has MUMPS allocate 11 times its estimated
#: workspace at every factorization; the page faults cost a quarter of IPOPT's time at
#: n = 1024 (hybrid, optimizer wall: clipped walk 3.4 s -> 2.5 s, smooth 2.2 s -> 1.7 s).
#: IPOPT raises it by itself if MUMPS runs short.
#: ``alpha_for_y``: the step of the constraints' multipliers is the one that least leaves the optimality
#: conditions unmet (safeguarded), not the primal step. Where a start crosses a non-convex region the
#: line search cuts the primal step short, and with it the continuity rows' multipliers lagged
#: (clipped walks, hybrid, 256 to 1024 via-points, seeds 1-8, both starts: 1897 -> 1648 iterations,
#: the slowest start 135 -> 80, and the better start's optimum 0.023 % lower on average; smooth walks,
#: cubic, quintic and hermite7 no worse).
#: ``bound_relax_factor`` 0: IPOPT's default relaxes every bound by 1e-8 of it, so a solution may end
#: that far beyond a position range, past the exact check's 1e-9 rad, where time scaling cannot mend it
#: (a cubic through 4 via-points with ranges 0.5 deg around them: both starts 1.3e-9 rad out, the
#: task refused; now solved). Clipped 1024-via-point walks (hybrid, seeds 1025 + 1000 k, k < 8): the
#: same optima, 854 -> 892 iterations over both starts.
IPOPT_OPTIONS = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "ipopt.tol": 1e-10,
                 "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 500, "ipopt.mumps_mem_percent": 50,
                 "ipopt.alpha_for_y": "safer-min-dual-infeas", "ipopt.bound_relax_factor": 0.0}

#: IPOPT's tolerances for a program with Lukacs' forms (``sos.py``). Where a form holds its quantity on the
#: bound, its Gram matrix is singular and its triangular factor not unique: IPOPT reaches the optimum's total
#: early and then wanders along those factors with full steps that leave 1e-6 to 1e-4 of the form's rows unmet,
#: short of 1e-10. With 1e-8 (scripts/bench_scale.py's first walks, n = 8 to 32, and the paper case) every start
#: of hermite7 and trigonometric converged (at 1e-10: 7 of 24 starts detected an infeasible problem or stopped
#: at the acceptable level), in 42-95 iterations instead of 49-479, 1.1 to 10 times faster, each total 2e-8 to
#: 7e-8 of itself higher (trigonometric, paper case: 16.7156129 s against 16.7156125 s, 1.29 s against 5.05 s).
FORM_IPOPT_OPTIONS = {"ipopt.tol": 1e-8, "ipopt.constr_viol_tol": 1e-8}

#: IPOPT's settings for a round that starts from an earlier round's solution and multipliers (``TimingNLP.solve``:
#: the same program again with the robot model refitted, or a program with certificates added, whose new
#: rows and variables start at zero multipliers, ``_Program.carried``), and for every solve with the robot
#: model's rows (the start is a solved timing slowed down): a barrier parameter of 1e-4. On the bundled
#: tasks' robot-limit cases (``scripts/bench_robot_limits.py``) the totals are unchanged and IPOPT's
#: iterations fall: PUMA with torque binding 67 -> 45, with a 0.25 m/s tool speed 143 -> 84, UR5 with
#: torque binding 36 -> 19. The cut rounds of quintic and hermite7 (``scripts/bench_scale.py``, 8 to 64
#: via-points, both classes, one walk each; before, each round started cold from the last solution):
#: iterations over both starts 15-45 % fewer (hermite7 n = 64: 1597 -> 1348 smooth, 1733 -> 1440 clipped;
#: quintic 251 -> 196, 232 -> 180), the same totals (hermite7 smooth n = 64 0.0009 % higher, the others
#: equal to 1e-7).
WARM_IPOPT_OPTIONS = {"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-4}
#: Random duration shapes tried where every start ends outside a position range (``_range_feasible_start``).
RANGE_SHAPES = 50
#: Points of each of the two grids on the way from a result out of a range to a feasible one (``_towards``).
RETREAT_STEPS = 33
#: Programs ``TimingNLP`` keeps for reuse, the most recently used (``TimingNLP._program``).
KEPT_PROGRAMS = 4
#: A kept program is solved again only if the time limit's overrun this may cause is within this fraction
#: of the time left (``_Program.reusable``).
REUSE_OVERRUN = 0.1
#: Problems with at least this many segments solve their starts side by side, one process per start
#: (``concurrency.map_forked``: on two cores, two starts take one start's time); below, forking
#: costs more than it saves (``scripts/bench_scale.py``, hybrid, smooth walks: 30 -> 42 ms at n = 16,
#: 39 -> 50 ms at n = 32, where each start takes a few milliseconds).
CONCURRENT_SEGMENTS = 64
#: The same for the families whose limits certificates of degree 4 and above bound
#: (``SplineFormulation.limits_by_cuts``: quintic, hermite7, trigonometric; every start is long): side by side
#: from this many segments. hermite7 (with cut rounds then): paper case 2.25 -> 1.23 s, n = 32 walk 20.2 ->
#: 10.2 s; quintic: paper case 98 -> 88 ms.
CUT_CONCURRENT_SEGMENTS = 2
#: The status of a start whose solve the time limit ended (in its own process, from ``CONCURRENT_SEGMENTS``
#: on: IPOPT checks its own wall-time limit only between iterations, and one iteration of a degenerate
#: problem took 10 s at n = 1000).
OUT_OF_TIME = "stopped at the time limit"


@dataclass(frozen=True)
class Certificate:
    """A bound on q^(order) of one joint inside one segment (module docstring).

    Attributes:
        block, row: the segment, as its block in the formulation and its row there.
        joint, order: the joint and the derivative order (0 = position).
        side: +1 for the upper bound, -1 for the lower.
        degree: the degree of q^(order) on the segment.
        centre: where a cut is (None for the exact kinds).
        touch: for a touch, the end (0 or 1) where the polynomial has its double root.
        margin: for a cut of a position that was beyond its range there, how far inside the range it
            holds it [rad] (``POSITION_CUT_MARGIN``); 0 otherwise.
        sos: Lukacs' exact form (degree 4 to 8, ``sos.py``) rather than a cut.
        half_angle: the form certifies a trigonometric segment's quantity through t = tan(phi / 2)
            (``trigonometric.half_angle_map``: a polynomial of degree 8 in u, its constant bound times
            ``trigonometric.HALF_ANGLE_DENOMINATOR``).
    """

    block: int
    row: int
    joint: int
    order: int
    side: int
    degree: int
    centre: float | None = None
    touch: int | None = None
    margin: float = 0.0
    sos: bool = False
    half_angle: bool = False

    @property
    def kind(self) -> str:
        """``quadratic`` (exact, one variable), ``cubic`` (exact, two), ``touch`` (exact, none), ``sos4`` ..
        ``sos8`` (exact, ``sos.factor_count``) or ``cut`` (none)."""
        if self.touch is not None:
            return "touch"
        if self.sos:
            return f"sos{self.degree}"
        return {2: "quadratic", 3: "cubic"}.get(self.degree, "cut")

    @property
    def variable_count(self) -> int:
        """Variables of the certificate in the NLP."""
        return {"quadratic": 1, "cubic": 2}.get(self.kind, factor_count(self.degree) if self.sos else 0)

    @property
    def place(self) -> tuple[int, int, int, int, int]:
        """What it bounds: (block, row, joint, order, side)."""
        return self.block, self.row, self.joint, self.order, self.side

    def bound_weights(self) -> np.ndarray:
        """(degree + 1,) the coefficients of the polynomial the bound is multiplied by in the certified one:
        1, or the half-angle factor (``half_angle``)."""
        if self.half_angle:
            return trigonometric.HALF_ANGLE_DENOMINATOR
        return np.eye(self.degree + 1)[0]

    def model(self) -> np.ndarray:
        """(rows, degree + 1): the map from f's coefficients to those of the certified polynomial:
        the identity for the exact kinds, evaluation at ``centre`` (one row) for a cut."""
        if self.centre is None:
            return np.eye(self.degree + 1)
        return (self.centre ** np.arange(self.degree + 1))[None]


def quadratic_certificate(p, lam) -> list:
    """Rows (each >= 0) certifying p0 + p1 s + p2 s^2 >= 0 on [0, 1] with multiplier ``lam`` >= 0."""
    return [p[0], p[2] + lam, 4 * p[0] * (p[2] + lam) - (p[1] - lam) ** 2]


def cubic_certificate(p, a0, a2) -> list:
    """Rows (each >= 0) certifying p0 + .. + p3 s^3 >= 0 on [0, 1] with free numbers ``a0``, ``a2`` >= 0."""
    total = p[0] + p[1] + p[2] + p[3]
    return [p[0], a2 - p[3], 4 * a0 * a2 - (total - a0 - a2) ** 2, 4 * p[0] * (a2 - p[3]) - (p[0] + p[1] - a0) ** 2]


def touch_certificate(p, touch: int) -> list:
    """Rows (each >= 0) certifying p0 + .. + p3 s^3 >= 0 on [0, 1] when p has a double root at s = ``touch``
    (p1 = 0 for 0, p'(1) = 0 for 1; exact, module docstring)."""
    if touch == 0:
        return [p[0], p[2], p[2] + p[3]]
    return [p[0] + p[1] + p[2] + p[3], p[2] + 3 * p[3], p[2] + 2 * p[3]]


@dataclass(frozen=True)
class NLPOutcome(ReadOnlyArrays):
    """What one NLP solve from one start returned (durations not yet repaired).

    Attributes:
        durations: (S,) durations [s] of the last solved round (the start if none solved).
        iterations: IPOPT iterations over all rounds.
        rounds: solves made (one per round).
        status: IPOPT's return status of the last round.
        certificates: certificates in the last round.
        states: (n, J, 3) the via-point states of the last round, where the family's are free
            (``SplineFamily.free_states``); None: the family's rule (or no round solved).
    """

    durations: np.ndarray
    iterations: int
    rounds: int
    status: str
    certificates: int
    states: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)


class TimingNLP:
    """The sparse NLP of one ``TimingProblem``, solved from any start.

    Args:
        problem: the timing problem.
        reference: (S,) feasible durations [s] that set the variable scales.
        robot: torque and tool-speed limits to impose too (``robot_rows.py``), or None.
        ipopt: IPOPT options over ``IPOPT_OPTIONS`` for every solve (a window's looser tolerances,
            ``windows.py``).
    """

    def __init__(self, problem: TimingProblem, reference: np.ndarray, robot: RobotConstraints | None = None,
                 ipopt: dict[str, Any] | None = None):
        self.problem = problem
        self.ipopt = dict(ipopt or {})
        self.robot = robot if robot is not None and robot.supported else None
        #: whether the robot rows come with a trust region in position (``solve``): a family with free
        #: via-point states, whose positions at the samples those states move
        self.trusted = self.robot is not None and problem.family.free_states
        family = problem.family
        reference = np.asarray(reference, dtype=float)
        coefficients = family.batch_coefficients(problem.via_points, reference[None])
        self.scales = Scales.of(problem.limits, reference, max_abs(coefficients, reference[None], family.basis)[0])
        # The optimum takes no longer than a feasible reference (where time alone is the objective).
        feasible = not problem.uses_jerk_energy and bool(problem.evaluate_durations(reference[None]).feasible[0])
        longest = float(reference.sum()) if feasible else np.inf
        self.formulation = FORMULATIONS[family.name](family, problem.via_points, problem.limits, self.scales, longest)
        self._programs: dict[tuple[tuple[Certificate, ...], bool], _Program] = {}
        self._blocks: list[SegmentBlock] | None = None
        #: The caller ends solves at the time limit itself (``_solve_all``'s processes): kept programs are
        #: reused whatever their own limit.
        self.deadline_enforced = False

    @property
    def blocks(self) -> list[SegmentBlock]:
        """The formulation's segment blocks (those of the first program built: every program has the same
        segments, degrees and certified orders)."""
        if self._blocks is None:
            self._program([])
        assert self._blocks is not None
        return self._blocks

    def solve(self, start: np.ndarray, report: Callable[[NLPOutcome], None] | None = None) -> NLPOutcome:
        """``_solve`` with the shortest-segment floor (``TimingProblem.duration_floor``) left out of the
        durations' bounds where the problem has no duration bounds and the solve uses IPOPT's default start
        (no ``ipopt`` options: not a window nor the windows' stitched start), and solved again with it, from
        the durations reached raised to it, where one ended below it. (A solution without the floor that keeps
        to it is one with it.) A floor the optimum does not reach changes only IPOPT's path, which the bound's
        barrier bends: with the 1 ms floor of a task file, the two starts of 2 of 10 clipped random walks of
        256 via-points ended in different local optima (0.6 % apart) and, without it, at the same one, every
        walk (454 iterations over the 10, 470 with the floor; smooth walks and 64 and 128 via-points as
        before). The windows and the stitched start keep the floor: without it they took 7 % more
        iterations over 3 clipped walks of 1024 via-points, to the same optima."""
        problem = self.problem
        relaxable = (not self.ipopt and problem.bounds is None
                     and problem.duration_floor > DURATION_FLOOR * self.scales.time)
        outcome = self._solve(start, report, floored=not relaxable)
        if relaxable and np.any(outcome.durations < problem.duration_floor):
            log.debug("a duration below the %.3g s floor without it: solved again with the floor",
                      problem.duration_floor)
            again = self._solve(np.maximum(outcome.durations, problem.duration_floor), report, floored=True)
            outcome = replace(again, iterations=outcome.iterations + again.iterations)
        return outcome

    def _solve(self, start: np.ndarray, report: Callable[[NLPOutcome], None] | None, floored: bool) -> NLPOutcome:
        """Solve from durations ``start`` (S,) [s], adding certificates round by round; ``report``, if
        given, is called with each solved round's outcome (status ``OUT_OF_TIME``: what the solve
        returns if the time limit ends it there, ``_solve_all``). With robot rows, each round refits the
        robot model at the last round's trajectory; where the via-point states are free (``trusted``), a
        trust region in position r [rad] bounds how far the positions at the model's samples move in a
        round: none at first, then r = min(r, largest move) / 2 after a round whose model ends more than
        ``TRUST_SHRINK_GAP`` of a limit off and not half as far off as the round before, and 2 r after
        one within a quarter of that that used more than half of r (``robot_rows``' docstring)."""
        problem = self.problem
        h = np.asarray(start, dtype=float)
        states = None
        coefficients = problem.coefficients(h[None])[0]
        core = np.concatenate((np.log(h / self.scales.time), self.formulation.state_values(coefficients, h)))
        certificates: list[Certificate] = []
        if problem.family.free_states:  # every limit but the knot values is left to cuts: without cuts from
            # the start, the first round would shrink every duration towards 0 (and the next start from there)
            certificates, _ = self._certify([], coefficients, h, everywhere=True)
        frozen = self._freeze(coefficients, h)
        radius, gap = np.inf, np.inf  # the trust region in position, none until the model fails to settle
        iterations, status, rounds = 0, "not solved", 0
        previous: tuple[_Program, dict] | None = None
        while rounds < MAX_ROUNDS:
            rounds += 1
            program = self._program(certificates, warm=previous is not None)
            initial = {"x0": program.start(core, self._certificate_start(certificates, coefficients, h))}
            if previous is not None and previous[0] is program:  # the robot model refitted
                initial = {"x0": previous[1]["x"], "lam_x0": previous[1]["lam_x"], "lam_g0": previous[1]["lam_g"]}
            elif previous is not None:  # certificates added
                initial = previous[0].carried(previous[1], program, initial["x0"])
            model = np.zeros(0) if frozen is None else parameters(frozen).ravel(order="F")
            if frozen is not None and self.trusted:
                model = np.concatenate((model, frozen.q.ravel(), [1 / radius]))
            with stderr_captured():  # CasADi's own warnings (an interrupted solve) stay off the terminal
                solution = program.solver(**initial, lbx=program.lbx if floored else program.unfloored_lbx,
                                          ubx=program.ubx, lbg=program.lbg,
                                          ubg=program.ubg, p=model)
            previous = program, solution
            check_interrupted()  # IPOPT swallows a Ctrl-C or SIGTERM raised inside it
            stats = program.solver.stats()
            iterations += int(stats.get("iter_count", 0))
            status = str(stats.get("return_status", "unknown"))
            log.debug("round %d: %d certificates, IPOPT %s after %d iterations", rounds, len(certificates), status,
                      int(stats.get("iter_count", 0)))
            x = np.asarray(solution["x"], dtype=float).ravel()
            with np.errstate(over="ignore"):
                solved_h = self.scales.time * np.exp(x[:problem.segment_count])
            if (status not in SOLVED or not np.all(np.isfinite(x)) or not np.all(np.isfinite(solved_h))
                    or np.any(solved_h <= 0)):
                break  # keep the last solved round (or the start): more rounds would not help
            core = x[:len(core)]
            h = self.scales.time * np.exp(core[:problem.segment_count])
            states = self.formulation.via_point_states(core[problem.segment_count:])
            batch_states = None if states is None else states[None]
            coefficients = problem.coefficients(h[None], batch_states)[0]
            if report is not None:
                report(NLPOutcome(h, iterations, rounds, OUT_OF_TIME, len(certificates), states))
            settled = True
            if frozen is not None:  # the robot model was frozen at the previous round's trajectory
                assert self.robot is not None
                samples = spline_states(coefficients, h, *self._robot_points(), self.problem.family.basis)
                gap, before = model_error(self.robot, frozen, *samples), gap
                moved = float(np.abs(samples[0] - frozen.q).max())
                log.debug("round %d: the robot model is off by %.3g of a limit, the positions moved %.3g rad",
                          rounds, gap, moved)
                if self.trusted and gap > TRUST_SHRINK_GAP and gap > before / 2:
                    radius = min(radius, moved) / 2
                elif self.trusted and gap <= TRUST_SHRINK_GAP / 4 and moved > radius / 2:  # (the gap grows like
                    # the move squared)
                    radius *= 2
                settled = gap <= MODEL_TOLERANCE
                frozen = freeze(self.robot, *samples)
            if problem.evaluate_durations(h[None], batch_states).feasible[0]:
                if settled:
                    break
                continue
            certificates, changed = self._certify(certificates, coefficients, h)
            if not changed and settled:
                break
        if states is not None and self.robot is None:
            states = _settled_states(problem, h, states)
        return NLPOutcome(h, iterations, rounds, status, len(certificates), states)

    # ------------------------------------------------------------------ robot-aware limits

    def _robot_points(self) -> tuple[np.ndarray, np.ndarray]:
        """(segment, s) of the torque and tool-speed samples, block by block (``robot_rows.sample_points``)."""
        points = [sample_points(block.segments) for block in self.blocks]
        return np.concatenate([p[0] for p in points]), np.concatenate([p[1] for p in points])

    def _freeze(self, coefficients: np.ndarray, h: np.ndarray) -> FrozenModel | None:
        """The robot model frozen at the spline (coefficients (S, J, D+1), durations (S,)); None without one."""
        if self.robot is None:
            return None
        return freeze(self.robot, *spline_states(coefficients, h, *self._robot_points(), self.problem.family.basis))

    # ------------------------------------------------------------------ certificates

    def _bounds(self, order: int, joint: int) -> tuple[float, float]:
        """(lower, upper) bound of derivative ``order`` of ``joint`` [SI]; +-inf where absent."""
        limits = self.problem.limits
        if order == 0:
            return float(limits.lower[joint]), float(limits.upper[joint])
        magnitude = float(limits.magnitudes[order - 1, joint])
        return -magnitude, magnitude

    def _certified_orders(self, block: SegmentBlock) -> list[int]:
        """Orders of ``block`` that are limited and can peak inside a segment (degree >= 2)."""
        limits = self.problem.limits
        limited = [np.isfinite(limits.lower) | np.isfinite(limits.upper), *np.isfinite(limits.magnitudes)]
        return [d for d in block.certified if block.degree - d >= 2 and limited[d].any()]

    def _certify(self, certificates: list[Certificate], coefficients: np.ndarray,
                 h: np.ndarray, everywhere: bool = False) -> tuple[list[Certificate], bool]:
        """Certify every extreme inside a segment within FLAG_MARGIN of its bound or beyond; with
        ``everywhere``, also put a cut at every other extreme of a quantity that only cuts bound
        (degree 4 and above), on the side it lies (the first round of a family with free states).

        Exact certificates are added once; a cut is added unless one within
        ``CUT_SPACING`` covers the extreme. A joint that never moves (``still_joints``) gets none: every
        family keeps it at its via-point (a joint parked on its range bound, cut everywhere on the bound:
        hermite7's starts all stopped at IPOPT's iteration cap, 53 % above the optimum). Returns the new
        list and whether it changed.
        """
        result = list(certificates)
        placed: dict[tuple, list[Certificate]] = {}
        for certificate in result:
            placed.setdefault(certificate.place, []).append(certificate)
        changed = False
        resting = self.formulation.knot_resting_sides()
        moving = np.flatnonzero(~self.formulation.still_joints).tolist()  # a still joint stays at its via-point
        # Lukacs' forms where the states are free, but not beside robot rows: their rounds refit the robot model
        # (up to 12, in a trust region) and each solved the program with every form again (hermite7 with a
        # tool-speed cap, scripts/bench_robot_limits.py: PUMA 0.25 m/s 13.8 -> 63.8 s, 30 deg/s 11.5 -> 74.7 s
        # and 2.5 % longer, UR5 0.25 m/s 8.6 -> 26.4 s); cuts there, as before.
        free = self.problem.family.free_states and self.robot is None
        half_angle = self.problem.family.basis == "trigonometric"  # its forms through t = tan(phi / 2)
        for b, block in enumerate(self.blocks):
            orders = self._certified_orders(block)
            if not orders:
                continue
            local = coefficients[None, block.segments, :, :block.degree + 1]
            locations, values = segment_extrema(local, h[None, block.segments], orders, self.problem.family.basis)
            for o, order in enumerate(orders):
                s, f = locations[o, 0], values[o, 0]  # (K, J, C)
                inside = (s > 1e-9) & (s < 1 - 1e-9)
                for joint in moving:
                    low, high = self._bounds(order, joint)
                    span = high - low if np.isfinite(high - low) else 1.0
                    margin = FLAG_MARGIN * (span if order == 0 else high)
                    upper, lower = f[:, joint] > high - margin, f[:, joint] < low + margin
                    if everywhere and block.degree - order >= 4:
                        middle = (low + high) / 2 if np.isfinite(low + high) else 0.0
                        upper, lower = upper | (f[:, joint] >= middle), lower | (f[:, joint] < middle)
                    bounded = {1: bool(np.isfinite(high)), -1: bool(np.isfinite(low))}  # no cut on an absent
                    # bound (a joint without a range beside one with it): its row would be inf - inf
                    exact = free and order >= 1 and (half_angle or block.degree - order in SOS_DEGREES)
                    degree = 2 * trigonometric.ORDER if exact and half_angle else block.degree - order
                    for side, near in ((1, upper), (-1, lower)):
                        for row, c in np.argwhere(near & inside[:, joint] & bounded[side]):
                            found = Certificate(b, int(row), joint, order, side, degree, sos=exact,
                                                half_angle=exact and half_angle)
                            beyond = side * (f[row, joint, c] - (high if side > 0 else low)) > FEASIBILITY_TOLERANCE
                            if order == 0 and beyond and found.kind == "cut":
                                found = replace(found, margin=POSITION_CUT_MARGIN)
                            if found.kind == "cubic" and order == 0:
                                segment = block.segments[row]  # joins knots segment, segment + 1
                                ends = [e for e in (0, 1) if resting[segment + e, joint] == side]
                                found = replace(found, touch=ends[0] if ends else None)
                            changed |= _place(result, placed, found, float(s[row, joint, c]))
                    if everywhere and block.degree - order >= 4:  # no extreme inside (a joint at rest): no cut
                        # would hold the quantity there, and the first solve would make it anything
                        for row in np.flatnonzero(~inside[:, joint].any(axis=-1)):
                            for side, location in itertools.product([k for k in (1, -1) if bounded[k]], FLAT_CUTS):
                                found = Certificate(b, int(row), joint, order, side, degree, sos=exact,
                                                    half_angle=exact and half_angle)
                                changed |= _place(result, placed, found, location)
        return result, changed

    def _certified_polynomials(self, certificates: list[Certificate], f: list) -> list:
        """The certified polynomials p = side (bound - model(f)) / scale, coefficient by coefficient.

        ``f`` holds the certified quantities' coefficients power by power, each a
        vector over ``certificates`` (numpy arrays, or CasADi columns).
        """
        models = [c.model() for c in certificates]
        rows = max(m.shape[0] for m in models)
        weights = np.zeros((len(certificates), rows, len(f)))
        for i, m in enumerate(models):
            weights[i, :m.shape[0], :m.shape[1]] = m
        side = np.array([c.side for c in certificates], dtype=float)
        bound = np.array([self._bounds(c.order, c.joint)[c.side > 0] for c in certificates])
        scale = np.array([1.0 if c.order == 0 else abs(b) for c, b in zip(certificates, bound)])
        constant = side * bound / scale
        bound_weights = np.zeros((len(certificates), rows))
        for i, c in enumerate(certificates):
            bound_weights[i, :c.degree + 1] = c.bound_weights()[:rows]
        factor = _like(f[0], side / scale)
        p = []
        for j in range(rows):
            model = sum(_like(f[i], weights[:, j, i]) * f[i] for i in range(len(f)))
            p.append(_like(f[0], constant * bound_weights[:, j]) - factor * model)
        return p

    def _certificate_start(self, certificates: list[Certificate], coefficients: np.ndarray,
                           h: np.ndarray) -> np.ndarray:
        """Certificate variables at a spline: lambda = max(p1 + 2 p0, 0) for each quadratic
        (a0 alike for each cubic, whose a2 starts at 0; cuts have none), and the factors whose Lukacs form
        fits p for each form (``sos.sos_start``); IPOPT moves them."""
        if not certificates:
            return np.zeros(0)
        f = np.zeros((max(c.degree for c in certificates) + 1, len(certificates)))
        for i, c in enumerate(certificates):
            if c.kind in ("cut", "touch"):
                continue
            block = self.blocks[c.block]
            segment = block.segments[c.row]
            normalised = coefficients[segment, c.joint, :block.degree + 1]
            if block.basis != "trigonometric":  # P(s)'s coefficients from those in powers of the time
                normalised = normalised * h[segment] ** np.arange(block.degree + 1)
            f[:c.degree + 1, i] = block.certified_map(c.order) @ normalised / h[segment] ** c.order
        values = []
        for kind, chosen in _kinds(certificates):
            if kind in ("cut", "touch"):
                continue
            p = np.array(self._certified_polynomials([certificates[i] for i in chosen], list(f[:, chosen])))
            if certificates[chosen[0]].sos:
                values.append(sos_start(p, certificates[chosen[0]].degree).ravel())
                continue
            values.append(np.maximum(p[1] + 2 * p[0], 0.0))
            if kind == "cubic":
                values.append(np.zeros(len(chosen)))
        return np.concatenate(values) if values else np.zeros(0)

    # ------------------------------------------------------------------ building

    def _program(self, certificates: list[Certificate], warm: bool = False) -> "_Program":
        """The NLP with these certificates; its parameters are the robot model's numbers
        (``robot_rows.parameters``), where there is one. The ``KEPT_PROGRAMS`` last built are kept: a
        round whose certificates did not change (the robot model's rounds), or another start that
        needs the same ones, solves again without building again (0.3-0.4 s on the UR5 with torque
        rows)."""
        warm = warm or self.robot is not None  # every program with robot rows starts warm
        key = (tuple(certificates), warm)
        program = self._programs.pop(key, None)
        if program is None or not (self.deadline_enforced or program.reusable()):
            program = _Program(self, certificates, warm)
            if self._blocks is None:
                self._blocks = program.spline.blocks
        self._programs[key] = program  # the most recently used last
        while len(self._programs) > KEPT_PROGRAMS:
            self._programs.pop(next(iter(self._programs)))
        return program


#: The OpenBLAS that CasADi bundles, which MUMPS (IPOPT's linear solver) calls (a glob in CasADi's folder:
#: the wheel holds it under several names, of which the one loaded is found).
CASADI_BLAS = "libcasadi-tp-openblas*"


def _settled_states(problem: TimingProblem, h: np.ndarray, states: np.ndarray) -> np.ndarray:
    """The NLP's via-point states (n, J, 3) for durations ``h`` (S,) [s], each joint's replaced by the
    family's fixed rule (``rule_states``) where, at these durations, the rule meets that joint's limits
    and range and has the lower jerk energy, or the NLP's break them.

    Nothing in the objective ties the states of a joint whose limits do not bind: IPOPT left those of a
    loosely limited joint beside slow ones anywhere within its bounds (1e5 deg/s limits beside 1 deg/s
    ones: velocities of 6545 deg/s at a via-point of a 140 s plan), and 7th-order segments that large
    over 60 s lost their via-points to rounding (3e-7 deg). Joints are independent given the durations
    (no robot rows couple them), so each is settled alone; the total time is unchanged, and a
    time-jerk objective can only fall."""
    family, limits = problem.family, problem.limits
    durations = np.repeat(h[None], 2, axis=0)
    candidates = np.stack((states, family.rule_states(problem.via_points, h[None])[0]))
    coefficients = problem.coefficients(durations, candidates)
    ratios, _ = batch_scale_factors(coefficients, durations, limits, family.basis)
    meets = np.logical_not(ratio_exceeded(ratios).any(axis=1))  # (2, J)
    if limits.has_position_range:
        low, high = position_range(coefficients, durations, family.basis)
        meets &= ~range_exceeded(limits.range_excess(low, high))
    energy = jerk_energy(coefficients, durations, family.basis)
    ruled = meets[1] & (~meets[0] | (energy[1] < energy[0]))
    settled = states.copy()
    settled[:, ruled] = candidates[1][:, ruled]
    return settled


@functools.cache
def single_threaded_blas() -> int | None:
    """Have the OpenBLAS that CasADi bundles run on one thread in this process (and the processes it
    forks); returns its thread count after, or None where that library is not found (another build).

    It loads with IPOPT (the first ``nlpsol``) and starts a thread per core, which spins
    (``sched_yield``) between MUMPS's calls: 1.15 million calls, 4.2 s of system time in a 12 s run
    of two 1024-via-point solves; MUMPS's fronts on these banded systems are too small for threads
    to help. On two cores the spinning takes time from the other start's process and from the output
    writers' imports: ``planner plan`` on a clipped 1024-via-point walk (hybrid), optimization
    2.0 -> 1.7 s; on a smooth one 0.9-1.15 -> 0.87 s (medians of 2, ``scripts/bench_scale.py``'s walks).
    """
    import casadi as ca

    loaded_only = getattr(os, "RTLD_NOLOAD", None)  # never load a second copy: the wheel holds several files
    if loaded_only is None:
        return None
    for path in sorted(Path(ca.__file__).parent.glob(CASADI_BLAS)):
        try:
            library = ctypes.CDLL(str(path), mode=loaded_only)
            library.openblas_set_num_threads(1)
            return int(library.openblas_get_num_threads())
        except (OSError, AttributeError):  # not the copy IPOPT loaded, or a build without these calls
            continue
    return None


def _place(certificates: list[Certificate], placed: dict[tuple, list[Certificate]], found: Certificate,
           location: float) -> bool:
    """Add ``found`` for an extreme at ``location`` unless a certificate already covers it;
    True if it was added. ``placed`` indexes ``certificates`` by ``Certificate.place``, kept in step."""
    same = placed.setdefault(found.place, [])
    if found.kind == "cut":
        found = replace(found, centre=location)
        if any(c.centre is not None and abs(c.centre - location) <= CUT_SPACING for c in same):
            return False
    elif same:
        return False
    certificates.append(found)
    same.append(found)
    return True


_KINDS = ("quadratic", "cubic", *(f"sos{degree}" for degree in SOS_DEGREES), "cut", "touch")


def _kinds(certificates: list[Certificate]) -> list[tuple[str, np.ndarray]]:
    """Indices of the certificates of each kind, in ``_KINDS`` order (the order of their variables)."""
    kinds = np.array([c.kind for c in certificates])
    return [(kind, np.flatnonzero(kinds == kind)) for kind in _KINDS if np.any(kinds == kind)]


def _like(example, values: np.ndarray):
    """Constant ``values`` in the type of ``example``: as is beside numpy, as a column beside CasADi."""
    if isinstance(example, np.ndarray):
        return values
    import casadi as ca
    return ca.DM(values)


class _Program:
    """One CasADi/IPOPT program: variables, constraints and their bounds."""

    def __init__(self, nlp: TimingNLP, certificates: list[Certificate], warm: bool = False):
        """``warm``: solved from an earlier round's solution and multipliers (``carried``), or with robot
        rows, with IPOPT's warm-start settings (``WARM_IPOPT_OPTIONS``)."""
        import casadi as ca

        problem, scales = nlp.problem, nlp.scales
        segments = problem.segment_count
        eta = ca.MX.sym("log_durations", segments)
        h = scales.time * ca.exp(eta)
        spline = nlp.formulation.build(h)
        self.spline = spline
        count = spline.equalities.shape[0]
        rows: list[Any] = [spline.equalities]
        lower, upper = [np.zeros(count)], [np.zeros(count)]
        for expression, low, high in spline.constraints:
            rows.append(expression)
            lower.append(np.full(expression.shape[0], low))
            upper.append(np.full(expression.shape[0], high))
        extra: list[Any] = []
        extra_lower: list[np.ndarray] = []  # their bounds: 0, or none off a factor's diagonal
        row_count = sum(len(bound) for bound in lower)
        self.spline_rows = np.arange(row_count)
        self.segments = segments
        self.core_size = segments + spline.states.shape[0]
        #: each certificate's rows and variables (indices in g and x): a later round's program starts from
        #: this one's solution through them (``carried``)
        self.certificate_rows: dict[Certificate, list[int]] = {c: [] for c in certificates}
        self.certificate_variables: dict[Certificate, list[int]] = {c: [] for c in certificates}
        variable_count = self.core_size
        if certificates:
            f = _certified_quantities(ca, certificates, spline.blocks, h)
            for kind, chosen in _kinds(certificates):
                p = nlp._certified_polynomials([certificates[i] for i in chosen], [_pick(ca, fk, chosen) for fk in f])
                each = certificates[chosen[0]].variable_count
                variables = ca.MX.sym("certificate", each * len(chosen))
                for k in range(variables.shape[0]):  # the k-th of each in block k: a cubic's a0 then a2, a form's
                    # factor entries (``sos.py``) one by one
                    self.certificate_variables[certificates[chosen[k % len(chosen)]]].append(variable_count + k)
                variable_count += variables.shape[0]
                extra.append(variables)
                exact, degree = certificates[chosen[0]].sos, certificates[chosen[0]].degree
                extra_lower.append(np.repeat(factor_lower_bounds(degree), len(chosen)) if exact
                                   else np.zeros(variables.shape[0]))
                equalities = 0  # leading rows = 0 (the rest >= margin)
                if kind == "touch":
                    ends = np.array([certificates[i].touch for i in chosen])
                    at_start, at_end = touch_certificate(p, 0), touch_certificate(p, 1)
                    first = ca.DM((ends == 0).astype(float))
                    certified = [first * a + (1 - first) * b for a, b in zip(at_start, at_end)]
                elif kind == "cubic":
                    certified = cubic_certificate(p, variables[:len(chosen)], variables[len(chosen):])
                elif kind == "quadratic":
                    certified = quadratic_certificate(p, variables)
                elif exact:
                    certified = sos_residuals(p, [variables[k * len(chosen):(k + 1) * len(chosen)]
                                                  for k in range(each)], degree)
                    equalities = len(certified)
                else:
                    certified = p[:1]
                rows += certified
                for k in range(len(certified) * len(chosen)):
                    self.certificate_rows[certificates[chosen[k % len(chosen)]]].append(row_count + k)
                row_count += len(certified) * len(chosen)
                inequalities = len(certified) - equalities
                lower += ([np.zeros(len(chosen))] * equalities
                          + [np.array([certificates[i].margin for i in chosen])] * inequalities)
                upper += [np.zeros(len(chosen))] * equalities + [np.full(len(chosen), np.inf)] * inequalities
        model = ca.MX.zeros(0, 1)
        sampled, sampled_values = ca.MX.zeros(0, 1), ca.MX.zeros(0, 1)
        mapped_rows: list[_MappedRows] = []
        if nlp.robot is not None:  # the robot model's rows at every sample, its numbers the NLP's parameters
            joints = problem.joint_count
            function = point_rows(ca, nlp.robot, joints)
            low, high = row_bounds(nlp.robot, joints)
            counts = [len(block.segments) * SAMPLES_PER_SEGMENT for block in spline.blocks]
            model = ca.MX.sym("robot_model", function.size1_in(3) * sum(counts))
            numbers = ca.reshape(model, function.size1_in(3), sum(counts))
            if nlp.trusted:  # the positions at the samples stay within a radius of those frozen at (its
                # inverse a parameter: 0 where there is no such region yet)
                frozen_at, reach = ca.MX.sym("anchor", joints * sum(counts)), ca.MX.sym("inverse_radius")
                model = ca.vertcat(model, frozen_at, reach)
                anchor = ca.reshape(frozen_at, joints, sum(counts))
            offset = 0
            sampled_parts: list[Any] = []
            value_parts: list[Any] = []
            for block, count in zip(spline.blocks, counts):
                # The samples' q, q', q'' are variables of their own, equal to the spline's there: the rows'
                # derivatives then pass through those equalities rather than through each row's chain
                # (``robot_rows``' module docstring)
                states = [ca.MX.sym(f"sampled_{order}", joints, count) for order in range(3)]
                mapped_rows.append(_MappedRows(len(rows), sum(len(bound) for bound in lower), variable_count
                                               + sum(part.shape[0] for part in sampled_parts), states,
                                               numbers[:, offset:offset + count]))
                sampled_parts += [ca.vec(state) for state in states]
                value_parts += [ca.vec(value) for value in _sampled_states(ca, block, h)]
                rows.append(ca.vec(function.map(count)(*states, mapped_rows[-1].model)))
                lower.append(np.tile(low, count))
                upper.append(np.tile(high, count))
                if nlp.trusted:
                    rows.append(ca.vec(states[0] - anchor[:, offset:offset + count]) * reach)
                    lower.append(np.full(joints * count, -1.0))
                    upper.append(np.full(joints * count, 1.0))
                offset += count
            sampled, sampled_values = ca.vertcat(*sampled_parts), ca.vertcat(*value_parts)
        robot_end = sum(len(bound) for bound in lower)
        self.robot_rows = np.arange(row_count, robot_end)
        # The samples' variables equal the spline's states there. Their rows' multipliers are not carried to a
        # later round's program (``carried``): they hold the robot rows' gradients of the model that round refits.
        rows.append(sampled - sampled_values)
        lower.append(np.zeros(sampled.shape[0]))
        upper.append(np.zeros(sampled.shape[0]))
        self.sampled_rows = np.arange(robot_end, robot_end + sampled.shape[0])
        #: (log durations, spline states) -> the samples' q, q', q'' the robot rows read (none without them)
        self.sampled_states = ca.Function("sampled_states", [eta, spline.states], [sampled_values])
        certificate_variables = ca.vertcat(*extra) if extra else ca.MX.zeros(0, 1)
        objective = ca.sum1(h)
        if problem.uses_jerk_energy:
            k_t, k_j = problem.weights
            objective = objective + (k_j / k_t) * _jerk_energy(ca, spline.blocks, h)
        margin = FREE_STATES_H_MAX_MARGIN if problem.family.free_states else 0.0
        h_high = problem.bounds[1] * (1 - margin) / scales.time if problem.bounds is not None else np.inf
        h_low = max(problem.duration_floor / scales.time, 0.0 if problem.bounds is not None else DURATION_FLOOR)
        h_high = max(h_high, h_low)  # (the margin below h_max, where h_min is h_max)
        size = certificate_variables.shape[0]
        with np.errstate(divide="ignore"):
            log_low, log_high = np.log(h_low), np.log(h_high)  # -inf, +inf where absent
        free = np.full(sampled.shape[0], np.inf)  # the samples' variables
        self.lbx = np.concatenate((np.full(segments, log_low), spline.lower, *extra_lower, -free))
        #: ``lbx`` without the problem's shortest-segment floor (``TimingNLP.solve``)
        self.unfloored_lbx = self.lbx.copy()
        if problem.bounds is None:
            self.unfloored_lbx[:segments] = np.log(DURATION_FLOOR)
        self.ubx = np.concatenate((np.full(segments, log_high), spline.upper, np.full(size, np.inf), free))
        self.lbg, self.ubg = np.concatenate(lower), np.concatenate(upper)
        variables = ca.vertcat(eta, spline.states, certificate_variables, sampled)
        self.sampled_variables = np.arange(len(self.lbx) - sampled.shape[0], len(self.lbx))
        remaining = remaining_time()  # IPOPT stops by itself at the time limit
        self.wall_limit = remaining
        # Not expanded to scalar form: building that costs more than it saves, with certificates too
        # (quintic, n = 128: 15.3 s expanded, 5.9 s not; hermite7 paper case 8.3 s, 2.8 s; hybrid,
        # n = 1024, without certificates: 3.5 s, 2.2 s).
        forms = FORM_IPOPT_OPTIONS if any(c.sos for c in certificates) else {}
        options: dict[str, Any] = {**IPOPT_OPTIONS, **forms, **nlp.ipopt, **(WARM_IPOPT_OPTIONS if warm else {}),
                                   "expand": False}
        if remaining is not None:
            options["ipopt.max_wall_time"] = max(remaining, 1e-3)
        constraints = ca.vertcat(*rows)
        if mapped_rows:
            options.update(_robot_derivative_functions(ca, mapped_rows, function, rows, constraints, variables,
                                                       objective / scales.time, model))
        self.solver = ca.nlpsol("timing", "ipopt", {"x": variables, "f": objective / scales.time,
                                                    "g": constraints, "p": model}, options)
        single_threaded_blas()
        self.built = time.monotonic()

    def start(self, core: np.ndarray, certificates: np.ndarray) -> np.ndarray:
        """The variables' start from ``core`` (the log durations over the time scale, then the spline's
        states) and the certificates' start ``certificates``: the samples' states, where the robot rows
        have them, are those ``core`` gives (``sampled_states``)."""
        sampled = np.asarray(self.sampled_states(core[:self.segments], core[self.segments:])).ravel()
        return np.concatenate((core, certificates, sampled))

    def carried(self, solution: dict, program: "_Program", x0: np.ndarray) -> dict:
        """The start of ``program`` (a later round's, with certificates added) from this program's
        ``solution``: its variables and multipliers where both programs have them (the spline's, the robot
        rows' and their samples' variables, the certificates kept), ``x0``'s values and zero multipliers for
        the new ones and for the samples' equalities (``__init__``)."""
        x, lam_x, lam_g = (np.asarray(solution[key], dtype=float).ravel() for key in ("x", "lam_x", "lam_g"))
        start, start_lam_x = np.array(x0, dtype=float), np.zeros(len(x0))
        start_lam_g = np.zeros(len(program.lbg))
        start[:self.core_size], start_lam_x[:self.core_size] = x[:self.core_size], lam_x[:self.core_size]
        start[program.sampled_variables] = x[self.sampled_variables]  # the same samples in both programs
        start_lam_x[program.sampled_variables] = lam_x[self.sampled_variables]
        start_lam_g[program.spline_rows] = lam_g[self.spline_rows]
        start_lam_g[program.robot_rows] = lam_g[self.robot_rows]
        for certificate, rows in program.certificate_rows.items():
            if certificate in self.certificate_rows:
                start_lam_g[rows] = lam_g[self.certificate_rows[certificate]]
                old, new = self.certificate_variables[certificate], program.certificate_variables[certificate]
                start[new], start_lam_x[new] = x[old], lam_x[old]
        return {"x0": start, "lam_x0": start_lam_x, "lam_g0": start_lam_g}

    def reusable(self) -> bool:
        """Whether solving again keeps to the time limit: IPOPT's own limit (``max_wall_time``) counts
        from each solve's start, so a program solved again may overrun the limit by the time since it
        was built; that time must be at most ``REUSE_OVERRUN`` of the time left then, and 1 s."""
        if self.wall_limit is None:
            return True
        since = time.monotonic() - self.built
        return since <= min(REUSE_OVERRUN * self.wall_limit, 1.0)


def _certified_quantities(ca, certificates: list[Certificate], blocks: list[SegmentBlock], h) -> list:
    """Coefficients of f(s) = q^(order)(s h) = h^-order P^(order)(s) of every certificate, power by power.

    A trigonometric segment's f is no polynomial in s: for its cuts, which only evaluate f at their centre,
    f is taken as the constant f(centre) (``SegmentBlock.weights``); for its forms (``half_angle``), as the
    polynomial in u of ``SegmentBlock.certified_map``, as the polynomial families' f is."""
    f = [ca.MX.zeros(len(certificates), 1) for _ in range(max(c.degree for c in certificates) + 1)]
    for b, order, half_angle in sorted({(c.block, c.order, c.half_angle) for c in certificates}):
        chosen = [i for i, c in enumerate(certificates) if (c.block, c.order, c.half_angle) == (b, order, half_angle)]
        block = blocks[b]
        rows = np.array([certificates[i].row for i in chosen])
        joints = np.array([certificates[i].joint for i in chosen])
        flat = rows + len(block.segments) * joints
        inverse = 1.0 / _pick(ca, h, block.segments[rows]) ** order
        # Certificate chosen[i] takes row i of ``term``: a sparse 0/1 matrix (dense, it would cost
        # certificates x chosen entries to build, every round).
        spread = ca.DM(ca.Sparsity.triplet(len(certificates), len(chosen), list(chosen), list(range(len(chosen)))),
                       1.0)
        if block.basis == "trigonometric" and not half_angle:
            weights = block.weights(np.array([certificates[i].centre for i in chosen]), order)  # (8, chosen)
            at_centre = sum(ca.DM(weights[i]) * _pick(ca, ca.vec(block.coefficients[i]), flat)
                            for i in range(len(block.coefficients)))
            f[0] = f[0] + ca.mtimes(spread, at_centre * inverse)
            continue
        weights = block.certified_map(order)
        picked = {i: _pick(ca, ca.vec(block.coefficients[i]), flat) for i in np.flatnonzero(weights.any(axis=0))}
        for power, row in enumerate(weights):
            terms = [float(row[i]) * column for i, column in picked.items() if row[i] != 0]
            f[power] = f[power] + ca.mtimes(spread, sum(terms[1:], terms[0]) * inverse)
    return f


@dataclass(frozen=True)
class _MappedRows:
    """One block's robot rows in a program (``_Program``): their item in its list of rows and the first of
    them in g, the first of their samples' variables (q, then q', then q'', each (J, count) column-major),
    those variables and the robot model's numbers (a column per sample)."""

    item: int
    first_row: int
    first_variable: int
    states: list
    model: Any

    @property
    def count(self) -> int:
        """The samples."""
        return self.states[0].shape[1]

    def entries(self, ca, function, *inputs, rows_of_g: bool) -> tuple[Any, np.ndarray, np.ndarray]:
        """The nonzeros (a column) of a ``robot_rows.point_derivatives`` ``function`` mapped over the
        samples, with its further ``inputs`` (the multipliers), and their rows and columns in the program:
        rows of g (``rows_of_g``; the Jacobian's) or variables (the Hessian's); columns variables."""
        joints, count = self.states[0].shape[0], self.count
        pattern = function.sparsity_out(0)
        local_rows, local_columns = (np.tile(index, count) for index in pattern.get_triplet())
        points = np.repeat(np.arange(count), pattern.nnz())

        def variable(local: np.ndarray) -> np.ndarray:  # state local of a sample: order local // J, joint local % J
            return self.first_variable + local // joints * joints * count + local % joints + joints * points

        rows = self.first_row + local_rows + pattern.size1() * points if rows_of_g else variable(local_rows)
        values = function.map(count)(*self.states, self.model, *inputs)  # point after point, the pattern's nonzeros
        return ca.sparsity_cast(values, ca.Sparsity.dense(len(rows), 1)), rows, variable(local_columns)


def _placed(ca, entries: list[tuple[Any, np.ndarray, np.ndarray]], shape: tuple[int, int]):
    """A sparse ``shape`` MX of (nonzeros, rows, columns) ``entries`` (``_MappedRows.entries``)."""
    values = ca.vertcat(*[part[0] for part in entries])
    rows, columns = (np.concatenate([part[k] for part in entries]) for k in (1, 2))
    order = np.lexsort((rows, columns))  # CasADi's compressed-column order
    return ca.sparsity_cast(values[order.tolist()],
                            ca.Sparsity.triplet(*shape, rows[order].tolist(), columns[order].tolist()))


def _robot_derivative_functions(ca, mapped_rows: list[_MappedRows], function, rows: list, constraints, variables,
                                objective, model) -> dict[str, Any]:
    """nlpsol's ``jac_g`` and ``hess_lag`` options: IPOPT's constraint Jacobian and Lagrangian Hessian of a
    program with the robot rows of ``function`` (``robot_rows.point_rows``), theirs from their own symbolic
    derivatives (``robot_rows.point_derivatives``) mapped over the samples and placed, CasADi's AD for the
    objective and every other row (``rows``: the program's list of rows; the robot rows' items left out
    of it as structural zeros; ``constraints``: all of them, g)."""
    jacobian, hessian = point_derivatives(ca, function)
    size, count = variables.shape[0], constraints.shape[0]
    robot_items = {part.item for part in mapped_rows}
    others = ca.vertcat(*[ca.MX(row.shape[0], 1) if i in robot_items else row for i, row in enumerate(rows)])
    objective_multiplier, multipliers = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", count)
    per_point = function.size1_out(0)
    robot_jacobian = _placed(ca, [part.entries(ca, jacobian, rows_of_g=True) for part in mapped_rows], (count, size))
    robot_hessian = _placed(ca, [part.entries(ca, hessian, ca.reshape(
        multipliers[part.first_row:part.first_row + per_point * part.count], per_point, part.count),
                                              rows_of_g=False) for part in mapped_rows], (size, size))
    others_hessian = ca.hessian(objective_multiplier * objective + ca.dot(multipliers, others), variables)[0]
    return {"jac_g": ca.Function("nlp_jac_g", [variables, model],
                                 [constraints, ca.jacobian(others, variables) + robot_jacobian],
                                 ["x", "p"], ["g", "jac_g_x"]),
            "hess_lag": ca.Function("nlp_hess_l", [variables, model, objective_multiplier, multipliers],
                                    [ca.triu(others_hessian) + robot_hessian],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])}


def _sampled_states(ca, block: SegmentBlock, h) -> tuple:
    """(J, K * SAMPLES_PER_SEGMENT) q, q', q'' of ``block``'s segments at s = m / SAMPLES_PER_SEGMENT,
    a column per sample, segment-major (``robot_rows.sample_points``): q^(d)(s h) = h^-d P^(d)(s).

    One product per order, the coefficients (K J, D + 1) times the basis values (D + 1, M), and
    reshapes: the NLP's derivatives go through a few large nodes rather than M (D + 1) small ones."""
    segments = len(block.segments)
    joints = block.coefficients[0].shape[1]
    stacked = ca.horzcat(*[ca.vec(c) for c in block.coefficients])  # (K J, D + 1), row k + K j
    inverse = ca.repmat(1.0 / _pick(ca, h, block.segments), joints, 1)  # (K J, 1)
    s = np.arange(SAMPLES_PER_SEGMENT) / SAMPLES_PER_SEGMENT
    states = []
    for order in range(3):
        values = ca.mtimes(stacked, ca.DM(block.weights(s, order)))  # (K J, M): entry [k + K j, m]
        if order:
            values = values * ca.repmat(inverse ** order, 1, SAMPLES_PER_SEGMENT)
        # [k + K j, m] -> (J, M K) with column m + M k
        states.append(ca.reshape(ca.reshape(values, segments, joints * SAMPLES_PER_SEGMENT).T,
                                 joints, SAMPLES_PER_SEGMENT * segments))
    return tuple(states)


def _pick(ca, column, indices):
    """Entries ``indices`` of a CasADi column, as a column (indexing a 1 x 1 one would give a row)."""
    indices = np.asarray(indices, dtype=int)
    return ca.reshape(column[indices.tolist()], len(indices), 1)


def _jerk_energy(ca, blocks: list[SegmentBlock], h):
    """Sum over segments and joints of the jerk energy, h^-5 b^T G b (``SegmentBlock.jerk_gram``)."""
    total = 0
    for block in blocks:
        gram = block.jerk_gram()
        if not gram.any():
            continue
        b = block.coefficients
        duration = ca.repmat(h[block.segments.tolist()], 1, b[0].shape[1])
        integral = sum(gram[i, k] * b[i] * b[k] for i in range(len(b)) for k in range(len(b)) if gram[i, k] != 0)
        total = total + ca.sum1(ca.sum2(integral / duration ** 5))
    return total


def _concurrent(problem: TimingProblem) -> bool:
    """Whether ``problem``'s starts are solved side by side: from ``CONCURRENT_SEGMENTS`` segments on, or
    ``CUT_CONCURRENT_SEGMENTS`` for a family of degree 5 and above (certificates of degree 4 and above bound
    its limits)."""
    cut_only = FORMULATIONS[problem.family.name].limits_by_cuts
    return problem.segment_count >= (CUT_CONCURRENT_SEGMENTS if cut_only else CONCURRENT_SEGMENTS)


def _processes(problem: TimingProblem, starts: int) -> int:
    """How many processes solve ``starts`` starts of ``problem``: one each where they run side by side
    (``_concurrent``)."""
    return starts if _concurrent(problem) else 1


def nlp_settings(problem: TimingProblem, starts: int) -> dict:
    """The NLP's own settings for ``problem`` solved from ``starts`` starts, as ``summary.json`` records them."""
    return {"ipopt": {key.removeprefix("ipopt."): value for key, value in IPOPT_OPTIONS.items()
                      if key.startswith("ipopt.") and key not in ("ipopt.print_level", "ipopt.sb")},
            "warm_rounds": {key.removeprefix("ipopt."): value for key, value in WARM_IPOPT_OPTIONS.items()},
            "variables": "log-durations and knot states", "max_rounds": MAX_ROUNDS, "flag_margin": FLAG_MARGIN,
            "processes": _processes(problem, starts)}


def nlp_refine(problem: TimingProblem, starts: dict[str, np.ndarray], tracker: SearchTracker,
               ipopt: dict[str, Any] | None = None) -> None:
    """Solve the sparse NLP from each named start (S,) [s], then from their recombination, and offer
    the repaired results.

    Every start is first repaired (``TimingProblem.evaluate``: feasible and
    tight), so the tracker holds a feasible candidate even if a solve fails.
    One ``TimingNLP``, scaled by the best repaired start, serves them all. Where
    the solved starts differ, the NLP solves once more from their recombination
    (``starts.recombined``), reported as the start ``recombined``. A
    ``StartReport`` per start goes to ``tracker.starts``. ``ipopt``: options over
    ``IPOPT_OPTIONS`` (``TimingNLP``).
    """
    labels = list(starts)
    repaired = tracker.evaluate(np.array([starts[label] for label in labels]))
    nlp = TimingNLP(problem, repaired.durations[int(np.argmin(repaired.objective))], ipopt=ipopt)
    nlp.blocks  # builds the program without certificates once, before any process forks
    solved = _report_all(tracker, labels, _solve_all(nlp, list(repaired.durations)))
    kept = [(durations, report.objective) for durations, report in solved
            if report.status in SOLVED and report.feasible]
    start = recombination(kept)
    if start is not None:
        _report_all(tracker, ["recombined"], _solve_all(nlp, list(tracker.evaluate(start[None]).durations)))
    if not kept and problem.limits.has_position_range:
        inside = _range_feasible_start(problem, tracker)
        if inside is not None:
            outside, _ = min(solved, key=lambda item: item[1].objective)
            _report_all(tracker, ["inside the ranges"], _solve_all(nlp, [inside]))
            _towards(problem, tracker, outside, inside)


def _range_feasible_start(problem: TimingProblem, tracker: SearchTracker) -> np.ndarray | None:
    """Feasible durations (S,) [s] for a problem whose starts all ended outside a position range, or None.

    Positions depend on the ratios of the durations only (time scaling keeps them), so a shape whose
    positions stay in range is feasible once repaired. Equal durations and ``RANGE_SHAPES`` random ones
    (a fixed seed) are tried; each goes to ``tracker``, which so holds a feasible result if any is, and
    the NLP solves once more from the best (quintic with ranges binding inside segments: cut rounds
    that IPOPT did not solve left both starts 1.75e-5 rad outside, where equal durations fit). Where the
    via-point states are free, each shape is tried at rest at every via-point too: every segment then stays
    between its two via-points, so with the via-points in range it is feasible once repaired (a task every
    start of hermite7 and trigonometric failed on was refused, though feasible).
    """
    shapes = np.vstack((np.ones(problem.segment_count),
                        np.random.default_rng(0).uniform(0.05, 1.0, (RANGE_SHAPES, problem.segment_count))))
    tried = tracker.evaluate(shapes)  # repaired: scaled until every magnitude holds
    if problem.family.free_states:  # and at rest at every via-point, where each segment stays between its two
        # via-points (hermite7's and trigonometric's rule overshot a range by 1e-7 deg where every start failed)
        at_rest = problem.evaluate_states(shapes, np.zeros((len(shapes), *problem.via_points.shape, 3)))
        tracker.offer(at_rest)
        tried = at_rest if not tried.feasible.any() else tried
    if not tried.feasible.any():
        return None
    return tried.durations[int(np.argmin(np.where(tried.feasible, tried.objective, np.inf)))]


def _towards(problem: TimingProblem, tracker: SearchTracker, outside: np.ndarray, inside: np.ndarray) -> None:
    """Offer ``tracker`` the feasible durations nearest ``outside`` (S,) [s] (a solve's result a little out
    of a position range) on the way to the feasible ``inside`` (S,) [s]: h(l) = outside^(1 - l) inside^l,
    repaired, for l on a grid of ``RETREAT_STEPS`` points and again, as finely, between the first
    feasible one and the point before it."""
    low, high = 0.0, 1.0
    for _ in range(2):
        steps = np.linspace(low, high, RETREAT_STEPS)
        blend = np.log(outside)[None] * (1 - steps[:, None]) + np.log(inside)[None] * steps[:, None]
        tried = tracker.evaluate(np.exp(blend))
        first = int(np.argmax(tried.feasible))
        if not tried.feasible[first] or first == 0:
            return
        low, high = steps[first - 1], steps[first]


def _solve_all(nlp: TimingNLP, starts: list[np.ndarray]) -> list[NLPOutcome]:
    """``nlp.solve`` from each start (S,) [s]: where they run side by side (``_concurrent``), one process
    each, ended at the time limit (IPOPT's own limit is checked only between iterations) with an outcome
    ``OUT_OF_TIME`` at the last round it solved, or at its start; otherwise one after another here, each
    start not begun by the time limit ``OUT_OF_TIME`` at its start."""
    processes, remaining = _processes(nlp.problem, len(starts)), remaining_time()
    if remaining is None:
        return map_forked(nlp.solve, starts, processes)
    if not _concurrent(nlp.problem):  # one after another here: none begun once the limit has passed (1000
        # starts of 15 ms each took a 5 s limit to 16 s)
        return [nlp.solve(start) if remaining_time() != 0.0 else NLPOutcome(start, 0, 0, OUT_OF_TIME, 0)
                for start in starts]
    nlp.deadline_enforced = True  # each solve runs in a process ended at the limit
    try:
        solved = map_forked_until(nlp.solve, starts, processes, time.monotonic() + remaining)
    finally:
        nlp.deadline_enforced = False
    return [NLPOutcome(start, 0, 0, OUT_OF_TIME, 0) if outcome is None else outcome
            for start, outcome in zip(starts, solved)]


def _report(tracker: SearchTracker, label: str, outcome: NLPOutcome) -> tuple[np.ndarray, StartReport]:
    """Repair and offer ``outcome`` to ``tracker``, log it and add its ``StartReport``; returns the
    repaired durations (S,) [s] and the report. The time limit is not checked (``_report_all``)."""
    problem = tracker.problem
    result = (problem.evaluate(outcome.durations[None]) if outcome.states is None
              else problem.evaluate_states(outcome.durations[None], outcome.states[None]))
    tracker.offer(result)
    report = StartReport(label, float(result.objective[0]), bool(result.feasible[0]), outcome.iterations,
                         outcome.rounds, outcome.status, outcome.certificates)
    tracker.starts.append(report)
    (log.info if report.status in SOLVED and report.feasible else log.warning)(
        "start %s: objective %.9g, %s, IPOPT %s, %d iterations in %d rounds, %d certificates", label,
        report.objective, "feasible" if report.feasible else "INFEASIBLE", report.status, report.iterations,
        report.rounds, report.certificates)
    return result.durations[0], report


def _report_all(tracker: SearchTracker, labels: list[str], outcomes: list[NLPOutcome]) -> list[tuple[np.ndarray,
                                                                                                   StartReport]]:
    """``_report`` each of ``outcomes`` under its label, then stop if the time limit has passed: every
    solve the limit ended has offered its last solved round first."""
    reported = [_report(tracker, label, outcome) for label, outcome in zip(labels, outcomes)]
    tracker.check_time()
    return reported


def robot_refine(problem: TimingProblem, robot: RobotConstraints,
                 start: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Durations (S,) [s] and via-point states (n, J, 3) (None: the family's rule) of the NLP with
    ``robot``'s torque and tool-speed rows (``robot_rows.py``) too, solved from durations ``start``
    (S,) [s]; the kinematic limits are then met exactly by slowing down where the rows' rounds left
    a kinematic limit exceeded (never sped up: the robot's limits may be what binds). The caller
    checks the torque and tool speed densely (``dynamics.meet_robot_limits``)."""
    nlp = TimingNLP(problem, start, robot)
    outcome = nlp.solve(np.asarray(start, dtype=float))
    h, states = outcome.durations, outcome.states
    repaired = problem.evaluate(h[None]) if states is None else problem.evaluate_states(h[None], states[None])
    if repaired.durations[0].sum() > h.sum():
        return repaired.durations[0], None if repaired.states is None else repaired.states[0]
    return h, states
