import logging
import re
import warnings

import numpy as np
import pytest

from planner import get_family
from planner.limits import JointLimits
from planner.report import markdown_cell, markdown_table, plot_profiles

#: Names that are markup somewhere (mathtext, TeX, legend's hidden "_" labels, printf) or lack glyphs in the font.
AWKWARD_NAMES = ["$x^2$", "$\\frac{$", "$x^$ and $y_$", "\\frac{", "_base", "100%", "a_b^c", "关节一", "مفصل",
                 "😀 wrist", "a/b c", "$", ""]


def trajectory_for(joints: int):
    via = np.linspace(0.0, 1.0, 3)[:, None] * np.arange(1, joints + 1)[None]
    return get_family("cubic").build(via, [1.0, 1.0, 1.0, 1.0])


@pytest.mark.parametrize("name", AWKWARD_NAMES)
def test_any_name_is_plain_text_without_warnings(name, tmp_path, capfd, caplog):
    trajectory = trajectory_for(2)
    limits = JointLimits.create(2, velocity=[10.0, 10.0])
    path = tmp_path / "profiles.png"
    with warnings.catch_warnings(record=True) as caught, caplog.at_level(logging.WARNING):
        warnings.simplefilter("always")
        plot_profiles(trajectory, limits, path, title=f"task {name}: cubic", joint_names=[name, "elbow"])
    assert path.read_bytes().startswith(b"\x89PNG")
    assert [str(w.message) for w in caught] == []
    assert caplog.records == []
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_every_joint_is_in_the_legend(tmp_path, monkeypatch):
    import matplotlib.figure

    legends = []
    original = matplotlib.figure.FigureBase.legend

    def spy(self, *args, **kwargs):
        legends.append(original(self, *args, **kwargs))
        return legends[-1]
    monkeypatch.setattr(matplotlib.figure.FigureBase, "legend", spy)
    names = ["_base", "$q$", "关节"]
    plot_profiles(trajectory_for(3), JointLimits.create(3), tmp_path / "p.png", joint_names=names)
    assert [text.get_text() for text in legends[0].get_texts()][:3] == names  # then the keys to the lines


def test_markdown_table_cells():
    table = markdown_table(["a", "b"], [[1.23456, float("inf")], ["x", 2]])
    assert table.splitlines() == ["| a | b |", "|---|---|", "| 1.235 | - |", "| x | 2 |"]


def test_a_long_trajectory_is_drawn_from_a_bounded_number_of_samples(tmp_path, monkeypatch):
    """Sampling at the figure's 200 Hz would exceed the sample cap: the figure samples more sparsely."""
    import planner.report as report
    from planner.splines import MAX_SAMPLES
    via = np.array([[0.0], [1.0], [0.5]])
    trajectory = get_family("cubic").build(via, np.full(4, 0.8 * MAX_SAMPLES / 200.0 / 4 * 2))
    assert trajectory.total_time * 200.0 > MAX_SAMPLES
    drawn = []
    original = trajectory.sample
    monkeypatch.setattr(type(trajectory), "sample", lambda self, rate: drawn.append(rate) or original(rate))
    report.plot_profiles(trajectory, JointLimits.create(1, velocity=[1.0]), tmp_path / "long.png")
    assert (tmp_path / "long.png").stat().st_size > 10_000
    assert drawn and drawn[0] * trajectory.total_time <= report.PLOT_SAMPLES + 1


def table_cells(row: str) -> list[str]:
    """The cells of one Markdown table row as GitHub splits them: at every pipe not escaped by a backslash."""
    parts = re.split(r"(?<!\\)\|", row.strip())
    assert parts[0] == "" and parts[-1] == "", f"a table row starts and ends with a pipe: {row!r}"
    return [part.strip() for part in parts[1:-1]]


def markdown_tables(text: str) -> list[list[str]]:
    """Every table of a Markdown text: runs of consecutive lines starting with a pipe."""
    tables, current = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            tables.append(current)
            current = []
    return tables


def assert_tables_render(text: str) -> None:
    """Every table has a header, a delimiter row of as many columns, and rows of as many cells."""
    tables = markdown_tables(text)
    assert tables, "no Markdown table found"
    for table in tables:
        header = table_cells(table[0])
        assert len(table) >= 2 and re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", table[1].strip()), table[:2]
        assert len(table_cells(table[1])) == len(header), table[:2]
        for row in table[2:]:
            assert len(table_cells(row)) == len(header), f"{row!r} breaks the table headed {table[0]!r}"


@pytest.mark.parametrize("text", ["max |v|", "|", "a | b", "\\|already escaped\\|", "two\nlines", "x\r\ny", "", "`|`"])
def test_any_cell_text_keeps_the_table_intact(text):
    table = markdown_table(["label", text], [[text, 1.0], ["row", text], [text, text]])
    assert_tables_render(table)
    assert len(table.splitlines()) == 5


def test_pipes_are_escaped_once():
    assert markdown_cell("max |v|") == "max \\|v\\|"
    assert markdown_cell("max \\|v\\|") == "max \\|v\\|"
    assert markdown_cell(float("nan")) == "-"


def test_the_torque_plot_shows_each_joint_over_its_own_limit(tmp_path, monkeypatch):
    """The fifth plot draws tau_j / L_j (not N m, where a 186 N m shoulder limit flattened a 20 N m wrist's
    binding torque to a line) and the limits once at +-1: a torque function of the times by hand, two joints
    whose limits differ 40 times, the drawn lines read back from the axes."""
    import matplotlib.figure

    figures = []
    original = matplotlib.figure.Figure.savefig

    def spy(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    limit = np.array([200.0, 5.0])

    def torques(times):
        return np.column_stack((100.0 * np.sin(times), -5.0 * np.cos(times)))
    plot_profiles(trajectory_for(2), JointLimits.create(2), tmp_path / "p.png", torques=(torques, limit))
    axis = figures[0].axes[4]
    assert axis.get_ylabel() == "torque / limit"
    curves = [line for line in axis.get_lines() if len(line.get_xdata()) > 2]
    assert len(curves) == 2
    for j, line in enumerate(curves):
        times = np.asarray(line.get_xdata())
        np.testing.assert_allclose(line.get_ydata(), torques(times)[:, j] / limit[j], rtol=1e-12)
    levels = sorted(line.get_ydata()[0] for line in axis.get_lines() if len(line.get_xdata()) == 2)
    assert levels == [-1.0, 1.0]
