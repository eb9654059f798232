"""zonotope.correct.bvls.box_lsq and fiber_lsq: the batched bounded least squares against scipy's BVLS and
problems whose solution is known by construction (KKT conditions)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import lsq_linear

from zonotope._errors import GeometryError
from zonotope._tol import BVLS_CONDITION, BVLS_KKT
from zonotope.correct import correction_problem
from zonotope.correct.bvls import MAX_ITER, PDAS_STEPS, box_lsq
from zonotope.correct.prior import ReflectancePrior, fiber_lsq, interior_solution
from zonotope.spectra.atypical import atypical_reflectances

GRID = np.arange(400.0, 701.0, 10.0)  # 31 bands


def scipy_rows(M, R):
    """The reference: scipy's BVLS, one problem at a time (the solver fiber_lsq used before)."""
    Ms = np.broadcast_to(M, (len(R), *M.shape[-2:]))
    return np.array([np.clip(lsq_linear(m, r, bounds=(0, 1), method="bvls").x, 0, 1) for m, r in zip(Ms, R)])


def objective(M, R, X):
    res = np.einsum("...pi,...i->...p", M, X) - R
    return 0.5 * np.sum(res**2, axis=-1)


def kkt_violation(M, R, X):
    """Largest violation of the KKT conditions of min ‖Mx − r‖², 0 ≤ x ≤ 1, relative to |M|ᵀ(|M||x| + |r|)
    (computed here independently of the module), and the largest distance outside [0, 1]. An entry within
    1e-15 of a bound (scipy returns 5.6e-17 for a 0) may meet either its bound's or the free condition."""
    g = np.einsum("...pi,...p->...i", M, np.einsum("...pi,...i->...p", M, X) - R)
    A = np.abs(M)
    scale = np.einsum("...pi,...p->...i", A, np.einsum("...pi,...i->...p", A, np.abs(X)) + np.abs(R))
    v = np.abs(g)
    v = np.where(X <= 1e-15, np.minimum(v, np.maximum(-g, 0)), v)
    v = np.where(X >= 1 - 1e-15, np.minimum(v, np.maximum(g, 0)), v)
    outside = np.maximum(-X, 0) + np.maximum(X - 1, 0)
    return np.max(v / np.maximum(scale, 1e-300), axis=-1), np.max(outside, axis=-1)


def known_solution(rng, M, N, n_lower, n_upper, near=0, size=1.0):
    """Responses ``r`` whose bounded minimiser is a chosen ``x*``: ``n_lower`` entries at 0 with
    multiplier ``g > 0``, ``n_upper`` at 1 with ``g < 0``, the others inside with ``g = 0`` (``near`` of
    them within 1e-7 of a bound; multipliers of magnitude ``size``): ``r = M x* − M (MᵀM)⁻¹ g`` gives
    ``Mᵀ(M x* − r) = g`` (KKT, and unique for full-rank M)."""
    n = M.shape[1]
    X = rng.uniform(0.05, 0.95, (N, n))
    G = np.zeros((N, n))
    for i in range(N):
        idx = rng.permutation(n)
        lo, up = idx[:n_lower], idx[n_lower : n_lower + n_upper]
        close = idx[n_lower + n_upper : n_lower + n_upper + near]
        X[i, lo], X[i, up] = 0.0, 1.0
        X[i, close] = np.where(rng.random(close.size) < 0.5, 1e-7, 1 - 1e-7)
        G[i, lo] = size * rng.uniform(0.1, 2.0, n_lower)
        G[i, up] = -size * rng.uniform(0.1, 2.0, n_upper)
    W = np.linalg.solve(M.T @ M, G.T).T @ M.T
    return X, X @ M.T - W


@pytest.fixture(scope="module")
def real():
    """A Prior MAP as the splat pipeline's correct step poses it: three cameras' 9 channels, whitened by
    per-channel noise (σ_ref = 0.005), the SHARED objective U = prior.root, b = U μ, and responses of
    natural and atypical reflectances plus noise that the closed form does NOT cover."""
    grid = np.arange(400.0, 681.0, 10.0)  # the Sigma's measured range
    cams = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]
    problem = correction_problem(cams, shape=grid, training="rawtoaces 190")
    rng = np.random.default_rng(5)
    sigma = rng.uniform(0.0025, 0.01, problem.k)
    ref = float(np.median(sigma))
    Phi = problem.Phi * (ref / sigma)
    prior = ReflectancePrior.fit(problem.training)
    aty, _ = atypical_reflectances(grid, 150, seed=4)
    X = np.vstack([problem.training, np.clip(aty, 0, 1)])
    X = X[rng.integers(0, len(X), 3000)] * rng.uniform(0.2, 1.0, (3000, 1))
    C = X @ Phi + rng.normal(0.0, ref, (3000, problem.k))
    _, interior = interior_solution(prior, Phi, C, noise=ref)
    C = C[~interior][:150]
    U = prior.root
    M = np.vstack([U, Phi.T / ref])
    R = np.hstack([np.broadcast_to(U @ prior.mean, (len(C), U.shape[0])), C / ref])
    return {"Phi": Phi, "C": C, "prior": prior, "noise": ref, "M": M, "R": R}


# -- against scipy's BVLS, row by row -------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(3))
def test_shared_matrix_matches_scipy_rows(seed):
    """Random tall M (40 × 31), responses spread so that each row has some variables at 0 or 1."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((40, 31))
    R = (rng.uniform(-0.5, 1.5, (60, 31))) @ M.T + 0.3 * rng.standard_normal((60, 40))
    x, fallback = box_lsq(M, R)
    ref = scipy_rows(M, R)
    on_bounds = np.sum((ref <= 0) | (ref >= 1), axis=1)
    assert on_bounds.min() >= 1 and np.any(np.sum(ref >= 1, axis=1) >= 1)  # both bounds are exercised
    np.testing.assert_allclose(x, ref, atol=1e-9, rtol=0)
    assert np.all(kkt_violation(M, R, x)[0] <= 1e-12)
    assert not fallback.all()  # the batched method, not only the fallback, produced these


def test_per_row_matrices_match_scipy_rows():
    rng = np.random.default_rng(7)
    M = rng.standard_normal((25, 35, 31))
    R = np.einsum("npi,ni->np", M, rng.uniform(-0.5, 1.5, (25, 31))) + 0.3 * rng.standard_normal((25, 35))
    x, fallback = box_lsq(M, R)
    np.testing.assert_allclose(x, scipy_rows(M, R), atol=1e-9, rtol=0)
    assert not fallback.all()


def test_real_prior_map_matches_scipy_and_is_batched(real):
    """The splat correct step's problem: every row is settled by the batched method (no fallback) and
    agrees with scipy's per-row BVLS to 1e-9 in reflectance; fiber_lsq returns the same."""
    M, R = real["M"], real["R"]
    assert len(R) >= 100
    x, fallback = box_lsq(M, R)
    assert not fallback.any()
    ref = scipy_rows(M, R)
    assert np.mean(np.sum((ref <= 0) | (ref >= 1), axis=1)) >= 2  # real bounds are active
    np.testing.assert_allclose(x, ref, atol=1e-9, rtol=0)
    prior = real["prior"]
    xf = fiber_lsq(real["Phi"], real["C"], prior.root, prior.root @ prior.mean, noise=real["noise"])
    np.testing.assert_allclose(xf, ref, atol=1e-9, rtol=0)


def test_fiber_lsq_per_row_objective_matches_scipy(real):
    """fiber_lsq with one objective block per response (as project_to_mmv calls it), noisy and exact."""
    prior, Phi, C = real["prior"], real["Phi"], real["C"][:12]
    rng = np.random.default_rng(3)
    A = prior.root * rng.uniform(0.5, 2.0, (len(C), 1, 1))
    b = np.einsum("nij,j->ni", A, prior.mean)
    for noise in (real["noise"], 0.0):
        x = fiber_lsq(Phi, C, A, b, noise=noise)
        s = (
            np.full(len(C), 1 / noise)
            if noise
            else 1e5 * np.linalg.norm(A, 2, axis=(1, 2)) / np.linalg.norm(Phi, 2)
        )
        M = np.concatenate([A, s[:, None, None] * Phi.T], axis=1)
        R = np.hstack([b, s[:, None] * C])
        np.testing.assert_allclose(x, scipy_rows(M, R), atol=1e-9, rtol=0)


# -- solutions known by construction (hypothesis) -------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 31),
    extra=st.integers(0, 12),
    frac_lower=st.floats(0, 1),
    frac_upper=st.floats(0, 1),
    near=st.integers(0, 3),
)
def test_known_kkt_solution_is_returned(seed, n, extra, frac_lower, frac_upper, near):
    """Problems built with a chosen minimiser (entries at 0, at 1, inside and just inside a bound;
    strictly complementary multipliers): it is returned, and the KKT conditions hold."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((n + extra, n)) + 2.0 * np.eye(n + extra, n)  # full column rank
    n_lower = int(frac_lower * n)
    n_upper = int(frac_upper * (n - n_lower))
    X, R = known_solution(rng, M, 8, n_lower, n_upper, near=min(near, n - n_lower - n_upper))
    x, _ = box_lsq(M, R)
    np.testing.assert_allclose(x, X, atol=1e-9, rtol=0)
    viol, outside = kkt_violation(M, R, x)
    assert np.all(outside == 0) and np.all(viol <= 1e-12)


@pytest.mark.parametrize("noise", [1e-4, 3e-6])
def test_ill_conditioned_but_accepted_problem_is_refined(real, noise):
    """The real problem with a small σ: cond(MᵀM) ≈ 4e5 and 4e8, below :data:`BVLS_CONDITION` (1e9). One
    solve of the normal equations errs by up to ≈ cond·ε; the steps are repeated until the free
    gradient vanishes (iterative refinement), so the answer is scipy's within 1e-9 — and it comes from
    the batched method (at most a few rows fall back; at σ = 3e-6, where the responses lie thousands of
    σ outside the solid, most of them from the primal phase)."""
    prior, Phi, C = real["prior"], real["Phi"], real["C"][:60]
    M = np.vstack([prior.root, Phi.T / noise])
    R = np.hstack([np.broadcast_to(prior.root @ prior.mean, (len(C), Phi.shape[0])), C / noise])
    ev = np.linalg.eigvalsh(M.T @ M)
    assert 1e5 < ev[-1] / ev[0] < BVLS_CONDITION
    x, fallback = box_lsq(M, R)
    assert fallback.sum() <= 3
    np.testing.assert_allclose(x, scipy_rows(M, R), atol=1e-9, rtol=0)
    assert np.all(kkt_violation(M, R, x)[0][~fallback] <= BVLS_KKT)  # as documented
    if noise < 1e-5:  # responses ≫ σ outside the solid: the first phase alone leaves most rows
        assert box_lsq(M, R, max_iter=PDAS_STEPS)[1].sum() > len(R) / 2


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 31), extra=st.integers(0, 12))
def test_interior_unconstrained_solution_is_returned_unchanged(seed, n, extra):
    """r = M x with x inside (0, 1)ⁿ: the unconstrained minimiser is feasible, hence the answer."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((n + extra, n)) + 2.0 * np.eye(n + extra, n)
    X = rng.uniform(0.01, 0.99, (6, n))
    x, fallback = box_lsq(M, X @ M.T)
    assert not fallback.any()
    np.testing.assert_allclose(x, X, atol=1e-12, rtol=0)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), noise=st.floats(0.001, 0.05), push=st.floats(0.0, 0.5))
def test_noisy_responses_outside_the_solid_are_feasible_and_optimal(real, seed, noise, push):
    """Responses pushed outside the object-colour solid (no reflectance makes them) with noise σ: the
    answer is in [0, 1], meets the KKT conditions and is at least as good as scipy's."""
    rng = np.random.default_rng(seed)
    prior, Phi = real["prior"], real["Phi"]
    C = real["C"][rng.integers(0, len(real["C"]), 6)]
    C = C * (1 + push) + push * rng.standard_normal(C.shape)
    x = fiber_lsq(Phi, C, prior.root, prior.root @ prior.mean, noise=noise)
    M = np.vstack([prior.root, Phi.T / noise])
    R = np.hstack([np.broadcast_to(prior.root @ prior.mean, (6, Phi.shape[0])), C / noise])
    viol, outside = kkt_violation(M, R, x)
    assert np.all(outside == 0) and np.all(viol <= 1e-12)
    assert np.all(objective(M, R, x) <= objective(M, R, scipy_rows(M, R)) * (1 + 1e-12))


@pytest.mark.parametrize("kind", ["wide", "zero column", "repeated column"])
def test_rank_deficient_matrix_goes_to_scipy_and_is_optimal(kind):
    """MᵀM singular (the minimiser is not unique): every row is solved by scipy's BVLS, and the answer
    is a minimiser (KKT) with scipy's objective value."""
    rng = np.random.default_rng(11)
    M = rng.standard_normal((20, 12))
    if kind == "wide":
        M = M[:8]
    elif kind == "zero column":
        M[:, 3] = 0.0
    else:
        M[:, 5] = M[:, 2]
    R = rng.uniform(-0.5, 1.5, (10, 12)) @ M.T
    x, fallback = box_lsq(M, R)
    assert fallback.all()
    np.testing.assert_allclose(objective(M, R, x), objective(M, R, scipy_rows(M, R)), rtol=1e-10, atol=1e-12)
    assert np.all(kkt_violation(M, R, x)[0] <= 1e-10)


def test_exact_constraint_form_goes_to_scipy(real, monkeypatch):
    """noise = 0 (constraint rows of weight 1e5, cond(MᵀM) ≈ 1e11): too ill-conditioned for box_lsq's
    normal equations, which hands every row to scipy; fiber_lsq solves them with fiber_box_lsq and
    agrees with scipy's per-row answer to round-off, and its reference twin (``_STIFF_SOLVER`` off) is
    scipy's answer exactly, as before."""
    import zonotope.correct.prior as prior_module

    prior, Phi, C = real["prior"], real["Phi"], real["C"][:8] * 0.8
    U = prior.root
    s = 1e5 * np.linalg.norm(U, 2) / np.linalg.norm(Phi, 2)
    M = np.vstack([U, s * Phi.T])
    R = np.hstack([np.broadcast_to(U @ prior.mean, (len(C), U.shape[0])), s * C])
    _, fallback = box_lsq(M, R)
    assert fallback.all()
    ref = scipy_rows(M, R)
    np.testing.assert_allclose(fiber_lsq(Phi, C, U, U @ prior.mean), ref, atol=1e-9, rtol=0)
    monkeypatch.setattr(prior_module, "_STIFF_SOLVER", False)
    np.testing.assert_array_equal(fiber_lsq(Phi, C, U, U @ prior.mean), ref)


# -- the fallback path ----------------------------------------------------------------------------------


def test_iteration_cap_zero_and_one_fall_back_to_scipy(real):
    M, R = real["M"], real["R"][:40]
    ref = scipy_rows(M, R)
    x0, fb0 = box_lsq(M, R, max_iter=0)
    assert fb0.all()
    np.testing.assert_array_equal(x0, ref)  # scipy's own answer, bit for bit
    x1, fb1 = box_lsq(M, R, max_iter=1)
    assert 0 < fb1.sum() < len(R)  # one step settles the rows whose warm start had the right sets
    np.testing.assert_allclose(x1, ref, atol=1e-9, rtol=0)


def test_cycling_row_is_solved_by_the_primal_phase_or_falls_back():
    """A 3-variable problem on which the primal–dual active-set iteration cycles with period 3 (its
    sets go {x₂, x₃ at 1} → {x₃ at 1} → {x₁, x₂ at 0; x₃ at 1} → {x₁ at 0} → {x₃ at 1} → ..., never the
    solution's {x₁ at 0, x₃ at 1}): the monotone primal phase solves it; with no primal steps left
    (``max_iter = PDAS_STEPS``) it falls back to scipy. The other row is settled by the first phase."""
    M = np.array([[2.5, -3.5, 0.5], [0.0, -1.0, 1.5], [2.0, -2.5, 0.5]])
    cycling = np.array([-2.0, 2.5, -1.0])
    R = np.vstack([cycling, np.array([0.3, 0.2, 0.4]) @ M.T])
    for cap, fell_back in ((MAX_ITER, False), (PDAS_STEPS, True)):
        x, fallback = box_lsq(M, R, max_iter=cap)
        assert fallback.tolist() == [fell_back, False]
        np.testing.assert_allclose(x[0], [0.0, 23 / 39, 1.0], atol=1e-12)  # scipy's: x₂ = 0.58974...
        np.testing.assert_allclose(x[1], [0.3, 0.2, 0.4], atol=1e-12)
    assert np.all(kkt_violation(M, R, x)[0] <= 1e-12)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12))
def test_primal_phase_alone_matches_scipy(seed, n):
    """Random square M (far from an M-matrix: the first phase often cycles) and responses well outside
    the box: the primal phase settles the rows the first leaves (7 % of them: 29 of 390 rows over 40
    seeds), so none falls back; each answer meets the KKT conditions and is at least as good as scipy's.
    (Not "equal to scipy's": on seed=311112474, n=6 scipy's BVLS stops at a point 0.2 % worse, KKT
    violated by 1.6e-3, where ours agrees with scipy's TRF.)"""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((n, n)) @ np.diag(rng.uniform(0.05, 1.0, n)) @ rng.standard_normal((n, n))
    ev = np.linalg.eigvalsh(M.T @ M)
    assume(ev[0] * BVLS_CONDITION > ev[-1])  # else scipy's by design (see the rank-deficient test)
    R = rng.uniform(-1.0, 2.0, (10, n)) @ M.T + rng.standard_normal((10, n))
    x, fallback = box_lsq(M, R)
    assert not fallback.any()
    assert np.all(kkt_violation(M, R, x)[0] <= 1e-12)  # M is regular: the unique minimiser
    assert np.all(objective(M, R, x) <= objective(M, R, scipy_rows(M, R)) * (1 + 1e-12))


# -- bad input ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("M", "r", "match"),
    [
        (np.ones((4, 3)), np.ones((2, 5)), r"same p"),
        (np.ones((2, 4, 3)), np.ones((3, 4)), r"same p \(and N\)"),
        (np.ones(4), np.ones((2, 4)), r"M must be \(p, n\)"),
        (np.ones((4, 3)), np.ones(4), r"r \(N, p\)"),
        (np.full((4, 3), np.nan), np.ones((2, 4)), r"NaN or inf"),
        (np.ones((4, 3)), [["a", "b", "c", "d"]], r"r: expected an array of numbers"),
    ],
)
def test_bad_shapes_and_values_are_geometry_errors(M, r, match):
    with pytest.raises(GeometryError, match=match):
        box_lsq(M, r)


def test_fiber_lsq_mismatched_shapes_are_geometry_errors(real):
    prior, Phi = real["prior"], real["Phi"]
    with pytest.raises(GeometryError, match=r"one response column per column of Phi"):
        fiber_lsq(Phi, np.ones((2, Phi.shape[1] + 1)), prior.root, prior.root @ prior.mean, noise=0.01)
    with pytest.raises(GeometryError, match=r"one A column per wavelength"):
        fiber_lsq(Phi, np.ones((2, Phi.shape[1])), prior.root[:, 1:], prior.root @ prior.mean, noise=0.01)


@pytest.mark.parametrize("cap", [-1, 2.5])
def test_bad_iteration_cap_is_a_geometry_error(cap):
    with pytest.raises(GeometryError, match=r"max_iter"):
        box_lsq(np.eye(3), np.ones((1, 3)), max_iter=cap)


def test_empty_batch():
    x, fallback = box_lsq(np.eye(3), np.zeros((0, 3)))
    assert x.shape == (0, 3) and fallback.shape == (0,)
