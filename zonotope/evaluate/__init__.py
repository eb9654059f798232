"""Evaluation harness: CIEDE2000 of every estimator on natural and atypical reflectance sets.

For a camera set (1–3 cameras, channels stacked), an illuminant and a training set, every estimator
of :data:`zonotope.correct.CORRECTION_METHODS` is fitted once and applied to the responses of each
test set; the table reports ΔE00 mean / median / 95th percentile / max against the true target
colours, the fraction of regression estimates that lie inside the metamer mismatch volume (MMV),
the share of every estimator's answers that lie outside the MMV of its input (physically impossible
colours: no reflectance gives both, by the exact test
:func:`zonotope.mismatch.membership.outside_mmv_fraction`;
noise-free level only) and MMV volume statistics (XYZ units, Y_white = 1).

Noise levels
------------
Every row belongs to one noise level: noise-free, a constant σ, or a shot + read
:class:`~zonotope.correct.NoiseModel` (default :data:`DEFAULT_NOISE`: noise-free and two shot-limited
levels, low and high ISO). At each level every estimator is fitted for that noise through
:func:`zonotope.correct.noise_options` (so the regressions "Cheung 2004" and "Finlayson 2015" are the
noise-aware baselines) and applied to noisy held-out responses. The noise draws are seeded per camera
set and test set and shared by every method and every level (the same standard normal draws, scaled by
each level's σ per response): comparisons between methods and between levels are paired.

Test sets
---------
Built in (always available): ColorChecker N Ohta, CIE 1995 TCS, NIST CQS 9.0, and the seeded
atypical generator :func:`zonotope.spectra.atypical.atypical_reflectances`. With a data folder laid out
like ``../shared/data`` (see its README) also: a seeded subset of the 1269 matte Munsell chips,
the SFU 1995 Krinov natural surfaces and Vrhel objects (subsets), and the CIE 224:2017 colour
evaluation samples. Test reflectances are clipped to [0, 1] (a few measured values exceed 1 by
fluorescence or gloss; they would be outside the object-colour solid). A second, independently written
atypical generator (:func:`zonotope.spectra.atypical.structured_reflectances`: multi-transition steps,
thin-film fringes, rough spectra) is the set "atypical B", so that an estimator tuned on one atypical
family can be checked on another.

Evaluation that cannot be tuned to
----------------------------------
Training and test reflectances are split by source: every test spectrum within ``exclude_within``
(default 0.02) of a training spectrum at every wavelength (L∞ distance) is removed from the test set
before anything is computed (the rawtoaces 190 training set holds ColorChecker, Munsell and Vrhel-like
samples; the notes say how many were removed per set). Besides the per-set rows, :class:`Evaluation`
keeps every sample's ΔE00, so it reports pooled mean / 95th percentile / max over all sets of one kind
(:meth:`Evaluation.pooled_stats`) and paired comparisons on the same samples
(:meth:`Evaluation.paired`: how often A beats B, and by how much).

Package layout
--------------
:mod:`~zonotope.evaluate.sets` (test sets and the training split) and
:mod:`~zonotope.evaluate.noise` (noise levels, labels and seeded draws) →
:mod:`~zonotope.evaluate.table` (:class:`Evaluation`: rows, pooled statistics, paired comparisons,
Markdown) → :mod:`~zonotope.evaluate.run` (:class:`EvaluationConfig`, :func:`evaluate`).
"""

from __future__ import annotations

from .noise import DEFAULT_NOISE as DEFAULT_NOISE  # the command line's and the tests' names
from .noise import _noise_levels as _noise_levels
from .noise import noise_label as noise_label
from .run import DEFAULT_METHODS, EvaluationConfig, evaluate
from .sets import (
    ATYPICAL_SEED,
    TestSet,
    atypical_test_set,
    atypical_test_sets,
    natural_test_sets,
    source_split,
)
from .table import Evaluation, EvaluationRow, PairedComparison

__all__ = [
    "ATYPICAL_SEED",
    "DEFAULT_METHODS",
    "Evaluation",
    "EvaluationConfig",
    "EvaluationRow",
    "PairedComparison",
    "TestSet",
    "atypical_test_set",
    "atypical_test_sets",
    "evaluate",
    "natural_test_sets",
    "source_split",
]
