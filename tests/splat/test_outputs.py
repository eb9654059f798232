"""splat.outputs: per-camera split, PCA false colour, PSNR."""

from __future__ import annotations

import numpy as np
import pytest

from splat import Capture, SplatError, View, correct_image, look_at, pca_false_colour, psnr, split_cameras


def test_split_cameras():
    cam = look_at((0, -3, 0), (0, 0, 0), width=4, height=4)
    capture = Capture((View("a", cam, 1), View("b", cam, 2)), {1: (0, 1, 2), 2: (3, 4)})
    image = np.arange(2 * 3 * 5).reshape(2, 3, 5)
    parts = split_cameras(image, capture)
    np.testing.assert_array_equal(parts[1], image[..., :3])
    np.testing.assert_array_equal(parts[2], image[..., 3:])
    with pytest.raises(SplatError, match="channels"):
        split_cameras(image[..., :4], capture)


def test_pca_false_colour():
    rng = np.random.default_rng(0)
    basis = rng.normal(size=(3, 9))
    image = rng.normal(size=(8, 8, 3)) @ basis
    rgb = pca_false_colour(image)
    assert rgb.shape == (8, 8, 3) and rgb.min() >= 0 and rgb.max() <= 1
    # invariant to adding a constant and to the sign/scale of the data
    np.testing.assert_allclose(pca_false_colour(image * 2 + 5), rgb, atol=1e-9)
    one = pca_false_colour(image[..., :1])
    assert np.all(one[..., 1:] == 0.5)
    mask = np.zeros((8, 8), bool)
    mask[:4] = True
    assert pca_false_colour(image, mask=mask).shape == (8, 8, 3)
    with pytest.raises(SplatError):
        pca_false_colour(image, mask=np.zeros((8, 8), bool))


def test_psnr():
    a = np.zeros((4, 4))
    assert psnr(a, a) == float("inf")
    assert psnr(a, a + 0.1) == pytest.approx(20.0)
    with pytest.raises(SplatError):
        psnr(a, a[:2])


def test_correct_image_hands_the_aligned_channels_to_zonotope():
    import zonotope
    from zonotope.correct import correct

    cams = ("Nikon 5100 (NPL)", "Canon EOS 5D Mark II")
    shape = np.arange(400, 701, 10)
    G = zonotope.generators(list(cams), "D65", shape).values
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), shape).T[:16]
    image = (R @ G).reshape(4, 4, 6)
    view = look_at((0, -3, 0), (0, 0, 0), width=4, height=4)
    capture = Capture((View("a", view, 1), View("b", view, 2)), {1: (0, 1, 2), 2: (3, 4, 5)})
    opts = dict(method="Cheung 2004", shape=shape)
    XYZ = correct_image(image, capture, cams, **opts)
    assert XYZ.shape == (4, 4, 3)
    np.testing.assert_allclose(XYZ.reshape(-1, 3), correct(R @ G, list(cams), **opts))
    one = correct_image(image, capture, cams[1:], camera_ids=[2], **opts)
    np.testing.assert_allclose(one.reshape(-1, 3), correct((R @ G)[:, 3:], [cams[1]], **opts))
    with pytest.raises(SplatError, match="one per id"):
        correct_image(image, capture, cams[:1])


@pytest.mark.parametrize("method", ["reference", "cpu", "tiled"])
def test_render_depth_is_the_compositing_weighted_mean_depth(method):
    """One Gaussian: its depth wherever it is drawn, NaN elsewhere. Two on the optical axis: front-to-back
    compositing weights ``a₁`` and ``(1 − a₁) a₂``, each Gaussian's opacity at the pixel taken from a render
    of it alone."""
    from splat import init_gaussians, render, render_depth

    cam = look_at((0, 0, -4), (0, 0, 0), up=(0, 1, 0), width=32, height=32)
    g = init_gaussians(
        [[0.0, 0, 0], [0.02, 0.01, 3]], [[0.5], [0.5]], scales=np.array([0.2, 0.5]), opacity=0.6
    )
    one = np.array([True, False])
    depth, alpha = render_depth(g, cam, mask=one, method=method)
    drawn = alpha > 0
    assert drawn.any() and not drawn.all()
    np.testing.assert_allclose(depth[drawn], 4.0, rtol=1e-5)
    assert np.isnan(depth[~drawn]).all()

    depth, alpha = render_depth(g, cam, method=method)
    a1 = np.asarray(render(g, cam, mask=one, method=method).alpha, float)
    a2 = np.asarray(render(g, cam, mask=~one, method=method).alpha, float)
    both = (a1 > 0.05) & (a2 > 0.05)
    assert both.sum() > 20
    w1, w2 = a1[both], (1 - a1[both]) * a2[both]
    np.testing.assert_allclose(alpha[both], w1 + w2, rtol=1e-4)
    np.testing.assert_allclose(depth[both], (4 * w1 + 7 * w2) / (w1 + w2), rtol=1e-4)


def test_outputs_render_the_whole_model_whatever_the_tile_capacity(small_scene):
    """render_views and render_depth never drop Gaussian–tile pairs: at a capacity below the fullest
    tile the tiled back-end alone drops, the outputs equal the render with enough capacity."""
    from splat import RenderConfig, render, render_depth, render_views

    g, cam = small_scene
    full = render(g, cam, method="tiled", config=RenderConfig(tile_size=8, tile_capacity=128))
    small = RenderConfig(tile_size=8, tile_capacity=max(int(full.max_per_tile) // 4, 1))
    cut = render(g, cam, method="tiled", config=small)
    assert int(cut.n_dropped) > 0
    assert np.abs(np.asarray(cut.image) - np.asarray(full.image)).max() > 1e-2  # what dropping costs
    img = render_views(g, [cam], method="tiled", config=small)[0]
    np.testing.assert_allclose(img, np.asarray(full.image), atol=1e-6)
    depth, alpha = render_depth(g, cam, method="tiled", config=small)
    ref_depth, ref_alpha = render_depth(
        g, cam, method="tiled", config=RenderConfig(tile_size=8, tile_capacity=128)
    )
    np.testing.assert_allclose(alpha, ref_alpha, atol=1e-6)
    np.testing.assert_allclose(depth, ref_depth, atol=1e-5, equal_nan=True)
