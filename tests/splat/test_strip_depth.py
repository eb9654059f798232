"""The full-resolution stage's cheaper arithmetic: the CPU rasteriser's forward pass (the depth rendered
per strip) and the stage's float32 responses.

Independent truths: the forward kernel as it was before its per-column and per-row terms were hoisted
(``_forward_previous`` below, compiled the same way: it must give the very same numbers); the float64
upsampling (float32 must be its rounding); the stage with float64 responses (float32 responses must give
the same XYZ within :data:`splat._tol.FULL_FLOAT32_RTOL`).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from splat import _raster_kernel as kern
from splat._tol import FULL_FLOAT32_RTOL
from splat.rendering import _host_bins
from splat.strips import FullReprojection, Photograph, WorkingFusion, full_resolution_view, upsample_rows

from .test_strips_fullres import _SIZE, _Source, splat_scene  # noqa: F401  (the fixture)


@njit(cache=True)
def _forward_previous(
    means2d, conics, opac, colours, extents, offsets, ids, H, W, s, cut2, alpha_min, alpha_max, tmin, chunk
):
    """``splat._raster_kernel.forward`` as it was, every pixel's ``q`` from scratch; its tiles one after
    the other (``range`` for ``prange``: each tile's pixels depend on that tile alone, and a serial
    kernel compiles in a fraction of the time)."""
    k = colours.shape[1]
    nx = (W + s - 1) // s
    nt = offsets.shape[0] - 1
    C = np.zeros((H, W, k), colours.dtype)
    T = np.ones((H, W), colours.dtype)
    n_done = np.zeros((H, W), np.int32)
    for t in range(nt):
        ty, tx = t // nx, t % nx
        x0, y0 = tx * s, ty * s
        lo, hi = offsets[t], offsets[t + 1]
        Tl = np.ones((s, s))
        Cl = np.zeros((s, s, k))
        nd = np.full((s, s), hi - lo, np.int32)
        live = np.zeros((s, s), np.bool_)
        live[: min(s, H - y0), : min(s, W - x0)] = True
        n_live = min(s, H - y0) * min(s, W - x0)
        for r in range(lo, hi):
            if tmin > 0 and (r - lo) % chunk == 0:
                for oy in range(s):
                    for ox in range(s):
                        if live[oy, ox] and Tl[oy, ox] <= tmin:
                            live[oy, ox] = False
                            nd[oy, ox] = r - lo
                            n_live -= 1
                if n_live == 0:
                    break
            g = ids[r]
            ox0, ox1, oy0, oy1 = kern._box(g, means2d, extents, x0, y0, s, W, H)
            for oy in range(oy0, oy1 + 1):
                py = np.float32(y0 + oy) + np.float32(0.5)
                for ox in range(ox0, ox1 + 1):
                    if not live[oy, ox]:
                        continue
                    px = np.float32(x0 + ox) + np.float32(0.5)
                    alpha, _, _, _, _ = kern._alpha(
                        px, py, g, means2d, conics, opac, cut2, alpha_min, alpha_max
                    )
                    if alpha == 0:
                        continue
                    w = alpha * Tl[oy, ox]
                    for j in range(k):
                        Cl[oy, ox, j] += colours[g, j] * w
                    Tl[oy, ox] *= 1 - alpha
        for oy in range(min(s, H - y0)):
            for ox in range(min(s, W - x0)):
                T[y0 + oy, x0 + ox] = Tl[oy, ox]
                n_done[y0 + oy, x0 + ox] = nd[oy, ox]
                for j in range(k):
                    C[y0 + oy, x0 + ox, j] = Cl[oy, ox, j]
    return C, T, n_done


def _scene(seed: int, G: int, H: int, W: int, k: int, dtype):
    """Random projected Gaussians binned as the CPU back-end bins them: the kernel's arguments."""
    rng = np.random.default_rng(seed)
    means2d = np.stack([rng.uniform(-10, W + 10, G), rng.uniform(-10, H + 10, G)], 1)
    sx, sy = rng.uniform(0.5, 12, G), rng.uniform(0.5, 12, G)
    rho = rng.uniform(-0.95, 0.95, G)
    a, b, c = sx**2, rho * sx * sy, sy**2
    det = a * c - b * b
    conics = np.stack([c / det, -b / det, a / det], 1)
    extents = 3.0 * np.sqrt(np.stack([a, c], 1))
    opac = rng.uniform(0.0, 1.0, G)
    colours = rng.uniform(0, 2, (G, k))
    aux = np.concatenate([extents, rng.uniform(1, 5, (G, 1)), (rng.random((G, 1)) < 0.9)], 1)
    means2d, conics, opac, colours, aux = (
        np.ascontiguousarray(x, dtype) for x in (means2d, conics, opac, colours, aux)
    )
    ext, offsets, ids, _ = _host_bins(means2d, aux, H, W, 16)
    return means2d, conics, opac, colours, ext, offsets, ids, H, W, 16


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    G=st.integers(1, 60),
    H=st.integers(1, 45),
    W=st.integers(1, 45),
    k=st.integers(1, 3),
    f64=st.booleans(),
    tmin=st.sampled_from([0.0, 1e-4, 0.2]),
)
def test_forward_equals_the_previous_kernel_bit_for_bit(seed, G, H, W, k, f64, tmin):
    """The hoisted kernel composites in the same order with the same operations and types: colours,
    transmittance and the entries each pixel went through are identical, also with termination."""
    dtype = np.float64 if f64 else np.float32
    args = _scene(seed, G, H, W, k, dtype)
    cuts = tuple(np.float32(v) for v in (9.0, 1.0 / 255.0, 0.99))
    new = kern.forward(*args, *cuts, np.float32(tmin), 4)
    old = _forward_previous(*args, *cuts, np.float32(tmin), 4)
    for x, y in zip(new, old, strict=True):
        assert x.dtype == y.dtype
        np.testing.assert_array_equal(x, y)
    assert (old[1] < 1).any() or G < 3  # something was drawn


@pytest.mark.parametrize("f", [2, 3])
def test_upsample_rows_float32_is_the_float64_rounded(f):
    """float32 in, float32 out: the float64 upsampling to float32 rounding; float64 unchanged."""
    rng = np.random.default_rng(f)
    img = rng.uniform(0, 1, (7, 9, 4))
    want = upsample_rows(img, f, 3, 17, 25)
    got = upsample_rows(img.astype(np.float32), f, 3, 17, 25)
    assert want.dtype == np.float64 and got.dtype == np.float32
    np.testing.assert_allclose(got, want, rtol=4 * np.finfo(np.float32).eps, atol=1e-7)


def test_full_resolution_view_float32_responses_match_float64(splat_scene, monkeypatch):  # noqa: F811
    """The stage's responses in float32 (the upsampled working fusion no longer widened to float64, so
    the root-polynomial regression and its white-point offset run on float32 responses): XYZ within
    FULL_FLOAT32_RTOL of the same stage on float64 responses, with the estimator the stage fits."""
    import splat.strips as strips
    from zonotope.correct import correction_problem, fit_correction

    problem = correction_problem(["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"])
    corrector = fit_correction(problem, method="Finlayson 2015", noise=0.01, white_point=True)
    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    rng = np.random.default_rng(5)
    X = np.clip(
        rng.dirichlet(np.full(len(problem.training), 0.05), (H // f) * (W // f)) @ problem.training, 0, 1
    )
    fused = problem.source_of(X).reshape(H // f, W // f, 9) * rng.uniform(0.05, 1, (H // f, W // f, 1))
    code = np.zeros((H // f, W // f), int)
    work = WorkingFusion(fused, code, {0: np.full(9, 0.01)}, slice(0, 3), f)
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.02))

    def fit(_):
        return corrector, np.ones(9)

    def run():
        return np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=8, reprojection=rep)))

    new = run()
    wide = strips.upsample_rows
    monkeypatch.setattr(strips, "upsample_rows", lambda img, *a: wide(np.asarray(img, np.float64), *a))
    old = run()
    assert new.dtype == old.dtype == np.float32
    np.testing.assert_allclose(new, old, rtol=FULL_FLOAT32_RTOL, atol=FULL_FLOAT32_RTOL * np.abs(old).max())
    assert not np.array_equal(new, old)  # the float64 path is really another computation
