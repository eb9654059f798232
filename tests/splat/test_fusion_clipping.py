"""Clipped photographs are bounds, not measurements: :func:`splat.fusion.unclipped` and the variance
:func:`splat.fusion.photo_variance` gives a clipped reading.

Independent truths: the clipped neighbourhoods found by brute force over every pixel and site; the
inverse-variance mean of two photographs of a flat scene, one of them long enough to clip, against the
scene's known value.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import splat
import splat.fusion as fusion
from splat.capture import RawView

_PROFILE = np.array([[2e-4, 1e-6], [1e-4, 4e-6], [3e-4, 2e-6]])


def _cfa_mask(H, W, pattern):
    m = np.zeros((H, W, 3), bool)
    for i in range(2):
        for j in range(2):
            m[i::2, j::2, "RGB".index(pattern[2 * i + j])] = True
    return m


def _view(values, weight, *, full_colour, exif=2.5):
    return RawView(
        name="cam/IMG_0001.dng",
        camera=0,
        values=np.asarray(values, np.float32),
        weight=np.asarray(weight, np.float32),
        exif=exif,
        profile=None,
        neutral=np.ones(3),
        full_colour=full_colour,
        noise_profile=_PROFILE,
    )


@settings(max_examples=40, deadline=None)
@given(
    H=st.integers(2, 9),
    W=st.integers(2, 9),
    pattern=st.sampled_from(["RGGB", "GBRG", "BGGR", "GRBG"]),
    reach=st.integers(0, 3),
    seed=st.integers(0, 2**16),
)
def test_unclipped_of_a_mosaic_matches_brute_force(H, W, pattern, reach, seed):
    """A pixel is unclipped iff no CFA site within Chebyshev distance ``reach`` has weight 0."""
    rng = np.random.default_rng(seed)
    on = _cfa_mask(H, W, pattern)
    bad_site = rng.random((H, W)) < 0.08
    weight = on & ~bad_site[..., None]
    values = np.where(on, np.where(bad_site[..., None], 1.0, 0.3), 0.0)
    got = fusion.unclipped(_view(values, weight, full_colour=False), reach=reach)
    for y, x in np.ndindex(H, W):
        near = [
            bad_site[yy, xx]
            for yy in range(max(0, y - reach), min(H, y + reach + 1))
            for xx in range(max(0, x - reach), min(W, x + reach + 1))
        ]
        assert got[y, x] == (not any(near))


def test_unclipped_of_a_full_colour_view_is_every_channel_usable():
    rng = np.random.default_rng(3)
    weight = rng.random((7, 5, 3)) > 0.1
    got = fusion.unclipped(_view(np.full((7, 5, 3), 0.5), weight, full_colour=True), reach=2)
    np.testing.assert_array_equal(got, weight.all(-1))


def test_unclipped_refuses_a_bad_reach():
    on = _cfa_mask(4, 4, "RGGB")
    with pytest.raises(splat.SplatError, match="reach"):
        fusion.unclipped(_view(on * 0.5, on, full_colour=False), reach=-1)


@pytest.mark.parametrize("reach", [None, 0, 1, 2])
def test_photo_variance_of_a_clipped_reading_is_the_full_scale(reach):
    """The noise model where unclipped, ``1 / e²`` within ``reach`` of a clipped site; None: no test."""
    H, W, e = 10, 12, 2.5
    on = _cfa_mask(H, W, "GBRG")
    values = on * 0.4
    weight = on.copy()
    weight[4, 5] = False  # one saturated site
    values[4, 5] = np.where(on[4, 5], 1.0, 0.0)
    view = _view(values, weight, full_colour=False, exif=e)
    photo = np.random.default_rng(35).uniform(0.0, 0.5, (H, W, 3))
    got = fusion.photo_variance(view, photo, reach=reach)
    model = (_PROFILE[:, 0] * photo * e + _PROFILE[:, 1]) / e**2
    clipped = np.zeros((H, W), bool)
    if reach is not None:
        clipped[max(0, 4 - reach) : 5 + reach, max(0, 5 - reach) : 6 + reach] = True
    np.testing.assert_allclose(got[~clipped], model[~clipped], rtol=1e-12)
    np.testing.assert_array_equal(got[clipped], 1 / e**2)


def test_a_clipped_photograph_gets_no_weight_next_to_a_measured_one():
    """Two photographs of a flat scene (white → 1 value 0.9 at exposure 1), one exposed to clip in its
    green sites: their inverse-variance mean with :func:`photo_variance` is the scene within a few σ of
    the noise; with the noise model alone (no clipping test) it is pulled down by the clipped green."""
    H = W = 48
    truth = np.array([0.9, 0.9, 0.9])
    rng = np.random.default_rng(11)
    photos, variances, naive = [], [], []
    for e in (0.8, 1.6):  # the longer exposure clips: 0.9 × 1.6 > 1 in every channel
        on = _cfa_mask(H, W, "RGGB")
        lin = truth * e + rng.normal(0.0, 0.002, (H, W, 3))
        sat = lin >= 1.0
        values = np.where(on, np.minimum(lin, 1.0), 0.0)
        view = _view(values, on & ~sat, full_colour=False, exif=e)
        photo = fusion.measured(view, np.ones(3), method="bilinear")
        photos.append(photo)
        variances.append(fusion.photo_variance(view, photo))
        naive.append(fusion.photo_variance(view, photo, reach=None))

    def mean(var):
        w = 1 / np.stack(var)
        return (np.stack(photos) * w).sum(0) / w.sum(0)

    inner = (slice(2, -2), slice(2, -2))
    np.testing.assert_allclose(mean(variances)[inner], np.broadcast_to(truth, (H - 4, W - 4, 3)), atol=0.01)
    assert np.mean(mean(naive)[inner]) < 0.9 - 0.1  # the clipped reading outvotes the measured one


def test_photo_variance_without_exposure_names_the_view():
    on = _cfa_mask(4, 4, "RGGB")
    view = dataclasses.replace(_view(on * 0.5, on, full_colour=False), exif=None)
    with pytest.raises(splat.SplatError, match="IMG_0001"):
        fusion.photo_variance(view, np.ones((4, 4, 3)))


# ------------------------------------------------------------------------------------- camera_levels


def _responses(n_cameras, seed, N=300):
    """Linear responses of ``n_cameras`` cameras to ``N`` smooth random spectra (a 6-dimensional
    cosine basis through random 3-channel sensitivities): the cameras' responses are linearly related
    only approximately, as real cameras' are."""
    rng = np.random.default_rng(seed)
    lam = np.linspace(0, 1, 31)
    basis = np.stack([np.cos(np.pi * j * lam) for j in range(6)], 1)
    spectra = np.clip(0.5 + 0.3 * rng.normal(size=(N, 6)) @ basis.T / 2, 0.02, 1)
    sens = np.concatenate(
        [np.exp(-((lam[:, None] - rng.uniform(0.1, 0.9, 3)) ** 2) / 0.02) for _ in range(n_cameras)], 1
    )
    return spectra @ sens / sens.sum(0)


@functools.cache
def _real_responses():
    """(training, scene): white → 1 responses of the Nikon 5100, the Sigma SD Merrill (Foveon) and the
    Canon 5D Mark II to the 190 training reflectances and to 53 natural surfaces (pixels draw from them)."""
    import zonotope
    from zonotope.correct import correction_problem

    pb = correction_problem(
        ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"], shape=np.arange(400, 681, 10.0)
    )
    sets = ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0")
    refl = np.concatenate([zonotope.resample(zonotope.reflectances(n), pb.wavelengths).T for n in sets])
    return pb.training @ pb.Phi, np.clip(refl, 0, 1) @ pb.Phi


@settings(max_examples=15, deadline=None)
@given(
    levels=st.lists(st.lists(st.floats(0.8, 1.25), min_size=3, max_size=3), min_size=3, max_size=3),
    fixed=st.sampled_from([None, 0, 2]),
    per_channel=st.sampled_from([(), (1,), (0, 2), (0, 1, 2)]),
    seed=st.integers(0, 2**16),
)
def test_camera_levels_recovers_known_levels(levels, fixed, per_channel, seed):
    """Pixels of natural surfaces (ColorChecker, CIE 1995 and NIST CQS samples) seen by camera k (its
    level per channel applied: an exposure and a white of its curves off by up to 25 % per channel)
    and camera c (its levels), the capture's three measured cameras (a Foveon among them): the levels
    come back per channel, relative to ``fixed`` (or with each channel's geometric mean 1), to within
    the cameras' spectral mismatch (the 3 × 3 maps are least squares on the training reflectances:
    1.3 % at most per channel for these cameras; levels within 2 % with one level per camera, 3 % per
    channel, 5 % when every camera has three and none is fixed)."""
    R, scene = _real_responses()
    rng = np.random.default_rng(seed + 1)
    lv = np.asarray(levels)  # (camera, channel); one level for all channels outside per_channel and
    for c in (set(range(3)) - set(per_channel)) | {fixed} - {None}:  # for the patch's (its white measured)
        lv[c] = lv[c, 0]
    pairs = []
    for k in range(3):
        for c in range(3):
            if c != k:
                idx = rng.choice(len(scene), 250)
                pairs.append(
                    (k, c, scene[idx, 3 * k : 3 * k + 3] * lv[k], scene[idx, 3 * c : 3 * c + 3] * lv[c])
                )
    got = fusion.camera_levels(pairs, R, 3, fixed=fixed, per_channel=per_channel)["level"]
    anchor = [c for c in range(3) if c not in per_channel] or [0, 1, 2]
    want = lv / (lv[fixed] if fixed is not None else np.exp(np.mean(np.log(lv[anchor]), axis=0)))
    assert got.shape == (3, 3)
    free_all = len(per_channel) == 3 and fixed is None  # nothing pins any channel: the maps' errors add
    np.testing.assert_allclose(got, want, rtol=0.05 if free_all else 0.03 if per_channel else 0.02)
    for c in set(range(3)) - set(per_channel):  # one level for all three channels
        assert np.ptp(got[c]) < 1e-9
    if fixed is not None:
        np.testing.assert_allclose(got[fixed], 1.0, atol=1e-12)


def test_camera_levels_leaves_a_camera_without_enough_shared_pixels_at_one():
    from splat._tol import CAMERA_LEVEL_MIN_PIXELS

    R = _responses(3, 5)
    few = CAMERA_LEVEL_MIN_PIXELS - 1
    pairs = [
        (0, 1, R[:250, 0:3], 0.9 * R[:250, 3:6]),
        (2, 0, R[:few, 6:9], R[:few, 0:3]),  # too few pixels: camera 2 stays unlinked
    ]
    got = fusion.camera_levels(pairs, R, 3, fixed=0)
    np.testing.assert_allclose(got["level"], [[1.0] * 3, [0.9] * 3, [1.0] * 3], rtol=0.02)
    assert [r[:3] for r in got["ratios"]] == [[0, 1, 250]] and len(got["ratios"][0][3]) == 3
    assert fusion.camera_levels([], R, 3)["level"].tolist() == [[1.0] * 3] * 3


def test_camera_levels_skips_a_pair_whose_sums_are_not_positive_both_ways():
    """A pair whose channel sums are zero, negative or not finite on either side carries no level (its
    log ratio is undefined): it is left out, not allowed to turn the levels into NaN."""
    R, scene = _real_responses()
    px = scene[np.random.default_rng(0).choice(len(scene), 250)]
    good = (0, 1, px[:, 0:3], 0.9 * px[:, 3:6])
    for bad_own in (np.zeros((250, 3)), -px[:, 0:3], np.full((250, 3), np.nan)):
        got = fusion.camera_levels([good, (2, 0, bad_own, px[:, 0:3])], R, 3, fixed=0, per_channel=(1,))
        assert np.all(np.isfinite(got["level"])) and [r[:2] for r in got["ratios"]] == [[0, 1]]
        np.testing.assert_allclose(got["level"][1], 0.9, rtol=0.03)


def test_camera_levels_refuses_training_responses_of_another_width():
    with pytest.raises(splat.SplatError, match="training responses"):
        fusion.camera_levels([], np.ones((10, 6)), 3)
