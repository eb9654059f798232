"""Noise levels of the evaluation: the defaults, their labels, checking, and the seeded draws."""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

from .._errors import OptionError
from ..correct.noise import NoiseModel, NoiseModelError, noise_model

__all__ = ["DEFAULT_NOISE", "noise_label"]

#: Noise levels evaluated by default: noise-free, and shot-limited noise of σ 0.002 and 0.005 at white
#: (low and high ISO of a current sensor, white-balanced; variance σ² · c per channel), the levels of
#: the decision record on the correction defaults, so that its table can be reproduced.
DEFAULT_NOISE: tuple = (
    0.0,
    NoiseModel.shot_limited(0.002, 1, source="shot-limited, σ 0.002 at white"),
    NoiseModel.shot_limited(0.005, 1, source="shot-limited, σ 0.005 at white"),
)


def noise_label(level) -> str:
    """Short name of a noise level in tables: ``"0"``, ``"σ 0.005"`` (constant σ), ``"shot σw 0.005"``
    (shot-limited, σ at white) or ``"SHOT:READ"`` (the ``--noise`` syntax), per channel if they differ."""
    if level is None or (isinstance(level, NoiseModel) and level.is_zero):
        return "0"
    if not isinstance(level, NoiseModel):
        s = np.atleast_1d(np.asarray(level, dtype=np.float64))
        return "0" if not np.any(s > 0) else "σ " + "/".join(f"{x:g}" for x in np.unique(s))
    shot, read = np.unique(level.shot), np.unique(level.read)
    if shot.size == 1 and read.size == 1:
        if read[0] == 0:
            return f"shot σw {np.sqrt(shot[0]):.3g}"
        if shot[0] == 0:
            return f"σ {np.sqrt(read[0]):.3g}"
        return f"{shot[0]:.3g}:{read[0]:.3g}"
    return "/".join(f"{a:.3g}:{b:.3g}" for a, b in zip(level.shot, level.read, strict=True))


def _noise_levels(what: str, noise) -> tuple:
    """``noise`` (one level: a number, a mapping, a NoiseModel; or a sequence of them) as a tuple of
    levels: None (noise-free), a σ or σ per channel, a NoiseModel. ``what`` names it in errors."""
    single = noise is None or isinstance(noise, int | float | dict | NoiseModel | np.ndarray)
    levels = [noise] if single else list(noise) if isinstance(noise, Sequence) else None
    if not levels or isinstance(noise, str):
        raise OptionError(
            f"{what}={noise!r}: give a noise level (0, a σ, a NoiseModel or "
            "{'shot': .., 'read': ..}) or a non-empty list of them."
        )
    out = []
    for level in levels:
        try:
            if isinstance(level, NoiseModel):
                k = level.k
            elif isinstance(level, dict):
                k = np.broadcast(
                    np.atleast_1d(level.get("shot", 0)), np.atleast_1d(level.get("read", 0))
                ).size
            else:
                k = max(np.size(level), 1)
            model = noise_model(level, k)
        except (TypeError, ValueError) as error:
            name = f"{what} {level!r}" if what.startswith("--") else f"{what}={level!r}"
            raise NoiseModelError(f"{name}: {str(error).split(': ', 1)[-1]}") from None
        if model is None:
            out.append(None)
        elif isinstance(level, NoiseModel | dict):
            out.append(model)
        else:
            out.append(float(level) if np.ndim(level) == 0 else np.asarray(level, dtype=np.float64))
    labels = [noise_label(level) for level in out]
    if len(set(labels)) != len(labels):
        raise OptionError(f"{what}: the levels {labels} repeat one; give each level once.")
    return tuple(out)


def _seed_of(seed: int, *names: str) -> list[int]:
    """Seed sequence of one (camera set, test set): stable across runs, methods and noise levels."""
    return [seed, *(zlib.crc32(n.encode()) for n in names)]
