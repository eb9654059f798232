"""On-disk cache of the costly part of a ``"Prior"`` fit: the atypical branch's MAP weights and radius
scale chosen by cross-validation (:func:`zonotope.correct.mmv.learn_mix`, hundreds of MMV centroids).

One small JSON file per fit, named by a key of everything the result depends on: the generators Φ and
Ψ (Ψ is the observer under the reference light, so fits for two references never share a file), the
training reflectances, the target-to-XYZ map, the fit's options, the noise (σ or model) and
the package and cache-format versions. A damaged or foreign file is refitted, not trusted.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np

from .noise import NoiseModel

__all__ = ["load_mix", "prior_fit_key", "save_mix"]

#: Bumped when the stored fields or their meaning change (older files are then refitted).
FORMAT = 1


def prior_fit_key(problem, config) -> str:
    """Hex key of a ``"Prior"`` fit of ``problem`` with ``config`` (a ``PriorConfig``)."""
    from .. import __version__

    h = hashlib.sha256()
    for a in (problem.Phi, problem.Psi, problem.training, problem.XYZ_from_target):
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    fields = {
        f.name: getattr(config, f.name)
        for f in dataclasses.fields(config)
        if f.name not in ("executor", "cache_dir", "noise")
    }
    noise = config.noise.key() if isinstance(config.noise, NoiseModel) else float(config.noise)
    h.update(repr((sorted(fields.items()), noise, __version__, FORMAT)).encode())
    return h.hexdigest()[:32]


def _path(cache_dir, key: str) -> Path:
    return Path(cache_dir) / f"prior-{key}.json"


def load_mix(cache_dir, key: str):
    """``(lam, mix_cv)`` stored for ``key``, or None (absent, damaged or of another format)."""
    path = _path(cache_dir, key)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("format") != FORMAT or data.get("key") != key:
            return None
        cv = dict(data["mix_cv"])
        cv["scores"] = {(float(a), float(b)): float(s) for a, b, s in cv["scores"]}
        for name in ("best", "one"):
            cv[name] = tuple(float(v) for v in cv[name])
        return tuple(float(v) for v in data["lam"]), cv
    except (OSError, ValueError, KeyError, TypeError):
        return None


def save_mix(cache_dir, key: str, lam, mix_cv: dict) -> Path:
    """Store ``(lam, mix_cv)`` for ``key`` (written atomically)."""
    from ..utilities.io import atomic_write_text

    cv = dict(mix_cv)
    cv["scores"] = [[a, b, s] for (a, b), s in mix_cv["scores"].items()]
    cv["best"], cv["one"] = list(mix_cv["best"]), list(mix_cv["one"])
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    text = json.dumps({"format": FORMAT, "key": key, "lam": list(lam), "mix_cv": cv})
    return atomic_write_text(_path(cache_dir, key), text)
