import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from planner import paper

settings.register_profile("project", deadline=None, max_examples=40, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("project")


@pytest.fixture
def paper_via() -> np.ndarray:
    return np.deg2rad(paper.VIA_POINTS_DEG)


@pytest.fixture
def paper_limits():
    return paper.paper_limits()


@st.composite
def via_and_durations(draw, family_name: str, max_points: int = 7, max_joints: int = 3):
    """Random via-points (n, J) [rad] and durations [s] for a family."""
    from planner import get_family
    n = draw(st.integers(2, max_points))
    joints = draw(st.integers(1, max_joints))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    via = rng.uniform(-3.0, 3.0, (n, joints))
    count = get_family(family_name).segment_count(n)
    durations = rng.uniform(0.2, 5.0, count)
    return via, durations
