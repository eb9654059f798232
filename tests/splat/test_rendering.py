"""splat.rendering: tiled back-end vs the exact reference, gradients, analytic footprint."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from splat import (
    Gaussians,
    RenderConfig,
    SplatError,
    init_gaussians,
    look_at,
    project,
    render,
)


def test_tiled_matches_reference_when_nothing_is_dropped(small_scene):
    g, cam = small_scene
    cfg = RenderConfig(tile_size=8, tile_capacity=128)
    tiled = render(g, cam, config=cfg)
    assert int(render(g, cam).n_dropped) == 0  # the default 16-pixel tiles too
    ref = render(g, cam, method="reference", config=cfg)
    assert int(tiled.n_dropped) == 0
    assert int(tiled.max_per_tile) <= 128
    assert tiled.image.shape == (20, 28, 4)
    np.testing.assert_allclose(tiled.image, ref.image, atol=2e-3)
    np.testing.assert_allclose(tiled.alpha, ref.alpha, atol=2e-3)
    assert float(ref.image.max()) > 0.1  # the scene is actually visible


def test_tiled_reports_what_it_drops(small_scene):
    g, cam = small_scene
    full = render(g, cam, config=RenderConfig(tile_size=8, tile_capacity=128))
    cap = int(full.max_per_tile) - 5
    small = render(g, cam, config=RenderConfig(tile_size=8, tile_capacity=cap))
    assert int(small.max_per_tile) == int(full.max_per_tile)
    assert int(small.n_dropped) >= 5
    exact = render(g, cam, config=RenderConfig(tile_size=8, tile_capacity=int(full.max_per_tile)))
    assert int(exact.n_dropped) == 0


@pytest.mark.parametrize("method", ["reference", "tiled"])
def test_gradients_pass_finite_differences_in_float64(method, make_gaussians):
    with jax.enable_x64(True):
        g = make_gaussians(G=8, N=2, seed=3, spread=0.5, dtype=jnp.float64)
        cam = look_at((0.2, -3.0, 0.3), (0, 0, 0), width=10, height=8, fov_deg=40, dtype=jnp.float64)
        # a smooth footprint (no cut-offs) so that finite differences are meaningful
        cfg = RenderConfig(
            alpha_min=0.0, sigma_cutoff=1e3, transmittance_min=0.0, tile_size=8, tile_capacity=8, chunk=4
        )
        w = jnp.asarray(np.random.default_rng(0).normal(size=(8, 10, 2)))

        def loss(params):
            return jnp.sum(w * render(params, cam, method=method, config=cfg).image)

        check_grads(loss, (g,), order=1, modes=["rev"], eps=1e-6, atol=1e-5, rtol=1e-5)


def test_single_gaussian_renders_its_analytic_footprint():
    s, z, o = 0.1, 3.0, 0.7
    g = init_gaussians(jnp.zeros((1, 3)), jnp.asarray([[1.0, 0.5, 2.0]]), scales=s, opacity=o)
    cam = look_at((0, -z, 0), (0, 0, 0), width=24, height=24, fov_deg=30)
    cfg = RenderConfig()
    out = render(g, cam, method="reference", config=cfg)
    f = float(cam.focal[0])
    var = (f * s / z) ** 2 + cfg.eps2d
    yy, xx = np.mgrid[0:24, 0:24] + 0.5
    r2 = ((xx - 12) ** 2 + (yy - 12) ** 2) / var
    alpha = o * np.exp(-0.5 * r2)
    alpha[(r2 > 9) | (alpha < 1 / 255)] = 0
    expected = alpha[..., None] * np.asarray(g.colours)[0]
    np.testing.assert_allclose(out.image, expected, atol=2e-6)
    np.testing.assert_allclose(out.alpha, alpha, atol=2e-6)
    np.testing.assert_allclose(render(g, cam, config=cfg).image, expected, atol=2e-6)
    pj = project(g, cam, config=cfg)
    np.testing.assert_allclose(pj.radii, 3 * np.sqrt(var), rtol=1e-5)
    np.testing.assert_allclose(pj.means2d, [[12, 12]], atol=1e-4)


def test_front_gaussian_hides_the_back_one_whatever_the_buffer_order():
    means = jnp.asarray([[0, 1.0, 0], [0, -1.0, 0]])  # the second is nearer to the camera at y = -4
    colours = jnp.asarray([[1.0, 0.0], [0.0, 1.0]])
    g = init_gaussians(means, colours, scales=0.3, opacity=0.99)
    flipped = init_gaussians(means[::-1], colours[::-1], scales=0.3, opacity=0.99)
    cam = look_at((0, -4, 0), (0, 0, 0), width=16, height=16)
    for method in ("reference", "tiled"):
        image = np.asarray(render(g, cam, method=method).image)
        c = image[8, 8]
        assert c[1] > 0.8 and c[0] < 0.1 * c[1]
        np.testing.assert_allclose(render(flipped, cam, method=method).image, image, atol=1e-6)


def test_mask_and_culling(small_scene):
    g, cam = small_scene
    G = g.n
    for method in ("reference", "tiled"):
        out = render(g, cam, method=method, mask=jnp.zeros(G, bool))
        np.testing.assert_allclose(out.image, 0.0)
        np.testing.assert_allclose(out.alpha, 0.0)
    # masked Gaussians receive exactly zero gradient
    mask = jnp.arange(G) < G // 2
    grad = jax.grad(lambda p: render(p, cam, mask=mask).image.sum())(g)
    assert np.all(np.asarray(grad.colour_params)[G // 2 :] == 0)
    assert np.any(np.asarray(grad.colour_params)[: G // 2] != 0)
    # behind the camera, or NaN: ignored, not propagated
    behind = Gaussians(g.means.at[:, 1].set(-10.0), g.quats, g.log_scales, g.opacity_logits, g.colour_params)
    assert float(render(behind, cam).alpha.max()) == 0.0
    bad = Gaussians(g.means.at[0].set(jnp.nan), g.quats, g.log_scales, g.opacity_logits, g.colour_params)
    assert np.all(np.isfinite(np.asarray(render(bad, cam).image)))
    background = render(
        g,
        cam,
        method="reference",
        mask=jnp.zeros(G, bool),
        config=RenderConfig(background=0.25, tile_size=8, tile_capacity=128),
    )
    np.testing.assert_allclose(background.image, 0.25)


def test_one_channel_and_errors():
    g = init_gaussians(jnp.zeros((2, 3)), jnp.ones((2, 1)), scales=0.2)
    cam = look_at((0, -3, 0), (0, 0, 0), width=8, height=8)
    assert render(g, cam).image.shape == (8, 8, 1)
    with pytest.raises(SplatError, match="method"):
        render(g, cam, method="cuda")
    with pytest.raises(SplatError, match="tile_capacity"):
        RenderConfig(tile_capacity=0)
    with pytest.raises(SplatError, match="colours"):
        init_gaussians(jnp.zeros((2, 3)), jnp.ones((3, 1)))
    with pytest.raises(SplatError):
        init_gaussians(jnp.zeros((2, 3)), jnp.ones((2, 1)), opacity=1.0)
