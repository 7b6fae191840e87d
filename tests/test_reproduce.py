"""``planner reproduce``'s report: Markdown that renders, references that exist, Figure 4 beside ours."""

import re
from pathlib import Path

import numpy as np
import pytest
from test_report import assert_tables_render

from planner import paper, reproduce

PROJECT = Path(__file__).resolve().parents[1]
#: Anything that would point outside the project: developer notes, absolute or parent paths, the web.
FOREIGN = ["TIMING-SPEC", "PAPER-DATA", "seed-paper", "DESIGN.md", "shared/", "../", "/work", "§", "http", "www."]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The quick reproduction of the hybrid, hermite7 and trigonometric families, written once: (folder, markdown,
    figure columns)."""
    folder = tmp_path_factory.mktemp("reproduce")
    drawn = []
    original = reproduce.plot_profile_columns
    with pytest.MonkeyPatch.context() as patch:
        def spy(columns, *args, **kwargs):
            drawn.append((columns, kwargs))
            return original(columns, *args, **kwargs)
        patch.setattr(reproduce, "plot_profile_columns", spy)
        reproduce.write_report(reproduce.run_all(quick=True, families=("hybrid", "hermite7", "trigonometric")), folder)
    return folder, (folder / "reproduction.md").read_text(), drawn


def test_every_table_of_the_report_renders(report):
    _, text, _ = report
    assert_tables_render(text)
    assert "max \\|velocity\\|, exact" in text


def test_the_report_cites_only_what_the_project_holds(report):
    folder, text, _ = report
    for word in FOREIGN:
        assert word not in text, f"the report points outside the project: {word!r}"
    named_files = set(re.findall(r"[\w./-]+\.(?:md|py|png|json|yaml|csv|rrd|urdf)\b", text))
    for name in named_files:
        assert (folder / name).exists() or (PROJECT / name).exists(), f"the report names a missing file {name!r}"
    held = (PROJECT / "planner" / "paper.py").read_text()
    for cited in set(re.findall(r"\b(?:Table|Figure) [IVX\d]+\b", text)):
        assert cited in held or cited == "Figure 4", f"the report cites {cited!r}, which planner/paper.py does not hold"
    assert f'"{paper.TITLE}"' in text
    assert paper.TITLE in (PROJECT / "README.md").read_text(), "the README gives the paper's citation the report uses"


def test_figure_4_shows_the_paper_beside_ours(report):
    folder, text, drawn = report
    assert (folder / reproduce.FIGURE_FILE).stat().st_size > 10_000
    assert f"`{reproduce.FIGURE_FILE}`" in text
    (columns, kwargs), = drawn
    theirs, ours, smooth = columns
    np.testing.assert_array_equal(theirs.trajectory.durations, paper.DURATIONS_S)
    times, positions = theirs.points
    np.testing.assert_allclose(times, np.concatenate(([0.0], np.cumsum(paper.DURATIONS_S)))[[0, 2, 3, 4, 5, 6, 7, 9]])
    np.testing.assert_allclose(np.rad2deg(positions), paper.VIA_POINTS_DEG)
    reported = [paper.TABLE_V_DEG[quantity] for quantity in ("velocity", "acceleration", "jerk")]
    np.testing.assert_allclose(np.rad2deg(theirs.levels), reported)
    assert ours.points is None and ours.levels is None and ours.trajectory.total_time < 17.5
    assert "Table II" in kwargs["points_label"] and "Table V" in kwargs["levels_label"]
    assert "Left" in kwargs["note"] and "Then ours" in kwargs["note"] and "hermite7" in kwargs["note"]
    # The right column is jerk-continuous (its jerk agrees from both sides of every interior knot), and faster.
    trajectory = smooth.trajectory
    knots = trajectory.knot_times[1:-1]
    left, right = trajectory.evaluate(knots - 1e-9, order=3), trajectory.evaluate(knots + 1e-9, order=3)
    np.testing.assert_allclose(left, right, atol=1e-5)
    assert smooth.trajectory.total_time < ours.trajectory.total_time


@pytest.mark.parametrize("family", ["hermite7", "trigonometric"])
def test_the_families_table_puts_the_jerk_continuous_families_below_hybrid(report, family):
    _, text, _ = report
    table = text.split("## Families compared")[1].split("##")[0]
    row = next(line for line in table.splitlines() if line.startswith(f"| {family} |"))
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert cells[4].startswith("-") and cells[4].endswith("%"), row  # no bounds: faster than hybrid
    # Against the lower bound for any trajectory (14.6212 s): every family above it, by its own total.
    for line in table.splitlines():
        if line.startswith("| ") and not line.startswith("| family"):
            values = [cell.strip() for cell in line.strip("|").split("|")]
            if values[3] != "-":
                assert values[5] == f"{100 * (float(values[3]) / 14.621183 - 1):+.2f} %", line


def test_the_speed_bound_shows_table_v_unreachable():
    via_times = np.concatenate(([0.0], np.cumsum(paper.DURATIONS_S)))[[0, 2, 3, 4, 5, 6, 7, 9]]
    bound = reproduce.speed_lower_bound_deg(paper.VIA_POINTS_DEG, via_times)
    assert bound[0] == pytest.approx(110 / paper.DURATIONS_S[6])  # joint 1: 100 -> -10 deg in h7
    assert bound[0] > paper.TABLE_V_DEG["velocity"][0]
