import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from conftest import clipped_walk
from planner import InfeasibleError, InputError, JointLimits, SettingError, get_family, kinematic_figures, paper
from planner.limits import FEASIBILITY_TOLERANCE, in_degrees_apart, time_scale_factor
from planner.timing import OPTIMIZERS, TimingProblem, cuckoo_search, optimize


@pytest.fixture(scope="module")
def paper_problem():
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())


@pytest.fixture(scope="module")
def bounded_problem():
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits(), bounds=paper.BOUNDS_S)


@given(st.floats(0.1, 3.0), st.floats(0.1, 5.0), st.floats(0.1, 5.0), st.floats(0.1, 5.0))
def test_single_quintic_reaches_analytic_optimum(distance, velocity, acceleration, jerk):
    """Rest-to-rest quintic: max|v| = 15 D / 8h, max|a| = 10 D / (sqrt(3) h^2), max|j| = 60 D / h^3."""
    limits = JointLimits.create(1, velocity=[velocity], acceleration=[acceleration], jerk=[jerk])
    problem = TimingProblem([[0.0], [distance]], "quintic", limits)
    expected = max(15 * distance / (8 * velocity), np.sqrt(10 * distance / (np.sqrt(3) * acceleration)),
                   np.cbrt(60 * distance / jerk))
    result = cuckoo_search(problem, nests=4, iterations=2, polish=False)
    assert result.total_time == pytest.approx(expected, rel=1e-9)
    assert result.feasible and result.max_ratio == pytest.approx(1.0, abs=1e-9)


def test_time_jerk_objective_reaches_analytic_optimum():
    """Quintic, no limits: f(h) = K_t h + K_j 720 D^2 / h^5, minimal at h = (3600 K_j D^2 / K_t)^(1/6)."""
    distance, k_t, k_j = 0.8, 2.0, 0.5
    problem = TimingProblem([[0.0], [distance]], "quintic", JointLimits.create(1), bounds=(0.1, 100.0),
                            objective="time-jerk", weights=(k_t, k_j))
    result = cuckoo_search(problem, nests=6, iterations=20, polish=False)
    expected = (3600 * k_j * distance ** 2 / k_t) ** (1 / 6)
    assert result.total_time == pytest.approx(expected, rel=1e-6)
    assert result.objective == pytest.approx(k_t * expected + k_j * 720 * distance ** 2 / expected ** 5, rel=1e-9)


@pytest.mark.parametrize("algorithm", ["cuckoo", "cuckoo-paper", "default"])
def test_paper_bounds_give_27_seconds(bounded_problem, algorithm):
    result = optimize(bounded_problem, algorithm, seed=3)
    assert result.total_time == pytest.approx(27.0, abs=1e-9)
    np.testing.assert_allclose(result.durations, 3.0)
    assert result.feasible and result.max_ratio == pytest.approx(0.827, abs=5e-4)


def test_unbounded_default_is_feasible_and_below_17_5(paper_problem):
    result = optimize(paper_problem, seed=0)
    assert result.feasible and result.total_time < 17.5
    assert result.max_ratio == pytest.approx(1.0, abs=1e-6)


def test_result_passes_dense_sampling_at_1khz(paper_problem):
    result = optimize(paper_problem, seed=1)
    trajectory = paper_problem.trajectory(result.durations)
    times, values = trajectory.sample(1000.0)
    limits = paper_problem.limits.magnitudes
    for order in (1, 2, 3):
        assert np.all(np.abs(values[order]).max(axis=0) <= limits[order - 1] * (1 + 1e-9))


def test_same_seed_same_result(paper_problem):
    first = cuckoo_search(paper_problem, iterations=5, polish=False, seed=11)
    second = cuckoo_search(paper_problem, iterations=5, polish=False, seed=11)
    other = cuckoo_search(paper_problem, iterations=5, polish=False, seed=12)
    np.testing.assert_array_equal(first.durations, second.durations)
    assert first.history == second.history
    assert not np.array_equal(first.durations, other.durations)


def test_bounds_respected_and_history_is_the_best_of_each_iteration():
    """The history holds one value per iteration, ending at the result's objective, and the search does
    improve on its first iteration (the history is not a constant)."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits(), bounds=(2.5, 3.5))
    result = cuckoo_search(problem, iterations=20, seed=0, polish=False)
    assert np.all(result.durations >= 2.5 - 1e-12) and np.all(result.durations <= 3.5 + 1e-12)
    assert result.feasible and len(result.history) == 20
    assert result.history[-1] == pytest.approx(result.objective, rel=1e-12) and result.history[-1] < result.history[0]
    shorter = cuckoo_search(problem, iterations=5, seed=0, polish=False)
    assert shorter.history == pytest.approx(result.history[:5], rel=1e-12)  # the same search, stopped earlier


@pytest.mark.parametrize("algorithm", sorted(set(OPTIMIZERS) - {"cuckoo-paper"}))
def test_every_optimizer_returns_a_feasible_trajectory(paper_problem, algorithm):
    budgets = {"cuckoo": {"iterations": 10}, "pso": {"iterations": 10}, "de": {"evaluations": 2000},
               "slsqp": {"starts": 2, "iterations": 20}, "default": {}, "nlp": {}}
    result = optimize(paper_problem, algorithm, seed=0, **budgets[algorithm])
    assert result.feasible and result.evaluations > 0 and result.wall_time_s > 0
    figures = kinematic_figures(paper_problem.trajectory(result.durations))
    assert figures.violations(paper_problem.limits) == []
    assert result.total_time < 20.0


def test_position_limits_are_enforced():
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    margin = np.deg2rad(5.0)
    limits = paper.paper_limits().with_overrides(lower=via.min(axis=0) - margin, upper=via.max(axis=0) + margin)
    unconstrained = optimize(TimingProblem(via, "hybrid", paper.paper_limits()), seed=0)
    overshoot = kinematic_figures(get_family("hybrid").build(via, unconstrained.durations)).violations(limits)
    assert overshoot, "the unconstrained optimum should leave this range, else the test proves nothing"
    problem = TimingProblem(via, "hybrid", limits)
    result = optimize(problem, seed=0)
    figures = kinematic_figures(problem.trajectory(result.durations))
    assert result.feasible and figures.violations(limits) == []


def test_via_point_outside_range_is_infeasible():
    limits = paper.paper_limits().with_overrides(upper=np.deg2rad([180, 180, 190, 180, 180, 180]))
    with pytest.raises(InfeasibleError, match="via-point 2 puts joint joint3 at 200 deg, outside its upper limit "
                                              "190 deg"):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", limits)


@pytest.mark.parametrize("rounding", [np.floor, np.ceil])
def test_via_point_on_a_bound_within_rounding_is_planned_on_it(rounding):
    """A via-point written as 200 deg against a bound with a URDF's nine decimals (3.490658503 or
    ..504 rad, just below or above it) is on the bound: accepted, moved onto it (the limits stay as
    given), the joint stops there, and the result passes the exact check against the limits given."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    upper = rounding(np.deg2rad([180, 180, 200, 180, 180, 180]) * 1e9) / 1e9
    assert 0 < abs(via[2, 2] - upper[2]) < FEASIBILITY_TOLERANCE
    limits = paper.paper_limits().with_overrides(upper=upper)
    problem = TimingProblem(via, "hybrid", limits)
    assert problem.limits is limits and problem.via_points[2, 2] == min(via[2, 2], upper[2])
    assert np.array_equal(np.delete(problem.via_points, 2, axis=0), np.delete(via, 2, axis=0))
    result = optimize(problem, seed=0)
    trajectory = problem.trajectory(result.durations)
    assert result.feasible and kinematic_figures(trajectory).violations(limits) == []
    at_rest = trajectory.evaluate(trajectory.via_times[2], order=1)[0, 2]
    passed = trajectory.evaluate(trajectory.via_times[2])[0, 2]
    assert abs(at_rest) < 1e-9 and abs(passed - min(via[2, 2], upper[2])) < 1e-12


def test_a_via_point_just_within_the_tolerance_outside_its_bound_is_planned_on_the_bound():
    """A hostile-input hunt's task (trigonometric, time-jerk weights [1e6, 0], limits of 1e8 deg/s, seven
    values on range bounds): via-point 2 puts joint1 9.9999999e-10 rad below its lower bound, within the
    1e-9 rad that makes it "on" the bound. Planned through it as given, the spline's rounding took the
    position there past the tolerance, and the plan failed as infeasible after 158 s naming the via-point's
    own value; it is moved onto the bound and planned, within the limits as given."""
    from planner.pipeline import plan

    lower = np.array([-122.7184278025889, -125.57715519928942])
    task = {"version": 1, "name": "on_bound", "trajectory": {"family": "trigonometric", "min_segment_s": 0.001},
            "optimizer": {"algorithm": "nlp", "objective": "time-jerk", "weights": [1e6, 0]},
            "waypoints": {"joints_deg": [
                [155.836511162433, -49.222753580111174], [-37.789581859767125, 107.72578076694231],
                [-122.71842785988468, -47.32562030393717], [-98.98684669570304, 27.275743878507654],
                [-98.98684669570304, 27.275743878507654], [155.836511162433, -52.615856500297824],
                [-2.621988793795424, 133.87506563127604], [-2.62198877660669, -125.57715519928942],
                [142.3323769713906, 63.43098341962127], [155.836511162433, 63.43098341962127]]},
            "limits": {"velocity_deg_s": [115238003.60923181, 58278512.43207402],
                       "acceleration_deg_s2": [58667777.24660493, 132291486.88809727],
                       "jerk_deg_s3": [642283494.4106071, 673843036.2280074],
                       "position_deg": [[lower[0], 155.836511162433], [lower[1], 133.875068496065]]}}
    below = np.deg2rad(lower[0]) - np.deg2rad(task["waypoints"]["joints_deg"][2][0])
    assert 0.99e-9 < below < FEASIBILITY_TOLERANCE
    result = plan(task)
    trajectory = result.trajectory
    assert result.feasible and kinematic_figures(trajectory).violations(result.limits) == []
    assert trajectory.evaluate(trajectory.via_times[2])[0, 0] == pytest.approx(np.deg2rad(lower[0]), abs=1e-12)


def test_via_point_just_outside_its_range_reads_outside():
    limits = paper.paper_limits().with_overrides(upper=np.deg2rad([180, 180, 200, 180, 180, 180]) - 1e-6)
    with pytest.raises(InfeasibleError, match=r"at 200 deg, outside its upper limit 199.9999 deg$"):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", limits)


@pytest.mark.parametrize("value, bound, expected", [
    (np.deg2rad(200.0), np.deg2rad(200.0) - 1e-6, ("200 deg", "199.9999 deg")),
    (np.deg2rad(-160.0) - 1e-8, np.deg2rad(-160.0), ("-160.000001 deg", "-160 deg")),
    (np.deg2rad(12.5), np.deg2rad(10.0), ("12.5 deg", "10 deg")),
])
def test_in_degrees_apart_reads_differently(value, bound, expected):
    said = in_degrees_apart(value, bound, 0)
    assert said[0] != said[1] and said[0].startswith(expected[0]) and said[1].startswith(expected[1])


def test_a_feasible_candidate_is_never_displaced_by_an_infeasible_one(paper_via, paper_limits):
    """The tracker keeps the best feasible candidate before any infeasible one, whatever their
    penalised objectives (an infeasible candidate with a small penalty once displaced a feasible NLP
    result), and among feasible ones the best."""
    from planner.timing.problem import Evaluation
    from planner.timing.result import SearchTracker

    class Offered:  # a problem whose evaluations are given: the tracker's rule alone is under test
        def __init__(self, problem):
            self.real, self.queue = problem, []

        def evaluate(self, candidates):
            return self.queue.pop(0)

        def __getattr__(self, name):
            return getattr(self.real, name)

    def evaluation(objectives, feasible):
        count = len(objectives)
        return Evaluation(np.full((count, 9), float(count)), np.array(objectives, dtype=float),
                          np.zeros((count, 3, 6)), np.zeros(count), np.array(feasible))

    problem = Offered(TimingProblem(paper_via, "hybrid", paper_limits))
    tracker = SearchTracker(problem)
    problem.queue = [evaluation([30.0, 20.0], [True, False]), evaluation([10.0], [False]),
                     evaluation([25.0, 40.0], [True, True]), evaluation([26.0], [True])]
    for _ in range(4):
        tracker.evaluate(np.zeros((1, 9)))
    assert tracker.best_feasible and tracker.best_objective == 25.0


def test_upper_bound_too_small_is_infeasible():
    """The paper's task needs longer between some via-points than the segments between them last at
    h_max = 0.5 s, whatever the family: refused, naming the joint, the via-points and both times."""
    for family in ("hybrid", "hermite7"):
        with pytest.raises(InfeasibleError, match=r"at most h_max = 0.5 s: joint joint\d takes at least [\d.]+ s "
                                                  r"from via-point \d to via-point \d within its velocity, "
                                                  r"acceleration and jerk limits, and the \d segments? between them "
                                                  r"last at most [\d.]+ s") as info:
            TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), family, paper.paper_limits(), bounds=(0.1, 0.5))
        assert info.value.quantity == "duration" and info.value.value > info.value.limit
        assert info.value.limit / 0.5 == round(info.value.limit / 0.5)


def test_bounds_are_refused_only_where_no_timing_within_them_meets_the_limits():
    """Every duration at h_max is not the least demanding timing of a cubic: shortening the last
    segments lowers its jerk here (sweep 15). The task was refused as "infeasible even with every
    duration at h_max" although durations within the bounds meet every limit."""
    limits = JointLimits.create(2, velocity=np.radians([72.80671849989245] * 2),
                                acceleration=np.radians([92.51673166454167] * 2),
                                jerk=np.radians([117.56257958393567] * 2))
    via = np.radians([[13.2, -50.8], [27.7, -109.8], [34.1, -128.2]])
    problem = TimingProblem(via, "cubic", limits, bounds=(0.01, 1.0), min_duration=0.001)
    assert not problem.evaluate_durations(np.ones((1, 4))).feasible[0]  # all at h_max breaks the jerk limit
    within = np.array([0.99994, 0.99993, 0.32420, 0.71463])
    assert kinematic_figures(problem.trajectory(within)).violations(limits) == []
    result = optimize(problem, "default")
    assert result.feasible and result.durations.max() <= 1.0
    assert kinematic_figures(problem.trajectory(result.durations)).violations(limits) == []


@pytest.mark.parametrize("kwargs, message", [
    ({"bounds": (5, 3)}, "0 < h_min <= h_max"),
    ({"bounds": (0, 3)}, "0 < h_min <= h_max"),
    ({"objective": "energy"}, "unknown objective 'energy'"),
    ({"weights": (0, 1)}, "K_t > 0"),
])
def test_bad_problem_settings(kwargs, message):
    with pytest.raises(InputError, match=message):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits(), **kwargs)


def test_no_limits_and_no_bounds_is_an_error():
    with pytest.raises(InputError, match="unbounded below"):
        TimingProblem([[0.0], [1.0]], "cubic", JointLimits.create(1))


@pytest.mark.parametrize("step", [0.0, 6.7e-294, 1e-10])
def test_limited_joints_that_do_not_move_are_no_limit_on_the_time(step):
    """Only joint 1 has a limit and it moves by at most the repeat tolerance: nothing bounds the time
    of joint 2's motion (a solve drove the durations to 1e-294 s and NumPy raised on its infs)."""
    with pytest.raises(InputError, match=r"unbounded below \(moving without a limit: joint2\)"):
        TimingProblem([[step, 1.0], [0.0, 0.0]], "hybrid", JointLimits.create(2, velocity=[1.0, np.inf]))
    TimingProblem([[step, 1.0], [0.0, 0.0]], "hybrid", JointLimits.create(2, velocity=[1.0, np.inf]), bounds=(1, 2))


def test_bad_optimizer_requests(paper_problem):
    with pytest.raises(InputError, match="unknown optimizer 'ga'"):
        optimize(paper_problem, "ga")
    with pytest.raises(SettingError, match="^optimizer setting nests: pso takes no such setting; it takes: seed, "
                                           "particles, iterations"):
        optimize(paper_problem, "pso", nests=3)
    with pytest.raises(InputError, match="needs duration bounds"):
        optimize(paper_problem, "cuckoo-paper")
    with pytest.raises(SettingError, match=r"^optimizer setting nests: must be an integer >= 2 and <= 10000, got 1$"):
        optimize(paper_problem, "cuckoo", nests=1)
    for algorithm in ("default", "cuckoo-paper"):  # they pass their settings on to Cuckoo Search
        with pytest.raises(SettingError, match=f"{algorithm} takes no such setting") as caught:
            optimize(paper_problem, algorithm, particles=3)
        assert caught.value.setting == "particles"


@pytest.mark.parametrize("value, problem", [
    ("4", "must be a number, got '4' (text: write the number without quotes)"),
    (True, "must be a number, got True"), (4.5, "must be a whole number, got 4.5"), ([4], "must be a number"),
    (float("nan"), "must be a finite number, got nan"), (10**400, "must be an integer >= 2 and <= 10000"),
])
def test_an_optimizer_setting_of_the_wrong_kind_is_named_not_raised_raw(paper_problem, value, problem):
    with pytest.raises(SettingError) as caught:
        optimize(paper_problem, "cuckoo", nests=value)
    assert (caught.value.setting, str(caught.value)) == ("nests", f"optimizer setting nests: {caught.value.problem}")
    assert caught.value.problem.startswith(problem)


def test_settings_are_checked_against_the_same_ranges_as_a_task_file(paper_problem):
    from planner.task import RANGES
    from planner.timing import SETTING_RANGES

    assert all(RANGES[f"optimizer.{name}"] is rule for name, rule in SETTING_RANGES.items())
    for name, rule in SETTING_RANGES.items():
        algorithm = next(a for a in ("cuckoo", "pso", "de", "slsqp") if name in _parameters(a))
        outside = "yes" if rule is bool else (rule.low if rule.low_open else rule.low - 1)
        with pytest.raises(SettingError, match=f"^optimizer setting {name}: must be "):
            optimize(paper_problem, algorithm, **{name: outside})
    with pytest.raises(SettingError, match="^optimizer setting refine_starts: must be at most nests"):
        optimize(paper_problem, "cuckoo", nests=3, refine_starts=4)
    with pytest.raises(SettingError, match="^optimizer setting progress: must be a callable"):
        optimize(paper_problem, "cuckoo", progress=3)


def test_numpy_scalars_are_settings_like_python_numbers(paper_problem):
    plain = optimize(paper_problem, "cuckoo", nests=4, iterations=2, pa=0.5, seed=3)
    numpy = optimize(paper_problem, "cuckoo", nests=np.int64(4), iterations=np.int32(2), pa=np.float32(0.5),
                     seed=np.uint8(3))
    assert numpy.durations.tolist() == plain.durations.tolist()
    assert numpy.settings == plain.settings


def _parameters(algorithm: str) -> set[str]:
    import inspect

    from planner.timing import settings_signature
    return set(inspect.signature(settings_signature(algorithm)).parameters)


def test_a_type_error_inside_an_optimizer_is_not_blamed_on_the_settings(paper_problem, monkeypatch):
    import planner.timing as timing

    def broken(problem, *, iterations: int = 5):
        raise TypeError("a bug inside the optimizer")

    monkeypatch.setitem(timing.OPTIMIZERS, "pso", broken)
    with pytest.raises(TypeError, match="a bug inside"):
        optimize(paper_problem, "pso", iterations=3)


def test_wrong_joint_count_in_limits():
    with pytest.raises(InputError, match="limits are for 2 joints, via-points have 6"):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", JointLimits.create(2, velocity=[1, 1]))


TINY_WALK = np.linspace(-0.00038593, 0.00425594, 10)[:, None].repeat(3, axis=1)  # toppra's small_joint_1 shape


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic"])
@pytest.mark.parametrize("algorithm", sorted(OPTIMIZERS))
def test_every_optimizer_keeps_the_minimum_segment_duration(family, algorithm):
    """A tiny motion under loose limits: without a floor the optimum has nanosecond segments;
    with one, every optimizer returns durations >= the floor that pass the exact check."""
    limits = JointLimits.create(3, velocity=[100.0] * 3, acceleration=[100.0] * 3)
    bounds = (1e-4, 0.1) if algorithm == "cuckoo-paper" else None
    problem = TimingProblem(TINY_WALK, family, limits, min_duration=2e-3, bounds=bounds)
    settings = {"iterations": 3} if algorithm in ("cuckoo", "cuckoo-paper", "pso") else {}
    result = optimize(problem, algorithm, seed=0, **settings)
    assert result.feasible and result.durations.min() >= 2e-3 * (1 - 1e-9)
    figures = kinematic_figures(problem.trajectory(result.durations))
    assert not figures.violations(limits)


def test_minimum_segment_duration_costs_time_only_where_it_binds():
    limits = JointLimits.create(3, velocity=[100.0] * 3, acceleration=[100.0] * 3)
    free = optimize(TimingProblem(TINY_WALK, "hybrid", limits), "nlp")
    floored = optimize(TimingProblem(TINY_WALK, "hybrid", limits, min_duration=1e-3), "nlp")
    assert free.durations.min() < 1e-6  # the degenerate optimum the floor exists for
    assert floored.durations.min() == pytest.approx(1e-3, rel=1e-6) and floored.total_time > free.total_time
    paper_free = optimize(TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits()), "nlp")
    paper_floored = optimize(TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits(),
                                           min_duration=1e-3), "nlp")
    assert paper_floored.total_time == pytest.approx(paper_free.total_time, rel=1e-9)


def test_minimum_segment_duration_is_checked():
    limits = paper.paper_limits()
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    with pytest.raises(InputError, match="minimum segment duration 6 s exceeds the upper duration bound 5 s"):
        TimingProblem(via, "hybrid", limits, bounds=(3, 5), min_duration=6)
    with pytest.raises(InputError, match="min_duration must be >= 0"):
        TimingProblem(via, "hybrid", limits, min_duration=-1)
    repaired = TimingProblem(via, "hybrid", limits, min_duration=4.0).evaluate(np.full((1, 9), 0.5))
    assert repaired.feasible[0] and repaired.durations.min() >= 4.0


def test_the_time_limit_stops_slsqp_inside_a_start(monkeypatch):
    """The clock runs out after the starts are evaluated: SLSQP stops at its next finite-difference batch
    (S + 1 points), not after its start's iterations (a 3 s limit took 65 s at 70 via-points)."""
    import planner.timing.result as result_module

    calls = []

    def remaining_time():  # time left at the first check (the starts' evaluation), none after
        calls.append(None)
        return 1.0 if len(calls) == 1 else 0.0

    monkeypatch.setattr(result_module, "remaining_time", remaining_time)
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    result = optimize(problem, "slsqp", time_limit_s=1000.0, starts=1, iterations=1000)
    assert result.stop_reason == "time limit of 1000 s reached" and result.feasible
    assert result.evaluations <= 1 + 2 * (problem.segment_count + 1)


@pytest.mark.parametrize("algorithm, settings", [("cuckoo", {"nests": 50, "iterations": 100000}),
                                                  ("pso", {"particles": 50, "iterations": 100000}),
                                                  ("nlp", {}), ("slsqp", {"starts": 10000})])
def test_time_limit_stops_any_optimizer_with_a_feasible_best(algorithm, settings):
    # As configured, every search but the NLP's (about 0.1 s anyway) would run for minutes.
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    result = optimize(problem, algorithm, time_limit_s=0.3, **settings)
    if algorithm != "nlp":
        assert result.stop_reason == "time limit of 0.3 s reached"
    assert result.feasible and np.isfinite(result.total_time)
    figures = kinematic_figures(problem.trajectory(result.durations))
    assert not figures.violations(paper.paper_limits())


@pytest.mark.parametrize("limit", [0, -1, float("nan"), float("inf"), True, "5"])
def test_a_time_limit_must_be_a_positive_number_of_seconds(limit):
    """nan meant no limit and 0 or -1 stopped at once, without a word."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits())
    with pytest.raises(InputError, match="time_limit_s must be a finite number of seconds > 0"):
        optimize(problem, "nlp", time_limit_s=limit)
    assert optimize(problem, "nlp", time_limit_s=np.float64(30)).feasible


def test_the_default_planner_falls_back_to_the_shapes_when_its_nests_end_infeasible():
    """Eight via-points, three on range bounds: the NLP from Cuckoo Search's nests (scaled by a nest)
    ends infeasible or short of full convergence far above the NLP from the cheap shapes; the default
    runs the shapes too and keeps the better."""
    from conftest import clipped_walk
    via, limits = clipped_walk(8, 9)
    problem = TimingProblem(via, "hybrid", limits)
    explored = cuckoo_search(problem, nests=10, iterations=5, refine_starts=2, seed=0)
    result = optimize(problem)
    assert result.feasible and result.total_time == pytest.approx(optimize(problem, "nlp").total_time, rel=1e-9)
    if not explored.feasible:  # the case this guards (it was so when written)
        assert result.stop_reason.startswith("the NLP from Cuckoo Search's nests ended infeasible")
    elif explored.objective > result.objective:  # so it is with IPOPT's alpha_for_y safer-min-dual-infeas
        assert result.stop_reason.startswith("the NLP from Cuckoo Search's nests fell short of full convergence "
                                             "(start nest")
    figures = kinematic_figures(problem.trajectory(result.durations))
    assert figures.violations(limits) == []


def test_hermite7_takes_bounds_its_fixed_rule_alone_could_not_meet():
    """Bounds around hermite7's own optimum: the parabola rule's trajectory at h_max breaks a limit, but
    optimized via-point states meet them, so the problem is not refused up front and the optimum is kept."""
    via, limits = np.deg2rad(paper.VIA_POINTS_DEG), paper.paper_limits()
    free = optimize(TimingProblem(via, "hermite7", limits), "nlp")
    bounds = (0.999 * free.durations.min(), 1.001 * free.durations.max())
    fixed_rule = get_family("hermite7").build(via, np.full(len(free.durations), bounds[1]))
    assert kinematic_figures(fixed_rule).violations(limits)  # what the up-front check would have refused
    bounded = optimize(TimingProblem(via, "hermite7", limits, bounds=bounds), "nlp")
    assert bounded.feasible and bounded.total_time == pytest.approx(free.total_time, rel=1e-4)
    assert np.all(bounded.durations >= bounds[0] * (1 - 1e-9)) and np.all(bounded.durations <= bounds[1] * (1 + 1e-9))


def test_nested_time_limits_end_at_the_earliest_deadline():
    from planner.timing.result import remaining_time, time_limit
    with time_limit(10.0):
        with time_limit(100.0):
            assert 9.0 < remaining_time() <= 10.0  # the enclosing limit ends first
        with time_limit(1.0):
            assert 0.0 < remaining_time() <= 1.0
        with time_limit(None):
            assert remaining_time() <= 10.0
        assert remaining_time() > 9.0
    assert remaining_time() is None


# The repair and the set-up checks, against independent computations (from a mutation run over
# planner/timing/problem.py: each of these once let a changed line pass the suite).
PAPER_VIA = np.deg2rad(paper.VIA_POINTS_DEG)



# equal bounds are a valid (fixed) duration
def test_equal_bounds_fix_every_duration():
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), bounds=(5.0, 5.0))
    assert problem.bounds == (5.0, 5.0)
    result = optimize(problem, "nlp")
    assert result.feasible and np.allclose(result.durations, 5.0)


# the errors name the right joint, quantity, value
def test_h_max_infeasibility_names_the_worst_joint_and_quantity():
    limits = JointLimits.create(3, velocity=[10.0] * 3, acceleration=[10.0, 10.0, 0.01])
    via = np.array([[0.0, 0.0, 0.0], [0.1, 0.1, 0.5], [0.2, 0.0, 1.0]])
    with pytest.raises(InfeasibleError) as caught:
        TimingProblem(via, "cubic", limits, bounds=(2.0, 2.0))  # one timing: every duration at h_max
    error = caught.value
    # (3, J), independent: the figures of the trajectory at h_max
    peak = kinematic_figures(TimingProblem(via, "cubic", limits).trajectory(np.full(4, 2.0))).max_abs
    assert (error.joint, error.joint_index, error.quantity, error.limit) == ("joint3", 2, "acceleration", 0.01)
    assert error.value == pytest.approx(peak[1, 2], rel=1e-9)
    assert "joint3 acceleration" in str(error) and str(error).count("deg/s^2") == 2


def test_out_of_range_via_point_error_fields():
    limits = JointLimits.create(2, velocity=[1.0, 1.0], lower=[-1.0, -1.0], upper=[1.0, 1.0])
    with pytest.raises(InfeasibleError) as caught:
        TimingProblem([[0.0, 0.0], [0.5, 1.5]], "cubic", limits)
    error = caught.value
    assert (error.joint, error.joint_index, error.quantity, error.value, error.limit) == ("joint2", 1, "position", 1.5,
                                                                                         1.0)


# the repair at the minimum segment duration
def test_raising_to_the_floor_then_scaling_up_keeps_every_limit():
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), min_duration=1.0)
    x = np.array([0.9383, 0.8251, 0.0526, 0.8645, 0.0819, 0.7432, 0.2169, 0.87, 0.5644])
    repaired = problem.evaluate(x[None])
    assert repaired.feasible[0] and repaired.durations.min() >= 1.0 and repaired.ratios.max() <= 1 + 1e-9


def test_time_jerk_objective_of_a_floored_repair_is_kt_t_plus_kj_e():
    k_t, k_j = 1.0, 0.01
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), min_duration=1.0, objective="time-jerk",
                            weights=(k_t, k_j))
    x = np.full(9, 1.0)
    x[3] = 0.05
    repaired = problem.evaluate(x[None])
    h = repaired.durations[0]
    assert h.min() >= 1.0
    energy = kinematic_figures(problem.trajectory(h)).jerk_energy.sum()
    assert repaired.objective[0] == pytest.approx(k_t * h.sum() + k_j * energy, rel=1e-9)


def test_floored_repair_reports_the_position_excess():
    via, limits = clipped_walk(8, 3)
    problem = TimingProblem(via, "cubic", limits, min_duration=0.5)
    x = np.array([0.076, 0.766, 0.561, 0.363, 0.799, 0.338, 0.481, 0.177, 0.433])
    repaired = problem.evaluate(x[None])
    trajectory = problem.trajectory(repaired.durations[0])
    positions = trajectory.evaluate(np.linspace(0, trajectory.total_time, 200001))
    sampled = max(float(np.max(limits.lower - positions)), float(np.max(positions - limits.upper)), 0.0)
    assert repaired.position_excess[0] == pytest.approx(sampled, rel=1e-3, abs=1e-9)


def test_bounded_repair_reports_the_position_excess():
    via, limits = clipped_walk(8, 3)
    problem = TimingProblem(via, "cubic", limits, bounds=(0.2, 5.0))
    repaired = problem.evaluate(np.full((1, problem.segment_count), 2.0))
    trajectory = problem.trajectory(repaired.durations[0])
    positions = trajectory.evaluate(np.linspace(0, trajectory.total_time, 200001))
    sampled = max(float(np.max(limits.lower - positions)), float(np.max(positions - limits.upper)), 0.0)
    assert repaired.position_excess[0] == pytest.approx(sampled, rel=1e-3, abs=1e-9)


# time-jerk objective: unbounded repair, batches, hermite7
def test_time_jerk_repair_objective_is_kt_t_plus_kj_e_one_at_a_time_and_in_a_batch():
    k_t, k_j = 1.0, 0.01
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), objective="time-jerk", weights=(k_t, k_j))
    batch = np.vstack((np.linspace(0.3, 1, 9), np.linspace(1, 0.3, 9)))
    evaluated = problem.evaluate(batch)
    for h, objective in zip(evaluated.durations, evaluated.objective):
        energy = kinematic_figures(problem.trajectory(h)).jerk_energy.sum()
        assert objective == pytest.approx(k_t * h.sum() + k_j * energy, rel=1e-9)


def test_hermite7_time_jerk_plans():
    problem = TimingProblem(PAPER_VIA, "hermite7", paper.paper_limits(), objective="time-jerk", weights=(1.0, 0.01))
    result = optimize(problem, "nlp")
    assert result.feasible and result.objective > result.total_time


# repair with bounds, tightness, no-limit identity
def test_bounded_repair_of_a_candidate_is_feasible_and_tight():
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), bounds=(0.5, 3.0))
    x = np.array([1.6667, 2.5747, 1.8097, 2.8908, 2.2915, 2.7803, 2.8559, 2.5056, 0.8059])
    repaired = problem.evaluate(x[None])
    assert repaired.feasible[0] and repaired.ratios.max() == pytest.approx(1.0, abs=1e-9)
    assert 0.5 <= repaired.durations.min() and repaired.durations.max() <= 3.0


def test_one_candidate_past_h_max_does_not_make_the_whole_batch_infeasible():
    problem = TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), bounds=(0.5, 3.0))
    batch = np.random.default_rng(0).uniform(0.5, 3.0, (400, 9))  # some repairs end above h_max
    together = problem.evaluate(batch)
    assert (together.durations > 3.0 * (1 + 1e-12)).any(axis=1).any()
    assert together.feasible[79] and problem.evaluate(batch[79][None]).feasible[0]


def test_repair_is_tight_under_loose_limits():
    limits = JointLimits.create(6, velocity=[100.0] * 6, acceleration=[100.0] * 6)
    repaired = TimingProblem(PAPER_VIA, "cubic", limits).evaluate(np.linspace(0.3, 1.0, 9)[None])
    assert repaired.ratios.max() == pytest.approx(1.0, abs=1e-9)


def test_without_magnitude_limits_the_repair_keeps_a_candidate_inside_the_bounds():
    problem = TimingProblem(PAPER_VIA, "cubic", JointLimits.create(6), bounds=(0.5, 3.0))
    x = np.linspace(0.6, 2.9, 9)
    np.testing.assert_allclose(problem.evaluate(x[None]).durations[0], x)


def test_a_dip_below_the_lower_range_is_infeasible():
    limits = JointLimits.create(1, velocity=[10.0], acceleration=[10.0], lower=[-0.005], upper=[2.0])
    problem = TimingProblem([[0.0], [1.0], [0.0], [1.0]], "cubic", limits)
    evaluated = problem.evaluate_durations(np.ones((1, 5)))
    trajectory = problem.trajectory(evaluated.durations[0])
    below = -0.005 - trajectory.evaluate(np.linspace(0, trajectory.total_time, 20001)).min()
    assert below > 0 and not evaluated.feasible[0]
    assert evaluated.position_excess[0] == pytest.approx(below, rel=1e-3)


def test_time_objective_is_the_total_time_whatever_the_weights():
    result = optimize(TimingProblem(PAPER_VIA, "cubic", paper.paper_limits(), weights=(2.0, 1.0)), "nlp")
    assert result.objective == pytest.approx(result.total_time, rel=1e-12)


@pytest.mark.parametrize("algorithm", ["nlp", "cuckoo"])
def test_an_optimum_on_h_max_is_feasible(algorithm):
    distance, k_t, k_j = 0.8, 2.0, 0.5  # unbounded optimum 2.88 s per segment, above h_max = 2 s
    problem = TimingProblem([[0.0], [distance], [0.0]], "quintic", JointLimits.create(1), bounds=(0.1, 2.0),
                            objective="time-jerk", weights=(k_t, k_j))
    result = optimize(problem, algorithm, seed=0)
    assert result.feasible and np.allclose(result.durations, 2.0)


@pytest.mark.parametrize("keywords, message", [
    ({"bounds": (1e-300, 1e-299)}, r"bounds \[h_min, h_max\] must each be >= 1e-06 and <= 1e\+06 s"),
    ({"bounds": (1e-6, 1e300)}, r"bounds \[h_min, h_max\] must each be >= 1e-06 and <= 1e\+06 s"),
    ({"min_duration": 1e300}, r"min_duration must be >= 0 s and <= 1e\+06 s, got 1e\+300")])
@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic", "hermite7"])
def test_duration_bounds_beyond_any_robot_are_refused_by_name(keywords, message, family):
    """They ended in NumPy's LinAlgError or SciPy's ValueError while the problem was set up (sweep 8)."""
    with pytest.raises(InputError, match=message):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG[:4]), family, paper.paper_limits(), **keywords)


def test_the_shortest_allowed_bounds_are_infeasible_by_name_not_by_a_numerical_failure():
    with pytest.raises(InfeasibleError, match=r"infeasible with every duration at h_max = 1e-06 s"):
        TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG[:4]), "hybrid", paper.paper_limits(), bounds=(1e-6, 1e-6))


def test_bounds_a_hair_too_short_say_by_how_much_the_limit_is_exceeded():
    """1e-9 below the shortest feasible uniform duration, the extreme and the limit print alike: the
    message gives their ratio (sweep 10)."""
    via, limits = np.deg2rad(paper.VIA_POINTS_DEG[:4]), paper.paper_limits()
    segments = get_family("hybrid").segment_count(len(via))
    shortest = time_scale_factor(kinematic_figures(get_family("hybrid").build(via, np.ones(segments))).ratios(limits))
    h = shortest * (1 - 1e-9)
    with pytest.raises(InfeasibleError, match=r"limit [0-9.]+ deg/s\S* \(1\.00000000[1-3] times it\)"):
        TimingProblem(via, "hybrid", limits, bounds=(h, h))
    TimingProblem(via, "hybrid", limits, bounds=(shortest, shortest))  # the shortest itself is feasible


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic", "hermite7"])
@pytest.mark.parametrize("offset_deg", [720.0, -99990.0])
def test_timing_does_not_depend_on_where_the_joints_sit(family, offset_deg):
    """The same motion of 1e-4 deg, at 0 deg and far from it, under limits of its own size: the same
    optimum, feasible by the exact check at both places (quintic's B-spline and the NLP's coefficients
    rounded relative to the positions: a jerk 1e-9 over its limit at 720 deg, refused at 3600 deg)."""
    motion = np.deg2rad(np.array([[0.0, 0.0], [1e-4, -2e-4], [3e-5, 0.5e-4], [1.5e-4, 1e-4]]))
    small = np.deg2rad(np.array([1e-4, 1e-4]))
    limits = JointLimits.create(2, velocity=small, acceleration=small, jerk=10 * small)
    totals = []
    for offset in (0.0, np.deg2rad(offset_deg)):
        problem = TimingProblem(motion + offset, family, limits)
        result = optimize(problem, "default")
        trajectory = problem.trajectory(result.durations, result.knot_states)
        assert result.feasible and not kinematic_figures(trajectory).violations(limits)
        totals.append(result.total_time)
    assert totals[1] == pytest.approx(totals[0], rel=1e-6)


@pytest.mark.parametrize("family", ["cubic", "hybrid"])
@pytest.mark.parametrize("algorithm", ["pso", "de"])
def test_a_bounded_result_called_feasible_passes_the_exact_check(family, algorithm):
    """Within duration bounds the repair scales until every ratio holds by the exact check's own test
    (``ratio_exceeded``): PSO's best here sat at an acceleration ratio of 1 + 1.9e-9, which a
    time-scale factor within 1 + 1e-9 let through and the final check refused."""
    via = np.radians([[0.0, 0.0], [30.0, -10.0]])
    limits = JointLimits.create(2, velocity=np.radians([50, 50]), acceleration=np.radians([100, 100]),
                                jerk=np.radians([500, 500]))
    problem = TimingProblem(via, family, limits, bounds=(0.5, 0.6))
    for seed in range(3):
        result = optimize(problem, algorithm, seed=seed)
        assert result.feasible
        assert kinematic_figures(problem.trajectory(result.durations)).violations(limits) == []
        assert result.total_time == pytest.approx(1.6209372704, rel=1e-9)  # the default planner's optimum


@given(st.lists(st.floats(0.05, 0.3), min_size=4, max_size=4))
def test_the_bounded_repair_is_feasible_exactly_when_the_exact_check_passes(shape):
    """Whatever the candidate, a bounded evaluation's verdict is the exact check's on the durations
    it returns, with those durations inside the bounds."""
    via = np.radians([[0.0, 0.0], [30.0, -10.0], [10.0, 20.0]])
    limits = JointLimits.create(2, velocity=np.radians([50, 50]), acceleration=np.radians([100, 100]),
                                jerk=np.radians([500, 500]))
    problem = TimingProblem(via, "cubic", limits, bounds=(0.05, 2.0))
    evaluation = problem.evaluate(np.array([shape]))
    exact = kinematic_figures(problem.trajectory(evaluation.durations[0])).violations(limits)
    h = evaluation.durations[0]
    inside = bool(np.all(h >= 0.05 * (1 - 1e-12)) and np.all(h <= 2.0 * (1 + 1e-12)))
    assert bool(evaluation.feasible[0]) == (exact == [] and inside)


@given(st.lists(st.floats(0.0, 2e-9), min_size=3, max_size=60), st.floats(0.1, 1.0))
def test_every_given_via_point_is_within_the_repeat_tolerance_of_the_one_planned(steps, move):
    """A chain of steps each below the repeat tolerance is not merged into its first via-point as a
    whole: each given via-point lies within the tolerance of the via-point it is merged into, and the
    via-points kept are further apart than it (the second joint's last move makes it a motion)."""
    from planner.timing.problem import REPEAT_TOLERANCE

    first = np.concatenate(([0.0], np.cumsum(steps)))
    given = np.column_stack((first, np.where(np.arange(len(first)) == len(first) - 1, move, 0.0)))
    problem = TimingProblem(given, "cubic", JointLimits.create(2, velocity=[1.0, 1.0]))
    planned = problem.via_points[problem.via_index]
    assert np.abs(planned - given).max() <= REPEAT_TOLERANCE
    assert np.all(np.abs(np.diff(problem.via_points, axis=0)).max(axis=1) > REPEAT_TOLERANCE)
    assert np.all(np.diff(problem.via_index) >= 0) and problem.via_index[0] == 0


@pytest.mark.parametrize("algorithm, settings", [
    ("default", {}), ("nlp", {}), ("cuckoo", {"nests": 4, "iterations": 2}),
    ("cuckoo-paper", {"nests": 4, "iterations": 2}), ("pso", {"particles": 4, "iterations": 2}),
    ("de", {"population": 2, "evaluations": 40}), ("slsqp", {"starts": 2, "iterations": 3})])
def test_a_run_the_time_limit_ends_records_every_setting_as_a_whole_run(algorithm, settings):
    """summary.json's settings let a run be repeated: a run the time limit ended recorded only the
    settings the task gave (none: {}), not the defaults it ran with; it records the same as a whole run."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG), "hybrid", paper.paper_limits(), bounds=(3.0, 5.0))
    whole = optimize(problem, algorithm, **settings)
    cut = optimize(problem, algorithm, time_limit_s=1e-9, **settings)
    assert cut.stop_reason.startswith("time limit") and not whole.stop_reason.startswith("time limit")
    assert cut.settings == whole.settings and set(settings) <= set(whole.settings)


@pytest.mark.parametrize("apart, merged", [(5e-10, True), (1e-9, True), (2e-9, False), (1e-8, False),
                                           (1e-6, False), (1e-3, False)])
def test_via_points_a_nanoradian_apart_are_merged_and_further_ones_planned_through(apart, merged):
    """The repeat tolerance is 1e-9 rad, written here as a number (the test above reads the module's
    constant, and moves with it): a via-point that far from the one before, in its only moving joint, is
    one stop with it; 2e-9 rad and more apart, it is a via-point of its own, passed at its own time."""
    via = np.array([[0.0, 0.0], [0.5, 0.3], [0.5 + apart, 0.3], [1.0, 0.0]])
    problem = TimingProblem(via, "cubic", JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0],
                                                             jerk=[5.0, 5.0]))
    assert len(problem.via_points) == (3 if merged else 4)
    trajectory = problem.trajectory(problem.evaluate(np.ones((1, problem.segment_count))).durations[0])
    times = trajectory.via_times
    assert (times[2] == times[1]) == merged
    np.testing.assert_allclose(trajectory.evaluate(times)[:, 0], via[:, 0], rtol=0, atol=1e-9 if merged else 1e-12)


@pytest.mark.parametrize("call, named", [
    (lambda p: p.evaluate_durations([1.0, 1.0, 1.0]), "4 segment durations, got 3"),
    (lambda p: p.evaluate_durations([1.0] * 5), "4 segment durations, got 5"),
    (lambda p: p.evaluate_durations([-1.0, 1.0, 1.0, 1.0]), "durations[0] is -1.0 s"),
    (lambda p: p.evaluate_durations([0.0, 1.0, 1.0, 1.0]), "durations[0] is 0.0 s"),
    (lambda p: p.evaluate([[1.0, np.nan, 1.0, 1.0]]), "candidates"),
    (lambda p: p.to_search_space(None), "durations must be numeric"),
    (lambda p: p.coefficients([1.0, 1.0, 1.0, 1.0], np.zeros((1, 3, 2, 3))), "fixes its via-point states"),
    (lambda p: TimingProblem(3, "cubic", p.limits), "via_points"),
    (lambda p: TimingProblem(None, "cubic", p.limits), "via_points"),
])
def test_timing_problem_methods_name_a_bad_argument(call, named):
    """TimingProblem's public methods check what they are given: a wrong count, a duration <= 0 or
    not a number, states for a family that fixes them, via-points that are no array."""
    problem = TimingProblem([[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]], "cubic", JointLimits.create(2, velocity=[1.0, 1.0]))
    with pytest.raises(InputError, match=named.replace("[", r"\[").replace("]", r"\]")):
        call(problem)
    assert problem.coefficients([1.0, 1.0, 1.0, 1.0]).shape == (1, 4, 2, 4)  # a list is as good as an array


def test_free_states_of_the_wrong_shape_are_named():
    problem = TimingProblem([[0.0], [1.0], [0.5]], "hermite7", JointLimits.create(1, velocity=[1.0]))
    with pytest.raises(InputError, match=r"states must have shape \(1, 3, 1, 3\)"):
        problem.evaluate_states([1.0, 1.0], np.zeros((1, 2, 1, 3)))


Q_BASE = {"version": 1, "name": "q_base",
          "waypoints": {"joints_deg": [[0.000912, -0.03087], [0.145859, 0.081892], [-0.157816, -0.129694],
                                       [-0.177392, -0.176984], [-0.153462, -0.152642], [0.083755, -0.277198]]},
          "limits": {"acceleration_deg_s2": [683.2748, 12.0001], "jerk_deg_s3": [414.6119, 66.6299]},
          "trajectory": {"family": "quintic"}, "optimizer": {"algorithm": "nlp"}}


def test_where_no_shape_converges_the_nlp_tries_equal_durations_and_says_so(monkeypatch):
    """A sweep's case: IPOPT 3.14.11 (CasADi 3.7) stopped both shapes' starts at its iteration cap on these
    via-points, and converged 2 % lower on the same via-points shifted by 360 deg. The second round starts
    warm from the first's solution and multipliers, and both reach that optimum, also started cold with the
    duration floor as a bound (as before). Where no shape's start solves (whether IPOPT stops at its cap here
    depends on its version: 3.14.19 converges; so the shapes' solves are reported unconverged here), a third
    start from equal durations is solved, and the stop reason names the starts that did not converge."""
    import dataclasses

    from planner import plan
    from planner.timing import nlp

    shifted = {**Q_BASE, "waypoints": {"joints_deg": (np.array(Q_BASE["waypoints"]["joints_deg"]) + 360).tolist()}}
    warm, other = plan(Q_BASE), plan(shifted)
    assert other.optimization.stop_reason == warm.optimization.stop_reason == "NLP from 2 shapes"
    assert warm.trajectory.total_time == pytest.approx(other.trajectory.total_time, rel=1e-9)
    monkeypatch.setattr(nlp, "WARM_IPOPT_OPTIONS", {})  # later rounds start from the last solution only
    assert plan(Q_BASE).trajectory.total_time == pytest.approx(other.trajectory.total_time, rel=1e-9)
    solve = nlp.TimingNLP.solve
    monkeypatch.setattr(nlp.TimingNLP, "solve", lambda self, start, report=None: self._solve(start, report, True))
    assert plan(Q_BASE).trajectory.total_time == pytest.approx(other.trajectory.total_time, rel=1e-9)

    def shapes_unconverged(self, start, report=None):
        outcome = solve(self, start, report)
        if np.ptp(start) <= 1e-9 * np.max(start):  # equal durations: the fallback's own start
            return outcome
        return dataclasses.replace(outcome, status="Maximum_Iterations_Exceeded")
    monkeypatch.setattr(nlp.TimingNLP, "solve", shapes_unconverged)
    base = plan(Q_BASE)
    assert [s.status for s in base.optimization.starts][2] == "Solve_Succeeded"
    assert base.trajectory.total_time == pytest.approx(other.trajectory.total_time, rel=1e-9)
    assert [s.label for s in base.optimization.starts] == ["cruise", "stop-at-turns", "uniform"]
    assert base.optimization.stop_reason == ("NLP from 3 shapes; 2 of 3 starts fell short of IPOPT's full convergence "
                                             "(start cruise: IPOPT Maximum_Iterations_Exceeded)")


@pytest.mark.parametrize("family", ["cubic", "hybrid", "quintic"])
def test_a_joint_parked_on_its_range_bound_changes_nothing(family):
    """A joint whose via-points are all equal, on its range bound (a URDF joint parked at its limit): every
    family keeps it still, so the timing is that of the other joints alone. Its fixed knot velocities beside
    its continuity and range rows made the NLP's constraints dependent: every start ended
    Error_In_Step_Computation and cubic/hybrid came out 7-8 % slower."""
    moving = np.deg2rad([[0, 0], [40, -20], [90, 10], [30, 30], [-20, 5], [10, 40]])
    parked = np.column_stack((moving, np.zeros(len(moving))))
    kinematic = dict(velocity=np.deg2rad([60, 60, 50]), acceleration=np.deg2rad([120, 120, 100]),
                     jerk=np.deg2rad([600, 600, 500]))
    limits = JointLimits.create(3, lower=np.deg2rad([-100, -100, 0]), upper=np.deg2rad([100, 100, 170]), **kinematic)
    alone = JointLimits.create(2, lower=np.deg2rad([-100, -100]), upper=np.deg2rad([100, 100]),
                               **{key: value[:2] for key, value in kinematic.items()})
    with_parked = optimize(TimingProblem(parked, family, limits), "nlp")
    without = optimize(TimingProblem(moving, family, alone), "nlp")
    assert with_parked.feasible and with_parked.total_time == pytest.approx(without.total_time, rel=1e-6)
    assert all(start.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level") for start in with_parked.starts)


def test_free_states_are_not_repaired_below_h_min():
    """hermite7 with every duration fixed at 1.3 s: the NLP's timing meets the limits without reaching one,
    and the repair shrank it to 1.285 s, below h_min, then refused it as outside the bounds (sweep 16's
    follow-up); the same at 1.4 s. A solve on h_min is kept there, feasible, its largest ratio below 1."""
    via = np.radians([[0, 0], [40, -20], [90, 10]])
    limits = JointLimits.create(2, velocity=np.radians([60, 60]), acceleration=np.radians([120, 120]),
                                jerk=np.radians([600, 600]))
    for h in (1.3, 1.4):
        problem = TimingProblem(via, "hermite7", limits, bounds=(h, h))
        result = optimize(problem, "nlp")
        assert result.feasible and np.array_equal(result.durations, [h, h]) and result.max_ratio < 1
        trajectory = problem.trajectory(result.durations, result.knot_states)
        assert kinematic_figures(trajectory).violations(limits) == []
        slack = problem.evaluate_states(result.durations[None], result.knot_states[None])
        assert np.array_equal(slack.durations[0], [h, h]) and slack.feasible[0]


@pytest.mark.parametrize("via", [[[0.0, 0.0], [1e308, 0.0]], [[-1e308, 0.0], [1e308, 0.0]],
                                 [[0.0, 0.0], [0.0, 1746.0]]])
def test_via_points_beyond_the_largest_position_are_refused_naming_them(via):
    """Via-points of 1e308 rad were taken, then overflowed the spline (warnings, and an error naming the
    optimizer's "candidates"); a task file caps angles at 1e5 deg, and so does a timing problem."""
    limits = JointLimits.create(2, velocity=[1.0, 1.0], acceleration=[2.0, 2.0], jerk=[10.0, 10.0])
    k, j = next((k, j) for k in range(2) for j in range(2) if abs(via[k][j]) > 1745.33)
    with np.errstate(all="raise"):
        with pytest.raises(InputError, match=f"via-point {k}, joint {j}: .* rad is beyond the largest position the "
                                             f"planner takes, \\+-1745.33 rad \\(100000 deg\\)"):
            TimingProblem(np.array(via), "hybrid", limits)
    assert TimingProblem(np.array([[0.0, 0.0], [0.0, 1745.0]]), "hybrid", limits).joint_count == 2


@pytest.mark.parametrize("velocity", [0.0, 1e3, 1e4, 1e6])
def test_a_candidate_whose_states_no_spline_can_hold_is_infeasible(velocity):
    """hermite7 through 0, 1, 0.5 rad over two 1000 s segments, only acceleration and jerk limited (1e6): an
    interior via-point velocity of 1e4 rad/s keeps every limit (ratios 5e-5) but swings the position by some
    1e7 rad, where rounding parts the segments' ends by more than the build's tolerance. A time-limited NLP
    iterate kept such states as its best, and the plan then failed to build it (a fuzzed task, 2026-12-07):
    the evaluation now calls a candidate feasible only where its trajectory builds."""
    problem = TimingProblem(np.array([[0.0], [1.0], [0.5]]), "hermite7",
                            JointLimits.create(1, acceleration=[1e6], jerk=[1e6]))
    h = np.array([1000.0, 1000.0])
    states = np.zeros((3, 1, 3))
    states[1, 0, 0] = velocity
    evaluation = problem.evaluate_durations(h[None], states[None])
    assert evaluation.ratios.max() < 1e-2
    try:
        problem.trajectory(h, states)
        built = True
    except InputError as exc:
        assert "rounding" in str(exc)
        built = False
    assert built is (velocity <= 1e3)
    assert bool(evaluation.feasible[0]) is built
