"""The operations of a RAW pipeline, one pure function each (arrays in, arrays out).

Order of a standard development (see :func:`isp.default_pipeline`)::

    linearise → white_balance → demosaic → camera_to_XYZ (or apply_correction)
              → XYZ_to_linear_sRGB → tonemap → encode_sRGB → orient

Conventions: mosaics are ``(H, W)`` float arrays with a 2 × 2 Bayer pattern named by ``cfa``
(``"RGGB"`` ...); images are ``(..., 3)`` with channels last; linear values are relative to the
sensor's saturation (1.0) or to the white (Y = 1).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import colour
import numpy as np

from zonotope.utilities import MethodRegistry

from ._config import float_array
from ._errors import PipelineError, PipelineMethodError
from ._tol import WHITE_XY
from .cfa import CHANNEL_INDEX, cfa_masks, check_cfa
from .dng import D50_xy, DNGProfile

__all__ = [
    "DEMOSAIC_METHODS",
    "TONEMAP_METHODS",
    "XYZ_to_linear_sRGB",
    "apply_correction",
    "auto_bright_white",
    "camera_to_XYZ",
    "default_method",
    "demosaic",
    "demosaic_Malvar2004",
    "demosaic_Menon2007",
    "demosaic_bilinear",
    "encode_sRGB",
    "linearise",
    "matrix_XYZ_from_balanced",
    "mosaic",
    "orient",
    "tonemap",
    "tonemap_Reinhard2002",
    "tonemap_auto_bright",
    "tonemap_clip",
    "white_balance",
]


def _mosaic_array(x, what: str = "mosaic") -> np.ndarray:
    a = float_array(x, what)
    if a.ndim != 2 or a.shape[0] < 2 or a.shape[1] < 2:
        raise PipelineError(f"{what}: expected a Bayer mosaic of shape (H, W) with H, W ≥ 2; got {a.shape}.")
    return a


def _image_array(x, what: str = "image") -> np.ndarray:
    a = float_array(x, what)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise PipelineError(
            f"{what}: expected channels last, shape (..., 3); got {a.shape}. "
            "Demosaic a mosaic before this stage."
        )
    return a


def _finite(a: np.ndarray, what: str) -> None:
    if not np.all(np.isfinite(a)):
        raise PipelineError(f"{what}: contains NaN or inf ({int(np.sum(~np.isfinite(a)))} values).")


def _site_values(values2x2: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    H, W = shape
    return np.tile(values2x2, ((H + 1) // 2, (W + 1) // 2))[:H, :W]


def mosaic(rgb, *, cfa: str = "RGGB") -> np.ndarray:
    """Sample a full RGB image through a Bayer colour filter array.

    Parameters
    ----------
    rgb : array_like of shape (H, W, 3)
    cfa
        2 × 2 pattern.

    Returns
    -------
    ndarray of shape (H, W)
    """
    a = _image_array(rgb, "rgb")
    if a.ndim != 3:
        raise PipelineError(f"rgb: expected shape (H, W, 3); got {a.shape}.")
    return np.sum(a * cfa_masks(a.shape[:2], cfa), axis=-1)


# ---------------------------------------------------------------------------------------------
# Linearisation and white balance
# ---------------------------------------------------------------------------------------------


def linearise(mosaic, *, black_level, white_level: float, table=None, clip: bool = True) -> np.ndarray:
    """Raw values → linear values with 0 at black and 1 at saturation.

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
        Raw values.
    black_level : float or array_like of shape (2, 2)
        Black level per CFA site.
    white_level
        Saturation value (after ``table`` when given).
    table : array_like of shape (n,), optional
        DNG LinearizationTable, applied first (raw value ``v`` → ``table[min(v, n-1)]``).
    clip
        Clip the result to [0, 1] (negative noise and over-range values).

    Returns
    -------
    ndarray of shape (H, W), float64
    """
    m = _mosaic_array(mosaic)
    _finite(m, "mosaic")
    if table is not None:
        t = np.asarray(table, dtype=np.float64).ravel()
        m = t[np.clip(m, 0, t.size - 1).astype(np.int64)]
    black = _site_values(np.broadcast_to(np.asarray(black_level, dtype=np.float64), (2, 2)), m.shape)
    span = float(white_level) - black
    if np.any(span <= 0):
        raise PipelineError(f"white_level={white_level} must exceed the black level ({black.max()}).")
    out = (m - black) / span
    return np.clip(out, 0.0, 1.0) if clip else out


def white_balance(x, *, neutral, cfa: str | None = None, clip: bool = True) -> np.ndarray:
    """Divide each channel by the camera neutral, so that the scene white becomes (1, 1, 1).

    The neutral is first normalised to max 1, so every gain is ≥ 1 (as LibRaw does); with ``clip``
    saturated pixels stay white instead of turning magenta.

    Parameters
    ----------
    x : array_like of shape (H, W) with ``cfa``, or (..., 3)
        Linear mosaic or image.
    neutral : array_like of shape (3,)
        Camera response to the scene white (DNG AsShotNeutral), any positive scale.
    cfa
        Bayer pattern when ``x`` is a mosaic.
    clip
        Clip the result at 1.

    Returns
    -------
    ndarray of the shape of ``x``
    """
    n = np.asarray(neutral, dtype=np.float64).reshape(-1)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
        raise PipelineError(f"neutral: expected 3 positive finite values, got {n}.")
    gains = n.max() / n
    if cfa is not None:
        m = _mosaic_array(x)
        g2 = np.array([gains[CHANNEL_INDEX[c]] for c in check_cfa(cfa)]).reshape(2, 2)
        out = m * _site_values(g2, m.shape)
    else:
        out = _image_array(x) * gains
    return np.minimum(out, 1.0) if clip else out


# ---------------------------------------------------------------------------------------------
# Demosaicing
# ---------------------------------------------------------------------------------------------


def _colour_demosaicing():
    """Import colour-demosaicing, muting its scipy.ndimage.filters deprecation notice (not ours)."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning, message=".*scipy.ndimage")
        import colour_demosaicing
    return colour_demosaicing


def _padded(method: str, kernel: str, mosaic, cfa: str) -> np.ndarray:
    """colour-demosaicing's ``kernel`` on ``mosaic`` mirror-padded by the ``pad`` of ``method``'s entry.

    colour-demosaicing's bilinear and Malvar kernels use scipy's ``reflect`` border mode, which
    repeats the edge row and so puts samples of the wrong colour under the kernel, spoiling a 1–2
    pixel frame. numpy's ``reflect`` mirrors about the edge sample (x → -x, x → 2(H-1) - x): parity,
    hence the CFA colour of every padded site, is preserved, also for pads larger than the image.
    """
    fn = getattr(_colour_demosaicing(), kernel)
    m, cfa = _mosaic_array(mosaic), check_cfa(cfa)
    pad = DEMOSAIC_METHODS.properties(method)["pad"]
    H, W = m.shape
    out = fn(np.pad(m, pad, mode="reflect"), cfa)
    return np.asarray(out[pad : pad + H, pad : pad + W], dtype=np.float64)


def demosaic_bilinear(mosaic, *, cfa: str = "RGGB") -> np.ndarray:
    """Bilinear demosaicing (the method of the thesis).

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
    cfa
        2 × 2 pattern.

    Returns
    -------
    ndarray of shape (H, W, 3)

    Notes
    -----
    colour-demosaicing's implementation, on a mosaic mirror-padded by the entry's ``pad``.
    """
    return _padded("bilinear", "demosaicing_CFA_Bayer_bilinear", mosaic, cfa)


def demosaic_Malvar2004(mosaic, *, cfa: str = "RGGB") -> np.ndarray:
    """Malvar, He & Cutler (2004) gradient-corrected linear demosaicing.

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
    cfa
        2 × 2 pattern.

    Returns
    -------
    ndarray of shape (H, W, 3)

    References
    ----------
    Malvar, H. S., He, L., & Cutler, R. (2004). High-quality linear interpolation for demosaicing of
    Bayer-patterned color images. ICASSP 2004, vol. 3, 485–488 (the 5 × 5 filters of Fig. 2).
    """
    return _padded("Malvar 2004", "demosaicing_CFA_Bayer_Malvar2004", mosaic, cfa)


def demosaic_Menon2007(mosaic, *, cfa: str = "RGGB") -> np.ndarray:
    """Menon, Andriani & Calvagno (2007) directional filtering and a posteriori decision (DDFAPD).

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
    cfa
        2 × 2 pattern.

    Returns
    -------
    ndarray of shape (H, W, 3)

    References
    ----------
    Menon, D., Andriani, S., & Calvagno, G. (2007). Demosaicing With Directional Filtering and a
    posteriori Decision. IEEE TIP, 16(1), 132–141 (with the refining step of section IV).
    """
    return _padded("Menon 2007", "demosaicing_CFA_Bayer_Menon2007", mosaic, cfa)


#: Demosaicing algorithms by name (``demosaic(..., method=name)``; case and punctuation ignored).
#: Properties: ``pad``, the mirror padding in pixels (even, so the CFA phase is kept) that covers
#: the kernel's reach; ``default=True`` on the method every front end uses when none is named.
DEMOSAIC_METHODS: MethodRegistry[Callable[..., np.ndarray]] = MethodRegistry(
    "demosaicing", error=PipelineMethodError
)
DEMOSAIC_METHODS.register("bilinear", demosaic_bilinear, pad=2)
DEMOSAIC_METHODS.register("Malvar 2004", demosaic_Malvar2004, pad=4, default=True)
DEMOSAIC_METHODS.register("Menon 2007", demosaic_Menon2007, pad=8)


def default_method(table: MethodRegistry) -> str:
    """The name registered with ``default=True`` in ``table`` (exactly one per isp registry).

    Defaults of functions and of the ``isp`` command ask this, so the default is stated once, on
    its registry entry.
    """
    names = table.names(default=True)
    if len(names) != 1:
        raise PipelineError(
            f"{table!r}: expected one method registered with default=True; got {list(names)}."
        )
    return names[0]


def _resolve(method: str, table: MethodRegistry, what: str) -> str:
    return table.resolve(method, argument=what)


def demosaic(mosaic, *, cfa: str = "RGGB", method: str = default_method(DEMOSAIC_METHODS)) -> np.ndarray:
    """Reconstruct a full RGB image from a Bayer mosaic.

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
    cfa
        2 × 2 pattern.
    method
        Key of :data:`DEMOSAIC_METHODS` (case, spaces and punctuation ignored: ``"menon2007"``).

    Returns
    -------
    ndarray of shape (H, W, 3)

    Raises
    ------
    PipelineMethodError
        Unknown method (the message lists the valid ones).
    """
    m = _mosaic_array(mosaic)
    _finite(m, "mosaic")
    return DEMOSAIC_METHODS[_resolve(method, DEMOSAIC_METHODS, "method")](m, cfa=cfa)


# ---------------------------------------------------------------------------------------------
# Colour
# ---------------------------------------------------------------------------------------------


def matrix_XYZ_from_balanced(profile: DNGProfile, neutral) -> np.ndarray:
    """DNG camera → XYZ D50 matrix for *white-balanced* camera RGB (see :func:`white_balance`).

    Parameters
    ----------
    profile
        The camera's DNG profile (ColorMatrix1/2, ...).
    neutral : array_like of shape (3,)
        AsShotNeutral (the scene white's camera response).

    Returns
    -------
    ndarray of shape (3, 3)
        ``XYZ_D50 = M @ rgb_balanced``; ``M @ (1, 1, 1)`` is the D50 white with Y = 1.
    """
    n = np.asarray(neutral, dtype=np.float64)
    n = n / n.max()
    return profile.camera_to_XYZ_D50(n) @ np.diag(n)


def camera_to_XYZ(rgb, *, matrix) -> np.ndarray:
    """Apply a 3 × 3 camera → XYZ matrix to every pixel.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    matrix : array_like of shape (3, 3)
        ``XYZ = matrix @ rgb`` (e.g. :func:`matrix_XYZ_from_balanced`).

    Returns
    -------
    ndarray of shape (..., 3)
    """
    M = np.asarray(matrix, dtype=np.float64)
    if M.shape != (3, 3) or not np.all(np.isfinite(M)):
        raise PipelineError(f"matrix: expected a finite (3, 3) matrix, got shape {M.shape}.")
    return _image_array(rgb, "rgb") @ M.T


def apply_correction(
    responses,
    *,
    XYZ_from_responses: Callable[[np.ndarray], np.ndarray],
    white_response=None,
    cat: str = "Bradford",
) -> np.ndarray:
    """Camera responses → XYZ D50 with any colour-correction callable (replaces the ColorMatrix).

    The callable's white is taken as ``XYZ_from_responses(white_response)``; the result is adapted
    from that white to D50 (``cat``) and scaled so the white has Y = 1, i.e. it is on the same
    footing as :func:`camera_to_XYZ` with :func:`matrix_XYZ_from_balanced`.

    Parameters
    ----------
    responses : array_like of shape (..., k)
        Linear camera responses (white-balanced so the scene white is (1, …, 1) unless
        ``white_response`` says otherwise).
    XYZ_from_responses
        ``(N, k) → (N, 3)`` estimator, e.g. a fitted ``zonotope.correct`` corrector or
        ``lambda c: c @ M.T``.
    white_response : array_like of shape (k,), optional
        Response of the scene white; default all ones.
    cat
        Chromatic adaptation transform (colour-science name).

    Returns
    -------
    ndarray of shape (..., 3)

    Raises
    ------
    PipelineError
        The callable returns the wrong shape, NaN, or a white with Y ≤ 0.
    """
    c = np.asarray(responses, dtype=np.float64)
    k = c.shape[-1]
    w = np.ones(k) if white_response is None else np.asarray(white_response, dtype=np.float64)
    flat = c.reshape(-1, k)
    XYZ = np.asarray(XYZ_from_responses(flat), dtype=np.float64)
    white = np.asarray(XYZ_from_responses(w[None, :]), dtype=np.float64).reshape(-1)
    if XYZ.shape != (flat.shape[0], 3) or white.shape != (3,):
        raise PipelineError(
            f"XYZ_from_responses must map (N, {k}) → (N, 3); got {XYZ.shape} (white {white.shape})."
        )
    if not np.all(np.isfinite(XYZ)) or not np.all(np.isfinite(white)):
        raise PipelineError(
            "XYZ_from_responses returned NaN or inf; check the responses are inside "
            "its domain (e.g. finite, non-negative)."
        )
    if white[1] <= 0:
        raise PipelineError(f"XYZ_from_responses maps the white {w} to XYZ {white} with Y ≤ 0.")
    D50 = colour.xy_to_XYZ(D50_xy)
    M = colour.adaptation.matrix_chromatic_adaptation_VonKries(white / white[1], D50, transform=cat)
    return ((XYZ / white[1]) @ M.T).reshape(*c.shape[:-1], 3)


def XYZ_to_linear_sRGB(XYZ, *, white_xy=D50_xy, cat: str = "Bradford") -> np.ndarray:
    """XYZ (white ``white_xy``, Y = 1) → linear sRGB (D65), adapting the white when it differs.

    Parameters
    ----------
    XYZ : array_like of shape (..., 3)
    white_xy : array_like of shape (2,)
        Chromaticity of the white of ``XYZ`` (default D50, the DNG connection space).
    cat
        Chromatic adaptation transform used when ``white_xy`` is not D65.

    Returns
    -------
    ndarray of shape (..., 3)
    """
    X = _image_array(XYZ, "XYZ")
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    same = np.allclose(np.asarray(white_xy, dtype=np.float64), srgb.whitepoint, atol=WHITE_XY)
    return colour.XYZ_to_RGB(
        X,
        srgb,
        illuminant=np.asarray(white_xy, dtype=np.float64),
        chromatic_adaptation_transform=None if same else cat,
    )


def encode_sRGB(rgb, *, clip: bool = True) -> np.ndarray:
    """Linear sRGB → non-linear sRGB with the IEC 61966-2-1 inverse EOTF (not a plain 2.2 gamma).

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    clip
        Clip to [0, 1] first (out-of-gamut and over-range values).

    Returns
    -------
    ndarray of shape (..., 3)
    """
    a = _image_array(rgb, "rgb")
    if clip:
        a = np.clip(a, 0.0, 1.0)
    return colour.models.eotf_inverse_sRGB(a)


# ---------------------------------------------------------------------------------------------
# Tone mapping (global operators on linear RGB)
# ---------------------------------------------------------------------------------------------

_Y_sRGB = np.array(colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1])


def tonemap_Reinhard2002(
    rgb, *, key: float | None = 0.18, white: float | None = None, log_offset: float = 1e-6
) -> np.ndarray:
    """Reinhard et al. (2002) global photographic operator on luminance; chromaticity kept.

    ``L = key / L̄ · Y`` with ``L̄`` the log-average luminance (eq. 1–2), then
    ``L_d = L (1 + L / L_white²) / (1 + L)`` (eq. 4); RGB is scaled by ``L_d / Y``.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
        Linear sRGB.
    key
        Middle-grey target of the log-average luminance; None keeps the exposure (``L = Y``).
    white
        Smallest luminance mapped to 1 (after scaling); default the largest ``L``.
    log_offset
        The paper's δ: added to Y inside the log average so black pixels stay finite (named so
        because ``eps`` is the MMV certification tolerance and ``delta`` the noise tolerance
        elsewhere in the project).

    Returns
    -------
    ndarray of shape (..., 3)

    References
    ----------
    Reinhard, E., Stark, M., Shirley, P., & Ferwerda, J. (2002). Photographic tone reproduction for
    digital images. ACM TOG 21(3), 267–276, equations 1, 2 and 4.
    """
    from ._tol import CHUNK_PIXELS

    a = np.asarray(rgb)
    a = a if a.dtype in (np.float32, np.float64) else _image_array(rgb, "rgb")
    if a.ndim < 1 or a.shape[-1] != 3:
        _image_array(a, "rgb")  # the one message for a wrong shape
    flat = a.reshape(-1, 3)
    out = np.empty(a.shape, dtype=a.dtype)
    flat_out = out.reshape(-1, 3)
    # in chunks of pixels, in float64: temporaries of one chunk whatever the image size; a float32
    # image stays float32 (the pipeline's images between global stages)
    chunks = [slice(i, i + CHUNK_PIXELS) for i in range(0, flat.shape[0], CHUNK_PIXELS)]

    def luminance(c: slice) -> np.ndarray:
        return np.maximum(flat[c].astype(np.float64, copy=False) @ _Y_sRGB, 0.0)

    n = flat.shape[0]
    if key is None:
        scale = 1.0
    else:
        log_sum = math.fsum(float(np.sum(np.log(log_offset + luminance(c)))) for c in chunks)
        scale = key / float(np.exp(log_sum / n)) if n else 1.0
    Lw = (
        float(white)
        if white is not None
        else max((scale * float(luminance(c).max()) for c in chunks), default=0.0)
    )
    if Lw <= 0:
        return np.zeros_like(a)
    for c in chunks:
        Y = luminance(c)
        L = scale * Y
        Ld = (L + (L / Lw) ** 2) / (1.0 + L)  # = L (1 + L / Lw²) / (1 + L), without underflowing Lw²
        # a / Y first (chromaticity-like, O(1)), then × Ld: Ld / Y overflows when a whole image is
        # subnormal (its brightest pixel still maps to 1; found by hypothesis)
        x = flat[c].astype(np.float64, copy=False)
        chroma = np.divide(x, Y[:, None], out=np.zeros_like(x), where=Y[:, None] > 0)
        flat_out[c] = chroma * Ld[:, None]
    return out


def tonemap_clip(rgb, *, exposure: float = 0.0) -> np.ndarray:
    """Exposure (EV) then clip to [0, 1]: no tone curve.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    exposure
        Gain in stops (finite, at most ±``isp._tol.EXPOSURE_STOPS_MAX``).

    Returns
    -------
    ndarray of shape (..., 3)
    """
    return np.clip(_image_array(rgb, "rgb") * _gain(exposure), 0.0, 1.0)


def _gain(exposure) -> float:
    """``2 ** exposure`` for a gain in stops, or the one-line error of a bad value."""
    from ._tol import EXPOSURE_STOPS_MAX

    if isinstance(exposure, bool) or not isinstance(exposure, int | float | np.number):
        raise PipelineError(f"exposure={exposure!r}: expected a number of stops.")
    if not abs(float(exposure)) <= EXPOSURE_STOPS_MAX:  # NaN fails too
        raise PipelineError(
            f"exposure={exposure!r}: a gain in stops must be finite and within ±{EXPOSURE_STOPS_MAX:g}."
        )
    return 2.0 ** float(exposure)


def auto_bright_white(rgb, *, fraction: float | None = None) -> float:
    """The linear value LibRaw's auto-bright maps to white: the largest over the channels of the
    value that ``fraction`` of the pixels reach or exceed (dcraw's ``convert_to_rgb`` histogram,
    ``perc = 0.01 · width · height``, ``t_white`` the highest channel's level).

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
        Linear RGB (any range).
    fraction
        Share of the pixels allowed at or above white (default :data:`isp._tol.AUTO_BRIGHT_FRACTION`).

    Returns
    -------
    float
        0 for an image with no positive value.
    """
    from ._tol import AUTO_BRIGHT_BINS, AUTO_BRIGHT_FRACTION, CHUNK_PIXELS

    fraction = AUTO_BRIGHT_FRACTION if fraction is None else fraction
    if isinstance(fraction, bool) or not (isinstance(fraction, int | float) and 0 < fraction < 1):
        raise PipelineError(f"fraction={fraction!r}: the share of pixels at white must be in (0, 1).")
    a = np.asarray(rgb)
    a = a if a.dtype in (np.float32, np.float64) else _image_array(rgb, "rgb")
    flat = a.reshape(-1, a.shape[-1])
    chunks = [flat[i : i + CHUNK_PIXELS] for i in range(0, flat.shape[0], CHUNK_PIXELS)]
    top = max((float(np.max(c)) for c in chunks), default=0.0)
    if not top > 0:
        return 0.0
    # one pass of histograms (dcraw counts a 13-bit histogram from the top); bins of top / 2¹⁶
    hist = np.zeros((flat.shape[1], AUTO_BRIGHT_BINS), dtype=np.int64)
    for c in chunks:
        idx = np.clip((c.astype(np.float64, copy=False) * (AUTO_BRIGHT_BINS / top)).astype(np.int64), 0, None)
        np.minimum(idx, AUTO_BRIGHT_BINS - 1, out=idx)
        for ch in range(flat.shape[1]):
            hist[ch] += np.bincount(idx[:, ch], minlength=AUTO_BRIGHT_BINS)
    allowed = fraction * flat.shape[0]
    white = 0
    for h in hist:  # the first bin from the top at which more than ``allowed`` pixels are counted
        above = np.cumsum(h[::-1])
        level = AUTO_BRIGHT_BINS - 1 - int(np.searchsorted(above, allowed, side="right"))
        white = max(white, level)
    return top * max(white, 1) / AUTO_BRIGHT_BINS


def tonemap_auto_bright(rgb, *, fraction: float | None = None, exposure: float = 0.0) -> np.ndarray:
    """LibRaw's (dcraw's) automatic brightness: scale so that ``fraction`` of the pixels reach white, clip.

    No tone curve: the output is linear up to white (the sRGB transfer function of ``encode_sRGB``
    is the only curve), so mid-tones keep their ratios to the highlights. ``rawpy``'s default
    ``postprocess()`` does the same scaling (``bright=1``, ``auto_bright_thr=0.01``).

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
        Linear RGB.
    fraction
        Share of the pixels at or above white (default :data:`isp._tol.AUTO_BRIGHT_FRACTION`, 1 %
        as LibRaw's ``auto_bright_thr``).
    exposure
        A further gain in stops (LibRaw's ``bright``, in stops), within ±``EXPOSURE_STOPS_MAX``.

    Returns
    -------
    ndarray of shape (..., 3)
        In [0, 1]; zeros for an image with no positive value.

    References
    ----------
    Coffin, D. dcraw.c, ``convert_to_rgb`` and ``write_ppm_tiff`` (the histogram and ``t_white``);
    LibRaw ``libraw_output_params_t::auto_bright_thr``.
    """
    from ._tol import CHUNK_PIXELS

    gain = _gain(exposure)
    a = np.asarray(rgb)
    a = a if a.dtype in (np.float32, np.float64) else _image_array(rgb, "rgb")
    white = auto_bright_white(a, fraction=fraction)
    out = np.zeros(a.shape, dtype=a.dtype)  # a float32 image stays float32 (memory)
    if white > 0:
        flat, flat_out = a.reshape(-1, a.shape[-1]), out.reshape(-1, a.shape[-1])
        for i in range(0, flat.shape[0], CHUNK_PIXELS):
            c = slice(i, i + CHUNK_PIXELS)
            flat_out[c] = np.clip(flat[c].astype(np.float64, copy=False) * (gain / white), 0.0, 1.0)
    return out


#: Global tone-mapping operators by name (``tonemap(..., method=name)``); ``default=True`` marks the
#: operator every front end uses when none is named.
TONEMAP_METHODS: MethodRegistry[Callable[..., np.ndarray]] = MethodRegistry(
    "tone-mapping", error=PipelineMethodError
)
TONEMAP_METHODS.register("Reinhard 2002", tonemap_Reinhard2002, reach=None)  # global: a mean
TONEMAP_METHODS.register("clip", tonemap_clip, reach=0)  # per pixel: strip-wise in a pipeline
# the default: rawpy's / LibRaw's brightness (docs/notes/2026-11-29-isp-default-brightness.md)
TONEMAP_METHODS.register("auto-bright", tonemap_auto_bright, default=True, reach=None)  # global: a histogram


def tonemap(rgb, *, method: str = default_method(TONEMAP_METHODS), **options) -> np.ndarray:
    """Apply a global tone-mapping operator of :data:`TONEMAP_METHODS`.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    method
        Operator name (case and punctuation ignored).
    **options
        Keyword options of the operator (an unknown one raises ``TypeError``).

    Returns
    -------
    ndarray of shape (..., 3)
    """
    return TONEMAP_METHODS[_resolve(method, TONEMAP_METHODS, "method")](rgb, **options)


# ---------------------------------------------------------------------------------------------
# Geometry
# ---------------------------------------------------------------------------------------------


def orient(image, orientation: int) -> np.ndarray:
    """Rotate / mirror an image for display as its TIFF/EXIF Orientation tag says.

    Parameters
    ----------
    image : array_like of shape (H, W) or (H, W, c)
        The picture as stored (row 0 is the sensor's first row).
    orientation
        1 as stored; 2 mirrored left–right; 3 rotated 180°; 4 mirrored top–bottom; 5 transposed;
        6 rotated 90° clockwise; 7 transverse (mirrored, then 90° clockwise); 8 rotated 90°
        counter-clockwise (TIFF 6.0 tag 274, the codes rawpy/LibRaw's ``sizes.flip`` stands for).

    Returns
    -------
    ndarray
        A view of ``image``; shape (W, H, ...) for codes 5–8.

    Examples
    --------
    >>> a = np.arange(6).reshape(2, 3)
    >>> orient(a, 6)
    array([[3, 0],
           [4, 1],
           [5, 2]])
    """
    a = np.asarray(image)
    if a.ndim not in (2, 3):
        raise PipelineError(f"image: expected shape (H, W) or (H, W, c); got {a.shape}.")
    if isinstance(orientation, bool) or orientation not in range(1, 9):
        raise PipelineError(f"orientation={orientation!r}: expected a TIFF Orientation code 1–8.")
    return {
        1: lambda x: x,
        2: np.fliplr,
        3: lambda x: np.rot90(x, 2),
        4: np.flipud,
        5: lambda x: np.swapaxes(x, 0, 1),
        6: lambda x: np.rot90(x, -1),
        7: lambda x: np.rot90(np.fliplr(x), -1),
        8: lambda x: np.rot90(x, 1),
    }[int(orientation)](a)
