"""zonotope.correct.bvls.fiber_box_lsq, the exact-constraint bounded least squares of Prior's MAP,
against scipy's per-row BVLS of the stacked rows and against exact rational arithmetic."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

from zonotope._errors import GeometryError
from zonotope.correct import correction_problem
from zonotope.correct.bvls import fiber_box_lsq
from zonotope.correct.prior import ReflectancePrior, interior_solution


@pytest.fixture(scope="module")
def nikon():
    pb = correction_problem("Nikon 5100 (NPL)", target="CIE 1931 2°", shape=np.arange(400.0, 701.0, 10.0))
    prior = ReflectancePrior.fit(pb.training)
    return pb.Phi, prior


def stacked(A, b, Phi, C, w):
    """The problem as fiber_lsq posed it before: rows [A; w Φᵀ], right-hand side [b; w c]."""
    N = len(C)
    A = np.broadcast_to(A, (N, *np.shape(A)[-2:]))
    w = np.broadcast_to(w, (N,))
    M = np.concatenate([A, w[:, None, None] * Phi.T], axis=1)
    return M, np.hstack([b, w[:, None] * C])


def scipy_rows(M, R):
    return np.array([np.clip(lsq_linear(m, r, bounds=(0, 1), method="bvls").x, 0, 1) for m, r in zip(M, R)])


def objective(M, R, X):
    return 0.5 * np.sum((np.einsum("npi,ni->np", M, X) - R) ** 2, axis=1)


def responses(Phi, prior, rng, N, top):
    """Responses the closed form does not cover: inside the solid and (top > 1) outside it."""
    C = rng.uniform(0.0, top, (4 * N, Phi.shape[1]))
    _, interior = interior_solution(prior, Phi, C)
    return C[~interior][:N]


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), top=st.floats(0.3, 1.8), per_row=st.booleans())
def test_matches_scipy_on_the_stacked_rows(nikon, seed, top, per_row):
    """The exact-constraint MAP (weight 1e5 relative, as fiber_lsq sets it), one objective for all rows or
    one per row: the same reflectances as scipy's BVLS (1e-9) and never a worse objective."""
    Phi, prior = nikon
    rng = np.random.default_rng(seed)
    C = responses(Phi, prior, rng, 24, top)
    U = prior.root
    A = U * rng.uniform(0.5, 2.0, (len(C), 1, 1)) if per_row else U
    b = np.einsum("...ij,j->...i", np.broadcast_to(A, (len(C), *U.shape)), prior.mean)
    w = 1e5 * np.linalg.norm(A, 2, axis=(-2, -1)) / np.linalg.norm(Phi, 2)
    x, fallback = fiber_box_lsq(A, b, Phi, C, w)
    M, R = stacked(A, b, Phi, C, w)
    ref = scipy_rows(M, R)
    assert not fallback.any()
    np.testing.assert_allclose(x, ref, atol=1e-9, rtol=0)
    assert np.all(objective(M, R, x) <= objective(M, R, ref) * (1 + 1e-12))


def exact_free_minimiser(M, r, free, x):
    """The minimiser over the free variables of ``x`` (others held), by Gaussian elimination in exact
    rational arithmetic on the normal equations."""
    fixed = np.where(free, 0.0, x)
    rhs = r - M @ fixed
    cols = np.flatnonzero(free)
    Mf = [[Fraction(float(v)) for v in row[cols]] for row in M]
    rf = [Fraction(float(v)) for v in rhs]
    m = len(cols)
    H = [
        [sum(row[i] * row[j] for row in Mf) for j in range(m)] + [sum(row[i] * v for row, v in zip(Mf, rf))]
        for i in range(m)
    ]
    for c in range(m):
        p = max(range(c, m), key=lambda i: abs(H[i][c]))
        H[c], H[p] = H[p], H[c]
        for i in range(c + 1, m):
            f = H[i][c] / H[c][c]
            H[i] = [a - f * b for a, b in zip(H[i], H[c])]
    z = [Fraction(0)] * m
    for c in reversed(range(m)):
        z[c] = (H[c][m] - sum(H[c][j] * z[j] for j in range(c + 1, m))) / H[c][c]
    out = x.copy()
    out[cols] = [float(v) for v in z]
    return out


def test_free_variables_are_exact_where_few_are_free():
    """Three stacked cameras (9 constraint rows) and random responses, far outside their joint solid:
    fewer free variables than constraint rows, where the λ system alone is good to 1e-7 only. The
    returned free variables equal the exact rational minimiser on the returned active set to 1e-13."""
    cams = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]
    pb = correction_problem(cams, shape=np.arange(400.0, 681.0, 10.0))
    prior = ReflectancePrior.fit(pb.training)
    rng = np.random.default_rng(2)
    C = rng.uniform(0.0, 1.2, (3, 9))  # nine channels no one reflectance gives
    U = prior.root
    w = 1e5 * np.linalg.norm(U, 2) / np.linalg.norm(pb.Phi, 2)
    b = np.broadcast_to(U @ prior.mean, (len(C), U.shape[0]))
    x, fallback = fiber_box_lsq(U, b, pb.Phi, C, w)
    assert not fallback.any()
    M, R = stacked(U, b, pb.Phi, C, w)
    for i in range(len(C)):
        free = (x[i] > 0) & (x[i] < 1)
        assert free.sum() < pb.k  # the hard case
        np.testing.assert_allclose(x[i], exact_free_minimiser(M[i], R[i], free, x[i]), atol=1e-13, rtol=0)


def test_iteration_cap_zero_is_scipy_and_bad_input_is_refused(nikon):
    Phi, prior = nikon
    C = responses(Phi, prior, np.random.default_rng(1), 5, 1.5)
    U = prior.root
    b = np.broadcast_to(U @ prior.mean, (len(C), U.shape[0]))
    x, fallback = fiber_box_lsq(U, b, Phi, C, 1e3, max_iter=0)
    assert fallback.all()
    M, R = stacked(U, b, Phi, C, 1e3)
    np.testing.assert_array_equal(x, scipy_rows(M, R))
    for bad in (
        dict(F=Phi[:5]),
        dict(c=C[:, :2]),
        dict(weight=0.0),
        dict(weight=np.ones(len(C) + 1)),
        dict(b=np.full_like(b, np.nan)),
    ):
        args = dict(A=U, b=b, F=Phi, c=C, weight=1e3) | bad
        with pytest.raises(GeometryError, match="fiber_box_lsq"):
            fiber_box_lsq(**args)
    with pytest.raises(GeometryError, match="max_iter"):
        fiber_box_lsq(U, b, Phi, C, 1e3, max_iter=-1)
