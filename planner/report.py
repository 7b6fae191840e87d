"""Tables and profile figures of a planned trajectory, in degrees (the paper's units)."""

from __future__ import annotations

import logging
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .limits import PROFILE_QUANTITIES, JointLimits
from .read_only import ReadOnlyArrays, freeze_arrays
from .splines import PiecewisePolynomial

#: Most samples per joint drawn in a profile figure (about 1200 pixels wide: four per pixel column).
PLOT_SAMPLES = 5_000
#: Via-point times are drawn as vertical lines up to this many via-points.
PLOT_VIA_LINES = 200


def markdown_cell(value) -> str:
    """One table cell as Markdown text: floats with 3 decimals ("-" when not finite), pipes escaped
    (a bare ``|`` would end the cell) and line breaks as spaces (one would end the row)."""
    if isinstance(value, (float, np.floating)):
        return f"{value:.3f}" if np.isfinite(value) else "-"
    return " ".join(str(value).replace("\\|", "|").replace("|", "\\|").splitlines())


def markdown_table(header: list[str], rows: list[list]) -> str:
    """A GitHub Markdown table; floats with 3 decimals; any text safe in a cell (``markdown_cell``)."""
    lines = ["| " + " | ".join(markdown_cell(v) for v in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(markdown_cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


@dataclass(frozen=True)
class ProfileColumn(ReadOnlyArrays):
    """One trajectory drawn as a column of four profiles, with optional reference values.

    Attributes:
        trajectory: the trajectory [rad, s].
        title: the column's heading (plain text).
        waypoint_via: indices of the task's waypoints among the via-points (default all).
        points: optional (times (n,) [s], positions (n, J) [rad]): reference positions drawn as
            circles in the joints' colours on the position panel.
        levels: optional (3, J) reference magnitudes of velocity, acceleration and jerk
            [rad/s^d], drawn at +- the value, dash-dotted in the joints' colours (NaN: none).
    """

    trajectory: PiecewisePolynomial
    title: str = ""
    waypoint_via: np.ndarray | None = None
    points: tuple[np.ndarray, np.ndarray] | None = None
    levels: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self)


def _dashes(joint: int, joints: int) -> tuple:
    """Joint ``joint``'s limit dashes, interleaved with the other joints' so that equal limits all show."""
    return 3.0 * joint, (3.0, 3.0 * max(joints - 1, 1))


def _draw_column(axes, column: ProfileColumn, limits: JointLimits, colours: list[str], rate_hz: float) -> list:
    """Draw ``column`` into four axes (position .. jerk); returns the joints' profile lines (one per joint)."""
    trajectory = column.trajectory
    times, values = trajectory.sample(min(rate_hz, PLOT_SAMPLES / trajectory.total_time))
    joints = trajectory.joint_count
    via_times = trajectory.via_times
    is_waypoint = np.zeros(len(via_times), dtype=bool)
    waypoint_via = column.waypoint_via
    is_waypoint[np.arange(len(via_times)) if waypoint_via is None else np.asarray(waypoint_via)] = True
    bounds = [(limits.lower, limits.upper)] + [(-m, m) for m in limits.magnitudes]
    joint_lines: list = []
    for k, axis in enumerate(axes):
        lines = []
        for j in range(joints):
            colour = colours[j % len(colours)]
            lines += axis.plot(times, np.rad2deg(values[k, :, j]), color=colour, linewidth=1.4)
            for bound in (bounds[k][0][j], bounds[k][1][j]):
                if np.isfinite(bound):
                    axis.axhline(np.rad2deg(bound), color=colour, linestyle=_dashes(j, joints), linewidth=0.9,
                                 alpha=0.8)
            if k == 0 and column.points is not None:
                point_times, positions = column.points
                axis.plot(point_times, np.rad2deg(positions[:, j]), "o", color=colour, markeredgecolor="black",
                          markersize=5, zorder=3)
            if k > 0 and column.levels is not None and np.isfinite(column.levels[k - 1, j]):
                level = np.rad2deg(column.levels[k - 1, j])
                for value in (-level, level):
                    axis.axhline(value, color=colour, linestyle="-.", linewidth=1.1)
        if len(via_times) <= PLOT_VIA_LINES:  # one collection per kind: an artist per line costs ~0.5 ms each
            for chosen, colour, width in ((is_waypoint, "0.45", 0.9), (~is_waypoint, "0.75", 0.6)):
                axis.vlines(via_times[chosen], 0.0, 1.0, transform=axis.get_xaxis_transform(), colors=colour,
                            linestyles=":", linewidth=width)
        axis.grid(alpha=0.3)
        joint_lines = joint_lines or lines
    if column.title:
        axes[0].set_title(column.title, fontsize=10)
    axes[-1].set_xlabel("time [s]")
    return joint_lines


def _draw_torques(axis, trajectory: PiecewisePolynomial, torques: Callable[[np.ndarray], np.ndarray],
                  limit: np.ndarray, colours: list[str], rate_hz: float) -> None:
    """Each joint's torque as a fraction of its limit, tau_j / L_j, against time in its colour, and the
    limits at +-1 dashed: on one scale, the joint that binds reaches the band whatever its limit in N m
    (drawn in N m, a large limit such as a shoulder's set the scale and flattened the wrist's torques)."""
    times = trajectory.sample_times(min(rate_hz, PLOT_SAMPLES / trajectory.total_time))
    ratios = torques(times) / limit
    for j in range(ratios.shape[1]):
        axis.plot(times, ratios[:, j], color=colours[j % len(colours)], linewidth=1.4)
    for bound in (-1.0, 1.0):
        axis.axhline(bound, color="0.3", linestyle="--", linewidth=0.9)
    axis.set_ylabel("torque / limit")
    axis.set_xlabel("time [s]")
    axis.grid(alpha=0.3)


def _legend_keys(columns: list[ProfileColumn], points_label: str, levels_label: str) -> tuple[list, list[str]]:
    """Legend entries for the limits, the via-point lines and the reference values the columns draw."""
    from matplotlib.lines import Line2D

    keys = [Line2D([], [], color="0.3", linestyle="--", linewidth=0.9)]
    labels = ["limits (dashed, in the joint's colour)"]
    drawn = [c for c in columns if len(c.trajectory.via_times) <= PLOT_VIA_LINES]
    if drawn:
        keys.append(Line2D([], [], color="0.45", linestyle=":", linewidth=0.9))
        labels.append("waypoint times")
        if any(c.waypoint_via is not None and len(np.unique(c.waypoint_via)) < len(c.trajectory.via_times)
               for c in drawn):
            keys.append(Line2D([], [], color="0.75", linestyle=":", linewidth=0.6))
            labels.append("inserted via-points")
    if any(c.points is not None for c in columns):
        keys.append(Line2D([], [], color="0.6", marker="o", markeredgecolor="black", linestyle="none"))
        labels.append(points_label)
    if any(c.levels is not None for c in columns):
        keys.append(Line2D([], [], color="0.3", linestyle="-.", linewidth=1.1))
        labels.append(levels_label)
    return keys, labels


@contextmanager
def _plain_text_figures():
    """matplotlib.pyplot with the Agg backend, in a context where text is plain (no mathtext)
    and missing glyphs are drawn as boxes without a warning. matplotlib's own log says only what it
    copes with itself (a cache folder it cannot write, in a temporary one instead): errors only."""
    logging.getLogger("matplotlib").setLevel(logging.ERROR)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with matplotlib.rc_context({"text.parse_math": False}), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .* missing from font", category=UserWarning)
        yield plt


def prepare_figure() -> None:
    """Import matplotlib as ``plot_profiles`` uses it, ahead of the figure (``pipeline.output_writers``)."""
    with _plain_text_figures():
        pass


def _save(plt, figure, path: Path, dpi: int) -> None:
    """Write ``figure`` as PNG at ``dpi`` and close it. zlib level 1: a line figure's encoding takes
    a third of the time of matplotlib's default level 6, for a file about a fifth larger."""
    figure.savefig(path, dpi=dpi, pil_kwargs={"compress_level": 1})
    plt.close(figure)


def plot_profiles(trajectory: PiecewisePolynomial, limits: JointLimits, path: Path, *, title: str = "",
                  rate_hz: float = 200.0, joint_names: list[str] | None = None,
                  waypoint_via: np.ndarray | None = None,
                  torques: tuple[Callable[[np.ndarray], np.ndarray], np.ndarray] | None = None) -> None:
    """Position, velocity, acceleration and jerk of every joint against time, as PNG; with
    ``torques`` (a function of times (K,) [s] giving (K, J) torques [N m], and the (J,) limits
    [N m]), a fifth plot of each joint's torque as a fraction of its limit (the limits at +-1).

    Dashed lines in each joint's colour mark its limits; joints whose limits share a value
    interleave their dashes, so each stays visible. Dotted grey lines mark the times of the
    task's waypoints (``waypoint_via``: their indices among the via-points; default all) and
    fainter ones the via-points inserted between them (linear mode), up to ``PLOT_VIA_LINES``
    via-points. The legend says all of this. A long trajectory is sampled more sparsely than
    ``rate_hz``, at ``PLOT_SAMPLES`` samples in all: a figure is about a thousand pixels wide.
    The title and joint names are plain text, whatever they hold (``$...$`` is not mathtext, a
    leading ``_`` does not hide a joint); characters the font lacks are drawn as boxes, without
    a warning.
    """
    column = ProfileColumn(trajectory, waypoint_via=waypoint_via)
    names = joint_names or list(limits.names)
    with _plain_text_figures() as plt:
        rows = 4 if torques is None else 5
        figure, axes = plt.subplots(rows, 1, figsize=(11, 3 * rows), sharex=True)
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        lines = _draw_column(axes[:4], column, limits, colours, rate_hz)
        for k, axis in enumerate(axes[:4]):
            axis.set_ylabel(f"{PROFILE_QUANTITIES[k].name} [{PROFILE_QUANTITIES[k].degree_unit}]")
        if torques is not None:
            _draw_torques(axes[4], trajectory, *torques, colours, rate_hz)
            axes[3].set_xlabel("")
        keys, labels = _legend_keys([column], "", "")
        # A fixed layout (tight_layout would draw the figure once more): the title, the legend's rows, the axes.
        below_title = 0.995 - (0.02 if title else 0.0)
        if title:
            figure.suptitle(title, y=0.995, va="top")
        columns = min(len(lines) + len(keys), 5)
        legend_rows = -(-(len(lines) + len(keys)) // columns)
        # Labels given explicitly: legend() would drop names starting with "_".
        figure.legend(lines + keys, names + labels, ncol=columns, loc="upper center", bbox_to_anchor=(0.5, below_title),
                      fontsize=8)
        figure.subplots_adjust(left=0.085, right=0.985, bottom=0.045 * 4 / rows,
                               top=below_title - (0.008 + 0.0145 * legend_rows) * 4 / rows, hspace=0.1)
        _save(plt, figure, path, dpi=110)


def plot_profile_columns(columns: list[ProfileColumn], limits: JointLimits, path: Path, *, title: str = "",
                         note: str = "", rate_hz: float = 200.0, joint_names: list[str] | None = None,
                         points_label: str = "reference positions",
                         levels_label: str = "reference maxima (+-)") -> None:
    """Several trajectories side by side as PNG: one column of four profiles each (as
    ``plot_profiles``), each row on one vertical scale so the columns compare at a glance.

    ``note`` is printed under the title (plain text, wrapped by the caller); the legend names the
    joints, the limits, the via-point lines and the reference values the columns draw
    (``points_label``, ``levels_label``).
    """
    names = joint_names or list(limits.names)
    with _plain_text_figures() as plt:
        figure, axes = plt.subplots(4, len(columns), figsize=(7.5 * len(columns), 13), sharey="row", squeeze=False)
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        lines = [_draw_column(axes[:, c], column, limits, colours, rate_hz) for c, column in enumerate(columns)][0]
        for k in range(4):
            axes[k, 0].set_ylabel(f"{PROFILE_QUANTITIES[k].name} [{PROFILE_QUANTITIES[k].degree_unit}]")
        keys, labels = _legend_keys(columns, points_label, levels_label)
        heading = "\n".join(part for part in (title, note) if part)
        below_heading = 0.995 - (0.013 * (heading.count("\n") + 1) + 0.005 if heading else 0.0)
        if heading:
            figure.suptitle(heading, fontsize=10, y=0.995, va="top")
        figure.legend(lines + keys, names + labels, ncol=min(len(lines) + len(keys), 6), loc="upper center",
                      bbox_to_anchor=(0.5, below_heading), fontsize=8)
        figure.subplots_adjust(left=0.06, right=0.99, bottom=0.045, top=below_heading - 0.065, hspace=0.12,
                               wspace=0.05)
        _save(plt, figure, path, dpi=100)
