"""The source paper reproduced and corrected: its Tables IV, V, VI and Figure 4, beside ours.

For the paper case (Table II via-points, Table III limits) and each spline
family x optimizer, with the paper's bounds [3, 5] s and without bounds,
this runs the timing optimization and reports total time, largest
constraint ratio, evaluations and wall time; then Tables V and VI (exact
max and time-averaged |v|, |a|, |j|) for the paper's own durations and for
ours, beside the numbers the paper reports. Figure 4 (the paper's profiles,
a plot without numbers) is recomputed from its Tables II and IV and drawn
beside ours, with the numbers the paper does give for it: the via-points
(Table II) at Table IV's times and the maxima it reports (Table V).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import paper
from .export import write_json
from .kinematics import KinematicFigures, kinematic_figures
from .limits import QUANTITIES
from .progress import TerminalProgress
from .report import ProfileColumn, markdown_table, plot_profile_columns
from .splines import get_family
from .timing import OptimizationResult, TimingProblem, optimize
from .timing.lower_bound import time_lower_bound

OPTIMIZER_LABELS = {"cuckoo": "CS (ours: repair + NLP)", "nlp": "sparse NLP (from cheap shapes)",
                    "cuckoo-paper": "CS (plain, as the paper)", "pso": "PSO", "de": "DE (scipy)",
                    "slsqp": "SLSQP multi-start"}
#: Budgets small enough for a test run (``quick``).
QUICK_SETTINGS = {"cuckoo": {"iterations": 10}, "nlp": {}, "cuckoo-paper": {"iterations": 10},
                  "pso": {"iterations": 10}, "de": {"evaluations": 600}, "slsqp": {"starts": 2, "iterations": 20}}


@dataclass(frozen=True)
class Run:
    """One optimizer's result for one family and one setting of the duration bounds."""

    family: str
    bounds: tuple[float, float] | None
    algorithm: str
    result: OptimizationResult


#: The families the comparison runs. ``hermite7``'s and ``trigonometric``'s via-point states are optimized by
#: the NLP stages (ours, and the sparse NLP); the population optimizers use their fixed rule (``parabola_states``).
COMPARED_FAMILIES = ("cubic", "hybrid", "quintic", "hermite7", "trigonometric")


def run_all(*, quick: bool = False, seed: int = 0, families=COMPARED_FAMILIES,
            progress: TerminalProgress | None = None) -> list[Run]:
    """Every family x bounds x optimizer on the paper case."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    limits = paper.paper_limits()
    runs = []
    for bounds in (paper.BOUNDS_S, None):
        for family in families:
            problem = TimingProblem(via, family, limits, bounds=bounds)
            for algorithm in OPTIMIZER_LABELS:
                if algorithm == "cuckoo-paper" and bounds is None:
                    continue
                paper_settings = paper.CUCKOO_SETTINGS if algorithm.startswith("cuckoo") else {}
                settings = dict(QUICK_SETTINGS[algorithm]) if quick else dict(paper_settings)
                if progress:
                    progress.note(f"{family}, bounds {_bounds_label(bounds)}, {OPTIMIZER_LABELS[algorithm]}")
                runs.append(Run(family, bounds, algorithm, optimize(problem, algorithm, seed=seed, **settings)))
    return runs


def _bounds_label(bounds) -> str:
    return f"[{bounds[0]:g}, {bounds[1]:g}] s" if bounds else "none"


def _figures_block(title: str, figures: KinematicFigures, with_paper: bool) -> tuple[str, dict]:
    """A Markdown table of exact max and mean |v|, |a|, |j| (and, optionally, the paper's Tables V, VI)."""
    rows, data = [], {}
    for name, table, paper_table in (("max", figures.max_abs, paper.TABLE_V_DEG),
                                     ("mean", figures.mean_abs, paper.TABLE_VI_DEG)):
        for d, quantity in enumerate(QUANTITIES):
            ours = np.rad2deg(table[d])
            rows.append([f"{name} |{quantity}|, exact", *ours, float(ours.mean())])
            data[f"{name}_{quantity}_deg"] = ours
            if with_paper:
                theirs = np.array(paper_table[quantity])
                rows.append([f"{name} |{quantity}|, paper reports", *theirs, float(theirs.mean())])
    header = ["", *[f"J{j + 1}" for j in range(6)], "average"]
    return f"### {title}\n\n" + markdown_table(header, rows), data


def write_report(runs: list[Run], folder: Path) -> None:
    """Write reproduction.md, reproduction.json and the Figure 4 equivalent (figure4.png) into the
    existing ``folder`` (the CLI publishes it through ``planner.outputs.output_folder``)."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    limits = paper.paper_limits()
    lines = ["# The paper reproduced", "",
             f'The source paper: "{paper.TITLE}". Its case: Table II via-points, Table III limits.',
             "All figures are exact (roots of polynomial derivatives). Times in s, angles in degrees.", ""]
    # Table IV and the optimizer comparison.
    header = ["bounds", "family", "optimizer", "total time [s]", "largest ratio", "feasible", "evaluations",
              "wall time [s]"]
    rows = [[_bounds_label(r.bounds), r.family, OPTIMIZER_LABELS[r.algorithm], f"{r.result.total_time:.4f}",
             f"{r.result.max_ratio:.4f}", r.result.feasible, r.result.evaluations, f"{r.result.wall_time_s:.3f}"]
            for r in runs]
    paper_figures = kinematic_figures(get_family("hybrid").build(via, paper.DURATIONS_S))
    paper_evaluations = 2 * paper.CUCKOO_SETTINGS["nests"] * paper.CUCKOO_SETTINGS["iterations"]
    rows.insert(0, ["[3, 5] s", "hybrid", "CS, the paper's Table IV", f"{paper.DURATIONS_S.sum():.4f}",
                    f"{paper_figures.ratios(limits).max():.4f}", True, paper_evaluations, "-"])
    lines += ["## Optimizers compared (total time; Table IV's setting first)", "", markdown_table(header, rows), ""]
    best_of: dict = {}
    for r in runs:
        key = (r.family, r.bounds)
        if r.result.feasible and (key not in best_of or r.result.total_time < best_of[key].result.total_time):
            best_of[key] = r
    lines += _families_block(best_of)
    lines += ["## Table IV: durations of the hybrid spline", ""]
    header = ["", *[f"h{k + 1}" for k in range(9)], "total"]
    table_rows = [["paper (CS, bounds [3, 5])", *paper.DURATIONS_S, float(paper.DURATIONS_S.sum())]]
    for bounds in (paper.BOUNDS_S, None):
        if ("hybrid", bounds) in best_of:
            r = best_of[("hybrid", bounds)]
            table_rows.append([f"ours ({OPTIMIZER_LABELS[r.algorithm]}, bounds {_bounds_label(bounds)})",
                               *r.result.durations, r.result.total_time])
    lines += [markdown_table(header, table_rows), ""]
    bound = speed_lower_bound_deg(paper.VIA_POINTS_DEG, get_family("hybrid").build(via, paper.DURATIONS_S).via_times)
    reported = np.array(paper.TABLE_V_DEG["velocity"])
    lines += ["## Tables V and VI: max and time-averaged |v|, |a|, |j|", "",
              "The paper's Table V cannot be reproduced by any trajectory through Table II with its own",
              "Table IV durations: a joint that moves by D between two via-points passed dt apart reaches",
              "the speed D / dt somewhere between them (mean value theorem), and for",
              f"{int(np.sum(reported < bound))} of the 6 joints that lower bound already exceeds the maximum speed",
              "Table V reports. Its numbers are shown beside the exact ones.", ""]
    lines += [markdown_table(["", *[f"J{j + 1}" for j in range(6)]], [
        ["max |velocity| at least (Table II, Table IV times)", *bound],
        ["max |velocity|, the paper's Table V", *reported],
        ["Table V below the bound", *["yes" if r < b else "no" for r, b in zip(reported, bound)]]]), ""]
    block, paper_data = _figures_block("The paper's durations (Table IV), hybrid spline", paper_figures, True)
    lines += [block, ""]
    ours_data = {}
    for bounds in (paper.BOUNDS_S, None):
        if ("hybrid", bounds) in best_of:
            r = best_of[("hybrid", bounds)]
            block, ours_data[_bounds_label(bounds)] = _figures_block(
                f"Ours, hybrid, bounds {_bounds_label(bounds)}: T = {r.result.total_time:.4f} s",
                kinematic_figures(get_family("hybrid").build(via, r.result.durations)), False)
            lines += [block, ""]
    figure4_lines, columns = figure4_columns(best_of.get(("hybrid", None)), best_of.get(("hermite7", None)))
    lines += figure4_lines
    (folder / "reproduction.md").write_text("\n".join(lines) + "\n")
    write_json(folder / "reproduction.json", {
        "paper": paper.TITLE,
        "runs": [{"family": r.family, "bounds_s": r.bounds, "algorithm": r.algorithm,
                  "durations_s": r.result.durations, "total_time_s": r.result.total_time,
                  "max_ratio": r.result.max_ratio, "feasible": r.result.feasible,
                  "evaluations": r.result.evaluations, "wall_time_s": r.result.wall_time_s,
                  "seed": r.result.seed, "settings": r.result.settings} for r in runs],
        "paper_durations": {"durations_s": paper.DURATIONS_S, "figures": paper_data,
                            "max_velocity_lower_bound_deg_s": bound},
        "ours": ours_data,
    })
    plot_profile_columns(
        columns, limits, folder / FIGURE_FILE, title="The paper's Figure 4, recomputed, beside ours",
        note=FIGURE_NOTE, joint_names=[f"J{j + 1}" for j in range(6)],
        points_label="the paper's Table II via-points at Table IV's times",
        levels_label="the paper's Table V maxima (+-), as reported")


#: The Figure 4 equivalent, in the output folder.
FIGURE_FILE = "figure4.png"
#: The files ``write_report`` writes.
REPORT_FILES = ("reproduction.md", "reproduction.json", FIGURE_FILE)
#: What the figure shows, printed under its title.
FIGURE_NOTE = ("The paper's Figure 4 is a plot without numbers. Left: the hybrid spline through Table II with "
               "Table IV's durations, recomputed exactly; circles and dash-dotted lines are the numbers the paper "
               "gives\nfor it (Table II via-points, Table V maxima). Then ours: the same spline and limits, "
               "time-optimal without duration bounds, and the jerk-continuous hermite7. Dashed: Table III limits. "
               "Each row shares one scale.")


def speed_lower_bound_deg(via_deg: np.ndarray, via_times: np.ndarray) -> np.ndarray:
    """(J,) a lower bound on each joint's max |velocity| [deg/s] for any trajectory through ``via_deg``
    (n, J) [deg] at ``via_times`` (n,) [s]: the largest |p_{i+1} - p_i| / (t_{i+1} - t_i) (mean value theorem)."""
    return (np.abs(np.diff(via_deg, axis=0)) / np.diff(via_times)[:, None]).max(axis=0)


def _families_block(best_of: dict) -> list[str]:
    """The best feasible total time of each family, with and without the paper's bounds, against ``hybrid``,
    and without bounds against the lower bound for any trajectory (``time_lower_bound``)."""
    bound = time_lower_bound(np.deg2rad(paper.VIA_POINTS_DEG), paper.paper_limits())
    families = list(dict.fromkeys(family for family, _ in best_of))
    rows = []
    for family in families:
        row = [family]
        for bounds in (paper.BOUNDS_S, None):
            run, hybrid = best_of.get((family, bounds)), best_of.get(("hybrid", bounds))
            if run is None:
                row += ["-", "-"]
                continue
            row.append(f"{run.result.total_time:.4f}")
            row.append(f"{100 * (run.result.total_time / hybrid.result.total_time - 1):+.2f} %" if hybrid else "-")
        free = best_of.get((family, None))
        row.append(f"{100 * (free.result.total_time / bound - 1):+.2f} %" if free else "-")
        rows.append(row)
    header = ["family", "bounds [3, 5] s: best total time [s]", "against hybrid", "no bounds: best total time [s]",
              "against hybrid", "against the lower bound"]
    return ["## Families compared (the best feasible run of each)", "",
            "`hermite7` and `trigonometric` (Simon & Isik's segments) are jerk-continuous, and the NLP stages",
            "choose their via-point velocities, accelerations and jerks with the durations (the other optimizers",
            "take them from a fixed rule); the other families fix them from the durations. No trajectory of any",
            f"kind through Table II's via-points within Table III's limits takes less than {bound:.4f} s (a lower",
            "bound: each joint stops wherever it turns, and each of its moves between stops takes at least its",
            "bang-bang time; `planner.timing.lower_bound`).", "",
            markdown_table(header, rows), ""]


def figure4_columns(ours: Run | None, jerk_continuous: Run | None = None) -> tuple[list[str], list[ProfileColumn]]:
    """The report's Figure 4 section and the figure's columns: the paper's Table IV durations with
    its Table II and Table V numbers, then ``ours`` (the best hybrid run without bounds) if any, then
    ``jerk_continuous`` (the best hermite7 run without bounds) if any."""
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    hybrid = get_family("hybrid")
    theirs = hybrid.build(via, paper.DURATIONS_S)
    levels = np.deg2rad(np.array([paper.TABLE_V_DEG[quantity] for quantity in QUANTITIES]))
    columns = [ProfileColumn(theirs, f"The paper's Table IV durations (bounds [3, 5] s), T = {theirs.total_time:.3f} s",
                             points=(theirs.via_times, via), levels=levels)]
    lines = ["## Figure 4: profiles of the hybrid spline", "",
             f"`{FIGURE_FILE}` shows position, velocity, acceleration and jerk of every joint. The paper's",
             "Figure 4 is a plot without numbers, so its profiles are recomputed here from the paper's Table II",
             "via-points and Table IV durations (left column), with the numbers the paper does give for them",
             "drawn on top: the Table II via-points at the times Table IV puts them, and the Table V maxima",
             "(as plus and minus lines), which the recomputed profiles do not match: the tables above compare",
             "them."]
    if ours is None:
        lines += ["No hybrid run without bounds was feasible, so the figure shows the paper's column only.", ""]
        return lines, columns
    trajectory = hybrid.build(via, ours.result.durations)
    columns.append(ProfileColumn(trajectory, f"Ours: {OPTIMIZER_LABELS[ours.algorithm]}, no bounds, "
                                             f"T = {trajectory.total_time:.3f} s"))
    lines += ["The middle column is ours: the same spline and limits, durations from",
              f"{OPTIMIZER_LABELS[ours.algorithm]} without bounds (T = {trajectory.total_time:.4f} s against the",
              f"paper's {theirs.total_time:.4f} s)."]
    if jerk_continuous is not None:
        smooth = get_family("hermite7").build(via, jerk_continuous.result.durations,
                                              jerk_continuous.result.knot_states)
        columns.append(ProfileColumn(smooth, f"Ours, hermite7 (C3): {OPTIMIZER_LABELS[jerk_continuous.algorithm]}, "
                                             f"no bounds, T = {smooth.total_time:.3f} s"))
        lines += [f"The right column is the jerk-continuous `hermite7` through the same via-points (T = "
                  f"{smooth.total_time:.4f} s): its jerk has no jumps."]
    lines += ["Dashed lines are the Table III limits; each row of the figure has one vertical scale.", ""]
    return lines, columns
