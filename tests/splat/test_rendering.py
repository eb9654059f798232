"""splat.rendering: tiled back-end vs the exact reference, the numba ``cpu`` back-end vs the tiled one
(values and gradients), finite differences, analytic footprint."""

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
    tiled = render(g, cam, method="tiled", config=cfg)
    assert int(render(g, cam, method="tiled").n_dropped) == 0  # the default 16-pixel tiles too
    ref = render(g, cam, method="reference", config=cfg)
    assert int(tiled.n_dropped) == 0
    assert int(tiled.max_per_tile) <= 128
    assert tiled.image.shape == (20, 28, 4)
    np.testing.assert_allclose(tiled.image, ref.image, atol=2e-3)
    np.testing.assert_allclose(tiled.alpha, ref.alpha, atol=2e-3)
    assert float(ref.image.max()) > 0.1  # the scene is actually visible


def test_tiled_reports_what_it_drops(small_scene):
    g, cam = small_scene
    full = render(g, cam, method="tiled", config=RenderConfig(tile_size=8, tile_capacity=128))
    cap = int(full.max_per_tile) - 5
    small = render(g, cam, method="tiled", config=RenderConfig(tile_size=8, tile_capacity=cap))
    assert int(small.max_per_tile) == int(full.max_per_tile)
    assert int(small.n_dropped) >= 5
    enough = RenderConfig(tile_size=8, tile_capacity=int(full.max_per_tile))
    exact = render(g, cam, method="tiled", config=enough)
    assert int(exact.n_dropped) == 0
    # the cpu back-end has no capacity: at the capacity that drops, it still equals the full render
    cpu = render(g, cam, method="cpu", config=RenderConfig(tile_size=8, tile_capacity=cap))
    assert int(cpu.n_dropped) == 0 and int(cpu.max_per_tile) == int(full.max_per_tile)
    np.testing.assert_allclose(cpu.image, full.image, atol=1e-6)


@pytest.mark.parametrize("batch", [0, 3])
def test_tiled_batches_of_tiles_equal_one_tile_at_a_time(batch, make_gaussians):
    """``tile_batch`` (all tiles, or batches of 3 with a ragged last one) only changes how the tiles are
    scheduled: the image, alpha and every gradient equal the sequential map's, per-chunk termination and
    the skipped chunks past a tile's last Gaussian included."""
    g = make_gaussians(G=120, N=4, seed=3, spread=0.9)
    aniso = np.random.default_rng(4).normal(0, 0.4, g.log_scales.shape)  # so that rotations matter
    g = Gaussians(g.means, g.quats, g.log_scales + aniso, g.opacity_logits, g.colour_params)
    cam = look_at((0.4, -3.0, 0.5), (0, 0, 0), width=30, height=21, fov_deg=55)
    one = RenderConfig(tile_size=8, transmittance_min=0.2, chunk=8, tile_batch=1)
    many = RenderConfig(tile_size=8, transmittance_min=0.2, chunk=8, tile_batch=batch)
    a, b = render(g, cam, method="tiled", config=one), render(g, cam, method="tiled", config=many)
    np.testing.assert_allclose(b.image, a.image, atol=1e-6)
    np.testing.assert_allclose(b.alpha, a.alpha, atol=1e-6)
    assert int(a.n_dropped) == int(b.n_dropped) == 0 and float(a.image.max()) > 0.1
    w = jnp.asarray(np.random.default_rng(0).normal(size=a.image.shape), jnp.float32)

    def loss(params, c):
        return jnp.sum(render(params, cam, method="tiled", config=c).image * w)

    for x, y in zip(jax.tree.leaves(jax.grad(loss)(g, one)), jax.tree.leaves(jax.grad(loss)(g, many))):
        assert np.abs(np.asarray(x)).max() > 0
        np.testing.assert_allclose(y, x, atol=1e-5 * np.abs(np.asarray(x)).max(), rtol=0)
    # the default (None) picks by device: one tile at a time here, on the CPU
    c = render(g, cam, method="tiled", config=RenderConfig(tile_size=8, transmittance_min=0.2, chunk=8))
    np.testing.assert_array_equal(c.image, a.image)
    for bad in (-1, 1.5, "all"):
        with pytest.raises(SplatError, match="tile_batch"):
            RenderConfig(tile_batch=bad)


@pytest.fixture
def x64_everywhere():
    """float64 in every thread (the ``jax.enable_x64`` context manager does not reach the thread on
    which JAX runs the cpu back-end's host callback)."""
    before = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", before)


@pytest.mark.parametrize("method", ["reference", "tiled", "cpu"])
def test_gradients_pass_finite_differences_in_float64(method, make_gaussians, x64_everywhere):
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
    for method in ("tiled", "cpu"):
        np.testing.assert_allclose(render(g, cam, method=method, config=cfg).image, expected, atol=2e-6)
    pj = project(g, cam, config=cfg)
    np.testing.assert_allclose(pj.radii, 3 * np.sqrt(var), rtol=1e-5)
    np.testing.assert_allclose(pj.means2d, [[12, 12]], atol=1e-4)


def test_front_gaussian_hides_the_back_one_whatever_the_buffer_order():
    means = jnp.asarray([[0, 1.0, 0], [0, -1.0, 0]])  # the second is nearer to the camera at y = -4
    colours = jnp.asarray([[1.0, 0.0], [0.0, 1.0]])
    g = init_gaussians(means, colours, scales=0.3, opacity=0.99)
    flipped = init_gaussians(means[::-1], colours[::-1], scales=0.3, opacity=0.99)
    cam = look_at((0, -4, 0), (0, 0, 0), width=16, height=16)
    for method in ("reference", "tiled", "cpu"):
        image = np.asarray(render(g, cam, method=method).image)
        c = image[8, 8]
        assert c[1] > 0.8 and c[0] < 0.1 * c[1]
        np.testing.assert_allclose(render(flipped, cam, method=method).image, image, atol=1e-6)


def test_mask_and_culling(small_scene):
    g, cam = small_scene
    G = g.n
    for method in ("reference", "tiled", "cpu"):
        out = render(g, cam, method=method, mask=jnp.zeros(G, bool))
        np.testing.assert_allclose(out.image, 0.0)
        np.testing.assert_allclose(out.alpha, 0.0)
    # masked Gaussians receive exactly zero gradient
    mask = jnp.arange(G) < G // 2
    for method in ("tiled", "cpu"):
        grad = jax.grad(lambda p, m=method: render(p, cam, method=m, mask=mask).image.sum())(g)
        for leaf in jax.tree.leaves(grad):
            assert np.all(np.asarray(leaf)[G // 2 :] == 0)
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


CPU_CASES = [
    RenderConfig(),
    RenderConfig(tile_size=8, transmittance_min=0.0),
    RenderConfig(tile_size=4, transmittance_min=0.3, chunk=4, background=0.2),  # termination matters
    RenderConfig(tile_size=16, alpha_max=0.5, alpha_min=0.05, sigma_cutoff=2.0),  # clipped alphas
]


@pytest.mark.parametrize("cfg", CPU_CASES)
def test_cpu_backend_equals_tiled_values_and_gradients(cfg, make_gaussians):
    """The numba back-end composites the same tiles with the same per-chunk termination as "tiled":
    images, alphas and every parameter's gradient (through its hand-written backward pass) agree to
    float32 rounding when the tiled back-end drops nothing."""
    g = make_gaussians(G=150, N=5, seed=7, spread=0.9)
    aniso = np.random.default_rng(2).normal(0, 0.4, g.log_scales.shape)  # so that rotations matter
    g = Gaussians(g.means, g.quats, g.log_scales + aniso, g.opacity_logits, g.colour_params)
    cam = look_at((0.3, -3.2, 0.6), (0, 0, 0), width=37, height=29, fov_deg=55)
    tiled_cfg = RenderConfig(**{**cfg.__dict__, "tile_capacity": 512})
    a = render(g, cam, method="tiled", config=tiled_cfg)
    b = render(g, cam, method="cpu", config=cfg)
    assert int(a.n_dropped) == 0 and int(b.max_per_tile) == int(a.max_per_tile)
    np.testing.assert_allclose(b.image, a.image, atol=1e-6)
    np.testing.assert_allclose(b.alpha, a.alpha, atol=1e-6)
    assert float(a.image.max()) > 0.1
    rng = np.random.default_rng(1)
    wi = jnp.asarray(rng.normal(size=a.image.shape), jnp.float32)
    wa = jnp.asarray(rng.normal(size=a.alpha.shape), jnp.float32)

    def loss(params, method, c):
        out = render(params, cam, method=method, config=c)
        return jnp.sum(out.image * wi) + jnp.sum(out.alpha * wa)

    ga = jax.tree.leaves(jax.grad(loss)(g, "tiled", tiled_cfg))
    gb = jax.tree.leaves(jax.grad(loss)(g, "cpu", cfg))
    for x, y in zip(ga, gb):
        x, y = np.asarray(x), np.asarray(y)
        assert np.abs(x).max() > 0
        np.testing.assert_allclose(y, x, atol=2e-5 * np.abs(x).max(), rtol=0)


def test_cpu_backend_under_jit_vmap_and_threads(small_scene):
    """The host kernels run inside jit, under vmap (one view after another) and from several threads."""
    from concurrent.futures import ThreadPoolExecutor

    from splat.training import stack_cameras

    g, cam = small_scene
    cams = [cam, look_at((-0.4, -3.5, 0.5), (0, 0, 0), width=28, height=20, fov_deg=50)]
    one = [np.asarray(render(g, c, method="cpu").image) for c in cams]
    batched = jax.vmap(lambda c: render(g, c, method="cpu").image)(stack_cameras(cams))
    np.testing.assert_allclose(batched, np.stack(one), atol=0)
    with ThreadPoolExecutor(4) as ex:
        again = list(ex.map(lambda c: np.asarray(render(g, c, method="cpu").image), cams * 4))
    for i, x in enumerate(again):
        np.testing.assert_array_equal(x, one[i % 2])


def test_cpu_backend_refuses_operands_narrowed_by_jax():
    """Float64 traced but float32 received (``jax.enable_x64`` as a context manager, callback on another
    thread): an error that says what to do, not a float64 result computed from float32 digits."""
    from splat.rendering import _host_forward

    f32 = np.zeros((3, 2), np.float32)
    with pytest.raises(SplatError, match="jax_enable_x64"):
        _host_forward(
            f32, f32, f32[:, 0], f32, np.zeros((3, 4)), H=4, W=4, config=RenderConfig(), dtype=np.float64
        )


def test_auto_picks_the_cpu_backend_on_the_cpu(small_scene):
    from splat.rendering import default_method

    g, cam = small_scene
    expected = "cpu" if jax.default_backend() == "cpu" else "tiled"
    assert default_method() == expected
    np.testing.assert_array_equal(render(g, cam).image, render(g, cam, method=expected).image)


def test_cpu_backend_bins_a_huge_gaussian_into_every_tile(x64_everywhere):
    """A Gaussian whose cut-off box is wider than an int64 can count (its pixel bounds are clipped
    before the int conversion in the kernels) still covers every tile, as in the tiled back-end."""
    with jax.enable_x64(True):
        g = init_gaussians(
            jnp.zeros((1, 3)), jnp.asarray([[0.3, 0.6]]), scales=1e20, opacity=0.8, dtype=jnp.float64
        )
        cam = look_at((0, -3, 0), (0, 0, 0), width=40, height=24, dtype=jnp.float64)
        assert float(project(g, cam).extents.min()) > 1e19  # > 2**63
        a = render(g, cam, method="tiled")
        b = render(g, cam, method="cpu")
    np.testing.assert_allclose(b.image, a.image, atol=1e-12)
    np.testing.assert_allclose(b.image[..., 1], 0.8 * 0.6, rtol=1e-9)  # flat at this scale


@pytest.mark.parametrize(
    "cfg",
    [
        RenderConfig(tile_size=4, transmittance_min=0.0, chunk=4),
        RenderConfig(tile_size=4, transmittance_min=0.3, chunk=4, alpha_max=0.5),  # termination, clipping
    ],
)
def test_absgrad_probe_sums_each_pixels_absolute_centre_gradient(cfg, make_gaussians):
    """``absgrad_probe``'s gradient is Σ_p |∂L_p/∂μ₂ᴅ| per axis (AbsGS), checked against the per-pixel
    Jacobian of the composite with respect to a shift of the projected centres (brute force, no tap),
    in every back-end; the image does not depend on the probe, and the signed gradient is never larger."""
    from splat.rendering import _composite, _pad, _sorted

    g = make_gaussians(G=40, N=3, seed=5, spread=0.7)
    aniso = np.random.default_rng(6).normal(0, 0.4, g.log_scales.shape)
    g = Gaussians(g.means, g.quats, g.log_scales + aniso, g.opacity_logits, g.colour_params)
    cam = look_at((0.3, -3.0, 0.4), (0, 0, 0), width=13, height=10, fov_deg=50)
    w = jnp.asarray(np.random.default_rng(1).normal(size=(10, 13, 3)), jnp.float32)
    zero = jnp.zeros((40, 2), jnp.float32)

    def probe_grad(method):
        c = RenderConfig(**{**cfg.__dict__, "tile_capacity": 64})

        def loss(probe):
            return jnp.sum(w * render(g, cam, method=method, config=c, absgrad_probe=probe).image)

        assert int(render(g, cam, method=method, config=c).n_dropped) == 0
        np.testing.assert_array_equal(
            render(g, cam, method=method, config=c, absgrad_probe=zero + 5).image,
            render(g, cam, method=method, config=c).image,
        )
        return np.asarray(jax.grad(loss)(zero))

    got = {m: probe_grad(m) for m in ("reference", "tiled", "cpu")}
    assert got["cpu"].max() > 0
    np.testing.assert_allclose(got["cpu"], got["tiled"], atol=1e-5 * got["tiled"].max(), rtol=0)
    if cfg.transmittance_min == 0:  # the reference stops at other chunk boundaries otherwise
        pj = project(g, cam, config=cfg)
        order = np.argsort(np.where(pj.valid, pj.depths, np.inf), kind="stable")
        spj, _ = _sorted(pj)
        yy, xx = np.meshgrid(np.arange(10), np.arange(13), indexing="ij")
        px = jnp.asarray(np.stack([xx, yy], -1).reshape(-1, 2) + 0.5, jnp.float32)

        def per_pixel(shift):  # shift of the sorted centres -> each pixel's loss
            C, _ = _composite(px, _pad(spj.means2d + shift, 40), spj.conics, spj.opacities, spj.colours, cfg)
            return jnp.sum(C * w.reshape(-1, 3), axis=-1)

        J = np.asarray(jax.jacrev(per_pixel)(zero))  # [P, G, 2]
        brute = np.zeros((40, 2), np.float32)
        brute[order] = np.abs(J).sum(0)
        for m in ("reference", "tiled", "cpu"):
            np.testing.assert_allclose(got[m], brute, atol=1e-5 * brute.max(), rtol=0)
        signed = np.zeros((40, 2), np.float32)
        signed[order] = np.abs(J.sum(0))
        assert np.all(signed <= brute + 1e-6) and np.any(signed < 0.5 * brute)
