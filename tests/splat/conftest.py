"""Shared small scenes for the splat tests (tiny images keep the JAX compile time low)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

# pytest's default "prepend" import mode puts tests/ on sys.path, where this folder would shadow the
# real ``splat`` package as a namespace package when pytest is started as ``.venv/bin/pytest``
# (``python -m pytest`` has the repository root on sys.path already); a regular package anywhere
# on sys.path wins over namespace portions, so make sure the root is there.
_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)


def random_gaussians(G=120, N=4, *, seed=0, spread=1.0, dtype=None):
    import jax
    import jax.numpy as jnp

    from splat import init_gaussians

    r = np.random.default_rng(seed)
    g = init_gaussians(
        r.uniform(-spread, spread, (G, 3)),
        r.uniform(0.05, 0.9, (G, N)),
        scales=np.exp(r.uniform(np.log(0.04), np.log(0.15), G)),
        opacity=0.5,
        key=jax.random.key(seed),
        dtype=dtype or jnp.float32,
    )
    # varied opacities
    return type(g)(
        g.means, g.quats, g.log_scales, jnp.asarray(r.uniform(-2, 3, G), g.means.dtype), g.colour_params
    )


@pytest.fixture(scope="package")
def make_gaussians():
    """The factory :func:`random_gaussians` (G=120, N=4, *, seed, spread, dtype)."""
    return random_gaussians


@pytest.fixture(scope="package")
def small_scene():
    from splat import look_at

    g = random_gaussians()
    cam = look_at((0.4, -3.5, 0.8), (0, 0, 0), width=28, height=20, fov_deg=50)
    return g, cam
