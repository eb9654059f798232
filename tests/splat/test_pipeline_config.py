"""splat.capture.PipelineConfig holds the train step's TrainConfig: the flat training options of older
callers set and read it, dataclasses.replace keeps it, and the train step passes it to splat.train as it
is (only the checkpoint path added)."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from splat import SplatError, TrainConfig
from splat.capture import TRAIN_OPTIONS, PipelineConfig, capture_train_config, train_config

_options = st.fixed_dictionaries(
    {},
    optional={
        "steps": st.integers(1, 20000),
        "capacity": st.integers(1, 1 << 16),
        "seed": st.integers(0, 1000),
        "refine_exposure": st.booleans(),
        "refine_poses": st.booleans(),
        "depth_weight": st.floats(0, 100, allow_nan=False),
    },
)


def _schedule(steps: int, densify_until=None) -> dict:
    """The capture schedule as its docstring states it (written out here, not read from the code)."""
    return {
        "checkpoint_every": max(50, steps // 10),
        "densify_from": min(200, steps // 5),
        "densify_until": int(0.7 * steps) if densify_until is None else densify_until,
        "densify_every": max(25, min(100, steps // 20)),
        "densify_fraction": 0.3,
    }


@given(_options)
def test_old_keywords_set_and_read_the_train_config(opts):
    cfg = PipelineConfig(**opts)
    assert isinstance(cfg.train, TrainConfig)
    defaults = {"steps": 3000, "capacity": 4096, "seed": 0, "refine_exposure": False, "refine_poses": False}
    defaults["depth_weight"] = TrainConfig().depth_weight
    want = {**defaults, **opts}
    for name, value in want.items():
        assert getattr(cfg, name) == getattr(cfg.train, name) == value
    for name, value in _schedule(want["steps"]).items():
        assert getattr(cfg.train, name) == value
    assert cfg.densify_until == cfg.train.densify_until
    assert cfg.train == capture_train_config(**opts)
    # untouched TrainConfig fields keep TrainConfig's defaults
    assert cfg.train.lr_means == TrainConfig().lr_means and cfg.train.checkpoint is None


@given(_options, st.sampled_from(["Prior", "Centroid"]), st.integers(1, 5000))
def test_round_trip_through_train_and_replace(opts, method, steps):
    cfg = PipelineConfig(method=method, quantum=0.02, **opts)
    again = PipelineConfig(train=cfg.train, method=method, quantum=0.02)
    assert again == cfg and again.train is cfg.train
    assert dataclasses.replace(cfg, novel=2).train is cfg.train  # other options leave it alone
    custom = dataclasses.replace(cfg.train, lr_means=5e-4, densify_every=7)
    assert PipelineConfig(train=custom).train is custom  # a given TrainConfig is kept exactly
    assert dataclasses.replace(
        PipelineConfig(train=custom), seed=custom.seed + 1
    ).train == dataclasses.replace(custom, seed=custom.seed + 1)
    # a new step count moves the schedule with it, and keeps what was set by hand
    moved = dataclasses.replace(PipelineConfig(train=custom), steps=steps)
    assert moved.steps == steps and moved.train.lr_means == 5e-4 and moved.train.densify_every == 7
    for name, value in _schedule(steps).items():
        if name != "densify_every":
            assert getattr(moved.train, name) == value
    kept = dataclasses.replace(PipelineConfig(densify_until=0), steps=steps, densify_until=0)
    assert kept.train.densify_until == 0
    assert dataclasses.asdict(cfg)["train"] == dataclasses.asdict(cfg.train)


def test_the_mapping_names_train_config_fields_and_class_reads_give_the_defaults():
    fields = {f.name for f in dataclasses.fields(TrainConfig)}
    assert set(TRAIN_OPTIONS) <= fields
    assert not set(TRAIN_OPTIONS) & {f.name for f in dataclasses.fields(PipelineConfig)}
    assert PipelineConfig.steps == 3000 and PipelineConfig.capacity == 4096
    assert PipelineConfig.depth_weight == TrainConfig().depth_weight


@pytest.mark.parametrize(
    "bad, match",
    [
        ({"train": {"steps": 3}}, "train=.*TrainConfig"),
        ({"train": TrainConfig(checkpoint="/tmp/elsewhere.npz")}, "train.checkpoint"),
        ({"train": TrainConfig(steps=0)}, "steps=0"),
        ({"steps": "300"}, "steps='300'"),
        ({"capacity": True}, "capacity=True"),
        ({"densify_until": -1}, "densify_until"),
        ({"depth_weight": float("inf")}, "depth_weight"),
    ],
)
def test_bad_training_options_are_one_line_errors(bad, match):
    with pytest.raises(SplatError, match=match):
        PipelineConfig(**bad)


def test_the_train_step_passes_exactly_config_train(tmp_path, monkeypatch):
    """What splat.train receives is config.train with the step's checkpoint: nothing derived again."""
    import splat.training
    from splat.capture import fit_step, poses_step

    from .capture_helpers import write_capture

    cap = tmp_path / "cap"
    write_capture(cap, views=3, holdout=1)
    custom = dataclasses.replace(capture_train_config(steps=40, capacity=64), lr_means=7e-4, densify_every=9)
    cfg = PipelineConfig(train=custom, threads=1)
    poses_step(cap, tmp_path / "out", config=cfg)
    seen = {}

    class Stop(Exception):
        pass

    def fake_train(*args, config, **kw):
        seen["config"] = config
        raise Stop

    monkeypatch.setattr(splat.training, "train", fake_train)
    with pytest.raises(Stop):
        fit_step(cap, tmp_path / "out", config=cfg)
    ckpt = tmp_path / "out" / "train" / "checkpoint.npz"
    assert seen["config"] == dataclasses.replace(cfg.train, checkpoint=seen["config"].checkpoint)
    assert seen["config"].checkpoint.resolve() == ckpt.resolve()
    assert seen["config"] == train_config(cfg, seen["config"].checkpoint)


def test_any_training_field_is_in_the_train_steps_key(tmp_path):
    """A TrainConfig field outside the old flat options (lr_means) also decides whether a model is reused."""
    from splat.capture import poses_step, read_capture
    from splat.capture.train import _train_settings
    from splat.capture.workspace import Workspace

    from .capture_helpers import write_capture

    cap = tmp_path / "cap"
    write_capture(cap, views=3, holdout=1)
    spec = read_capture(cap)
    a = PipelineConfig(steps=40, capacity=64, threads=1)
    b = PipelineConfig(train=dataclasses.replace(a.train, lr_means=2e-3), threads=1)
    poses_step(cap, tmp_path / "out", config=a)
    ws = Workspace(spec, tmp_path / "out")
    ka = ws.begin("train", _train_settings(spec, a))
    assert ws.begin("train", _train_settings(spec, a)) == ka
    assert ws.begin("train", _train_settings(spec, b)) != ka
