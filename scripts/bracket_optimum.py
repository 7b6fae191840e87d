"""Bracket the fastest jerk-limited motion through the paper's via-points, whatever its family.

Below: ``planner.timing.lower_bound.time_lower_bound`` (no motion through the via-points in order,
from rest to rest, within the velocity, acceleration and jerk limits is faster). Above: a motion
found here, of piecewise-constant jerk with ``--pieces`` equal pieces per segment (the segment
durations and every piece's jerk are the variables, IPOPT through CasADi), then checked exactly
(the jerk per piece, the acceleration at the pieces' ends where it is linear, the velocity also at
the vertex of each piece's parabola) and scaled by the time-scaling lemma until every limit holds.
It is a local optimum of a restricted family, so the fastest motion lies between the two figures;
the spline families' optima (the default planner) are printed beside them.

    python scripts/bracket_optimum.py [--pieces 40]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from planner import paper
from planner.timing import TimingProblem, optimize
from planner.timing.lower_bound import time_lower_bound


def piecewise_constant_jerk(via: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, jerk: np.ndarray,
                            pieces: int, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment durations (S,) [s] and jerks (S pieces, J) [rad/s^3] of a motion through ``via`` (n, J) [rad]
    from rest to rest, its total time minimised by IPOPT from the durations ``start`` (S,): the limits held
    at the pieces' ends and middles (the exact check is ``exact_peaks``)."""
    import casadi as ca

    segments, joints = len(via) - 1, via.shape[1]
    opti = ca.Opti()
    h = opti.variable(segments)
    j = opti.variable(segments * pieces, joints)
    opti.subject_to(h >= 1e-3)
    q, v, a = ca.DM(via[0]).T, ca.DM.zeros(1, joints), ca.DM.zeros(1, joints)
    bounds = {name: ca.DM(value).T for name, value in (("v", velocity), ("a", acceleration))}
    for segment in range(segments):
        dt = h[segment] / pieces
        for piece in range(pieces):
            jk = j[segment * pieces + piece, :]
            middle = v + a * dt / 2 + jk * dt ** 2 / 8
            q = q + v * dt + a * dt ** 2 / 2 + jk * dt ** 3 / 6
            v = v + a * dt + jk * dt ** 2 / 2
            a = a + jk * dt
            for value, name in ((v, "v"), (middle, "v"), (a, "a")):
                opti.subject_to(opti.bounded(-bounds[name], value, bounds[name]))
        opti.subject_to(q == ca.DM(via[segment + 1]).T)
    opti.subject_to(v == 0)
    opti.subject_to(a == 0)
    for joint in range(joints):
        opti.subject_to(opti.bounded(-jerk[joint], j[:, joint], jerk[joint]))
    opti.minimize(ca.sum1(h))
    opti.set_initial(h, start)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "max_iter": 3000, "tol": 1e-9})
    solution = opti.solve()
    return np.atleast_1d(solution.value(h)), np.atleast_2d(solution.value(j))


def exact_peaks(via: np.ndarray, durations: np.ndarray, jerks: np.ndarray, pieces: int) -> tuple[np.ndarray, ...]:
    """(J,) max |velocity|, |acceleration|, |jerk| of the motion, exactly (module docstring), and the largest
    distance [rad] from a via-point at its time."""
    joints = via.shape[1]
    q, v, a = via[0].astype(float), np.zeros(joints), np.zeros(joints)
    peak_v, peak_a, missed = np.zeros(joints), np.zeros(joints), 0.0
    for segment, h in enumerate(durations):
        dt = h / pieces
        for jk in jerks[segment * pieces:(segment + 1) * pieces]:
            with np.errstate(divide="ignore", invalid="ignore"):
                vertex = np.where(jk != 0, -a / jk, -1.0)  # where v' = a = 0 inside the piece
            inside = (vertex > 0) & (vertex < dt)
            peak_v = np.maximum(peak_v, np.where(inside, np.abs(v + a * vertex + jk * vertex ** 2 / 2), 0.0))
            q = q + v * dt + a * dt ** 2 / 2 + jk * dt ** 3 / 6
            v = v + a * dt + jk * dt ** 2 / 2
            a = a + jk * dt
            peak_v, peak_a = np.maximum(peak_v, np.abs(v)), np.maximum(peak_a, np.abs(a))
        missed = max(missed, float(np.abs(q - via[segment + 1]).max()))
    return peak_v, peak_a, np.abs(jerks).max(axis=0), np.array(missed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pieces", type=int, default=40, help="constant-jerk pieces per segment")
    args = parser.parse_args()
    via, limits = np.deg2rad(paper.VIA_POINTS_DEG), paper.paper_limits()
    below = time_lower_bound(via, limits)
    print(f"lower bound (planner.timing.lower_bound): {below:.4f} s")
    results = {family: optimize(TimingProblem(via, family, limits))
               for family in ("hybrid", "hermite7", "trigonometric")}
    totals = {family: result.total_time for family, result in results.items()}
    for family, total in totals.items():
        print(f"{family} optimum (default planner): {total:.4f} s")
    starts = {"equal durations": np.full(len(via) - 1, 2.5), "hermite7's optimum": results["hermite7"].durations}
    best = np.inf
    for label, start in starts.items():
        began = time.perf_counter()
        durations, jerks = piecewise_constant_jerk(via, limits.velocity, limits.acceleration, limits.jerk,
                                                   args.pieces, start)
        peak_v, peak_a, peak_j, missed = exact_peaks(via, durations, jerks, args.pieces)
        scale = max(1.0, float(np.max(peak_v / limits.velocity)), float(np.sqrt(np.max(peak_a / limits.acceleration))),
                    float(np.cbrt(np.max(peak_j / limits.jerk))))
        total = float(durations.sum()) * scale
        print(f"piecewise-constant jerk from {label}: {total:.4f} s after scaling by {scale:.10f} (via-points met "
              f"within {float(missed):.1e} rad; largest velocity ratio {float(np.max(peak_v / limits.velocity)):.3f}; "
              f"{time.perf_counter() - began:.1f} s)")
        best = min(best, total)
    above = ", ".join(f"{family} at most {100 * (total / best - 1):.1f} % above it" for family, total in totals.items())
    print(f"the fastest motion takes between {below:.4f} and {best:.4f} s: the lower bound is within "
          f"{100 * (1 - below / best):.1f} % of it, {above}")


if __name__ == "__main__":
    main()
