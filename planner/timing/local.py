"""Local refinement of durations by SLSQP (the ``slsqp`` baseline), on the durations alone.

Variables: the durations h [s]. Objective: sum h (or K_t sum h + K_j E).
Constraints, one per limited (joint, order): g = 1 - r^(1/d) >= 0, which is
homogeneous of degree 1 in a common scale of h; one per finite position
bound: the exact range reached stays inside it. Jacobians by forward
differences, the S + 1 points evaluated in batches of bounded size.
"""

from __future__ import annotations

import numpy as np

from ..kinematics import batch_scale_factors, jerk_energy, position_range
from .problem import TimingProblem
from .result import CHUNK_COEFFICIENTS, SearchTracker

_STEP = 1e-7


class _Model:
    """Objective and constraints at a point and its forward-difference neighbours, cached."""

    def __init__(self, problem: TimingProblem, tracker: SearchTracker):
        self.problem = problem
        self.tracker = tracker
        limited = np.isfinite(problem.limits.magnitudes)  # (3, J)
        self.limited = limited
        self.roots = np.array([1.0, 0.5, 1.0 / 3.0])[:, None]
        self.lower = np.isfinite(problem.limits.lower)
        self.upper = np.isfinite(problem.limits.upper)
        self._key: bytes | None = None

    def _values(self, h: np.ndarray):
        """Objective (B,) and constraints (B, m) at durations h (B, S), ``CHUNK_COEFFICIENTS`` at a time
        (the S + 1 points of 3000 segments made one 1.2 GB array), the time limit checked after each."""
        rows = max(1, CHUNK_COEFFICIENTS // (self.problem.segment_count * self.problem.joint_count * 8))
        parts = [self._chunk_values(h[begin:begin + rows]) for begin in range(0, len(h), rows)]
        return np.concatenate([part[0] for part in parts]), np.concatenate([part[1] for part in parts])

    def _chunk_values(self, h: np.ndarray):
        """``_values`` of one chunk."""
        p = self.problem
        coefficients = p.family.batch_coefficients(p.via_points, h)
        ratios, _ = batch_scale_factors(coefficients, h, p.limits, p.family.basis)
        constraints = [(1.0 - ratios ** self.roots)[:, self.limited]]
        if self.lower.any() or self.upper.any():
            low, high = position_range(coefficients, h, p.family.basis)
            constraints.append((low - p.limits.lower)[:, self.lower])
            constraints.append((p.limits.upper - high)[:, self.upper])
        objective = h.sum(axis=1)
        if p.uses_jerk_energy:
            energy = jerk_energy(coefficients, h, p.family.basis).sum(axis=1)
            objective = p.weights[0] * objective + p.weights[1] * energy
        self.tracker.count(len(h))
        return objective, np.concatenate(constraints, axis=1)

    def at(self, x: np.ndarray):
        key = x.tobytes()
        if key != self._key:
            steps = _STEP * np.maximum(x, 1e-3)
            points = np.vstack((x, x + np.diag(steps)))
            objective, constraints = self._values(points)
            self._key = key
            self.f, self.g = objective[0], constraints[0]
            self.df = (objective[1:] - objective[0]) / steps
            self.dg = ((constraints[1:] - constraints[0]) / steps[:, None]).T
        return self


def refine(problem: TimingProblem, start: np.ndarray, tracker: SearchTracker, max_iterations: int = 20) -> None:
    """Run SLSQP from durations ``start`` (S,) [s] and offer its repaired result to ``tracker``."""
    model = _Model(problem, tracker)
    lower = max(problem.duration_floor, 0.0 if problem.bounds else 1e-3 * float(start.min()))
    upper = problem.bounds[1] if problem.bounds else None
    from scipy.optimize import minimize  # imported where used: 0.1 s of every run's start

    solution = minimize(
        lambda x: model.at(x).f, start, jac=lambda x: model.at(x).df, method="SLSQP",
        bounds=[(lower, upper)] * len(start),
        constraints=[{"type": "ineq", "fun": lambda x: model.at(x).g, "jac": lambda x: model.at(x).dg}],
        options={"maxiter": max_iterations, "ftol": 1e-12})
    if np.all(np.isfinite(solution.x)) and np.all(solution.x > 0):
        tracker.evaluate(solution.x[None])
