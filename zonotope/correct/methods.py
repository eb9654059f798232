"""Colour correction: from the responses of one or more cameras to the eye's XYZ (or LMS).

Every estimator maps source responses ``(..., k)`` (the channels of one or more cameras,
stacked) to target tristimulus values ``(..., m)``. They are fitted by :func:`fit_correction`
(``method=`` picks one of :data:`CORRECTION_METHODS`) on a :class:`CorrectionProblem`, which holds
the generator matrices Φ (camera) and Ψ (target) on one grid and the training reflectances.

Which estimator when
--------------------
``"Finlayson 2015"`` (root-polynomial regression)
    Best on natural, smooth reflectances (paints, Munsell chips, skin, foliage). Cheap. Can be far
    off (and even leave the metamer mismatch volume) for saturated, narrow-band or spiky spectra.
``"Cheung 2004"`` (least-squares k × m matrix) and ``"Dyer 2017"`` (ACES IDT matrix, 3 channels)
    Linear baselines: exposure-linear, never blow up, but less accurate than root-polynomials.
``"Centroid"``
    The volume centroid of the metamer mismatch volume (MMV): the best guess when nothing is known
    about the reflectance. Robust on atypical spectra, 3–5× worse than regression on natural ones.
``"Guarded"`` (default of :func:`~zonotope.correct.correct_image`)
    Noise-aware root-polynomial whose responses outside the training support (where it disagrees
    with the matrix more than on 97 % of the training responses) go to a matrix fitted on
    contrast-stretched training spectra; kept only where that helps on further stretched spectra
    (with one camera it is the root-polynomial). As good as the root-polynomial on natural colours
    and better than every regression on atypical ones with stacked cameras, at regression cost.
``"Projection"``
    Root-polynomial estimate moved onto the MMV (closest point in a locally linearised CIELAB
    metric) when it lies outside. Caps regression blow-ups; otherwise identical to regression.
``"Prior"`` (recommended default for unknown scenes)
    Posterior mean under a two-component prior on reflectances: *natural* (a Gaussian learnt from
    the training set) or *atypical* (any colour of the object-colour solid). The response decides,
    by Bayes' rule, how much of each conditional estimate to take: the projected regression for
    natural; for atypical a mix ``λ · MAP + (1 − λ) · MMV centroid`` whose ``λ`` is chosen by
    cross-validation on contrast-stretched training spectra (MAP is the better guess with one
    camera, the centroid with stacked ones; a second λ for MAP reflectances that the [0, 1] bounds
    cut off is kept where it beats one λ by more than a standard error). It behaves like
    regression on natural colours and like the better of MAP and centroid on atypical ones.
    Options: :class:`PriorConfig` or keywords.
    See :func:`fit_Prior`.

Module layout
-------------
:mod:`zonotope.correct.problem` (:class:`CorrectionProblem`, :class:`Corrector`) →
:mod:`zonotope.correct.regressions` (Cheung 2004, Finlayson 2015, Dyer 2017) →
:mod:`zonotope.correct.mmv` (Centroid, Projection, MAP, Prior) → this module (the
:data:`CORRECTION_METHODS` registry, :func:`fit_correction`, :func:`correct`). Import the public
names from here or from :mod:`zonotope`.

Target and ΔE convention
------------------------
The default target is the CIE 2015 2° XYZ observer with Y of the perfect white = 1
(``generators(..., normalise=1)``). CIE 2015 XYZ is by construction a fixed linear transform of the
Stockman & Sharpe 2° cone fundamentals (CIE 170-2:2015), so the MMV in XYZ is the linear image of
the LMS one: centroids, containment and projections carry over exactly. CIELAB uses the white of
the illuminant, i.e. the XYZ of the perfect reflector, as reference. An LMS target is accepted too;
it is mapped to XYZ by the least-squares 3 × 3 matrix between the two observers on the grid
(exact for Stockman & Sharpe ↔ CIE 2015).

References
----------
.. [1] Cheung, V., Westland, S., Connah, D., & Ripamonti, C. (2004). A comparative study of the
   characterisation of colour cameras by means of neural networks and polynomial transforms.
   Coloration Technology, 120(1), 19–25.
.. [2] Finlayson, G. D., Mackiewicz, M., & Hurlbert, A. (2015). Color Correction Using
   Root-Polynomial Regression. IEEE TIP, 24(5), 1460–1470 (eq. 6 for the terms).
.. [3] Dyer, S., et al. (2017). RAW to ACES (rawtoaces) v1; colour.matrix_idt.
.. [4] Logvinenko, A. D., Funt, B., & Godau, C. (2014). Metamer mismatching. IEEE TIP, 23(1).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._errors import OptionError
from .._tol import DELTA_SIGMAS
from ..utilities.registry import MethodRegistry
from .guarded import fit_Guarded
from .mmv import (
    PriorConfig,
    fit_Centroid,
    fit_MAP,
    fit_Prior,
    fit_Projection,
    mmv_centroids,
    select_regression,
)
from .neutral import white_point_option
from .noise import (
    NoiseModel,
    NoiseModelError,
    estimate_noise,
    noise_from_profile,
    noise_model,
    parse_noise,
)
from .problem import CorrectionProblem, Corrector, check_reflectances, correction_problem
from .regressions import (
    REGRESSIONS,
    expected_normal_equations,
    fit_Cheung2004,
    fit_Dyer2017,
    fit_Finlayson2015,
    root_polynomial_terms,
)

__all__ = [
    "CORRECTION_METHODS",
    "DELTA_SIGMAS",
    "IMAGE_METHOD",
    "CorrectionProblem",
    "Corrector",
    "NoiseModel",
    "NoiseModelError",
    "PriorConfig",
    "check_reflectances",
    "correct",
    "correction_problem",
    "estimate_noise",
    "expected_normal_equations",
    "fit_Centroid",
    "fit_Cheung2004",
    "fit_Dyer2017",
    "fit_Finlayson2015",
    "fit_Guarded",
    "fit_MAP",
    "fit_Prior",
    "fit_Projection",
    "fit_correction",
    "mmv_centroids",
    "noise_from_profile",
    "noise_model",
    "noise_options",
    "parse_noise",
    "root_polynomial_terms",
    "select_regression",
]

#: Estimators by name → fitting function ``fit(problem, **options) → Corrector``.
#:
#: Properties of each entry (``CORRECTION_METHODS.properties(name)``):
#:
#: ``closed_form``
#:     The estimate is a fixed, cheap function of the response (a regression): images are
#:     corrected pixel by pixel without the unique-colour cache, and ``evaluate`` reports how often
#:     its estimates leave the MMV.
#: ``needs_mmv``
#:     Fitting or applying it computes metamer mismatch volumes (the costly part of its run time).
#: ``centroid``
#:     The estimate *is* the MMV volume centroid (``evaluate`` computes it once together with the
#:     MMV volumes; its options are ``eps`` and ``delta`` instead of ``noise``).
#: ``noise_option``
#:     How it is told the responses' noise σ (:func:`noise_options`): ``"noise"`` (it accepts
#:     ``noise=σ``: training on noisy replicas / noisy evidence), ``"delta"`` (the MMV's response
#:     tolerance ``delta = DELTA_SIGMAS · σ``) or ``None`` (it ignores noise).
#: ``white_point``
#:     The default of its ``white_point`` option (every entry takes one): True adds the estimator's
#:     own offset along the achromatic axis near it
#:     (:func:`~zonotope.correct.neutral.white_point_preserving`), so that a response proportional to
#:     the white's maps to the white's colour at that luminance however noisy the responses it is
#:     fitted for (``docs/notes/2026-11-29-neutral-bias.md``).
#: ``image_default``
#:     True for exactly one entry: the estimator :func:`~zonotope.correct.correct_image` and
#:     ``zonotope correct`` fit when none is named (:data:`IMAGE_METHOD`), chosen by the evaluation
#:     table of ``docs/notes/2026-11-29-noise-default.md``.
CORRECTION_METHODS: MethodRegistry[Callable[..., Corrector]] = MethodRegistry("correction")

#: Default of each entry's ``white_point`` option (its registry property), from the measurements of
#: ``docs/notes/2026-11-29-neutral-bias.md``.
WHITE_POINT_DEFAULTS = {
    "Cheung 2004": False,
    "Finlayson 2015": False,
    "Dyer 2017": False,
    "Guarded": False,
    "Centroid": False,
    "Projection": False,
    "MAP": False,
    "Prior": False,
}


def _register(name: str, fit: Callable[..., Corrector], **properties) -> None:
    """Register ``fit`` under ``name`` with its ``white_point`` option (:func:`white_point_option`)."""
    default = WHITE_POINT_DEFAULTS[name]
    CORRECTION_METHODS.register(
        name, white_point_option(fit, default=default), white_point=default, **properties
    )


for _name in REGRESSIONS:
    _entry = REGRESSIONS.method(_name)
    _register(_name, _entry.function, aliases=_entry.aliases, **_entry.properties)
_register(
    "Guarded",
    fit_Guarded,
    aliases=("guarded root-polynomial", "guarded regression"),
    closed_form=True,
    needs_mmv=False,
    centroid=False,
    noise_option="noise",
    image_default=True,
)
_register(
    "Centroid",
    fit_Centroid,
    aliases=("mmv centroid",),
    closed_form=False,
    needs_mmv=True,
    centroid=True,
    noise_option="delta",
)
_register(
    "Projection", fit_Projection, closed_form=False, needs_mmv=True, centroid=False, noise_option="noise"
)
_register("MAP", fit_MAP, closed_form=False, needs_mmv=False, centroid=False, noise_option="noise")
_register(
    "Prior",
    fit_Prior,
    aliases=("prior posterior",),
    closed_form=False,
    needs_mmv=True,
    centroid=False,
    noise_option="noise",
)

#: The estimator of whole images when none is named: the one registry entry with ``image_default``.
(IMAGE_METHOD,) = CORRECTION_METHODS.names(image_default=True)


def noise_options(method: str, sigma, *, registry: MethodRegistry | None = None) -> dict:
    """The :func:`fit_correction` options that tell ``method`` its responses carry noise ``sigma``.

    The one place turning a noise level into estimator options, read from the method's
    ``noise_option`` property, so that a newly registered estimator gets its noise in every
    consumer (evaluation, the batch command, saved corrections, capture pipelines).

    Parameters
    ----------
    method : str
        Key or alias of ``registry``.
    sigma : float, array_like of shape (k,) or NoiseModel
        Noise level (standard deviation) of the responses, one value or one per channel, or a
        :class:`NoiseModel` (shot + read per channel: passed whole to ``"noise"`` estimators, its σ at
        white per channel for a ``"delta"`` tolerance); ``None``, 0 or a zero model means noise-free.
    registry : MethodRegistry, optional
        Default :data:`CORRECTION_METHODS`.

    Returns
    -------
    dict
        ``{"noise": sigma}`` (property ``"noise"``; one σ per channel as
        ``NoiseModel.constant(sigma, k)``, the per-channel form every such estimator takes),
        ``{"delta": DELTA_SIGMAS * sigma}`` (property
        ``"delta"``: the MMV's response tolerance, see :data:`DELTA_SIGMAS`), or ``{}`` for a
        noise-free level or a method without a noise option (property ``None``).

    Examples
    --------
    >>> noise_options("Centroid", 0.01)
    {'delta': 0.03}
    >>> noise_options("least squares", 0.01), noise_options("idt", 0.01), noise_options("Prior", 0)
    ({'noise': 0.01}, {}, {})
    >>> noise_options("Prior", [0.01, 0.02, 0.01])["noise"].read
    array([ 0.0001,  0.0004,  0.0001])
    """
    registry = CORRECTION_METHODS if registry is None else registry
    option = registry.properties(method).get("noise_option")
    if isinstance(sigma, NoiseModel):
        if sigma.is_zero or option is None:
            return {}
        if option == "noise":
            return {"noise": sigma}
        sigma = sigma.sigma_white  # the tolerance must hold for every response level: σ at white
    if sigma is None or option is None or not np.any(np.asarray(sigma, dtype=np.float64) > 0):
        return {}
    if option == "noise":
        s = np.asarray(sigma, dtype=np.float64)
        if s.ndim == 1 and s.size > 1:  # one σ per channel: the estimators take it as a constant model
            return {"noise": NoiseModel.constant(s, s.size, source="constant σ per channel")}
        return {"noise": sigma}
    if option == "delta":
        scaled = DELTA_SIGMAS * np.asarray(sigma, dtype=np.float64)
        return {"delta": float(scaled) if scaled.ndim == 0 else scaled}
    raise OptionError(
        f"{registry.resolve(method)}: noise_option={option!r} in its registry entry; "
        "allowed: 'noise', 'delta' or None."
    )


def fit_correction(
    cameras_or_problem,
    *,
    method: str = "Prior",
    target=None,
    illuminant=None,
    shape=None,
    training=None,
    reference=None,
    **options,
) -> Corrector:
    """Fit an estimator (see :data:`CORRECTION_METHODS` and the module notes on which to use).

    Parameters
    ----------
    cameras_or_problem
        A :class:`CorrectionProblem`, or the camera(s) to build one from with the other keywords
        (:func:`correction_problem`).
    method
        Key of :data:`CORRECTION_METHODS` (case and punctuation ignored) or an alias such as
        ``"root-polynomial"``, ``"least squares"``, ``"idt"``.
    target, illuminant, shape, training, reference
        Passed to :func:`correction_problem` when cameras are given (defaults ``"CIE 2015 2°"``,
        ``"D65"``, the cameras' common grid, ``"rawtoaces 190"``, and the target seeing the scene's
        light; ``reference="D65"`` fits scene light → colours as under D65). A
        :class:`CorrectionProblem` already holds them, so giving them with one is an error rather
        than silently ignored.
    **options
        Passed to the fitting function (e.g. ``degree=3``, ``noise=0.01``); every method also takes
        ``white_point`` (default: its registry property): True maps responses proportional to the
        white's to the grey's colour (:func:`~zonotope.correct.white_point_preserving`), which removes
        the cast on greys of fits for noisy responses.

    Raises
    ------
    UnknownMethodError
        Unknown method (the message lists the valid ones).
    OptionError
        ``target``, ``illuminant``, ``shape``, ``training`` or ``reference`` given with a
        :class:`CorrectionProblem`.
    """
    name = CORRECTION_METHODS.resolve(method)
    setup = {
        "target": target,
        "illuminant": illuminant,
        "shape": shape,
        "training": training,
        "reference": reference,
    }
    if isinstance(cameras_or_problem, CorrectionProblem):
        given = [key for key, value in setup.items() if value is not None]
        if given:
            raise OptionError(
                f"fit_correction: {', '.join(given)} given with a CorrectionProblem, which already holds "
                "them; pass them to correction_problem(...) instead, or pass the cameras here."
            )
        problem = cameras_or_problem
    else:
        given = {key: value for key, value in setup.items() if value is not None}
        problem = correction_problem(cameras_or_problem, **given)  # its defaults for the rest
    return CORRECTION_METHODS[name](problem, **options)


def correct(responses, cameras, *, method: str = "Prior", **options) -> np.ndarray:
    """Estimate target XYZ from source responses in one call.

    Parameters
    ----------
    responses : array_like of shape (..., k)
        Linear, white-balanced responses (the perfect white gives 1 in every channel).
    cameras
        Camera(s) whose stacked channels produced ``responses``, or a :class:`CorrectionProblem`.
    method, **options
        See :func:`fit_correction`.

    Returns
    -------
    ndarray of shape (..., m)

    Examples
    --------
    >>> import numpy as np
    >>> XYZ = correct(np.array([0.2, 0.3, 0.25]), "Nikon 5100 (NPL)", method="root-polynomial",
    ...               shape=np.arange(400, 701, 10))
    >>> XYZ.shape
    (3,)
    """
    return fit_correction(cameras, method=method, **options)(responses)
