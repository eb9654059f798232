"""splat.training: RawNeRF loss, channel masking, densification in a fixed buffer, resume, end to end."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from splat import (
    RenderConfig,
    SceneConfig,
    SplatError,
    TrainConfig,
    init_state,
    psnr,
    rawnerf_loss,
    render_views,
    synthetic_scene,
    train,
)


@pytest.fixture(scope="module")
def scene():
    return synthetic_scene(SceneConfig(width=24, height=24, views_per_camera=12, test_views_per_camera=1))


def tiny(steps, **kw) -> TrainConfig:
    kw.setdefault("capacity", 192)
    kw.setdefault("lr_means", 2e-3)  # short runs like faster rates
    kw.setdefault("lr_colours", 2e-2)
    return TrainConfig(
        steps=steps,
        densify_from=40,
        densify_every=40,
        densify_until=int(0.7 * steps),
        render=RenderConfig(tile_size=8, tile_capacity=128),
        **kw,
    )


def test_rawnerf_loss_matches_multinerf():
    rng = np.random.default_rng(0)
    pred = rng.uniform(0, 1.3, (5, 4))
    y = rng.uniform(0, 1, (5, 4))
    w = (rng.uniform(size=(5, 4)) > 0.3).astype(float)
    c = np.minimum(pred, 1)
    expected = np.sum(w * (c - y) ** 2 / (c + 1e-3) ** 2) / w.sum()
    np.testing.assert_allclose(rawnerf_loss(pred, y, w), expected, rtol=1e-5)
    g = np.asarray(jax.grad(rawnerf_loss)(jnp.asarray(pred), y, w))
    expected_g = np.where(pred < 1, 2 * w * (c - y) / (c + 1e-3) ** 2 / w.sum(), 0)
    np.testing.assert_allclose(g, expected_g, rtol=1e-4, atol=1e-7)


@pytest.mark.slow
def test_end_to_end_three_cameras_held_out_views(scene):
    assert len(scene.capture.views) == 36 and scene.images.shape[-1] == 9
    result = train(scene.capture, scene.images, scene.weights, config=tiny(400), bounds=scene.bounds)
    pred = render_views(
        result.gaussians,
        [v.camera for v in scene.test.views],
        mask=result.alive,
        config=RenderConfig(tile_size=8, tile_capacity=128),
    )
    assert pred.shape == scene.test_images.shape
    baseline = psnr(np.broadcast_to(scene.test_images.mean((0, 1, 2)), pred.shape), scene.test_images)
    score = psnr(pred, scene.test_images)
    print(f"held-out PSNR {score:.2f} dB (mean-colour baseline {baseline:.2f} dB)")
    assert score > 22 and score > baseline + 6, (score, baseline)
    # every channel is learnt, though each view measures only 3 of the 9
    for ch in range(9):
        assert psnr(pred[..., ch], scene.test_images[..., ch]) > 18
    h = result.history
    assert h["loss"][-40:].mean() < 0.5 * h["loss"][:40].mean()
    assert result.alive.sum() > 96 and result.alive.size == 192  # densified inside the fixed buffer


@pytest.mark.slow
def test_unmeasured_channels_do_not_matter_and_resume_is_exact(scene, tmp_path):
    cfg = tiny(30, checkpoint=tmp_path / "ckpt.npz", checkpoint_every=10, capacity=96)
    images = scene.images.copy()
    junk = images + (1 - scene.weights) * np.random.default_rng(0).uniform(size=images.shape)
    straight = train(scene.capture, images, scene.weights, config=cfg, bounds=scene.bounds)
    noisy = train(scene.capture, junk.astype(np.float32), scene.weights, config=cfg, bounds=scene.bounds)
    np.testing.assert_array_equal(straight.gaussians.colour_params, noisy.gaussians.colour_params)

    class Crash(Exception):
        pass

    def crash(step, state, loss):
        if step == 25:
            raise Crash

    with pytest.raises(Crash):
        train(scene.capture, images, scene.weights, config=cfg, bounds=scene.bounds, callback=crash)
    resumed = train(
        scene.capture, images, scene.weights, config=cfg, bounds=scene.bounds, resume=tmp_path / "ckpt.npz"
    )
    assert resumed.state.step == 30 and len(resumed.history["loss"]) == 10
    np.testing.assert_allclose(resumed.gaussians.means, straight.gaussians.means, atol=1e-6)
    np.testing.assert_array_equal(resumed.alive, straight.alive)


@pytest.mark.slow
def test_errors(scene, tmp_path):
    with pytest.raises(SplatError, match="shape"):
        train(scene.capture, scene.images[:3], scene.weights[:3], config=tiny(2), bounds=scene.bounds)
    state = init_state(tiny(2, capacity=64), bounds=scene.bounds, n_channels=9)
    assert int(state.alive.sum()) == 32
    from splat import load_checkpoint, save_checkpoint

    save_checkpoint(state, tmp_path / "s.npz")
    other = init_state(tiny(2, capacity=32), bounds=scene.bounds, n_channels=9)
    with pytest.raises(SplatError, match="capacity"):
        load_checkpoint(tmp_path / "s.npz", other)


@pytest.mark.slow
def test_exposure_refinement_recovers_wrong_exif(tmp_path):
    """Views whose EXIF exposure is off by a known factor: with the true Gaussians fixed (all Gaussian
    learning rates 0), training the log-exposures alone must find the factors; the reference view of
    each camera stays exactly at its EXIF exposure."""
    import dataclasses

    from splat import Capture, load_checkpoint, save_checkpoint

    sc = synthetic_scene(
        SceneConfig(views_per_camera=2, test_views_per_camera=1, noise=(0.0, 0.0), width=16, height=16)
    )
    V = len(sc.capture.views)
    rng = np.random.default_rng(3)
    factor = np.exp(rng.uniform(-0.25, 0.25, V))  # true exposure = EXIF × factor
    ids = [v.camera_id for v in sc.capture.views]
    refs = [ids.index(c) for c in sorted(set(ids))]  # one view per camera id
    assert len(refs) == 3
    factor[refs] = 1.0
    views = tuple(dataclasses.replace(v, exposure=v.exposure / f) for v, f in zip(sc.capture.views, factor))
    cap = Capture(views, sc.capture.channels, sc.capture.labels)
    zero = dict(lr_means=0.0, lr_log_scales=0.0, lr_quats=0.0, lr_opacity=0.0, lr_colours=0.0)
    cfg = TrainConfig(
        steps=100,
        capacity=sc.truth.n,
        densify_from=10_000,
        refine_exposure=True,
        lr_exposure=0.05,
        method="reference",  # the renderer of the scene's images (the tiled one would drop Gaussians)
        render=RenderConfig(chunk=64),
        checkpoint=tmp_path / "ckpt.npz",
        **zero,
    )
    start = init_state(cfg, bounds=sc.bounds, n_channels=9, points=sc.truth.means, n_views=V)
    save_checkpoint(start._replace(params=sc.truth), tmp_path / "start.npz")
    res = train(
        cap,
        sc.images,
        sc.weights,
        config=cfg,
        bounds=sc.bounds,
        resume=tmp_path / "start.npz",
        reference_views=refs,
    )
    np.testing.assert_array_equal(res.exposure_factors[refs], 1.0)
    np.testing.assert_allclose(res.exposure_factors, factor, rtol=0.01)
    np.testing.assert_array_equal(res.gaussians.colour_params, sc.truth.colour_params)
    # without refinement there is nothing to learn, and a checkpoint of one kind does not load into the other
    plain = init_state(tiny(1, capacity=sc.truth.n), bounds=sc.bounds, n_channels=9)
    assert plain.log_exposure is None and plain.exposure_opt is None
    with pytest.raises(SplatError, match="refine_exposure"):
        load_checkpoint(tmp_path / "ckpt.npz", plain)
    with pytest.raises(SplatError, match="no reference view"):
        train(cap, sc.images, sc.weights, config=cfg, bounds=sc.bounds, reference_views=refs[:2])
    with pytest.raises(SplatError, match="n_views"):
        init_state(cfg, bounds=sc.bounds, n_channels=9)


def test_centre_rate_decays_to_its_own_final_value():
    """After ``steps`` Adam steps of a constant gradient every update is ±rate · final, with the centres'
    final ratio ``lr_means_final`` and the other fields' ``lr_final``."""
    from splat.training import _optimiser

    g = init_state(TrainConfig(capacity=4), bounds=np.array([[0.0, 0, 0], [1, 1, 1]]), n_channels=3).params
    grads = jax.tree.map(jnp.ones_like, g)
    for final, expect in ((0.03, 0.03), (None, 0.3)):
        cfg = TrainConfig(steps=10, lr_final=0.3, lr_means_final=final)
        opt = _optimiser(cfg, extent=2.0)
        state = opt.init(g)
        for _ in range(11):  # the 11th update uses the rate at count = steps
            upd, state = opt.update(grads, state, g)
        np.testing.assert_allclose(np.asarray(upd.means), -cfg.lr_means * 2.0 * expect, rtol=1e-5)
        np.testing.assert_allclose(np.asarray(upd.colour_params), -cfg.lr_colours * 0.3, rtol=1e-5)


def test_recycling_frees_the_faintest_gaussians_of_a_full_buffer():
    from splat.training import _densify

    cfg = TrainConfig(
        capacity=8, densify_fraction=0.25, prune_opacity=0.005, split_scale=1.0, recycle_opacity=0.0
    )
    st = init_state(cfg, bounds=np.array([[0.0, 0, 0], [1, 1, 1]]), n_channels=3)
    p = st.params
    opacity = np.array([0.9, 0.02, 0.9, 0.04, 0.9, 0.9, 0.01, 0.9])
    p = dataclasses.replace(
        p,
        opacity_logits=jnp.asarray(np.log(opacity / (1 - opacity)), jnp.float32),
        log_scales=jnp.full((8, 3), np.log(0.01), jnp.float32),
    )
    grad = np.array([0.0, 0, 5, 0, 3, 0, 0, 1])
    st = st._replace(params=p, alive=jnp.ones(8, bool), grad_accum=jnp.asarray(grad), grad_count=jnp.ones(8))
    unchanged = _densify(st, cfg, extent=1.0)  # full buffer, no recycling: nothing to add
    np.testing.assert_array_equal(np.asarray(unchanged.params.means), np.asarray(p.means))
    out = _densify(st, dataclasses.replace(cfg, recycle_opacity=0.05), extent=1.0)
    # 0.25 · 8 = 2 new Gaussians: the two faintest (slots 6 and 1) become clones of the two with the
    # largest positional gradient (slots 2 and 4); slot 3 (0.04) stays
    assert np.asarray(out.alive).all()
    m = np.asarray(out.params.means)
    np.testing.assert_array_equal(m[[1, 6]], np.asarray(p.means)[[2, 4]])
    np.testing.assert_array_equal(m[3], np.asarray(p.means)[3])


def test_train_step_weighs_errors_with_the_configured_loss_offset(scene):
    """``TrainConfig.loss_offset`` is the ε of the loss each step reports: the step's loss equals
    ``rawnerf_loss(exposure · render, image, weight, offset=ε)`` of the state it started from."""
    from splat import train_step

    v = 0
    cam = scene.capture.views[v].camera
    img, w = jnp.asarray(scene.images[v]), jnp.asarray(scene.weights[v])
    mask = jnp.ones(img.shape[-1])
    losses = []
    for eps in (1e-3, 0.05):
        cfg = tiny(2, capacity=64, loss_offset=eps)
        state = init_state(cfg, bounds=scene.bounds, n_channels=9)
        _, loss, _ = train_step(state, cam, img, w, mask, 1.3, config=cfg, extent=1.0)
        pred = render_views(state.params, [cam], mask=state.alive, config=cfg.render)[0]
        np.testing.assert_allclose(
            float(loss), float(rawnerf_loss(1.3 * pred, img, w, offset=eps)), rtol=1e-4
        )
        losses.append(float(loss))
    assert losses[0] > 2 * losses[1]  # the larger ε weighs the same errors less


@pytest.mark.parametrize(
    "bad",
    [
        {"lr_means_final": 0.0},
        {"lr_means_final": 2.0},
        {"recycle_opacity": 1.0},
        {"loss_offset": 0.0},
        {"loss_offset": -1e-3},
        {"loss_offset": float("inf")},
        {"densify_gradient": "pixels"},
        {"flatten_weight": -1.0},
        {"flatten_weight": float("nan")},
    ],
)
def test_rate_and_recycling_options_are_checked(bad):
    with pytest.raises(SplatError, match=next(iter(bad))):
        TrainConfig(**bad)


def test_flatten_weight_thins_the_smallest_axis_of_alive_gaussians_only():
    """With nothing to fit (zero weights) the only gradient is the flatness penalty's: its value is
    ``λ · Σ_alive min(s) / (n_alive · extent)``, so one step moves exactly the smallest log-scale of each
    alive Gaussian (down, by Adam's first step ≈ the rate), nothing else, and the step reports the data
    loss (0), not the penalty."""
    from splat import look_at, train_step

    cam = look_at((0, -3, 0), (0, 0, 0), width=16, height=16)
    img, w, mask = jnp.zeros((16, 16, 3)), jnp.zeros((16, 16, 3)), jnp.ones(3)
    bounds = np.array([[-1.0, -1, -1], [1, 1, 1]])
    for lam in (0.0, 5.0):
        cfg = tiny(2, capacity=8, flatten_weight=lam)
        st = init_state(cfg, bounds=bounds, n_channels=3, n_init=5)
        ls = np.log(np.random.default_rng(1).uniform(0.02, 0.2, (8, 3)))
        st = st._replace(params=dataclasses.replace(st.params, log_scales=jnp.asarray(ls, jnp.float32)))
        new, loss, _ = train_step(st, cam, img, w, mask, 1.0, config=cfg, extent=2.0)
        assert float(loss) == 0.0
        d = np.asarray(new.params.log_scales) - np.asarray(st.params.log_scales)
        if lam == 0:
            np.testing.assert_array_equal(d, 0)
            continue
        smallest = np.arange(3)[None] == np.argmin(ls, axis=1)[:, None]
        moved = smallest & (np.arange(8) < 5)[:, None]
        np.testing.assert_allclose(d[moved], -cfg.lr_log_scales, rtol=1e-3)
        np.testing.assert_array_equal(d[~moved], 0)
        for k in ("means", "quats", "opacity_logits", "colour_params"):
            np.testing.assert_array_equal(getattr(new.params, k), getattr(st.params, k))


def test_screen_gradient_does_not_favour_near_gaussians():
    """``densify_gradient="screen"`` ranks Gaussians by the gradient of their pixel position: a
    Gaussian twice as far and twice as large projects to the same 2-D Gaussian and gets the same
    statistic, while the world-space gradient of its centre halves."""
    from splat import look_at, train_step

    cam = look_at((0, -3, 0), (0, 0, 0), width=24, height=24)
    img = jnp.zeros((24, 24, 3)).at[8:14, 10:16].set(0.4)
    w, mask = jnp.ones((24, 24, 3)), jnp.ones(3)
    near = np.array([0.05, 0.0, 0.03])
    eye = np.array([0.0, -3.0, 0.0])
    stats = {}
    for kind in ("world", "screen"):
        cfg = tiny(2, capacity=1, densify_gradient=kind)
        for d in (1.0, 2.0):
            st = init_state(cfg, bounds=np.array([[-1.0, -1, -1], [1, 1, 1]]), n_channels=3, n_init=1)
            p = dataclasses.replace(
                st.params,
                means=jnp.asarray([eye + d * (near - eye)], jnp.float32),
                log_scales=jnp.asarray([[np.log(0.08 * d), np.log(0.03 * d), np.log(0.05 * d)]], jnp.float32),
                opacity_logits=jnp.zeros(1),
                colour_params=jnp.zeros((1, 3)),
            )
            st, _, _ = train_step(st._replace(params=p), cam, img, w, mask, 1.0, config=cfg, extent=1.0)
            stats[kind, d] = float(st.grad_accum[0])
    assert stats["screen", 1.0] > 0
    np.testing.assert_allclose(stats["screen", 2.0], stats["screen", 1.0], rtol=1e-3)
    np.testing.assert_allclose(stats["world", 2.0], 0.5 * stats["world", 1.0], rtol=1e-3)


def test_absolute_gradient_ranks_a_gaussian_over_texture_whose_signed_gradient_cancels():
    """``densify_gradient="absolute"`` (AbsGS): a large Gaussian centred on a point-symmetric
    checkerboard is pulled both ways, so its signed positional gradient cancels (``"screen"`` ranks it
    near zero) while the sum of the absolute per-pixel gradients does not; the statistic is the norm of
    the render's ``absgrad_probe`` gradient."""
    from splat import look_at, render, train_step
    from splat.training import rawnerf_loss

    cam = look_at((0, -3, 0), (0, 0, 0), width=24, height=24)
    yy, xx = np.meshgrid(np.arange(24), np.arange(24), indexing="ij")
    board = np.where((yy // 2 + xx // 2) % 2 == 0, 0.1, 0.5)
    img = jnp.asarray(np.repeat(board[..., None], 3, -1), jnp.float32)
    w, mask = jnp.ones((24, 24, 3)), jnp.ones(3)
    stats = {}
    for kind in ("screen", "absolute"):
        cfg = tiny(2, capacity=1, densify_gradient=kind)
        st = init_state(cfg, bounds=np.array([[-1.0, -1, -1], [1, 1, 1]]), n_channels=3, n_init=1)
        p = dataclasses.replace(
            st.params,
            means=jnp.zeros((1, 3)),
            log_scales=jnp.full((1, 3), np.log(0.15), jnp.float32),
            opacity_logits=jnp.zeros(1),
            colour_params=jnp.zeros((1, 3)),
        )
        out, _, _ = train_step(st._replace(params=p), cam, img, w, mask, 1.0, config=cfg, extent=1.0)
        stats[kind] = float(out.grad_accum[0])

    def loss(probe):
        pred = render(p, cam, config=cfg.render, absgrad_probe=probe).image
        return rawnerf_loss(pred, img, w * mask, offset=cfg.loss_offset)

    expected = float(jnp.linalg.norm(jax.grad(loss)(jnp.zeros((1, 2)))))
    assert stats["absolute"] > 0
    np.testing.assert_allclose(stats["absolute"], expected, rtol=1e-5)
    assert stats["screen"] < 1e-3 * stats["absolute"]


def test_gpu_capacity_schedule_overrides_are_checked_before_any_work():
    from benchmarks.gpu_capacity import _overrides

    got = _overrides(["densify_gradient=world", "densify_fraction=0.5", "refine_exposure=true"])
    assert got == {"densify_gradient": "world", "densify_fraction": 0.5, "refine_exposure": True}
    with pytest.raises(SystemExit, match="FIELD=VALUE"):
        _overrides(["capacity=5"])  # set by --capacities
    with pytest.raises(SystemExit, match="FIELD=VALUE"):
        _overrides(["densify_gradient"])
    with pytest.raises(SplatError, match="densify_gradient"):
        _overrides(["densify_gradient=pixel"])
