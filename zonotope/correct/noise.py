"""Response noise as a model: shot + read variance per channel, in white-balanced units (white = 1).

The variance of channel ``j`` at a mean response ``c`` is ``shot_j · c + read_j`` (photon shot noise
grows with the signal, read noise does not). This is the model of the DNG ``NoiseProfile`` tag
(``σ = sqrt(S·x + O)``) expressed after white balance, so a profile, a constant σ and an estimate
from an image's flat regions all become the same object, which estimators fit against.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._errors import OptionError

__all__ = [
    "NoiseModel",
    "NoiseModelError",
    "estimate_noise",
    "noise_from_profile",
    "noise_model",
    "parse_noise",
]

#: σ at white above this (half the white level) is not noise a photograph could carry: a
#: ``NoiseProfile`` or an estimate that implies it is reported and ignored.
IMPLAUSIBLE_SIGMA_WHITE = 0.5


class NoiseModelError(OptionError):
    """A noise model that cannot be used: negative, NaN, or with the wrong number of channels."""


def _per_channel(name: str, value, k: int | None) -> np.ndarray:
    try:
        v = np.atleast_1d(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError):
        raise NoiseModelError(f"noise {name}={value!r}: give numbers ≥ 0, one per channel.") from None
    if v.ndim != 1 or (k is not None and v.size not in (1, k)):
        want = f"1 or {k}" if k is not None else "one per channel"
        raise NoiseModelError(f"noise {name} has shape {v.shape}; give {want} values (one per channel).")
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise NoiseModelError(f"noise {name}={v.tolist()!r}: every value must be finite and ≥ 0.")
    return v if k is None or v.size == k else np.full(k, v[0])


@dataclass(frozen=True, eq=False)
class NoiseModel:
    """Per-channel noise of linear, white-balanced responses: ``var_j(c) = shot_j · c_j + read_j``.

    Attributes
    ----------
    shot : ndarray of shape (k,)
        Variance per unit of response (photon shot noise), ≥ 0.
    read : ndarray of shape (k,)
        Variance at zero response (read noise), ≥ 0.
    source : str
        Where the model came from (``"given"``, ``"constant σ"``, ``"DNG NoiseProfile"``,
        ``"estimated from image"``, ...), for reports.

    Raises
    ------
    NoiseModelError
        A negative, NaN or infinite value, or ``shot`` and ``read`` of different channel counts.
    """

    shot: np.ndarray
    read: np.ndarray
    source: str = field(default="given", compare=False)

    def __post_init__(self):
        shot = _per_channel("shot", self.shot, None)
        read = _per_channel("read", self.read, None)
        if shot.size != read.size:
            if 1 not in (shot.size, read.size):
                raise NoiseModelError(
                    f"noise shot has {shot.size} channels and read {read.size}; give the same count."
                )
            k = max(shot.size, read.size)
            shot, read = np.broadcast_to(shot, (k,)).copy(), np.broadcast_to(read, (k,)).copy()
        shot.setflags(write=False)
        read.setflags(write=False)
        object.__setattr__(self, "shot", shot)
        object.__setattr__(self, "read", read)

    @classmethod
    def constant(cls, sigma, k: int, *, source: str = "constant σ") -> NoiseModel:
        """Signal-independent noise σ per channel (``read = σ²``, ``shot = 0``)."""
        s = _per_channel("sigma", sigma, k)
        return cls(np.zeros(k), s**2, source)

    @classmethod
    def shot_limited(cls, sigma_white, k: int, *, read=0.0, source: str = "shot-limited σ") -> NoiseModel:
        """Shot noise with σ ``sigma_white`` at white (``shot = σ_white²``) plus ``read`` variance."""
        s = _per_channel("sigma_white", sigma_white, k)
        return cls(s**2, _per_channel("read", read, k), source)

    @classmethod
    def from_noise_profile(
        cls, profile, *, white=1.0, k: int | None = None, source: str = "DNG NoiseProfile"
    ) -> NoiseModel:
        """From DNG ``NoiseProfile`` pairs ``(S, O)`` of the raw signal in [0, 1], as
        :func:`isp.noise_profile` returns them (shape ``(planes, 2)`` or ``(2,)``).

        The raw signal ``x`` of a channel whose perfect white reads ``white`` becomes the response
        ``c = x / white``, so ``var(c) = (S·x + O) / white² = (S / white) · c + O / white²``.

        Parameters
        ----------
        profile : array_like of shape (planes, 2) or (2,)
        white : float or array_like of shape (planes,)
            Raw level of the perfect white per channel (exposure × white-balance multipliers⁻¹).
        k : int, optional
            Expected channel count (a single pair is repeated to it).

        Raises
        ------
        NoiseModelError
            A malformed profile, or one implying σ at white > :data:`IMPLAUSIBLE_SIGMA_WHITE`
            (callers that read it from a file report this and ignore the profile).
        """
        try:
            P = np.asarray(profile, dtype=np.float64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise NoiseModelError(
                f"NoiseProfile {profile!r}: give (S, O) pairs, shape (planes, 2)."
            ) from None
        if k is not None and P.shape[0] not in (1, k):
            raise NoiseModelError(f"NoiseProfile has {P.shape[0]} (S, O) pairs; give 1 or {k}.")
        k = k if k is not None else P.shape[0]
        w = _per_channel("white", white, k)
        if np.any(w <= 0):
            raise NoiseModelError(f"NoiseProfile white={w.tolist()!r}: raw white levels must be > 0.")
        P = np.broadcast_to(P, (k, 2))
        model = cls(P[:, 0] / w, P[:, 1] / w**2, source)
        model.check_plausible()
        return model

    @property
    def k(self) -> int:
        """Number of channels."""
        return self.shot.size

    @property
    def sigma_white(self) -> np.ndarray:
        """σ per channel at the perfect white (response 1), shape (k,)."""
        return np.sqrt(self.shot + self.read)

    @property
    def is_zero(self) -> bool:
        """No noise at all (a noise-free model)."""
        return not (np.any(self.shot > 0) or np.any(self.read > 0))

    def check_plausible(self) -> NoiseModel:
        """Raise :class:`NoiseModelError` when σ at white exceeds :data:`IMPLAUSIBLE_SIGMA_WHITE`."""
        if np.any(self.sigma_white > IMPLAUSIBLE_SIGMA_WHITE):
            raise NoiseModelError(
                f"noise from {self.source}: σ at white {np.round(self.sigma_white, 4).tolist()} exceeds "
                f"{IMPLAUSIBLE_SIGMA_WHITE} (half the white level); not a plausible noise model."
            )
        return self

    def check_channels(self, k: int) -> NoiseModel:
        """The model for ``k`` channels: itself if it has ``k`` (a one-channel model is repeated), else
        :class:`NoiseModelError`."""
        if self.k == k:
            return self
        if self.k == 1:
            return NoiseModel(np.full(k, self.shot[0]), np.full(k, self.read[0]), self.source)
        raise NoiseModelError(f"noise model has {self.k} channels; the responses have {k}.")

    def variance(self, responses) -> np.ndarray:
        """Noise variance per channel at mean responses ``(..., k)`` → ``(..., k)`` (negative responses
        count as 0)."""
        c = np.asarray(responses, dtype=np.float64)
        return self.shot * np.maximum(c, 0.0) + self.read

    def sigma(self, responses) -> np.ndarray:
        """Noise σ per channel at mean responses ``(..., k)`` → ``(..., k)``."""
        return np.sqrt(self.variance(responses))

    def effective_sigma(self, responses) -> float:
        """One σ summarising the model over ``responses (N, k)``: the root mean variance over responses
        and channels (for estimators whose noise term is a single σ)."""
        return float(np.sqrt(np.mean(self.variance(responses))))

    def sample(self, responses, rng: np.random.Generator) -> np.ndarray:
        """Noisy copies of mean responses ``(..., k)``: Gaussian with the model's variance."""
        c = np.asarray(responses, dtype=np.float64)
        return c + rng.standard_normal(c.shape) * self.sigma(c)

    def key(self) -> tuple:
        """Hashable identity of the model (for caches): its values rounded to 12 significant digits."""
        return tuple(float(f"{x:.12g}") for x in np.concatenate([self.shot, self.read]))

    def describe(self) -> str:
        """One line: σ at white per channel, and the source."""
        s = ", ".join(f"{x:.4g}" for x in self.sigma_white)
        return f"σ at white [{s}] (shot + read; {self.source})"


def noise_from_profile(profile, *, white=1.0, k: int | None = None) -> tuple[NoiseModel | None, str]:
    """A noise model from a file's DNG ``NoiseProfile`` pairs, or None and why it was not used.

    The tolerant twin of :meth:`NoiseModel.from_noise_profile` for readers of files: a missing
    profile (None), a malformed one or an implausible one is reported in the returned note and
    ignored, so that the caller falls back to another source (e.g. ``correct_image(noise="auto")``).

    Returns
    -------
    model : NoiseModel or None
    note : str
        "" when the profile was used, else the one-line reason it was not.
    """
    if profile is None:
        return None, "no NoiseProfile in the file"
    try:
        return NoiseModel.from_noise_profile(profile, white=white, k=k), ""
    except NoiseModelError as exc:
        return None, f"NoiseProfile ignored: {exc}"


def noise_model(noise, k: int) -> NoiseModel | None:
    """A :class:`NoiseModel` of ``k`` channels from what users give as ``noise``.

    ``None`` or 0 → None (noise-free); a number σ or ``k`` numbers → constant σ per channel;
    a :class:`NoiseModel` → itself (checked for ``k`` channels); a mapping with ``"shot"`` and
    ``"read"`` → that model.

    Raises
    ------
    NoiseModelError
        Negative, NaN or wrong channel count.
    """
    if noise is None:
        return None
    if isinstance(noise, NoiseModel):
        return None if noise.is_zero else noise.check_channels(k)
    if isinstance(noise, dict):
        unknown = set(noise) - {"shot", "read", "source"}
        if unknown or not {"shot", "read"} <= set(noise):
            raise NoiseModelError(
                f"noise={noise!r}: a mapping needs exactly 'shot' and 'read' (and 'source')."
            )
        return noise_model(NoiseModel(noise["shot"], noise["read"], noise.get("source", "given")), k)
    if isinstance(noise, str | bytes):
        raise NoiseModelError(f"noise={noise!r}: give σ, one σ per channel, or a NoiseModel.")
    model = NoiseModel.constant(noise, k)
    return None if model.is_zero else model


def estimate_noise(
    image, *, block: int = 8, quantile: float = 0.25, bins: int = 12, max_tiles: int = 16_000
) -> NoiseModel:
    """Estimate the shot + read noise of a linear image from its flat regions.

    The image is cut into ``block × block`` tiles (a seeded sample of ``max_tiles`` on large
    images); in each, a plane (smooth shading) is fitted per channel and the residual variance kept.
    Textured tiles only add variance, so in each of ``bins`` brightness bins the ``quantile`` of the
    tiles' residual variances is taken and corrected for the χ² spread of a variance estimate (the
    ``quantile`` of ``σ² χ²_ν/ν``, ν the residual degrees of freedom); ``var = shot · mean + read``
    is then fitted to the bins by non-negative least squares.

    Parameters
    ----------
    image : array_like of shape (H, W, k)
        Linear, white-balanced responses; NaN tiles are skipped.
    block
        Tile size in pixels (≥ 4).
    quantile
        Quantile of the tiles' variances per bin (low: the flattest tiles).
    bins
        Brightness bins per channel.
    max_tiles
        Tiles used at most (a seeded sample of them on large images).

    Returns
    -------
    NoiseModel
        ``source = "estimated from image"``. Spatially correlated noise (after demosaicing or
        denoising) is underestimated: a DNG ``NoiseProfile`` is preferable when present.

    Raises
    ------
    NoiseModelError
        An image that is not ``(H, W, k)``, has fewer than 16 usable tiles, or whose estimate is
        implausible (:meth:`NoiseModel.check_plausible`).
    """
    from scipy.special import gammaincinv  # χ² quantiles without importing scipy.stats (1 s)

    img = np.asarray(image)
    if img.ndim != 3 or block < 4 or not np.issubdtype(img.dtype, np.number):
        raise NoiseModelError(
            f"estimate_noise: give an image of shape (H, W, k) and block ≥ 4; got {img.shape}, block={block}."
        )
    H, W, k = img.shape
    nh, nw = H // block, W // block
    if nh * nw < 16:
        raise NoiseModelError(f"estimate_noise: image {H}×{W} has fewer than 16 tiles of {block}×{block}.")
    which = np.arange(nh * nw)
    if which.size > max_tiles:  # a seeded sample of tiles: the estimate needs thousands, not millions
        which = np.sort(np.random.default_rng(0).choice(which, max_tiles, replace=False))
    r = (which // nw)[:, None] * block + np.arange(block)
    c = (which % nw)[:, None] * block + np.arange(block)
    tiles = img[r[:, :, None], c[:, None, :]].reshape(which.size, block * block, k)  # image dtype
    tiles = tiles[np.all(np.isfinite(tiles), axis=(1, 2))]
    if tiles.shape[0] < 16:
        raise NoiseModelError("estimate_noise: fewer than 16 tiles without NaN pixels.")
    yy, xx = np.mgrid[0:block, 0:block].reshape(2, -1).astype(np.float64)
    Q = np.linalg.qr(np.stack([np.ones_like(xx), xx, yy], axis=1))[0]  # plane per tile, orthonormal
    dof = block * block - 3
    mean, var = np.empty((tiles.shape[0], k)), np.empty((tiles.shape[0], k))
    for j in range(k):  # one channel at a time in float64: bounded memory
        t = np.asarray(tiles[..., j], dtype=np.float64)
        mean[:, j] = t.mean(axis=1)
        d = t - mean[:, j, None]  # the constant is in the plane: residual = d minus its slope part
        var[:, j] = (np.sum(d**2, axis=1) - np.sum((d @ Q[:, 1:]) ** 2, axis=1)) / dof
    correction = dof / (2.0 * gammaincinv(dof / 2.0, quantile))  # ν / χ²_ν quantile
    shot, read = np.zeros(k), np.zeros(k)
    for j in range(k):
        edges = np.unique(np.quantile(mean[:, j], np.linspace(0.0, 1.0, bins + 1)))
        which = np.clip(np.searchsorted(edges, mean[:, j], side="right") - 1, 0, max(edges.size - 2, 0))
        xs, ys, ws = [], [], []
        for b in range(max(edges.size - 1, 1)):
            sel = which == b
            if sel.sum() < 4:
                continue
            xs.append(np.median(mean[sel, j]))
            ys.append(np.quantile(var[sel, j], quantile) * correction)
            ws.append(np.sqrt(sel.sum()))
        if not xs:
            raise NoiseModelError("estimate_noise: too few tiles per brightness bin to fit a noise model.")
        xs, ys, ws = np.array(xs), np.array(ys), np.array(ws)
        rel = ws / np.maximum(ys, np.finfo(float).tiny)  # relative errors: dark and bright bins count alike
        A = np.stack([np.maximum(xs, 0.0), np.ones_like(xs)], axis=1) * rel[:, None]
        shot[j], read[j] = _nnls2(A, ys * rel)
    return NoiseModel(shot, read, "estimated from image").check_plausible()


def _nnls2(A: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Non-negative least squares with two unknowns: the unconstrained solution if it is ≥ 0, else
    the better of the two one-unknown solutions clipped at 0 (the KKT cases of a 2-D problem)."""
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    if np.all(x >= 0):
        return float(x[0]), float(x[1])
    best, out = np.inf, (0.0, 0.0)
    for j in (0, 1):
        a = A[:, j]
        v = max(float(a @ b) / max(float(a @ a), np.finfo(float).tiny), 0.0)
        r = float(np.sum((b - v * a) ** 2))
        if r < best:
            best, out = r, ((v, 0.0) if j == 0 else (0.0, v))
    return out


def noisy(responses, noise, rng: np.random.Generator) -> np.ndarray:
    """``responses (N, k)`` plus seeded noise of ``noise`` (a σ, or a :class:`NoiseModel`)."""
    C = np.asarray(responses, dtype=np.float64)
    if isinstance(noise, NoiseModel):
        return noise.sample(C, rng)
    return C + rng.normal(0.0, noise, C.shape) if noise > 0 else C


def scalar_sigma(noise, responses) -> float:
    """One σ for estimators whose noise term is a single number: ``noise`` itself when a σ, else the
    model's :meth:`NoiseModel.effective_sigma` over ``responses (N, k)`` (typically the training set's)."""
    if isinstance(noise, NoiseModel):
        return noise.effective_sigma(responses)
    return float(noise)


def parse_noise(text: str, *, auto: bool = True):
    """A ``--noise`` value: ``"auto"`` (if allowed), a σ (float), or ``"SHOT:READ"`` →
    ``{"shot": .., "read": ..}``; the one parser of every command that takes ``--noise``.

    Raises
    ------
    NoiseModelError
        Text that is none of these (one line naming the value and the accepted forms).
    """
    forms = ("'auto', " if auto else "0, ") + "a σ such as 0.005, or SHOT:READ such as 2.5e-5:0"
    if auto and text.strip().lower() == "auto":
        return "auto"
    if ":" in text:
        shot, _, read = text.partition(":")
        try:
            return {"shot": float(shot), "read": float(read)}
        except ValueError:
            raise NoiseModelError(
                f"--noise {text!r}: give SHOT:READ as two numbers, e.g. 2e-5:1e-7."
            ) from None
    try:
        return float(text)
    except ValueError:
        raise NoiseModelError(f"--noise {text!r}: give {forms}.") from None
