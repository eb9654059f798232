"""An interactive view of the corrected scene inside an HTML page: a small WebGL 2 splat viewer
(``splat_viewer.js``, shipped with the package) and the scene packed into the page, so that the page
needs no network and no other file.

The packed scene is 40 bytes per Gaussian (centre and covariance as float32, the sRGB-encoded colour and
the opacity as bytes), base64-encoded (4/3 of that in the page). The viewer projects and cuts off each
Gaussian as :func:`splat.render` does and composites them back to front, so its first frame, drawn at a
photograph's pose, matches the renderer's image of the same view up to 8-bit colour and sorting per
Gaussian rather than per pixel.

Why: a multispectral reconstruction is a 3-D scene; the report should let one look at it.
"""

from __future__ import annotations

import base64
import html
import json
from importlib.resources import files

import numpy as np

__all__ = [
    "BYTES_PER_GAUSSIAN",
    "SCENE",
    "covariances",
    "pack_scene",
    "viewer_html",
    "viewer_page",
    "viewer_script",
]

#: Size of one Gaussian's record in the packed scene (before base64).
BYTES_PER_GAUSSIAN = 40
#: Where a run's corrected scene is kept for the viewer, relative to ``OUT``: the corrected colour of
#: every alive Gaussian and the registered cameras (:func:`splat.export.prepare_scene` writes it), next
#: to the correct step's results so that it is removed with them when the model or the correction changes.
SCENE = "correct/scene.npz"


def viewer_script() -> str:
    """The viewer's JavaScript (``splat/viewer/splat_viewer.js``)."""
    return files(__package__).joinpath("splat_viewer.js").read_text(encoding="utf-8")


def covariances(quats, log_scales) -> np.ndarray:
    """World-space covariances ``R S Sᵀ Rᵀ`` (NumPy twin of :func:`splat.gaussians.covariances_from`).

    Parameters
    ----------
    quats : array_like of shape (G, 4)
        ``(w, x, y, z)``, normalised here.
    log_scales : array_like of shape (G, 3)

    Returns
    -------
    ndarray of shape (G, 3, 3)
    """
    q = np.asarray(quats, np.float64)
    q = q / np.maximum(np.linalg.norm(q, axis=-1, keepdims=True), np.finfo(np.float64).tiny)
    w, x, y, z = q.T
    R = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )
    M = R * np.exp(np.asarray(log_scales, np.float64))[..., None, :]
    return M @ np.swapaxes(M, -1, -2)


def pack_scene(arrays: dict[str, np.ndarray], rgb) -> bytes:
    """The viewer's records of G Gaussians.

    Parameters
    ----------
    arrays : dict
        ``means`` (G, 3), ``quats`` (G, 4), ``log_scales`` (G, 3), ``opacity_logits`` (G,).
    rgb : array_like of shape (G, 3)
        sRGB-encoded colours in [0, 1].

    Returns
    -------
    bytes
        G × :data:`BYTES_PER_GAUSSIAN`, little-endian.
    """
    G = len(arrays["means"])
    S = covariances(arrays["quats"], arrays["log_scales"])
    rec = np.empty(G, [("p", "<f4", 3), ("s", "<f4", 6), ("c", "u1", 4)])
    rec["p"] = arrays["means"]
    rec["s"] = S[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    opacity = 1 / (1 + np.exp(-np.asarray(arrays["opacity_logits"], np.float64)))
    rgba = np.concatenate([np.clip(rgb, 0, 1), opacity[:, None]], -1)
    rec["c"] = np.round(rgba * 255)
    return rec.tobytes()


def viewer_html(
    arrays: dict[str, np.ndarray], rgb, cameras: list[dict], *, width: int = 640, caption: str = ""
) -> str:
    """A self-contained HTML fragment (a ``<figure class='splat-viewer'>`` with its canvas, buttons, the
    packed scene and the viewer script) showing the Gaussians from ``cameras[0]`` first.

    Parameters
    ----------
    arrays, rgb
        As :func:`pack_scene`.
    cameras : list of dict
        ``name``, ``R`` (3, 3) world-to-camera, ``t`` (3,), ``focal`` (2,), ``principal`` (2,) and ``size``
        (W, H) in pixels; the canvas has the first one's aspect ratio, ``width`` pixels wide (intrinsics
        scaled to it).
    caption : str
        HTML put under the canvas.
    """
    if not cameras:
        raise ValueError("the viewer needs at least one camera to start from")
    W0, H0 = (int(v) for v in cameras[0]["size"])
    H = max(1, round(width * H0 / W0))
    doc = {
        "count": len(arrays["means"]),
        "data": base64.b64encode(pack_scene(arrays, rgb)).decode("ascii"),
        "cameras": [
            {
                "name": str(c["name"]),
                "R": np.asarray(c["R"], float).tolist(),
                "t": np.asarray(c["t"], float).tolist(),
                "focal": np.asarray(c["focal"], float).tolist(),
                "principal": np.asarray(c["principal"], float).tolist(),
                "size": [int(v) for v in c["size"]],
            }
            for c in cameras
        ],
    }
    scene = json.dumps(doc).replace("</", "<\\/")  # nothing in it may close the script element
    return (
        "<figure class='splat-viewer' style='margin:0'>"
        f"<canvas width='{width}' height='{H}' style='display:block;width:{width}px;height:{H}px;"
        "background:#000;touch-action:none;cursor:grab'></canvas>"
        "<div style='margin:4px 0'><button type='button' class='splat-prev' title='previous photograph'>◀"
        "</button> <button type='button' class='splat-next' title='next photograph'>▶</button> "
        "<span class='splat-label'></span></div>"
        f"<figcaption><span class='splat-status'>The interactive view needs JavaScript and WebGL 2."
        f"</span> {caption}</figcaption>"
        f"<script type='application/json' class='splat-scene'>{scene}</script>"
        f"<script>{viewer_script()}</script></figure>"
    )


def viewer_page(fragment: str, title: str = "splat viewer") -> str:
    """A minimal page around :func:`viewer_html`'s fragment (canvas at the top-left corner)."""
    return (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title></head><body style='margin:0;background:#fff'>"
        f"{fragment}</body></html>"
    )
