"""Fit a DNG camera profile (DCP) to a ``zonotope.correct`` estimator for one camera.

For each of two calibration illuminants (A and D65 by default) the estimator is fitted on the
camera's spectral sensitivities under that light (:func:`isp.metamer_correction`), and encoded the
way the DNG specification intends (chapter 6):

* **ColorMatrix** (XYZ → camera, not white-balanced): least squares over the training
  reflectances' true XYZ and raw camera responses, the white held exactly, so the camera neutral of
  the illuminant maps back to its chromaticity (the CCT that selects the interpolation weight);
* **ForwardMatrix** (white-balanced camera → XYZ D50): least squares to the estimator's output
  (Bradford-adapted from the illuminant's white to D50) with ``FM · (1, 1, 1) = XYZ(D50)`` exactly,
  as the specification requires;
* **ProfileHueSatMap** (2.5-D by default: 90 hues × 30 saturations × 1 value, the size of Adobe's
  and RawTherapee's profiles): what the matrix cannot say on natural colours. In linear ProPhoto
  RGB (the DNG SDK's HSV), each fitting colour gives three equations linear in the table entries —
  hue shift, saturation scale and value scale, bilinear in (hue, saturation) — solved as one
  sparse least squares with a smoothness term (second differences along hue, circular, and
  saturation) and the grey axis held at identity;
* **ProfileLookTable** (3-D: 36 × 12 × 8, sRGB-encoded value axis, ProfileLookTableEncoding 1):
  what the exposure-invariant parts cannot say — the estimator's lightness-dependent answer on
  atypical colours — fitted the same way with trilinear weights (see :func:`fit_dcp`, Notes).

Fitting colours (:func:`profile_reflectances`): natural ones — the training set, CIE 1995 TCS and
NIST CQS 9.0 (the ColorChecker sets are held out: they are what the benchmarks evaluate on) — for
the matrices and the HueSatMap, and seeded random smooth reflectances that fill the camera's gamut,
added for the LookTable. All are physically possible object colours at the white's exposure.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import colour
import numpy as np

from .._config import float_array
from .._errors import PipelineError
from .._tol import TABLE_GREY_SATURATION, TABLE_HARD_WEIGHT, TABLE_RIDGE, TABLE_RING_ROUNDING
from ..dng import D50_xy
from ..simulate import ILLUMINANT_LIGHT_SOURCE
from .dcp import PROPHOTO_FROM_XYZ, DCPProfile, _rgb_to_hsv, apply_hue_sat_map

__all__ = [
    "DCP_DEFAULT_DIMS",
    "LOOK_TABLE_DEFAULT_DIMS",
    "ProfileConfig",
    "ProfileFit",
    "fit_dcp",
    "fit_hue_sat_map",
    "profile_reflectances",
]

#: Default ProfileHueSatMap size (hue, saturation, value divisions): Adobe's and RawTherapee's.
DCP_DEFAULT_DIMS = (90, 30, 1)

#: Natural sets added to the training set. The ColorChecker sets ("ColorChecker N Ohta", "BabelColor
#: Average") are left out on purpose: they are the evaluation chart of the benchmarks and tests.
_NATURAL_SETS = ("CIE 1995 TCS", "NIST CQS 9.0")

#: Default ProfileLookTable size (hue, saturation, value divisions) and encoding (1: sRGB value axis).
LOOK_TABLE_DEFAULT_DIMS = (36, 12, 8)


def profile_reflectances(
    wavelengths,
    training: np.ndarray | None = None,
    *,
    n_random: int = 1500,
    seed: int = 0,
    return_natural: bool = False,
):
    """Reflectances the profile is fitted on: training + built-in natural sets + random smooth ones.

    Parameters
    ----------
    wavelengths : array_like of shape (n,)
    training : array_like of shape (N, n), optional
    n_random
        Seeded random smooth reflectances: a sigmoid of a random 6-term cosine series, which
        reaches the saturated colours natural sets lack.
    seed
    return_natural
        Also return the boolean mask of the natural rows (training and built-in sets).

    Returns
    -------
    ndarray of shape (M, n), values in [0, 1]
        The natural rows first (training, CIE 1995 TCS, NIST CQS 9.0), then the random ones. The
        ColorChecker sets are not among them: they are held out for evaluation.
    ndarray of bool, shape (M,)
        Only with ``return_natural``.
    """
    import zonotope

    w = float_array(wavelengths, "wavelengths")
    parts = [] if training is None else [float_array(training, "training")]
    for name in _NATURAL_SETS:
        parts.append(np.clip(zonotope.resample(zonotope.reflectances(name), w).T, 0.0, 1.0))
    n_nat = sum(p.shape[0] for p in parts)
    rng = np.random.default_rng(seed)
    t = (w - w.min()) / max(w.max() - w.min(), 1.0)
    basis = np.cos(np.pi * np.outer(np.arange(6), t))  # (6, n)
    coef = rng.normal(0.0, 1.0, (n_random, 6)) * np.array([1.5, 3.0, 3.0, 2.5, 2.0, 1.5])
    parts.append(1.0 / (1.0 + np.exp(-(coef @ basis))))
    R = np.concatenate(parts)
    if return_natural:
        return R, np.arange(R.shape[0]) < n_nat
    return R


def _weights(weights, N: int) -> np.ndarray:
    if weights is None:
        return np.ones(N)
    wt = float_array(weights, "weights").reshape(-1)
    if wt.shape != (N,) or not np.all(np.isfinite(wt)) or np.any(wt < 0) or not np.any(wt > 0):
        raise PipelineError(
            f"weights: need {N} finite non-negative values, not all 0 (got shape {wt.shape}); "
            "give one weight per fitting colour."
        )
    return wt


def _fit_white_preserving(X: np.ndarray, Y: np.ndarray, x_w: np.ndarray, y_w: np.ndarray) -> np.ndarray:
    """``M`` minimising ``Σ ‖M x_i − y_i‖²`` subject to ``M x_w = y_w`` (one KKT solve)."""
    A = X.T @ X
    K = np.block([[A, x_w[:, None]], [x_w[None, :], np.zeros((1, 1))]])
    rhs = np.vstack([X.T @ Y, y_w[None, :]])
    return np.linalg.solve(K, rhs)[:3].T


def _second_differences(H: int, S: int, V: int = 1):
    """Second differences of an (V, H, S) node grid: along hue (circular), saturation and value."""
    import scipy.sparse as sp

    idx = np.arange(V * H * S).reshape(V, H, S)
    triples = [(np.roll(idx, 1, axis=1), idx, np.roll(idx, -1, axis=1))]  # hue, circular
    if S > 2:
        triples.append((idx[:, :, :-2], idx[:, :, 1:-1], idx[:, :, 2:]))
    if V > 2:
        triples.append((idx[:-2], idx[1:-1], idx[2:]))
    a, b, c = (np.concatenate([t[k].ravel() for t in triples]) for k in range(3))
    m = a.size
    r = np.arange(m)
    return sp.csr_matrix(
        (
            np.concatenate([np.ones(m), -2 * np.ones(m), np.ones(m)]),
            (np.concatenate([r, r, r]), np.concatenate([a, b, c])),
        ),
        shape=(m, V * H * S),
    )


def _encode_value(v: np.ndarray, encoding: int) -> np.ndarray:
    """The value coordinate of a table: linear, or sRGB-encoded and clipped to [0, 1] (encoding 1)."""
    return colour.models.eotf_inverse_sRGB(np.clip(v, 0.0, 1.0)) if encoding == 1 else v


def fit_hue_sat_map(
    source,
    target,
    *,
    dims: Sequence[int] = DCP_DEFAULT_DIMS,
    smoothness: float = 1e-3,
    weights=None,
    encoding: int = 0,
    unbiased_saturation: float = 0.0,
) -> np.ndarray:
    """Fit a ProfileHueSatMap or ProfileLookTable taking linear ProPhoto ``source`` to ``target``.

    Parameters
    ----------
    source, target : array_like of shape (N, 3)
        Linear ProPhoto RGB before and after the table.
    dims
        (hue, saturation, value) divisions: value 1 for a 2.5-D table (exposure-invariant), more
        for a 3-D one (the value nodes at ``k / (V − 1)`` of the encoded value).
    smoothness
        Weight of the second-difference penalty relative to the mean data weight.
    weights : array_like of shape (N,), optional
        Non-negative weight per colour (default all 1); scaled to mean 1.
    encoding
        ProfileHueSatMapEncoding / ProfileLookTableEncoding: 0 linear, 1 sRGB-encoded value axis
        (and value scale), as :func:`isp.profiles.dcp.apply_hue_sat_map` reads it.
    unbiased_saturation
        Saturation rings up to this value (0: none) are held *bias-free*: per ring, the hue-mean
        of each entry is the identity's and its first hue harmonic (cos, sin) is 0. Noise spread
        evenly around the grey axis then keeps its mean to first order in the saturation, where a
        free table rotates and scales it hue by hue, moving near-grey means. Hue-varying
        corrections stay free.

    Returns
    -------
    ndarray of shape (V, H, S, 3)
        (hue shift °, saturation scale, value scale) per node.

    Notes
    -----
    With the input's SDK HSV ``(h, s, v)`` and the (bi/tri)linear node weights ``w``, the table
    gives ``h + (6/360) Σ w Δh``, ``s Σ w σ``, ``e(v) Σ w ν`` (``e`` the value encoding): linear
    in the entries. Rows are weighted so that each equation measures a chromaticity-like error:
    hue rows by ``s`` (hue matters in proportion to saturation), saturation rows in saturation
    units, value rows relative to ``v``. The second-difference penalty runs along hue (circular),
    saturation and value; the grey nodes (saturation 0) are held at identity.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    H, S, V = (int(d) for d in dims)
    if V < 1 or H < 1 or S < 2:
        raise PipelineError(
            f"dims={tuple(dims)}: a fitted table needs hue ≥ 1, saturation ≥ 2, value ≥ 1 divisions."
        )
    if encoding not in (0, 1):
        raise PipelineError(f"encoding={encoding!r}: 0 (linear) or 1 (sRGB-encoded value axis).")
    if not 0.0 <= unbiased_saturation <= 1.0:  # also refuses NaN
        raise PipelineError(
            f"unbiased_saturation={unbiased_saturation!r}: give a saturation in [0, 1] (0: no rings held)."
        )
    p = float_array(source, "source")
    q = float_array(target, "target")
    if p.ndim != 2 or p.shape[-1] != 3 or q.shape != p.shape or p.shape[0] == 0:
        raise PipelineError(
            f"source {p.shape} and target {q.shape}: give two (N, 3) arrays of linear ProPhoto RGB, N ≥ 1."
        )
    wt = _weights(weights, p.shape[0])
    h, s, v = _rgb_to_hsv(p)
    hq, sq, vq = _rgb_to_hsv(q)
    ok = (v > 0) & (vq > 0) & (s > TABLE_GREY_SATURATION) & np.all(np.isfinite(q), axis=-1) & (wt > 0)
    if V > 1 and encoding == 1:
        ok &= (v < 1) & (vq < 1)  # the encoded axis and scale saturate at 1
    if not np.any(ok):
        raise PipelineError(
            f"none of the {p.shape[0]} colours can be fitted (each is black, grey, not finite or of "
            "weight 0); give saturated colours with finite source and target."
        )
    h, s, v, hq, sq, vq = h[ok], s[ok], v[ok], hq[ok], sq[ok], vq[ok]
    sw = np.sqrt(wt[ok] / np.mean(wt[ok]))
    hs = h * (H / 6.0)
    h0 = np.clip(np.floor(hs).astype(np.int64), 0, H - 1)
    h1 = np.where(h0 >= H - 1, 0, h0 + 1)
    fh = hs - h0
    ss = s * (S - 1)
    s0 = np.clip(np.floor(ss).astype(np.int64), 0, S - 2)
    fs = ss - s0
    ve, vqe = _encode_value(v, encoding), _encode_value(vq, encoding)
    if V > 1:
        vs = ve * (V - 1)
        v0 = np.clip(np.floor(vs).astype(np.int64), 0, V - 2)
        fv = vs - v0
        vcorners = [(v0, 1.0 - fv), (v0 + 1, fv)]
    else:
        vcorners = [(np.zeros_like(h0), np.ones_like(h))]
    n = V * H * S
    N = h.size
    cols, wts = [], []
    for vi, wv in vcorners:
        for hi, wh in ((h0, 1.0 - fh), (h1, fh)):
            for si, ws in ((s0, 1.0 - fs), (s0 + 1, fs)):
                cols.append((vi * H + hi) * S + si)
                wts.append(wv * wh * ws)
    k = len(cols)
    W = sp.csr_matrix(
        (np.stack(wts, 1).ravel(), (np.repeat(np.arange(N), k), np.stack(cols, 1).ravel())), shape=(N, n)
    )
    dh = np.mod(hq - h + 3.0, 6.0) - 3.0  # hue difference in SDK units (6 per turn), wrapped
    D2 = _second_differences(H, S, V)
    grey = np.arange(V * H) * S  # saturation node 0 of every (value, hue)
    G = sp.csr_matrix((np.ones(grey.size), (np.arange(grey.size), grey)), shape=(grey.size, n))
    # rings up to unbiased_saturation: hue-mean of (entry − identity) and its first hue harmonic 0,
    # so that noise spread evenly around the grey axis keeps its mean (to first order in s)
    rings = [j for j in range(1, S) if j / (S - 1) <= unbiased_saturation + TABLE_RING_ROUNDING]
    ang = 2 * np.pi * np.arange(H) / H
    ub_rows = []
    for vi in range(V):
        for j in rings:
            nodes = (vi * H + np.arange(H)) * S + j
            for wvec in (np.ones(H), np.cos(ang), np.sin(ang)):
                ub_rows.append((nodes, wvec / H))
    if ub_rows:
        U = sp.csr_matrix(
            (
                np.concatenate([w for _, w in ub_rows]),
                (np.repeat(np.arange(len(ub_rows)), H), np.concatenate([nd for nd, _ in ub_rows])),
            ),
            shape=(len(ub_rows), n),
        )
        ub_ident = np.array([w.sum() for _, w in ub_rows])  # the rows' value at identity
    else:
        U = sp.csr_matrix((0, n))
        ub_ident = np.zeros(0)
    out = np.empty((n, 3))
    problems = [  # (row weights, rhs, identity value)
        (s * 6.0 / 360.0, s * dh, 0.0),
        (s, sq, 1.0),
        (np.ones(N), vqe / ve, 1.0),
    ]
    for k, (rw, rhs, ident) in enumerate(problems):
        rw, rhs = rw * sw, rhs * sw
        A = sp.diags(rw) @ W
        m2 = float(np.mean(rw**2))
        lam = smoothness * m2 * max(N / n, 1.0)
        ridge = TABLE_RIDGE * m2
        hard = TABLE_HARD_WEIGHT * m2
        AtA = A.T @ A + lam * (D2.T @ D2) + ridge * sp.eye(n) + hard * (G.T @ G)
        b = A.T @ rhs + ridge * ident * np.ones(n) + hard * ident * (G.T @ np.ones(grey.size))
        if U.shape[0]:
            AtA = AtA + hard * N * (U.T @ U)
            b = b + hard * N * (U.T @ (ident * ub_ident))
        out[:, k] = spla.spsolve(AtA.tocsc(), b)
    return out.reshape(V, H, S, 3)


@dataclass(frozen=True, eq=False)
class ProfileFit:
    """A fitted DCP and what it was fitted from.

    Attributes
    ----------
    profile : DCPProfile
    corrections : tuple of isp.MetamerCorrection
        The estimator under each calibration illuminant.
    illuminants : tuple of str
    reflectances : ndarray of shape (M, n)
        The fitting reflectances on ``wavelengths``.
    wavelengths : ndarray of shape (n,)
    natural : ndarray of bool, shape (M,)
        Which fitting reflectances are natural (training and built-in sets); the others are the
        random smooth ones, which only the LookTable is fitted on.
    targets : tuple of ndarray of shape (M, 3)
        Per calibration illuminant, the estimator's output for every fitting colour, XYZ D50
        (Bradford from the estimator's white, white Y = 1): what the profile encodes.
    """

    profile: DCPProfile
    corrections: tuple
    illuminants: tuple
    reflectances: np.ndarray
    wavelengths: np.ndarray
    natural: np.ndarray
    targets: tuple


def _light_source(name: str) -> int:
    code = ILLUMINANT_LIGHT_SOURCE.get(str(name).upper().replace(" ", ""))
    if code is None:
        raise PipelineError(
            f"illuminant {name!r}: a DCP calibration illuminant must be one of "
            f"{sorted(ILLUMINANT_LIGHT_SOURCE)} (EXIF LightSource codes)."
        )
    return code


def _dims(owner: str, name: str, value) -> tuple[int, int, int] | None:
    """A table size ``(hues, saturations, values)`` as a tuple of ints, or a PipelineError."""
    if value is None:
        return None
    try:
        dims = tuple(value)
    except TypeError:
        dims = ()
    ok = len(dims) == 3 and all(hasattr(d, "__index__") and not isinstance(d, bool) for d in dims)
    if ok:
        H, S, V = (int(d) for d in dims)
        ok = H >= 1 and S >= 2 and V >= 1
    if not ok:
        raise PipelineError(
            f"{owner}.{name}={value!r}: give (hues, saturations, values) integers with hues ≥ 1, "
            "saturations ≥ 2, values ≥ 1; or None for no table."
        )
    return (H, S, V)


@dataclass(frozen=True)
class ProfileConfig:
    """The options of :func:`fit_dcp`, checked when the object is made (the ``isp profile`` CLI
    builds one from its options before any fitting starts).

    Attributes
    ----------
    method : str, optional
        ``zonotope.correct`` estimator; None (default): :func:`isp.metamer.photograph_method`, the
        one ``zonotope`` uses for photographs.
    illuminants : tuple of two str
        The two calibration illuminants (names of :data:`isp.simulate.ILLUMINANT_LIGHT_SOURCE`),
        lower CCT first by convention.
    training : str, path or colour.MultiSpectralDistributions
        Training reflectances of the estimator and of the ColorMatrix.
    dims : tuple of three int, optional
        ProfileHueSatMap divisions (hue ≥ 1, saturation ≥ 2, value ≥ 1; 1 for the usual
        2.5-D table); None for no HueSatMap.
    look_table_dims : tuple of three int, optional
        ProfileLookTable divisions (hue ≥ 1, saturation ≥ 2, value ≥ 1); None for no LookTable.
        With ``dims=None, look_table_dims=None`` the profile is matrix-only.
    look_table_encoding : int
        ProfileLookTableEncoding: 1 (default) sRGB-encoded value axis, more nodes in the shadows;
        0 linear.
    atypical_weight : float
        Total weight of the random smooth reflectances in the LookTable fit relative to the
        natural ones' (default 1: equal), finite ≥ 0.
    unique_camera_model : str, optional
        The string a raw developer matches against the file's camera model (e.g. ``"Canon EOS
        550D"``); default the camera's name (a camera file's maker and model) as Adobe names the model
        (:func:`isp.profiles.models.canonical_model`).
    profile_name, copyright : str
        ProfileName (default ``"<camera> <method> (zonotope)"``), ProfileCopyright.
    embed_policy : int
        ProfileEmbedPolicy 0…3 (3 = no restrictions).
    n_random, seed : int
        Random smooth reflectances added to the fitting set (:func:`profile_reflectances`), ≥ 0.
    smoothness : float
        See :func:`fit_hue_sat_map`, finite ≥ 0.
    unbiased_saturation : float
        Rings of both tables up to this saturation, in [0, 1] (default 0.35: 10 of the
        HueSatMap's 30), are kept bias-free around the grey axis (:func:`fit_hue_sat_map`): a
        per-pixel table applied to noisy near-grey pixels otherwise shifts their mean. 0 switches it
        off.
    noise : zonotope.correct.NoiseModel, float or None
        Noise of the white-balanced responses (white = 1) the estimator is fitted for (e.g.
        :func:`isp.metamer.metamer_noise` of a RAW file of the camera); None: noise-free.
    estimator_options : mapping of str to object
        Keywords of the estimator's fitting function (e.g. ``{"degree": 3}``), passed on through
        :class:`isp.MetamerConfig`.

    Raises
    ------
    PipelineError
        A field out of range or of the wrong kind (named, with what is allowed).
    """

    method: str | None = None
    illuminants: Sequence[str] = ("A", "D65")
    training: Any = "rawtoaces 190"
    dims: Sequence[int] | None = DCP_DEFAULT_DIMS
    look_table_dims: Sequence[int] | None = LOOK_TABLE_DEFAULT_DIMS
    look_table_encoding: int = 1
    atypical_weight: float = 1.0
    unique_camera_model: str | None = None
    profile_name: str | None = None
    copyright: str = ""
    embed_policy: int = 3
    n_random: int = 1500
    seed: int = 0
    smoothness: float = 1e-3
    unbiased_saturation: float = 0.35
    noise: Any = None
    estimator_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from .._config import check_int, check_number, check_options
        from ..metamer import MetamerConfig

        owner = "ProfileConfig"
        if self.method is not None and not (isinstance(self.method, str) and self.method.strip()):
            raise PipelineError(f"{owner}.method={self.method!r}: give an estimator name, e.g. 'Prior'.")
        ills = (self.illuminants,) if isinstance(self.illuminants, str) else tuple(self.illuminants)
        if len(ills) != 2:
            raise PipelineError(f"{owner}.illuminants={ills}: give exactly two calibration illuminants.")
        codes = [_light_source(i) for i in ills]
        if codes[0] == codes[1]:
            raise PipelineError(
                f"{owner}.illuminants={ills}: give two different calibration illuminants (a DCP interpolates "
                "between them by colour temperature), e.g. ('A', 'D65')."
            )
        object.__setattr__(self, "illuminants", ills)
        object.__setattr__(self, "dims", _dims(owner, "dims", self.dims))
        object.__setattr__(self, "look_table_dims", _dims(owner, "look_table_dims", self.look_table_dims))
        if self.look_table_encoding not in (0, 1) or isinstance(self.look_table_encoding, bool):
            raise PipelineError(
                f"{owner}.look_table_encoding={self.look_table_encoding!r}: 0 (linear) or 1 "
                "(sRGB-encoded value axis)."
            )
        check_number(
            owner,
            "atypical_weight",
            self.atypical_weight,
            lambda v: np.isfinite(v) and v >= 0,
            "give a finite weight ≥ 0",
        )
        for name in ("unique_camera_model", "profile_name", "copyright"):
            v = getattr(self, name)
            if not (isinstance(v, str) or (v is None and name != "copyright")):
                raise PipelineError(f"{owner}.{name}={v!r}: give a text (ASCII, as DCP tags are).")
            if isinstance(v, str) and not v.isascii():
                raise PipelineError(
                    f"{owner}.{name}={v!r}: DCP text tags are ASCII; remove the non-ASCII characters."
                )
        check_int(owner, "embed_policy", self.embed_policy, minimum=0, maximum=3)
        check_int(owner, "n_random", self.n_random, minimum=0)
        check_int(owner, "seed", self.seed, minimum=0)
        check_number(
            owner,
            "smoothness",
            self.smoothness,
            lambda v: np.isfinite(v) and v >= 0,
            "give a finite number ≥ 0",
        )
        check_number(
            owner,
            "unbiased_saturation",
            self.unbiased_saturation,
            lambda v: 0.0 <= v <= 1.0,
            "give a saturation in [0, 1] (0: no rings held)",
        )
        opts = check_options(owner, "estimator_options", self.estimator_options)
        try:  # the same checks as the estimator will apply
            checked = MetamerConfig(noise=self.noise, estimator_options=opts)
        except PipelineError as exc:
            raise PipelineError(str(exc).replace("MetamerConfig.", f"{owner}.")) from None
        object.__setattr__(self, "estimator_options", opts)
        object.__setattr__(self, "noise", checked.noise)


def _camera_name(camera) -> str:
    """The camera's name: an MSDS's; a rawtoaces JSON file's maker and model, as
    ``zonotope.load_camera`` names it (``zonotope ssf estimate`` writes the DNG's make and model there);
    else the built-in name or the file's stem. Why: the profile's default UniqueCameraModel, which raw
    developers match against a file's camera, must not be a file name."""
    name = getattr(camera, "name", None)
    if name:
        return str(name)
    path = str(camera)
    if path.lower().endswith(".json") and os.path.isfile(path):
        import zonotope

        try:
            return str(zonotope.load_camera(path).name)
        except zonotope.ZonotopeError:
            pass  # the fit itself says what is wrong with the file
    return os.path.splitext(os.path.basename(path))[0]


def fit_dcp(
    camera,
    config: ProfileConfig | None = None,
    *,
    corrections: Sequence | None = None,
    **options,
) -> ProfileFit:
    """Fit a DNG camera profile (matrices + HueSatMap per illuminant + LookTable) to an estimator.

    Parameters
    ----------
    camera
        Built-in camera name, camera file (rawtoaces JSON / CSV) or colour MSDS.
    config
        The options (:class:`ProfileConfig`); default all defaults.
    corrections
        Already fitted :class:`isp.MetamerCorrection` objects, one per illuminant (skip fitting;
        then ``method``, ``training`` and ``estimator_options`` are not used).
    **options
        Fields of :class:`ProfileConfig` as keywords (override those of ``config``), e.g.
        ``method="MAP", n_random=300, noise=0.01``; the estimator's own options go in
        ``estimator_options`` (e.g. ``estimator_options={"degree": 3}``).

    Returns
    -------
    ProfileFit

    Notes
    -----
    What goes where follows what each part of a DCP can say. The ForwardMatrix and the 2.5-D
    HueSatMap are exposure-invariant, so they are fitted on the **natural** colours only (training
    set, CIE 1995 TCS, NIST CQS 9.0), where the estimators' regression branches are (nearly)
    exposure-invariant too. On atypical colours an MMV estimator's answer depends on the lightness
    (the metamer mismatch volume of a colour depends on how close it lies to the object-colour
    solid's boundary), which a 2.5-D table cannot express: fitted together, the random smooth
    spectra would pull the natural colours' entries. The single 3-D **LookTable** (value
    divisions, both illuminants' colours) then takes the colours after matrix and HueSatMap to the
    estimator, natural and random colours weighted ``1 : atypical_weight`` in total, so it stays
    near identity on natural colours. Its value axis assumes the perfect white reflector at value
    1 (white-balanced camera RGB ``(1, 1, 1)``): at other exposures its correction of atypical
    colours moves along the value axis; natural colours are not affected.
    """
    from .._config import with_options
    from ..metamer import MetamerConfig, metamer_correction
    from .models import canonical_model

    cfg = with_options(ProfileConfig, config, options, where="fit_dcp")
    illuminants, dims, look_table_dims = cfg.illuminants, cfg.dims, cfg.look_table_dims
    atypical_weight, look_table_encoding = cfg.atypical_weight, cfg.look_table_encoding
    smoothness, unbiased_saturation = cfg.smoothness, cfg.unbiased_saturation
    codes = [_light_source(i) for i in illuminants]
    if corrections is None:
        corrections = [
            metamer_correction(
                camera,
                MetamerConfig(
                    method=cfg.method,
                    illuminant=i,
                    training=cfg.training,
                    quantum=0.0,
                    target="CIE 1931 2°",
                    noise=cfg.noise,
                    estimator_options=cfg.estimator_options,
                ),
            )
            for i in illuminants
        ]
    elif len(corrections) != 2:
        raise PipelineError("corrections: give one fitted MetamerCorrection per illuminant.")
    D50 = colour.xy_to_XYZ(D50_xy)
    CM, FM, HSM = [], [], []
    lt_src, lt_dst, lt_w, targets = [], [], [], []
    R_all = nat = None
    for mc in corrections:
        prob = mc.corrector.problem
        w = prob.wavelengths
        if R_all is None:
            R_all, nat = profile_reflectances(
                w, prob.training, n_random=cfg.n_random, seed=cfg.seed, return_natural=True
            )
        elif R_all.shape[1] != w.size:
            raise PipelineError("the corrections of both illuminants must share one wavelength grid.")
        Phi = prob.Phi  # white-balanced: the white → 1 per channel
        XYZ_of = prob.Psi @ prob.XYZ_from_target
        # ColorMatrix: true XYZ → raw camera over the training set, white exact
        n = np.asarray(mc.neutral, dtype=np.float64)
        X_tr, C_tr = prob.training @ XYZ_of, (prob.training @ Phi) * n
        xw = XYZ_of.sum(0)
        CM.append(_fit_white_preserving(X_tr, C_tr, xw, n))
        # estimator output on the fitting colours (the random ones only for a LookTable), at D50
        c = R_all @ Phi
        T = np.asarray(mc(c), dtype=np.float64)
        white = np.asarray(mc(np.ones((1, 3))), dtype=np.float64)[0]
        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            white / white[1], D50, transform="Bradford"
        )
        T50 = (T / white[1]) @ cat.T
        targets.append(T50)
        is_nat = nat
        F = _fit_white_preserving(c[is_nat], T50[is_nat], np.ones(3), D50)
        FM.append(F)
        src = (c @ F.T) @ PROPHOTO_FROM_XYZ.T
        dst = T50 @ PROPHOTO_FROM_XYZ.T
        if dims is not None:
            table = fit_hue_sat_map(
                src[is_nat],
                dst[is_nat],
                dims=dims,
                smoothness=smoothness,
                unbiased_saturation=unbiased_saturation,
            )
            HSM.append(table)
            src = apply_hue_sat_map(src, table)
        if look_table_dims is not None:
            n_nat, n_rnd = int(is_nat.sum()), int((~is_nat).sum())
            lt_src.append(src)
            lt_dst.append(dst)
            lt_w.append(np.where(is_nat, 1.0, atypical_weight * n_nat / max(n_rnd, 1)))
    look = None
    if look_table_dims is not None:
        look = fit_hue_sat_map(
            np.concatenate(lt_src),
            np.concatenate(lt_dst),
            dims=look_table_dims,
            smoothness=smoothness,
            weights=np.concatenate(lt_w),
            encoding=look_table_encoding,
            unbiased_saturation=unbiased_saturation,
        )
    name = _camera_name(camera)
    profile = DCPProfile(
        color_matrix_1=CM[0],
        color_matrix_2=CM[1],
        forward_matrix_1=FM[0],
        forward_matrix_2=FM[1],
        calibration_illuminant_1=codes[0],
        calibration_illuminant_2=codes[1],
        hue_sat_map_1=HSM[0] if HSM else None,
        hue_sat_map_2=HSM[1] if HSM else None,
        look_table=look,
        look_table_encoding=look_table_encoding if look is not None else 0,
        profile_name=cfg.profile_name or f"{name} {corrections[0].method} (zonotope)",
        unique_camera_model=cfg.unique_camera_model or canonical_model(name),
        copyright=cfg.copyright,
        embed_policy=cfg.embed_policy,
    )
    return ProfileFit(
        profile=profile,
        corrections=tuple(corrections),
        illuminants=tuple(illuminants),
        reflectances=R_all,
        wavelengths=np.asarray(corrections[0].corrector.problem.wavelengths),
        natural=nat,
        targets=tuple(targets),
    )
