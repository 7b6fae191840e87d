"""Gaps in the tests of planner/timing/__init__.py found by mutation testing (mutmut)."""

import numpy as np

from planner import paper
from planner.timing import TimingProblem, optimize


def test_cuckoo_paper_takes_its_settings():
    """``cuckoo-paper`` passes its settings on to Cuckoo Search (the plain variant)."""
    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits(), bounds=(0.5, 8.0))
    result = optimize(problem, "cuckoo-paper", nests=4, iterations=3, seed=5)
    assert result.algorithm == "cuckoo-paper" and result.seed == 5
    assert result.settings["nests"] == 4 and result.settings["iterations"] == 3 and len(result.history) == 3
    assert result.settings["variant"] == "paper" and result.evaluations == 4 * (1 + 2 * 3)
