"""splat.sim.scenes: the synthetic capture is what its spectral model says it is."""

from __future__ import annotations

import numpy as np
import pytest

import zonotope
from splat import RenderConfig, SceneConfig, SplatError, bayer_mask, render_reference, synthetic_scene


@pytest.fixture(scope="module")
def scene():
    return synthetic_scene(SceneConfig(width=16, height=16, views_per_camera=2, test_views_per_camera=1))


def test_shapes_channels_and_mosaics(scene):
    assert scene.images.shape == (6, 16, 16, 9) and scene.test_images.shape == (3, 16, 16, 9)
    assert scene.capture.channels == {1: (0, 1, 2), 2: (3, 4, 5), 3: (6, 7, 8)}
    for v, w in zip(scene.capture.views, scene.weights):
        measured = w.any(axis=(0, 1))
        assert measured.tolist() == scene.capture.channel_mask(v).tolist()
        own = w[..., list(scene.capture.channels[v.camera_id])]
        if v.camera_id == 2:  # the Sigma (Foveon) measures every channel at every pixel
            assert own.all()
        else:
            np.testing.assert_array_equal(own, bayer_mask(16, 16))
    assert np.all(scene.images[scene.weights == 0] == 0)
    assert 0 <= scene.images.min() and scene.images.max() <= 1


def test_colours_are_reflectances_through_the_cameras(scene):
    cams = [zonotope.camera(c) for c in SceneConfig().cameras]
    cc = zonotope.reflectances("ColorChecker N Ohta")
    shape = zonotope.common_shape(*cams, cc, zonotope.reflectances("rawtoaces 190"))
    G = zonotope.generators(cams, "D65", shape).values
    np.testing.assert_allclose(G, scene.generators)
    first_patch = zonotope.resample(cc, shape)[:, 0] @ G
    np.testing.assert_allclose(np.asarray(scene.truth.colours)[0], first_patch, rtol=1e-3, atol=1e-5)
    # the held-out images are exact reference renders of the truth
    clean = render_reference(scene.truth, scene.test.views[0].camera, config=RenderConfig(chunk=64)).image
    np.testing.assert_allclose(scene.test_images[0], clean, atol=1e-6)


def test_noise_and_exposure(scene):
    v = 0
    view = scene.capture.views[v]
    ch = list(scene.capture.channels[view.camera_id])
    clean = render_reference(scene.truth, view.camera, config=RenderConfig(chunk=64)).image
    clean = np.asarray(clean)[..., ch]
    w = scene.weights[v][..., ch] > 0
    resid = scene.images[v][..., ch][w] - np.clip(view.exposure * clean[w], 0, 1)
    assert 0 < np.std(resid) < 0.05
    assert SceneConfig().exposure_range[0] <= view.exposure <= SceneConfig().exposure_range[1]


def test_bayer_mask_patterns_and_errors():
    m = bayer_mask(2, 2, "RGGB")
    assert m[0, 0, 0] and m[0, 1, 1] and m[1, 0, 1] and m[1, 1, 2]
    assert bayer_mask(4, 6, "BGGR").sum(-1).tolist() == np.ones((4, 6), int).tolist()
    with pytest.raises(SplatError, match="pattern"):
        bayer_mask(2, 2, "RGBW")
