"""The fused correction's uncertainty map (``splat.capture.correct.fused_uncertainty``): the rendered
channels told the render's local error (``rendered=``) against :func:`zonotope.correct.posterior_radius`
with those σ by hand; the other channels and the pixels where the render is as good as its σ keep
their radius."""

from __future__ import annotations

import numpy as np
import pytest

import zonotope
from splat.capture.correct import fused_uncertainty
from zonotope.correct import ReflectancePrior, posterior_radius


@pytest.fixture(scope="module")
def problem():
    return zonotope.correction_problem(["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"], target="CIE 1931 2°")


def test_the_render_channels_take_the_local_error_in_half_octaves(problem):
    rs, own = 0.03, 0.005
    sigma = {0: np.full(6, rs), 1: np.array([own, own, own, rs, rs, rs])}  # render alone; own + render
    code = np.array([[0, 0, 1, 1], [0, 1, 1, 0]])
    rng = np.random.default_rng(0)
    XYZ = problem.target_of(rng.uniform(0.1, 0.8, (8, problem.Phi.shape[0])))[:, :3].reshape(2, 4, 3)
    prior = ReflectancePrior.fit(problem.training)
    plain = fused_uncertainty(problem, XYZ, code, sigma, prior=prior)
    local = np.array([[0.0, 4 * rs, 0.5 * rs, 4 * rs], [rs, 4.2 * rs, np.nan, 1e9]])
    told = fused_uncertainty(problem, XYZ, code, sigma, prior=prior, rendered=(rs, local))
    same = np.array([[True, False, True, False], [True, False, True, False]])  # local ≤ σ (or unknown)
    np.testing.assert_array_equal(told[same], plain[same])
    for y, x, s_render in ((0, 1, 4 * rs), (0, 3, 4 * rs), (1, 1, 4 * rs), (1, 3, 2**10 * rs)):
        s_ = np.where(sigma[code[y, x]] == rs, s_render, sigma[code[y, x]])  # 4.2 σ rounds to 4 σ
        want = posterior_radius(problem, XYZ[y, x][None], s_, prior=prior)[0]
        assert told[y, x] == pytest.approx(want, rel=1e-5) and told[y, x] > plain[y, x]
