"""The default ProfileToneCurve of ``isp profile``: a camera-like rendering of scene-linear values.

A DCP's tone curve maps linear ProPhoto values in [0, 1] (the white just clipping at 1) to
linear output values, with the DNG SDK's hue-preserving RGB operator
(:func:`isp.profiles.dcp.apply_tone_curve`). A profile without one renders flat in RawTherapee
and darktable and gets Adobe's built-in curve in Adobe's software; with this one it renders
alike everywhere. The curve is our own closed form (no table is copied):

``f(x) = t (1 + a) / (t + a)`` with ``t = x^p``,

a toe (``p > 1``: slope 0 at black, so shadows and their noise are not lifted) followed by a
Reinhard-type shoulder (highlights roll off towards the white instead of clipping), with
``f(0) = 0`` and ``f(1) = 1``. ``p`` and ``a`` place scene mid-grey (18 %) where camera JPEGs and
Adobe's default rendering put it, about 1.1 stops up (:data:`MID_GREY_OUT`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MID_GREY_OUT", "TOE_POWER", "camera_tone_curve"]

#: Output of scene mid-grey (0.18): 0.39, ≈ 1.1 stops above it, as camera JPEGs and Adobe's
#: default curve render an 18 % card exposed by the meter (sRGB ≈ 167 of 255 before exposure
#: compensation).
MID_GREY_OUT = 0.39

#: Toe exponent p: slope 0 at black; 1.25 keeps the deep shadows' slope below 1 up to ≈ 2 % of the
#: white (a smaller p lifts the blacks, a larger one crushes the shadows).
TOE_POWER = 1.25


def camera_tone_curve(points: int = 65) -> np.ndarray:
    """The default tone curve as ``points`` (x, y) pairs, denser in the shadows.

    Returns
    -------
    ndarray of shape (points, 2)
        x increasing from 0 to 1, ``y = f(x)`` (see the module notes), ready for
        ``DCPProfile.tone_curve`` (:class:`isp.profiles.dcp.DCPProfile`).
    """
    x = np.linspace(0.0, 1.0, int(points)) ** 2  # the readers' cubic spline needs nodes in the toe
    g = 0.18**TOE_POWER
    a = g * (1.0 - MID_GREY_OUT) / (MID_GREY_OUT - g)  # f(0.18) = MID_GREY_OUT
    t = x**TOE_POWER
    return np.column_stack([x, t * (1.0 + a) / (t + a)])
