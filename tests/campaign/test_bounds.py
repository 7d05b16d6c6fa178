"""The mass bounds: the batch Fisher information against the Riccati recursion of a filter kept on the truth."""

import dataclasses

import numpy as np
import pytest

from postcapture.studies.robust import bound_with_model_error, mass_bounds
from postcapture.studies.setup import plan_run


@pytest.fixture(scope="module")
def plan(envisat):
    return plan_run(envisat, profile="realistic", duration=45.0, cases=("joint",))


def test_two_independent_computations_of_the_bound_agree(plan):
    """Without model error, the posterior CRLB recursion (an AugmentedEKF reading noise-free measurements of
    its own model from the true values) equals the batch Fisher bound with the same unknowns and priors."""
    bounds = mass_bounds(dataclasses.replace(plan, tuning=dataclasses.replace(plan.tuning, model_noise=0.0)))
    recursion = bound_with_model_error(plan, 0.0)
    batch = bounds["parameters"]
    assert np.abs(recursion.mass - plan.nominal_mass).max() < 0.01  # the estimate never left the truth
    assert recursion.mass_sigma[-1] == pytest.approx(batch.all_sensors, rel=0.05)
    k = np.flatnonzero(np.isfinite(batch.history))
    np.testing.assert_allclose(recursion.mass_sigma[k[5:]], batch.history[k[5:]], rtol=0.08)
    # the known model bounds the mass far tighter than one whose other parameters are unknown
    assert bounds["known_model"].all_sensors < 0.2 * batch.all_sensors


def test_model_error_loosens_the_bound(plan):
    tight = bound_with_model_error(plan, 0.0).mass_sigma[-1]
    loose = bound_with_model_error(plan, 1e-10).mass_sigma[-1]
    assert loose > 2.0 * tight
