"""Gaps in the tests of planner/timing/cuckoo.py found by mutation testing (mutmut)."""

import re

import numpy as np
import pytest

from planner import InputError, paper
from planner.timing import TimingProblem, cuckoo_search
from planner.timing.cuckoo import mantegna_sigma


def _problem(**keywords):
    """The paper's first four via-points and limits, cubic family: fast to search."""
    return TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:4], "cubic", paper.paper_limits(), **keywords)


def test_mantegna_sigma_has_its_published_values():
    """sigma_u = 0.6966 for beta = 1.5 (Yang & Deb 2009; Yang, Nature-Inspired Metaheuristic Algorithms,
    2010); beta = 1 (Cauchy): Gamma(2) sin(pi/2) / (Gamma(1) 1 2^0) = 1; beta = 2 (Gaussian): sin(pi) = 0."""
    assert mantegna_sigma(1.5) == pytest.approx(0.6966, abs=5e-5)
    assert mantegna_sigma(1.0) == pytest.approx(1.0, rel=1e-12)
    assert mantegna_sigma(2.0) == pytest.approx(0.0, abs=1e-7)


def test_mantegna_steps_have_the_tail_of_a_levy_stable_law_of_index_beta():
    """Mantegna's steps L = u / |v|^(1/beta), u ~ N(0, sigma_u^2), v ~ N(0, 1), have the tail of the
    symmetric stable law of unit scale: P(L > x) ~ C x^-beta with C = Gamma(beta) sin(pi beta / 2) / pi.
    Checked independently of the formula, from the tail of the sampled steps (fixed seed)."""
    from math import gamma, pi, sin

    beta = 1.5
    rng = np.random.default_rng(7)
    steps = (rng.standard_normal(2_000_000) * mantegna_sigma(beta)
             / np.abs(rng.standard_normal(2_000_000)) ** (1 / beta))
    x = 50.0
    tail = np.mean(steps > x) * x ** beta
    assert tail == pytest.approx(gamma(beta) * sin(pi * beta / 2) / pi, rel=0.1)


def test_cuckoo_search_defaults_are_the_documented_ones():
    """20 nests, 150 iterations (2 * nests evaluations each, after the nests' first one), pa = 0.25,
    beta = 1.5, seed 0, alpha 0.3 for ``improved``, refined by the NLP from the best nest."""
    result = cuckoo_search(_problem())
    assert {key: value for key, value in result.settings.items() if key != "nlp"} == {
        "nests": 20, "iterations": 150, "pa": 0.25, "alpha": 0.3, "beta": 1.5, "variant": "improved",
        "polish": True, "refine_starts": 1}
    assert "nlp" in result.settings and [start.label for start in result.starts] == ["nest 1"]
    assert result.seed == 0 and len(result.history) == 150 and result.evaluations > 20 * (1 + 2 * 150)
    assert result.algorithm == "cuckoo" and result.stop_reason == "completed 150 iterations and NLP refinement"
    unpolished = cuckoo_search(_problem(), polish=False)
    assert unpolished.evaluations == 20 * (1 + 2 * 150) and unpolished.stop_reason == "completed 150 iterations"
    assert unpolished.seed == 0


def test_the_paper_variant_defaults_to_yang_and_debs_step_and_no_polish():
    result = cuckoo_search(_problem(bounds=(0.5, 8.0)), variant="paper", nests=4, iterations=2)
    assert result.settings["alpha"] == 0.01 and result.settings["polish"] is False and "nlp" not in result.settings
    assert result.algorithm == "cuckoo-paper" and result.starts == [] and result.stop_reason == "completed 2 iterations"


def test_the_default_seed_is_zero():
    problem = _problem()
    default, zero = cuckoo_search(problem, nests=4, iterations=3, polish=False), \
        cuckoo_search(problem, nests=4, iterations=3, polish=False, seed=0)
    np.testing.assert_array_equal(default.durations, zero.durations)
    assert default.history == zero.history and default.seed == 0


@pytest.mark.parametrize("settings", [
    {"nests": 2}, {"iterations": 1}, {"pa": 0.0}, {"pa": 1.0}, {"alpha": 1e-9}, {"beta": 2.0}, {"beta": 1.0001},
    {"refine_starts": 4, "polish": True}, {"refine_starts": 1}])
def test_cuckoo_search_takes_the_edges_of_its_ranges(settings):
    settings = {"nests": 4, "iterations": 2, "polish": False} | settings
    result = cuckoo_search(_problem(), **settings)
    assert result.feasible and len(result.history) == settings["iterations"]
    assert result.evaluations >= settings["nests"] * (1 + 2 * settings["iterations"])


@pytest.mark.parametrize("settings", [
    {"nests": 1}, {"iterations": 0}, {"pa": -0.01}, {"pa": 1.01}, {"alpha": 0.0}, {"alpha": -0.3}, {"beta": 1.0},
    {"beta": 2.01}, {"refine_starts": 0}, {"refine_starts": 5}])
def test_cuckoo_search_refuses_settings_outside_its_ranges(settings):
    settings = {"nests": 4, "iterations": 2, "pa": 0.25, "alpha": 0.3, "beta": 1.5, "refine_starts": 1} | settings
    message = ("Cuckoo Search needs nests >= 2, iterations >= 1, 0 <= pa <= 1, alpha > 0, 1 < beta <= 2 and "
               "1 <= refine_starts <= nests; got nests={nests}, iterations={iterations}, pa={pa}, alpha={alpha}, "
               "beta={beta}, refine_starts={refine_starts}").format(**settings)
    with pytest.raises(InputError, match="^" + re.escape(message) + "$"):
        cuckoo_search(_problem(), polish=False, **settings)


def test_an_unknown_variant_is_refused_by_name():
    with pytest.raises(InputError, match=r"^unknown Cuckoo Search variant 'fast'; known: improved, paper$"):
        cuckoo_search(_problem(), variant="fast")


def test_the_paper_variant_without_bounds_is_refused_with_what_to_give():
    with pytest.raises(InputError, match=r"^the plain paper variant of Cuckoo Search \(cuckoo-paper\) needs duration "
                                         r"bounds: give optimizer\.bounds_s$"):
        cuckoo_search(_problem(), variant="paper")


def test_progress_is_reported_once_per_iteration_with_the_best_so_far():
    calls = []
    result = cuckoo_search(_problem(), nests=4, iterations=5, polish=False,
                           progress=lambda *args: calls.append(args))
    assert [(done, total) for done, total, _ in calls] == [(k, 5) for k in range(1, 6)]
    assert [best for _, _, best in calls] == result.history


def _recording(monkeypatch):
    """Record the batches TimingProblem.evaluate (repaired) and evaluate_durations (raw) receive."""
    seen = {"evaluate": [], "evaluate_durations": []}
    for name in seen:
        original = getattr(TimingProblem, name)

        def recording(self, candidates, *args, _original=original, _name=name, **keywords):
            seen[_name].append(np.array(candidates, dtype=float, copy=True))
            return _original(self, candidates, *args, **keywords)

        monkeypatch.setattr(TimingProblem, name, recording)
    return seen


def test_the_paper_variant_scores_its_candidates_as_raw_durations(monkeypatch):
    """``paper``: candidates are durations, evaluated with a penalty (no repair), all inside the bounds."""
    problem = _problem(bounds=(0.5, 8.0))
    seen = _recording(monkeypatch)
    cuckoo_search(problem, variant="paper", nests=4, iterations=2)
    assert seen["evaluate"] == []
    batches = seen["evaluate_durations"]
    assert len(batches) == 1 + 2 * 2 + 1  # the first nests, two proposals per iteration, the final check
    assert all(batch.shape == (4, problem.segment_count) for batch in batches[:-1])
    candidates = np.concatenate(batches[:-1])
    assert np.all(candidates >= 0.5) and np.all(candidates <= 8.0)


def test_the_improved_variant_keeps_the_repaired_durations_in_its_nests(monkeypatch):
    """``improved`` is Lamarckian: a nest holds its repaired durations (in the search space), so the best
    nest, whose Levy step x + alpha L (x - x_best) N is zero, proposes exactly its repaired point."""
    problem = _problem()
    seen = _recording(monkeypatch)
    cuckoo_search(problem, nests=4, iterations=1, polish=False, seed=3)
    first, levy = seen["evaluate"][0], seen["evaluate"][1]
    monkeypatch.undo()
    repaired = problem.evaluate(first)
    best = int(np.argmin(repaired.objective))
    np.testing.assert_allclose(levy[best], problem.to_search_space(repaired.durations)[best], rtol=1e-12)
    assert not np.allclose(levy[best], first[best], rtol=1e-6)  # the raw shape was scaled and clipped


@pytest.mark.parametrize("variant, bounds", [("improved", None), ("improved", (0.2, 3.0)), ("paper", (0.2, 3.0))])
def test_every_candidate_is_clipped_to_the_search_box(monkeypatch, variant, bounds):
    """Levy flights and discovery moves are clipped to the search box ([SHAPE_FLOOR, 1] shapes without
    bounds, [h_min, h_max] durations with them) before they are evaluated."""
    problem = _problem(bounds=bounds)
    lower, upper = problem.search_box()
    seen = _recording(monkeypatch)
    cuckoo_search(problem, variant=variant, nests=6, iterations=40, alpha=1.0, seed=4, polish=False)
    batches = seen["evaluate"] if variant == "improved" else seen["evaluate_durations"][:-1]
    candidates = np.concatenate(batches)
    assert len(candidates) == 6 * (1 + 2 * 40)
    assert np.all(candidates >= lower) and np.all(candidates <= upper)
    assert np.any(candidates == upper) and np.any(candidates == lower)  # the moves did reach both sides


def test_the_nlp_starts_from_the_best_final_nests_in_order(monkeypatch):
    """``refine_starts`` = 2: the NLP starts from the two best nests, labelled ``nest 1`` (the best: it holds
    the best objective of the search, the last history entry before the refinement) and ``nest 2``."""
    import planner.timing.cuckoo as cuckoo_module

    problem = _problem()
    given = {}
    refine = cuckoo_module.nlp_refine

    def recording(problem, starts, tracker):
        given.update({label: np.array(start, copy=True) for label, start in starts.items()})
        return refine(problem, starts, tracker)

    monkeypatch.setattr(cuckoo_module, "nlp_refine", recording)
    result = cuckoo_search(problem, nests=6, iterations=4, refine_starts=2, seed=2)
    assert list(given) == ["nest 1", "nest 2"] and [start.label for start in result.starts] == ["nest 1", "nest 2"]
    first, second = problem.evaluate(np.array([given["nest 1"], given["nest 2"]])).objective
    assert first == pytest.approx(result.history[-1], rel=1e-12) and second >= first


def test_the_nlp_settings_are_recorded_for_the_starts_it_was_given():
    """With the polish, ``settings['nlp']`` is what the NLP ran with for ``refine_starts`` starts: a quintic
    problem of two segments solves its starts side by side, one process each."""
    from planner.timing.nlp import nlp_settings

    problem = TimingProblem(np.deg2rad(paper.VIA_POINTS_DEG)[:3], "quintic", paper.paper_limits())
    result = cuckoo_search(problem, nests=4, iterations=1, refine_starts=2)
    assert result.settings["nlp"] == nlp_settings(problem, 2) and result.settings["nlp"]["processes"] == 2
