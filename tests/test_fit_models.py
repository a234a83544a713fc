"""fitting.fit_models: several models on one measurement, one after the other or two at once."""

import pytest

import fitting.fit
from fitting.fit import FitError, ModelCut, fit, prepare, warm_start
from fitting.fit_models import fit_models
from fitting.ranking import best_ranking_error
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
# a model, one that cannot win on a diffuse material (cut), one that starts from the first (+ms)
MODELS = ["ggx+lambert", "ggx", "ggx+lambert+ms"]


@pytest.fixture(scope="module")
def measured():
    return synthetic_measured("ggx+lambert", TRUTH, grid=(24, 24, 48, 1), noise=0.03, seed=5)


def _same(a, b):
    if isinstance(a, ModelCut):
        return isinstance(b, ModelCut) and (a.model, a.coarse_m1, a.bound) == (b.model, b.coarse_m1, b.bound)
    return (a.spec, a.parameters, a.errors) == (b.spec, b.parameters, b.errors)


def test_two_threads_give_the_fits_of_one_after_the_other(measured):
    """threads=1 is the loop the commands ran before (each fit warm-started from the
    results before it, cut against their best), and threads=2 gives its outcomes
    bit for bit, in order; ``known`` results are yielded as they are and read as fitted."""
    data = prepare(measured, samples=20_000)
    by_hand = []
    for model in MODELS:
        fitted = [r for r in by_hand if not isinstance(r, ModelCut)]
        try:
            by_hand.append(fit(measured, model, data=data, loss="hybrid", warm=warm_start(model, fitted),
                               cut_above=best_ranking_error(fitted)))
        except ModelCut as cut:
            by_hand.append(cut)
    assert isinstance(by_hand[1], ModelCut) and by_hand[2].optimizer["starts"] == 1    # cut, warm-started
    for threads in (1, 2):
        outcomes = list(fit_models(measured, MODELS, cut=True, threads=threads, data=data, loss="hybrid"))
        assert [model for model, _ in outcomes] == MODELS
        assert all(_same(a, b) for a, (_, b) in zip(by_hand, outcomes))
    known = {"ggx+lambert": by_hand[0]}
    outcomes = dict(fit_models(measured, MODELS, cut=True, threads=2, known=known, data=data, loss="hybrid"))
    assert outcomes["ggx+lambert"] is by_hand[0]
    assert _same(outcomes["ggx"], by_hand[1]) and _same(outcomes["ggx+lambert+ms"], by_hand[2])


def test_a_failing_fit_is_its_outcome_and_the_others_go_on(measured, monkeypatch):
    real = fitting.fit.fit

    def failing(measured, model, **options):
        if model == "ggx+burley":
            raise FitError("this fit fails")
        return real(measured, model, **options)
    monkeypatch.setattr(fitting.fit, "fit", failing)
    outcomes = dict(fit_models(measured, ["ggx+burley", "ggx+lambert"], threads=2, samples=5_000, starts=1))
    assert isinstance(outcomes["ggx+burley"], FitError)
    assert outcomes["ggx+lambert"].spec == "ggx+lambert"


def test_samples_that_cannot_be_prepared_fail_every_model_to_fit(measured):
    outcomes = list(fit_models(measured, MODELS, max_theta=0.5))
    assert [model for model, _ in outcomes] == MODELS
    assert all(isinstance(o, FitError) and "no valid samples" in str(o) for _, o in outcomes)
