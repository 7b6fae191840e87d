"""Tables and profile figures of a planned trajectory, in degrees (the paper's units)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from .limits import DEGREE_UNITS, QUANTITIES, JointLimits
from .splines import PiecewisePolynomial

#: Most samples per joint drawn in a profile figure.
PLOT_SAMPLES = 20_000
#: Via-point times are drawn as vertical lines up to this many via-points.
PLOT_VIA_LINES = 200


def markdown_table(header: list[str], rows: list[list]) -> str:
    """A GitHub Markdown table; floats with 3 decimals."""
    def cell(value):
        if isinstance(value, (float, np.floating)):
            return f"{value:.3f}" if np.isfinite(value) else "-"
        return str(value)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def plot_profiles(trajectory: PiecewisePolynomial, limits: JointLimits, path: Path, *, title: str = "",
                  rate_hz: float = 200.0, joint_names: list[str] | None = None,
                  waypoint_via: np.ndarray | None = None) -> None:
    """Position, velocity, acceleration and jerk of every joint against time, as PNG.

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
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    times, values = trajectory.sample(min(rate_hz, PLOT_SAMPLES / trajectory.total_time))
    names = joint_names or list(limits.names)
    joints = trajectory.joint_count
    via_times = trajectory.via_times
    is_waypoint = np.zeros(len(via_times), dtype=bool)
    is_waypoint[np.arange(len(via_times)) if waypoint_via is None else np.asarray(waypoint_via)] = True
    with matplotlib.rc_context({"text.parse_math": False}), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .* missing from font", category=UserWarning)
        figure, axes = plt.subplots(4, 1, figsize=(11, 12), sharex=True)
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        bounds = [(limits.lower, limits.upper)] + [(-m, m) for m in limits.magnitudes]
        for k, axis in enumerate(axes):
            lines = []
            for j in range(joints):
                colour = colours[j % len(colours)]
                lines += axis.plot(times, np.rad2deg(values[k, :, j]), color=colour, linewidth=1.4)
                dashes = (3.0 * j, (3.0, 3.0 * max(joints - 1, 1)))  # interleaved with the other joints'
                for bound in (bounds[k][0][j], bounds[k][1][j]):
                    if np.isfinite(bound):
                        axis.axhline(np.rad2deg(bound), color=colour, linestyle=dashes, linewidth=0.9, alpha=0.8)
            if len(via_times) <= PLOT_VIA_LINES:
                for t, waypoint in zip(via_times, is_waypoint):
                    axis.axvline(t, color="0.45" if waypoint else "0.75", linestyle=":",
                                 linewidth=0.9 if waypoint else 0.6)
            axis.set_ylabel(f"{('position', *QUANTITIES)[k]} [{DEGREE_UNITS[k]}]")
            axis.grid(alpha=0.3)
            if k == 0:  # labels given explicitly: legend() would drop names starting with "_"
                keys = [Line2D([], [], color="0.3", linestyle="--", linewidth=0.9)]
                labels = ["limits (dashed, in the joint's colour)"]
                if len(via_times) <= PLOT_VIA_LINES:
                    keys.append(Line2D([], [], color="0.45", linestyle=":", linewidth=0.9))
                    labels.append("waypoint times")
                    if not is_waypoint.all():
                        keys.append(Line2D([], [], color="0.75", linestyle=":", linewidth=0.6))
                        labels.append("inserted via-points")
                axis.legend(lines + keys, names + labels, ncol=min(joints + len(keys), 5), loc="lower center",
                            bbox_to_anchor=(0.5, 1.02), fontsize=8)
        axes[-1].set_xlabel("time [s]")
        if title:
            figure.suptitle(title)
        figure.tight_layout()
        figure.savefig(path, dpi=110)
        plt.close(figure)
