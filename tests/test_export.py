"""trajectory.csv and coefficients.json against the trajectory they export."""

import numpy as np
import pytest

import planner.export as export
from planner import InputError, get_family, paper
from planner.export import coefficients_document, read_trajectory_csv, write_trajectory_csv
from planner.splines import MAX_SAMPLES


@pytest.fixture
def trajectory():
    return get_family("hybrid").build(np.deg2rad(paper.VIA_POINTS_DEG), paper.DURATIONS_S)


def test_csv_written_in_pieces_equals_the_samples(tmp_path, trajectory, monkeypatch):
    monkeypatch.setattr(export, "CSV_PIECE_ROWS", 7)  # many piece boundaries, one ragged last piece
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 10.0)
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]  # the pieces' folder removed
    times, values = read_trajectory_csv(tmp_path / "t.csv")
    expected_times, expected = trajectory.sample(10.0)
    np.testing.assert_allclose(times, expected_times, rtol=1e-9)
    np.testing.assert_allclose(values, expected, rtol=1e-8, atol=1e-12)


def test_normalized_coefficients_evaluate_to_the_trajectory(trajectory):
    document = coefficients_document(trajectory)
    b = np.array(document["normalized_coefficients"])
    knots, durations = np.array(document["knot_times_s"]), np.array(document["durations_s"])
    times = np.linspace(0.0, trajectory.total_time, 977)
    k = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(durations) - 1)
    s = (times - knots[k]) / durations[k]
    values = np.einsum("njp,np->nj", b[k], s[:, None] ** np.arange(b.shape[-1]))
    np.testing.assert_allclose(values, trajectory.evaluate(times), atol=1e-12)


def test_normalized_coefficients_stay_small_for_short_segments():
    via = np.array([[0.0], [1e-4], [2e-4]])
    short = get_family("hybrid").build(via, np.array([1e-3, 2e-3, 2e-3, 1e-3]))
    document = coefficients_document(short)
    assert np.abs(document["coefficients"]).max() > 1e12  # local time: h^-7 growth
    assert np.abs(document["normalized_coefficients"]).max() < 1e-2  # the size of the motion


def test_sampling_is_capped_before_anything_is_allocated(trajectory):
    rate = 1.01 * MAX_SAMPLES / trajectory.total_time
    with pytest.raises(InputError, match=r"makes 1\.01e\+06 samples, above the cap of 1,000,000"):
        trajectory.sample(rate)
    assert len(trajectory.sample_times(0.99 * MAX_SAMPLES / trajectory.total_time)) <= MAX_SAMPLES


def test_csv_columns_carry_the_joint_names(tmp_path, trajectory):
    names = ["waist", "shoulder", "elbow, lower", "wrist 1", "wrist2", "wrist3"]
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 5.0, names)
    import csv
    with (tmp_path / "t.csv").open(encoding="utf-8") as handle:
        header = next(csv.reader(handle))
    assert header[:3] == ["time_s", "q_waist_deg", "q_shoulder_deg"] and header[3] == "q_elbow, lower_deg"
    assert header[-1] == "j_wrist3_deg_s3" and len(header) == 1 + 4 * 6
    times, values = read_trajectory_csv(tmp_path / "t.csv")
    np.testing.assert_allclose(values, trajectory.sample(5.0)[1], rtol=1e-8, atol=1e-12)


def test_coefficients_document_says_its_axes_and_degrees(trajectory):
    document = coefficients_document(trajectory)
    assert document["coefficients_axes"] == ["segment", "joint", "power"]
    assert document["segment_degrees"] == [7] + [3] * 7 + [7]  # hybrid: 7th-order ends, cubic interior


def test_json_keeps_the_digits_asked_for_at_any_depth_and_plain_types(tmp_path):
    """summary.json rounds to 12 significant digits (float noise of sums goes), inside lists and maps too;
    numpy scalars become plain ints and bools, non-finite floats null."""
    import json

    from planner.export import json_ready, write_json
    data = {"top": 14.999999999999998, "nested": {"list": [0.1 + 0.2, (1.0000000000001, np.float64(2.5))]},
            "count": np.int64(7), "flag": np.bool_(True), "off": np.bool_(False), "none": np.inf,
            "array": np.array([1 / 3])}
    write_json(tmp_path / "s.json", data, digits=12)
    read = json.loads((tmp_path / "s.json").read_text())
    assert read == {"top": 15.0, "nested": {"list": [0.3, [1.0, 2.5]]}, "count": 7, "flag": True, "off": False,
                    "none": None, "array": [0.333333333333]}
    assert type(read["count"]) is int and json_ready(np.bool_(True)) is True
    assert json_ready({"x": 14.999999999999998})["x"] == 14.999999999999998  # all digits by default


def test_value_per_line_json_reads_back_as_the_indented_one(tmp_path):
    """coefficients.json's layout: one key per line, the same document as the indented layout,
    arrays exact (all digits), non-finite entries of an array null, integer arrays integers."""
    import json

    from planner.export import write_json
    data = {"a": np.array([[1 / 3, 2.0], [1e-300, -7.25]]), "b": np.array([1.0, np.nan]), "c": np.arange(3),
            "d": {"nested": [np.float64(0.1), "关节"]}}
    write_json(tmp_path / "lines.json", data, value_per_line=True)
    write_json(tmp_path / "indented.json", data)
    text = (tmp_path / "lines.json").read_text(encoding="utf-8")
    read = json.loads(text)
    assert read == json.loads((tmp_path / "indented.json").read_text(encoding="utf-8"))
    assert read["a"] == [[1 / 3, 2.0], [1e-300, -7.25]] and read["b"] == [1.0, None] and read["c"] == [0, 1, 2]
    assert [type(v) for v in read["c"]] == [int] * 3
    assert len(text.splitlines()) == len(data) + 2 and text.endswith("}\n")


def test_coefficients_document_has_exactly_its_schema(trajectory):
    document = coefficients_document(trajectory, ["a", "b", "c", "d", "e", "f"])
    assert set(document) == {"format", "units", "basis", "normalized_basis", "joint_names", "coefficients_axes",
                             "segment_degrees", "knot_times_s", "durations_s", "via_times_s", "coefficients",
                             "normalized_coefficients"}
    assert document["format"] == "piecewise-polynomial/v1" and document["units"] == {"time": "s", "position": "rad"}
    assert document["joint_names"] == ["a", "b", "c", "d", "e", "f"]
    np.testing.assert_allclose(document["via_times_s"], trajectory.via_times)
    np.testing.assert_allclose(document["knot_times_s"], trajectory.knot_times)
    np.testing.assert_allclose(document["durations_s"], trajectory.durations)


def test_csv_lines_end_in_a_line_feed_only(tmp_path, trajectory):
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 10.0)
    raw = (tmp_path / "t.csv").read_bytes()
    assert b"\r" not in raw and raw.endswith(b"\n") and raw.count(b"\n") == len(trajectory.sample_times(10.0)) + 1


@pytest.mark.parametrize("joints", [1, 4, 6])
def test_a_csv_with_torque_columns_reads_back_every_kinematic_column(tmp_path, joints):
    """With fewer than 4 joints, or torques that look like a fifth block, the column count hid a wrong split."""
    via = np.deg2rad(np.random.default_rng(joints).uniform(-60, 60, (4, joints)))
    family = get_family("hybrid")
    trajectory = family.build(via, np.full(family.segment_count(4), 0.8))
    path = tmp_path / "t.csv"
    write_trajectory_csv(path, trajectory, 50.0, torques=lambda t: np.outer(np.sin(t), np.arange(1, joints + 1)))
    times, values = read_trajectory_csv(path)
    assert values.shape == (4, len(times), joints)
    np.testing.assert_allclose(values, np.stack([trajectory.evaluate(times, d) for d in range(4)]), rtol=1e-8,
                               atol=1e-9)


def test_json_ready_keeps_text_and_booleans():
    assert export.json_ready(np.array(["a", "b"])) == ["a", "b"]
    assert export.json_ready(np.array([True, False])) == [True, False]


def test_the_time_column_keeps_the_milliseconds_of_a_long_plan(tmp_path):
    """Times were written with 10 significant digits like the values: the last row of a 1.3e9 s plan
    read 1275384167 for 1275384167.064 s (sweep 11). Times keep 15."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    durations = np.asarray(paper.DURATIONS_S) * 1275384167.064 / np.sum(paper.DURATIONS_S)
    trajectory = get_family("cubic").build(via, durations)
    write_trajectory_csv(tmp_path / "t.csv", trajectory, 1e-7)
    times, _ = read_trajectory_csv(tmp_path / "t.csv")
    assert abs(times[-1] - trajectory.total_time) < 1e-5 and abs(times[-1] - 1275384167.064) < 1e-5
