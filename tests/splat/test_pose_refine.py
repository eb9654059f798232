"""Joint pose refinement (TrainConfig.refine_poses): the SE(3) correction, its gradient through the
projection, recovery of perturbed poses with the true Gaussians fixed, resume, options and plumbing."""

from __future__ import annotations

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from scipy.spatial.transform import Rotation

from splat import (
    Capture,
    RenderConfig,
    SplatError,
    TrainConfig,
    init_state,
    load_checkpoint,
    look_at,
    render,
    save_checkpoint,
    train,
)
from splat.camera import pose_corrected, so3_exp

ZERO_LR = dict(lr_means=0.0, lr_log_scales=0.0, lr_quats=0.0, lr_opacity=0.0, lr_colours=0.0)


def _angle_deg(Ra, Rb) -> float:
    c = (np.trace(np.asarray(Ra, float) @ np.asarray(Rb, float).T) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))))


def _centre(cam) -> np.ndarray:
    return -np.asarray(cam.R, float).T @ np.asarray(cam.t, float)


def test_so3_exp_matches_scipy_and_its_derivative_at_zero_is_the_generators():
    rng = np.random.default_rng(0)
    # tiny, both sides of the Taylor switch (θ² = 1e-4), moderate and large angles
    for theta in (0.0, 1e-6, 9.9e-3, 1.01e-2, 0.3, 2.5):
        axis = rng.normal(size=3)
        w = theta * axis / np.linalg.norm(axis)
        with jax.enable_x64(True):
            R = np.asarray(so3_exp(jnp.asarray(w, jnp.float64)))
        np.testing.assert_allclose(R, Rotation.from_rotvec(w).as_matrix(), atol=1e-14)
    np.testing.assert_array_equal(so3_exp(jnp.zeros(3)), np.eye(3))  # exactly the identity
    J = np.asarray(jax.jacfwd(so3_exp)(jnp.zeros(3)))  # (3, 3, 3): d R / d ω_i
    gens = np.zeros((3, 3, 3))
    for i in range(3):
        gens[i] = np.cross(np.eye(3)[i], np.eye(3)).T  # [e_i]×: column j is e_i × e_j
    np.testing.assert_array_equal(np.moveaxis(J, -1, 0), gens)
    # a batch, and a correction that is exactly 0 leaves the camera bit-for-bit unchanged
    Rb = so3_exp(jnp.asarray(rng.normal(size=(4, 2, 3)), jnp.float32))
    assert Rb.shape == (4, 2, 3, 3)
    cam = look_at((0.3, -3.0, 0.4), (0, 0, 0), width=10, height=8)
    same = pose_corrected(cam, jnp.zeros(6))
    np.testing.assert_array_equal(same.R, cam.R)
    np.testing.assert_array_equal(same.t, cam.t)
    with pytest.raises(SplatError, match="6-vector"):
        pose_corrected(cam, jnp.zeros(3))


def test_pose_correction_moves_the_centre_as_documented():
    with jax.enable_x64(True):
        cam = look_at((0.3, -3.0, 0.4), (0, 0, 0), width=10, height=8, dtype=jnp.float64)
        w, tau = np.array([0.02, -0.01, 0.03]), np.array([0.05, -0.02, 0.01])
        c = pose_corrected(cam, jnp.asarray(np.r_[w, tau]))
        R1 = Rotation.from_rotvec(w).as_matrix() @ np.asarray(cam.R)
        np.testing.assert_allclose(c.R, R1, atol=1e-14)
        # a rotation alone turns the camera about its own centre; τ moves the centre by −R'ᵀ τ
        np.testing.assert_allclose(_centre(pose_corrected(cam, jnp.asarray(np.r_[w, 0, 0, 0]))), _centre(cam))
        np.testing.assert_allclose(_centre(c), _centre(cam) - R1.T @ tau, atol=1e-14)


def test_render_gradient_wrt_pose_correction_passes_finite_differences(make_gaussians):
    """The pose enters the projection (centres, EWA Jacobian, rotation of the covariances; shared by both
    back-ends): the gradient of a rendered loss with respect to (ω, τ) matches central differences in
    float64."""
    with jax.enable_x64(True):
        g = make_gaussians(G=8, N=2, seed=3, spread=0.5, dtype=jnp.float64)
        cam = look_at((0.2, -3.0, 0.3), (0, 0, 0), width=10, height=8, fov_deg=40, dtype=jnp.float64)
        cfg = RenderConfig(  # a smooth footprint (no cut-offs) so that finite differences are meaningful
            alpha_min=0.0, sigma_cutoff=1e3, transmittance_min=0.0, chunk=4
        )
        w = jnp.asarray(np.random.default_rng(0).normal(size=(8, 10, 2)))

        @jax.jit
        def loss(xi):
            return jnp.sum(w * render(g, pose_corrected(cam, xi), method="reference", config=cfg).image)

        xi = jnp.asarray([0.01, -0.02, 0.015, 0.03, -0.01, 0.02])
        assert np.all(np.abs(np.asarray(jax.grad(loss)(xi))) > 1e-3)  # every component moves the image
        check_grads(loss, (xi,), order=1, modes=("rev",), eps=1e-6, atol=1e-5, rtol=1e-5)


RCFG = RenderConfig(chunk=32, background=0.3)


@pytest.fixture(scope="module")
def smooth():
    """Six 32 × 24 views around 150 Gaussians of 0.08–0.25 m in a 2 m cube, rendered exactly (no noise)
    over a grey background (on black, RawNeRF's relative loss makes the 1/255 alpha cut-off at every
    silhouette a jump that no gradient sees), all channels measured by one camera id."""
    from splat import View, init_gaussians

    r = np.random.default_rng(0)
    G = 150
    g = init_gaussians(
        r.uniform(-1, 1, (G, 3)),
        r.uniform(0.05, 0.9, (G, 3)),
        scales=np.exp(r.uniform(np.log(0.08), np.log(0.25), G)),
        opacity=0.5,
        key=jax.random.key(0),
    )
    g = type(g)(
        g.means, g.quats, g.log_scales, jnp.asarray(r.uniform(-1, 2, G), jnp.float32), g.colour_params
    )
    cams = [
        look_at((4 * np.cos(a), 4 * np.sin(a), 1 + 0.3 * np.sin(3 * a)), (0, 0, 0), width=32, height=24)
        for a in np.linspace(0, 2 * np.pi, 6, endpoint=False)
    ]
    images = np.stack([np.asarray(render(g, c, method="reference", config=RCFG).image) for c in cams])
    cap = Capture(tuple(View(f"v{i}", c, 1) for i, c in enumerate(cams)), {1: (0, 1, 2)}, ("R", "G", "B"))
    return g, cap, images, np.ones_like(images), np.array([[-1.5] * 3, [1.5] * 3])


def _reprojection_px(cam, true, X) -> float:
    def proj(c):
        p = X @ np.asarray(c.R, float).T + np.asarray(c.t, float)
        return np.asarray(c.focal, float) * p[:, :2] / p[:, 2:]

    return float(np.mean(np.linalg.norm(proj(cam) - proj(true), axis=1)))


@pytest.mark.slow
def test_pose_refinement_recovers_perturbed_poses_with_the_true_gaussians(smooth, tmp_path):
    """Four of six views perturbed by 1–2° and 1–3 % of the extent: with the true Gaussians held fixed,
    training the pose corrections alone brings every perturbed view's reprojection error (mean image
    displacement of the Gaussians' centres against the true camera) below 20 % of its perturbation and
    0.2 px; the two reference views keep their poses exactly.

    What the 32 × 24 images pin down is the projection: a turn about the image's y axis and a sideways
    shift of the centre move the picture almost alike (they differ only by the parallax of the scene's
    depth, ~0.1 px here), so the rotation and centre errors themselves fall only to 50–90 % in 100 steps.
    """
    g, cap0, images, weights, bounds = smooth
    V = len(cap0.views)
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))
    refs = [0, 3]
    rng = np.random.default_rng(7)
    perturb = np.zeros((V, 6))
    for v in set(range(V)) - set(refs):
        axis = rng.normal(size=3)
        perturb[v, :3] = np.radians(rng.uniform(1, 2)) * axis / np.linalg.norm(axis)
        d = rng.normal(size=3)
        perturb[v, 3:] = rng.uniform(0.01, 0.03) * extent * d / np.linalg.norm(d)
    views = tuple(
        dataclasses.replace(v, camera=pose_corrected(v.camera, jnp.asarray(p, jnp.float32)))
        for v, p in zip(cap0.views, perturb)
    )
    cap = Capture(views, cap0.channels, cap0.labels)
    cfg = TrainConfig(
        steps=100,
        capacity=g.n,
        densify_from=10_000,
        method="reference",  # the renderer of the images
        render=RCFG,
        refine_poses=True,
        lr_pose_rot=5e-3,
        lr_pose_trans=5e-3,
        **ZERO_LR,
    )
    start = init_state(cfg, bounds=bounds, n_channels=3, points=g.means, n_views=V)
    save_checkpoint(start._replace(params=g), tmp_path / "start.npz")
    res = train(
        cap,
        images,
        weights,
        config=cfg,
        bounds=bounds,
        resume=tmp_path / "start.npz",
        pose_reference_views=refs,
    )
    np.testing.assert_array_equal(res.pose_corrections[refs], 0.0)
    np.testing.assert_array_equal(res.gaussians.means, g.means)
    X = np.asarray(g.means, float)
    for v in set(range(V)) - set(refs):
        true = cap0.views[v].camera
        fixed = pose_corrected(views[v].camera, jnp.asarray(res.pose_corrections[v], jnp.float32))
        e0, e1 = _reprojection_px(views[v].camera, true, X), _reprojection_px(fixed, true, X)
        rot0, rot1 = _angle_deg(views[v].camera.R, true.R), _angle_deg(fixed.R, true.R)
        c0 = np.linalg.norm(_centre(views[v].camera) - _centre(true))
        c1 = np.linalg.norm(_centre(fixed) - _centre(true))
        print(
            f"view {v}: reprojection {e0:.3f} → {e1:.3f} px, rotation {rot0:.3f} → {rot1:.3f}°, "
            f"centre {c0 / extent:.4f} → {c1 / extent:.4f} extent"
        )
        assert e1 <= 0.2 * e0 and e1 <= 0.2, (v, e0, e1)
        assert rot1 < rot0 and c1 < c0, (v, rot0, rot1, c0, c1)


@pytest.mark.slow
def test_refine_poses_off_adds_nothing_and_resume_keeps_the_corrections(smooth, tmp_path):
    _, cap, images, weights, bounds = smooth
    V = len(cap.views)
    base = dict(steps=12, capacity=64, densify_from=4, densify_every=4, densify_until=9, checkpoint_every=4)
    base.update(method="reference", render=RCFG)
    # off: no pose state and no pose arrays in a checkpoint (the format of earlier checkpoints)
    plain = init_state(TrainConfig(**base), bounds=bounds, n_channels=3, n_views=V)
    assert plain.pose_delta is None and plain.pose_opt is None
    save_checkpoint(plain._replace(step=5), tmp_path / "p.npz")
    with np.load(tmp_path / "p.npz") as f:
        assert not [k for k in f.files if k.startswith("pose_")]

    # on: a run killed at step 10 and resumed from its step-8 checkpoint ends where a straight run does
    cfg = TrainConfig(
        **base, refine_poses=True, lr_pose_rot=5e-3, lr_pose_trans=5e-3, checkpoint=tmp_path / "c.npz"
    )
    straight = train(cap, images, weights, config=cfg, bounds=bounds)
    moved = np.any(straight.pose_corrections != 0, axis=1)
    from splat.training import _pose_reference_views, stack_cameras

    refs = _pose_reference_views(stack_cameras(v.camera for v in cap.views))  # the farthest pair
    assert moved.sum() == V - 2 and not moved[refs].any()

    class Crash(Exception):
        pass

    def crash(step, state, loss):
        if step == 10:
            raise Crash

    with pytest.raises(Crash):
        train(cap, images, weights, config=cfg, bounds=bounds, callback=crash)
    with np.load(tmp_path / "c.npz") as f:
        assert int(f["step"]) == 8 and [k for k in f.files if k.startswith("pose_")]
    resumed = train(cap, images, weights, config=cfg, bounds=bounds, resume=tmp_path / "c.npz")
    assert resumed.state.step == 12 and len(resumed.history["loss"]) == 4
    np.testing.assert_allclose(resumed.pose_corrections, straight.pose_corrections, atol=1e-7)
    np.testing.assert_allclose(resumed.gaussians.means, straight.gaussians.means, atol=1e-6)

    # a checkpoint without pose corrections (refine_poses off, or written before they existed) resumes
    # with refinement starting at 0; one with corrections does not load without refinement
    like = init_state(cfg, bounds=bounds, n_channels=3, n_views=V)
    old = load_checkpoint(tmp_path / "p.npz", like)
    assert old.step == 5
    np.testing.assert_array_equal(old.pose_delta, 0.0)
    np.testing.assert_array_equal(old.params.means, plain.params.means)
    no_pose = init_state(TrainConfig(**base), bounds=bounds, n_channels=3)
    with pytest.raises(SplatError, match="refine_poses"):
        load_checkpoint(tmp_path / "c.npz", no_pose)
    fewer = init_state(cfg, bounds=bounds, n_channels=3, n_views=V - 1)
    with pytest.raises(SplatError, match="number of views"):
        load_checkpoint(tmp_path / "c.npz", fewer)


def test_bad_pose_options_raise_splat_errors(smooth):
    for bad in (dict(lr_pose_rot=-1e-3), dict(lr_pose_trans=float("nan")), dict(lr_pose_trans="0.1")):
        with pytest.raises(SplatError, match=next(iter(bad))):
            TrainConfig(refine_poses=True, **bad)
    _, cap, images, weights, bounds = smooth
    cfg = TrainConfig(steps=1, capacity=32, refine_poses=True)
    for refs in ([], [0, 99], [-1, 2]):
        with pytest.raises(SplatError, match="pose_reference_views"):
            train(cap, images, weights, config=cfg, bounds=bounds, pose_reference_views=refs)
    with pytest.raises(SplatError, match="n_views"):
        init_state(cfg, bounds=bounds, n_channels=3)


def test_default_reference_views_are_the_farthest_pair():
    from splat.training import _pose_reference_views, stack_cameras

    views = [look_at((np.cos(a), np.sin(a), 0.1 * a), (0, 0, 0), width=8, height=6) for a in (0, 1, 2.5, 4)]
    cams = stack_cameras(views)
    c = np.array([_centre(v) for v in views])
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    i, j = _pose_reference_views(cams)
    assert i < j and d[i, j] == d.max()


def test_cli_and_pipeline_plumbing(smooth, tmp_path):
    """--refine-poses reaches TrainConfig; the render step's views get the corrections written to
    train/summary.json, held-out (uncorrected) views keep their poses."""
    from splat.capture import PipelineConfig, refined_views, train_config
    from splat.cli import _parser

    args = _parser().parse_args(["train", "cap", "-o", "out", "--refine-poses"])
    assert args.refine_poses and not _parser().parse_args(["run", "cap", "-o", "out"]).refine_poses
    assert train_config(PipelineConfig(refine_poses=True)).refine_poses
    assert not train_config(PipelineConfig()).refine_poses
    views = list(smooth[1].views[:3])
    assert refined_views(views, tmp_path) == views  # no training summary: nothing to apply
    xi = [0.01, -0.02, 0.005, 0.03, 0.0, -0.01]
    (tmp_path / "train").mkdir()
    (tmp_path / "train" / "summary.json").write_text(json.dumps({"pose_corrections": {views[1].name: xi}}))
    out = refined_views(views, tmp_path)
    assert out[0] is views[0] and out[2] is views[2]
    want = pose_corrected(views[1].camera, jnp.asarray(xi, jnp.float32))
    np.testing.assert_allclose(out[1].camera.R, want.R, atol=1e-7)
    np.testing.assert_allclose(out[1].camera.t, want.t, atol=1e-7)
    assert out[1].name == views[1].name and out[1].exposure == views[1].exposure
