"""Randomized end-to-end check (in the spirit of ruckig's): random via-points, limits, families,
bounds, objectives and duration floors are planned through ``planner.plan`` as task files would
be, and every result is checked independently (``conftest.assert_plan_holds``: dense sampling of
every limit, the reported figures, the floor and bounds, the via-points at their times)."""

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from conftest import assert_plan_holds, dense_extremes
from planner import InfeasibleError, JointLimits, get_family
from planner.pipeline import plan
from planner.task import parse_task

_DEGREES = st.floats(-170.0, 170.0, allow_nan=False).map(lambda x: round(x, 3))


@st.composite
def joint_tasks(draw) -> dict:
    """A joint-space task file's data, every array drawn by hypothesis (so failures shrink)."""
    joints = draw(st.integers(1, 3))
    count = draw(st.integers(2, 5))
    via = draw(hnp.arrays(float, (count, joints), elements=_DEGREES))
    if np.ptp(via, axis=0).max() < 0.5:  # a motion of at least half a degree
        via[-1, 0] = via[0, 0] + 1.0
    magnitude = st.floats(5.0, 400.0).map(lambda x: round(x, 2))
    limits = {"velocity_deg_s": draw(st.lists(magnitude, min_size=joints, max_size=joints)),
              "acceleration_deg_s2": draw(st.lists(magnitude, min_size=joints, max_size=joints)),
              "jerk_deg_s3": draw(st.lists(magnitude, min_size=joints, max_size=joints))}
    if draw(st.booleans()):  # position ranges that contain the via-points, with a margin
        margin = draw(st.floats(0.1, 30.0))
        limits["position_deg"] = [[float(via[:, j].min() - margin), float(via[:, j].max() + margin)]
                                  for j in range(joints)]
    optimizer = {"algorithm": draw(st.sampled_from(["default", "nlp"])),
                 "objective": draw(st.sampled_from(["time", "time-jerk"]))}
    if optimizer["objective"] == "time-jerk":
        optimizer["weights"] = [1.0, draw(st.sampled_from([1e-4, 1e-2, 1.0]))]
    min_segment = draw(st.sampled_from([1e-3, 0.05]))
    if draw(st.booleans()):  # bounds the shortest segment fits in (else the task is refused as it should be)
        low = draw(st.floats(0.01, 2.0))
        optimizer["bounds_s"] = [low, max(low * draw(st.floats(1.0, 50.0)), min_segment)]
    return {"version": 1, "waypoints": {"joints_deg": via.tolist()}, "limits": limits,
            "trajectory": {"family": draw(st.sampled_from(["hybrid", "quintic", "cubic", "hermite7", "trigonometric"])),
                           "min_segment_s": min_segment},
            "optimizer": optimizer}


@settings(max_examples=60)
@given(joint_tasks())
def test_every_planned_result_holds_every_limit(data):
    task = parse_task(data, name="random")
    try:
        result = plan(task)
    except InfeasibleError as error:
        event("infeasible")
        assert_truly_infeasible(task, error)
        return
    event(f"planned {task.family} by {result.optimization.algorithm}")
    assert_plan_holds(result)


def assert_truly_infeasible(task, error) -> None:
    """An infeasible verdict is checked against timings tried here: magnitudes can always be met by
    slowing down (time scaling) unless an upper duration bound forbids it, but position ranges depend
    on the ratios of the durations only. So: no duration ratios tried (uniform and 50 random ones)
    may keep the positions in range while, scaled to meet the magnitudes, fitting the bounds."""
    family = get_family(task.family)
    via = task.joint_waypoints
    limits = JointLimits.create(via.shape[1], **task.limits)
    count = family.segment_count(len(via))
    shapes = np.vstack((np.ones(count), np.random.default_rng(0).uniform(0.05, 1.0, (50, count))))
    low_bound, high_bound = task.optimizer["bounds"] or (0.0, np.inf)
    for shape in shapes:
        largest, low, high = dense_extremes(family.build(via, shape))
        if np.any(low < limits.lower - 1e-9) or np.any(high > limits.upper + 1e-9):
            continue  # this shape leaves a position range at every scale
        orders = np.arange(1, 4)[:, None]
        scale = max(float(np.max((largest / limits.magnitudes) ** (1 / orders))), task.min_segment_s / shape.min())
        fits = max(scale, low_bound / shape.min()) * shape.max() <= high_bound * (1 - 1e-6)
        assert not fits, f"{error}, yet durations {shape * scale} [s] hold every limit"
