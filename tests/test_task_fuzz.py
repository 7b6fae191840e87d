"""Randomized task input: whatever is at any key, and whatever bytes a file holds, loading
either gives a ``Task`` or raises a ``PlannerError`` with a one-line message of bounded length."""

from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner.errors import MESSAGE_CHARS, PlannerError
from planner.task import Task, load_task, parse_task

ROOT = Path(__file__).resolve().parents[1]
BASE = ROOT / "scripts" / "tasks" / "puma560_paper_cartesian.yaml"
FUZZ = settings(max_examples=150, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def base_task() -> dict:
    """The paper's Cartesian task with every optional section present, so that every key can be hit."""
    data = yaml.safe_load(BASE.read_text())
    data["robot"]["urdf"] = str(ROOT / "robots" / "puma560.urdf")
    data["limits"] = {"velocity_deg_s": [100] * 6, "acceleration_deg_s2": [60] * 6, "jerk_deg_s3": [60] * 6,
                      "position_deg": [[-180, 180]] * 6}
    data["ik"] = {"branch": "optimal", "start_deg": [0] * 6, "seed": 0}
    data["path"] = {"mode": "linear", "tolerance_m": 0.001, "tolerance_deg": 0.5}
    data["trajectory"] = {"family": "hybrid", "sample_rate_hz": 100, "min_segment_s": 0.001}
    data["optimizer"] = {"algorithm": "cuckoo", "seed": 0, "bounds_s": [1, 5], "objective": "time",
                         "weights": [1, 1], "nests": 10, "iterations": 5, "pa": 0.25, "polish": True}
    return data


def key_paths(node, prefix=()):
    """Every (key or index) path in the base task."""
    if isinstance(node, dict):
        items = node.items()
    elif isinstance(node, list):
        items = enumerate(node)
    else:
        return
    for key, child in items:
        yield prefix + (key,)
        yield from key_paths(child, prefix + (key,))


BASE_TASK = base_task()
PATHS = list(key_paths(BASE_TASK))
SCALARS = st.one_of(st.none(), st.booleans(), st.text(max_size=20),
                    st.integers(), st.integers(min_value=-(10**400), max_value=10**400),
                    st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from(["hybrid", "joint", "linear", "optimal", "cuckoo", "time", "tool", ""]))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=6),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=20)


def assert_well_formed(error: PlannerError) -> None:
    text = str(error)
    assert "\n" not in text and len(text) <= MESSAGE_CHARS


def replaced(path, value) -> dict:
    data = yaml.safe_load(yaml.safe_dump(BASE_TASK))  # a deep copy
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return data


@FUZZ
@given(path=st.sampled_from(PATHS), value=VALUES)
def test_any_value_at_any_key_gives_a_task_or_a_planner_error(path, value):
    try:
        assert isinstance(parse_task(replaced(path, value), source=BASE), Task)
    except PlannerError as error:
        assert_well_formed(error)


@FUZZ
@given(value=VALUES, key=st.one_of(st.text(max_size=10), st.integers(), st.none(), st.booleans()))
def test_unknown_keys_and_whole_documents_give_a_planner_error(value, key):
    for data in (value, {**BASE_TASK, key: value}):
        try:
            parse_task(data, source=BASE)
        except PlannerError as error:
            assert_well_formed(error)


ENCODINGS = ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "utf-32", "latin-1", "cp1252", "shift_jis"]


@FUZZ
@given(data=st.data())
def test_any_file_gives_a_task_or_a_planner_error(tmp_path_factory, data):
    kind = data.draw(st.sampled_from(["bytes", "text", "mutated"]))
    if kind == "bytes":
        raw = data.draw(st.binary(max_size=200))
    elif kind == "text":
        encoding = data.draw(st.sampled_from(ENCODINGS))
        raw = data.draw(st.text(max_size=100)).encode(encoding, "replace")
    else:  # the valid task with a few characters changed, then encoded
        text = BASE.read_text().replace("../../robots/", str(ROOT / "robots") + "/")
        for _ in range(data.draw(st.integers(1, 4))):
            at = data.draw(st.integers(0, len(text) - 1))
            text = text[:at] + data.draw(st.text(max_size=3)) + text[at + 1:]
        raw = text.encode(data.draw(st.sampled_from(ENCODINGS)), "replace")
    path = tmp_path_factory.mktemp("fuzz") / "task.yaml"
    path.write_bytes(raw)
    try:
        assert isinstance(load_task(path), Task)
    except PlannerError as error:
        assert_well_formed(error)
