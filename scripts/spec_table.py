"""Print TIMING-SPEC §5: the hybrid spline through Table II with the paper's Table IV durations."""

import numpy as np

from planner import get_family, kinematic_figures, paper


def main() -> None:
    via = np.deg2rad(paper.VIA_POINTS_DEG)
    figures = kinematic_figures(get_family("hybrid").build(via, paper.DURATIONS_S))
    ratios = figures.ratios(paper.paper_limits())
    print(f"hybrid spline, Table II via-points, Table IV durations (T = {figures.total_time:.4f} s)")
    print("joint               " + "".join(f"{j + 1:>9d}" for j in range(6)))
    rows = [("max|vel|  deg/s", figures.max_abs[0]), ("max|acc|  deg/s^2", figures.max_abs[1]),
            ("max|jerk| deg/s^3", figures.max_abs[2]), ("mean|vel| deg/s", figures.mean_abs[0])]
    for label, values in rows:
        print(f"{label:<20}" + "".join(f"{v:9.3f}" for v in np.rad2deg(values)))
    print(f"largest constraint ratio: {ratios.max():.3f}")


if __name__ == "__main__":
    main()
