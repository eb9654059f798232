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
  and RawTherapee's profiles): what the matrix cannot say. In linear ProPhoto RGB (the DNG SDK's
  HSV), each fitting colour gives three equations linear in the table entries — hue shift,
  saturation scale and value scale, bilinear in (hue, saturation) — solved as one sparse least
  squares with a smoothness term (second differences along hue, circular, and saturation) and the
  grey axis held at identity.

Fitting colours: the training set, the other built-in natural sets, and seeded random smooth
reflectances that fill the camera's gamut (:func:`profile_reflectances`). All of them are
physically possible object colours at the white's exposure; the table is exposure-invariant (2.5-D).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import colour
import numpy as np

from ._errors import PipelineError
from .dcp import PROPHOTO_FROM_XYZ, DCPProfile, _rgb_to_hsv
from .dng import D50_xy
from .simulate import ILLUMINANT_LIGHT_SOURCE

__all__ = ["DCP_DEFAULT_DIMS", "ProfileFit", "fit_dcp", "fit_hue_sat_map", "profile_reflectances"]

#: Default ProfileHueSatMap size (hue, saturation, value divisions): Adobe's and RawTherapee's.
DCP_DEFAULT_DIMS = (90, 30, 1)

_NATURAL_SETS = ("ColorChecker N Ohta", "BabelColor Average", "CIE 1995 TCS", "NIST CQS 9.0")


def profile_reflectances(
    wavelengths, training: np.ndarray | None = None, *, n_random: int = 1500, seed: int = 0
) -> np.ndarray:
    """Reflectances the profile is fitted on: training + built-in natural sets + random smooth ones.

    Parameters
    ----------
    wavelengths : array_like of shape (n,)
    training : array_like of shape (N, n), optional
    n_random
        Seeded random smooth reflectances: a sigmoid of a random 6-term cosine series, which
        reaches the saturated colours natural sets lack.
    seed

    Returns
    -------
    ndarray of shape (M, n), values in [0, 1]
    """
    import zonotope

    w = np.asarray(wavelengths, dtype=np.float64)
    parts = [] if training is None else [np.asarray(training, dtype=np.float64)]
    for name in _NATURAL_SETS:
        parts.append(np.clip(zonotope.resample(zonotope.reflectances(name), w).T, 0.0, 1.0))
    rng = np.random.default_rng(seed)
    t = (w - w.min()) / max(w.max() - w.min(), 1.0)
    basis = np.cos(np.pi * np.outer(np.arange(6), t))  # (6, n)
    coef = rng.normal(0.0, 1.0, (n_random, 6)) * np.array([1.5, 3.0, 3.0, 2.5, 2.0, 1.5])
    parts.append(1.0 / (1.0 + np.exp(-(coef @ basis))))
    return np.concatenate(parts)


def _fit_white_preserving(X: np.ndarray, Y: np.ndarray, x_w: np.ndarray, y_w: np.ndarray) -> np.ndarray:
    """``M`` minimising ``Σ ‖M x_i − y_i‖²`` subject to ``M x_w = y_w`` (one KKT solve)."""
    A = X.T @ X
    K = np.block([[A, x_w[:, None]], [x_w[None, :], np.zeros((1, 1))]])
    rhs = np.vstack([X.T @ Y, y_w[None, :]])
    return np.linalg.solve(K, rhs)[:3].T


def _second_differences(H: int, S: int):
    import scipy.sparse as sp

    n = H * S
    rows = []
    idx = np.arange(n).reshape(H, S)
    for i in range(H):  # along hue, circular
        a, b, c = idx[(i - 1) % H], idx[i], idx[(i + 1) % H]
        rows.append((a, b, c))
    for j in range(1, S - 1):  # along saturation
        rows.append((idx[:, j - 1], idx[:, j], idx[:, j + 1]))
    a = np.concatenate([r[0] for r in rows])
    b = np.concatenate([r[1] for r in rows])
    c = np.concatenate([r[2] for r in rows])
    m = a.size
    r = np.arange(m)
    return sp.csr_matrix(
        (
            np.concatenate([np.ones(m), -2 * np.ones(m), np.ones(m)]),
            (np.concatenate([r, r, r]), np.concatenate([a, b, c])),
        ),
        shape=(m, n),
    )


def fit_hue_sat_map(
    source, target, *, dims: Sequence[int] = DCP_DEFAULT_DIMS, smoothness: float = 1e-3
) -> np.ndarray:
    """Fit a 2.5-D ProfileHueSatMap taking linear ProPhoto ``source`` colours to ``target``.

    Parameters
    ----------
    source, target : array_like of shape (N, 3)
        Linear ProPhoto RGB before and after the table.
    dims
        (hue, saturation, value) divisions; the value divisions must be 1 (2.5-D).
    smoothness
        Weight of the second-difference penalty relative to the mean data weight.

    Returns
    -------
    ndarray of shape (1, H, S, 3)
        (hue shift °, saturation scale, value scale) per node.

    Notes
    -----
    With the input's SDK HSV ``(h, s, v)`` and the bilinear node weights ``w``, the table gives
    ``h + (6/360) Σ w Δh``, ``s Σ w σ``, ``v Σ w ν``: linear in the entries. Rows are weighted so
    that each equation measures a chromaticity-like error: hue rows by ``s`` (hue matters in
    proportion to saturation), saturation rows in saturation units, value rows relative to ``v``.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    H, S, V = (int(d) for d in dims)
    if V != 1 or H < 1 or S < 2:
        raise PipelineError(
            f"dims={tuple(dims)}: a fitted HueSatMap is 2.5-D (hue ≥ 1, saturation ≥ 2, value = 1)."
        )
    p = np.asarray(source, dtype=np.float64)
    q = np.asarray(target, dtype=np.float64)
    h, s, v = _rgb_to_hsv(p)
    hq, sq, vq = _rgb_to_hsv(q)
    ok = (v > 0) & (vq > 0) & (s > 1e-4) & np.all(np.isfinite(q), axis=-1)
    h, s, v, hq, sq, vq = h[ok], s[ok], v[ok], hq[ok], sq[ok], vq[ok]
    hs = h * (H / 6.0)
    h0 = np.clip(np.floor(hs).astype(np.int64), 0, H - 1)
    h1 = np.where(h0 >= H - 1, 0, h0 + 1)
    fh = hs - h0
    ss = s * (S - 1)
    s0 = np.clip(np.floor(ss).astype(np.int64), 0, S - 2)
    fs = ss - s0
    n = H * S
    N = h.size
    cols = np.stack([h0 * S + s0, h0 * S + s0 + 1, h1 * S + s0, h1 * S + s0 + 1], axis=1)
    wts = np.stack([(1 - fh) * (1 - fs), (1 - fh) * fs, fh * (1 - fs), fh * fs], axis=1)
    W = sp.csr_matrix((wts.ravel(), (np.repeat(np.arange(N), 4), cols.ravel())), shape=(N, n))
    dh = np.mod(hq - h + 3.0, 6.0) - 3.0  # hue difference in SDK units (6 per turn), wrapped
    D2 = _second_differences(H, S)
    grey = np.arange(H) * S  # saturation node 0
    G = sp.csr_matrix((np.ones(H), (np.arange(H), grey)), shape=(H, n))
    out = np.empty((H * S, 3))
    problems = [  # (row weights, rhs, identity value)
        (s * 6.0 / 360.0, s * dh, 0.0),
        (s, sq, 1.0),
        (np.ones(N), vq / v, 1.0),
    ]
    for k, (rw, rhs, ident) in enumerate(problems):
        A = sp.diags(rw) @ W
        lam = smoothness * float(np.mean(rw**2)) * max(N / n, 1.0)
        ridge = 1e-6 * float(np.mean(rw**2))
        AtA = A.T @ A + lam * (D2.T @ D2) + ridge * sp.eye(n) + 1e3 * float(np.mean(rw**2)) * (G.T @ G)
        b = A.T @ rhs + ridge * ident * np.ones(n) + 1e3 * float(np.mean(rw**2)) * ident * (G.T @ np.ones(H))
        out[:, k] = spla.spsolve(AtA.tocsc(), b)
    return out.reshape(1, H, S, 3)


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
    """

    profile: DCPProfile
    corrections: tuple
    illuminants: tuple
    reflectances: np.ndarray
    wavelengths: np.ndarray


def _light_source(name: str) -> int:
    code = ILLUMINANT_LIGHT_SOURCE.get(str(name).upper().replace(" ", ""))
    if code is None:
        raise PipelineError(
            f"illuminant {name!r}: a DCP calibration illuminant must be one of "
            f"{sorted(ILLUMINANT_LIGHT_SOURCE)} (EXIF LightSource codes)."
        )
    return code


def fit_dcp(
    camera,
    *,
    method: str = "Prior",
    illuminants: Sequence[str] = ("A", "D65"),
    training="rawtoaces 190",
    dims: Sequence[int] | None = DCP_DEFAULT_DIMS,
    unique_camera_model: str | None = None,
    profile_name: str | None = None,
    copyright: str = "",
    embed_policy: int = 3,
    n_random: int = 1500,
    seed: int = 0,
    smoothness: float = 1e-3,
    corrections: Sequence | None = None,
    **options,
) -> ProfileFit:
    """Fit a DNG camera profile (matrices + HueSatMap per illuminant) to a correction estimator.

    Parameters
    ----------
    camera
        Built-in camera name, camera file (rawtoaces JSON / CSV) or colour MSDS.
    method
        ``zonotope.correct`` estimator (default ``"Prior"``).
    illuminants
        The two calibration illuminants (names of :data:`isp.simulate.ILLUMINANT_LIGHT_SOURCE`),
        lower CCT first by convention.
    training
        Training reflectances of the estimator and of the ColorMatrix.
    dims
        ProfileHueSatMap divisions (hue, saturation, 1); None for a matrix-only profile.
    unique_camera_model
        The string a raw developer matches against the file's camera model (e.g. ``"Canon EOS
        550D"``); default the camera's name.
    profile_name, copyright, embed_policy
        ProfileName, ProfileCopyright, ProfileEmbedPolicy (3 = no restrictions).
    n_random, seed
        Random smooth reflectances added to the fitting set (:func:`profile_reflectances`).
    smoothness
        See :func:`fit_hue_sat_map`.
    corrections
        Already fitted :class:`isp.MetamerCorrection` objects, one per illuminant (skip fitting).
    **options
        Passed to :func:`isp.metamer_correction` (e.g. ``noise=0.01``).

    Returns
    -------
    ProfileFit
    """
    from . import metamer_correction

    if len(illuminants) != 2:
        raise PipelineError(f"illuminants={tuple(illuminants)}: give exactly two calibration illuminants.")
    codes = [_light_source(i) for i in illuminants]
    if corrections is None:
        corrections = [
            metamer_correction(
                camera,
                method=method,
                illuminant=i,
                training=training,
                quantum=0.0,
                target="CIE 1931 2°",
                **options,
            )
            for i in illuminants
        ]
    elif len(corrections) != 2:
        raise PipelineError("corrections: give one fitted MetamerCorrection per illuminant.")
    D50 = colour.xy_to_XYZ(D50_xy)
    CM, FM, HSM = [], [], []
    R_all = None
    for mc in corrections:
        prob = mc.corrector.problem
        w = prob.wavelengths
        if R_all is None:
            R_all = profile_reflectances(w, prob.training, n_random=n_random, seed=seed)
        elif R_all.shape[1] != w.size:
            raise PipelineError("the corrections of both illuminants must share one wavelength grid.")
        Phi = prob.Phi  # white-balanced: the white → 1 per channel
        XYZ_of = prob.Psi @ prob.XYZ_from_target
        # ColorMatrix: true XYZ → raw camera over the training set, white exact
        n = np.asarray(mc.neutral, dtype=np.float64)
        X_tr, C_tr = prob.training @ XYZ_of, (prob.training @ Phi) * n
        xw = XYZ_of.sum(0)
        CM.append(_fit_white_preserving(X_tr, C_tr, xw, n))
        # estimator output on all fitting colours, adapted to D50
        c = R_all @ Phi
        T = np.asarray(mc(c), dtype=np.float64)
        white = np.asarray(mc(np.ones((1, 3))), dtype=np.float64)[0]
        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            white / white[1], D50, transform="Bradford"
        )
        T50 = (T / white[1]) @ cat.T
        F = _fit_white_preserving(c, T50, np.ones(3), D50)
        FM.append(F)
        if dims is not None:
            src = (c @ F.T) @ PROPHOTO_FROM_XYZ.T
            dst = T50 @ PROPHOTO_FROM_XYZ.T
            HSM.append(fit_hue_sat_map(src, dst, dims=dims, smoothness=smoothness))
    name = getattr(camera, "name", None) or os.path.splitext(os.path.basename(str(camera)))[0]
    profile = DCPProfile(
        color_matrix_1=CM[0],
        color_matrix_2=CM[1],
        forward_matrix_1=FM[0],
        forward_matrix_2=FM[1],
        calibration_illuminant_1=codes[0],
        calibration_illuminant_2=codes[1],
        hue_sat_map_1=HSM[0] if HSM else None,
        hue_sat_map_2=HSM[1] if HSM else None,
        profile_name=profile_name or f"{name} {corrections[0].method} (zonotope)",
        unique_camera_model=unique_camera_model or str(name),
        copyright=copyright,
        embed_policy=embed_policy,
    )
    return ProfileFit(
        profile=profile,
        corrections=tuple(corrections),
        illuminants=tuple(illuminants),
        reflectances=R_all,
        wavelengths=np.asarray(corrections[0].corrector.problem.wavelengths),
    )
