"""Camera model names: one camera sold under several names (EOS 550D = Rebel T2i = Kiss X4).

A DCP names its camera by UniqueCameraModel, which raw developers compare with the file's
camera; Adobe's and RawTherapee's profiles use one name per camera (``"Canon EOS 550D"``), while a
file says what the camera was sold as (``"Canon EOS Kiss X4"``, ``"Canon EOS REBEL T2i"``).
:data:`CAMERA_ALIASES` is the one table of those families, in Adobe's names (as LibRaw's
``normalized_model`` spells them); :func:`canonical_model` maps any spelling to that name and
:func:`same_camera` compares two.
"""

from __future__ import annotations

import re

__all__ = ["CAMERA_ALIASES", "canonical_model", "same_camera"]

#: Adobe's name (DNG UniqueCameraModel of Adobe's and RawTherapee's profiles) → the other names the
#: same camera is sold or recorded under (regional names: Rebel in the Americas, Kiss in Japan).
#: Sources: LibRaw's camera list and ``normalized_model`` table, Adobe DNG Converter's profiles.
CAMERA_ALIASES: dict[str, tuple[str, ...]] = {
    "Canon EOS 300D": ("Canon EOS Digital Rebel", "Canon EOS Kiss Digital"),
    "Canon EOS 350D": ("Canon EOS Digital Rebel XT", "Canon EOS Kiss Digital N"),
    "Canon EOS 400D": ("Canon EOS Digital Rebel XTi", "Canon EOS Kiss Digital X"),
    "Canon EOS 450D": ("Canon EOS Rebel XSi", "Canon EOS Kiss X2"),
    "Canon EOS 500D": ("Canon EOS Rebel T1i", "Canon EOS Kiss X3"),
    "Canon EOS 550D": ("Canon EOS Rebel T2i", "Canon EOS Kiss X4"),
    "Canon EOS 600D": ("Canon EOS Rebel T3i", "Canon EOS Kiss X5"),
    "Canon EOS 650D": ("Canon EOS Rebel T4i", "Canon EOS Kiss X6i"),
    "Canon EOS 700D": ("Canon EOS Rebel T5i", "Canon EOS Kiss X7i"),
    "Canon EOS 750D": ("Canon EOS Rebel T6i", "Canon EOS Kiss X8i"),
    "Canon EOS 760D": ("Canon EOS Rebel T6s", "Canon EOS 8000D"),
    "Canon EOS 800D": ("Canon EOS Rebel T7i", "Canon EOS Kiss X9i"),
    "Canon EOS 850D": ("Canon EOS Rebel T8i", "Canon EOS Kiss X10i"),
    "Canon EOS 100D": ("Canon EOS Rebel SL1", "Canon EOS Kiss X7"),
    "Canon EOS 200D": ("Canon EOS Rebel SL2", "Canon EOS Kiss X9"),
    "Canon EOS 250D": ("Canon EOS Rebel SL3", "Canon EOS Kiss X10", "Canon EOS 200D II"),
    "Canon EOS 1000D": ("Canon EOS Rebel XS", "Canon EOS Kiss F"),
    "Canon EOS 1100D": ("Canon EOS Rebel T3", "Canon EOS Kiss X50"),
    "Canon EOS 1200D": ("Canon EOS Rebel T5", "Canon EOS Kiss X70", "Canon EOS Hi"),
    "Canon EOS 1300D": ("Canon EOS Rebel T6", "Canon EOS Kiss X80"),
    "Canon EOS 2000D": ("Canon EOS Rebel T7", "Canon EOS Kiss X90", "Canon EOS 1500D"),
    "Canon EOS 4000D": ("Canon EOS Rebel T100", "Canon EOS 3000D"),
    "Canon EOS M50": ("Canon EOS Kiss M",),
    "Canon EOS M50 Mark II": ("Canon EOS Kiss M2",),
    "Olympus E-410": ("Olympus EVOLT E-410",),
    "Olympus E-510": ("Olympus EVOLT E-510",),
    "Panasonic DMC-FZ1000": ("Leica V-LUX (Typ 114)",),
}


def _key(name: str) -> str:
    """Lower case, no spaces or punctuation, the maker written once ("Canon Canon EOS…")."""
    s = re.sub(r"[^0-9a-z]+", "", str(name).lower())
    for make in ("canon", "nikon", "olympus", "pentax", "panasonic", "leica", "sony", "fujifilm"):
        while s.startswith(make + make):
            s = s[len(make) :]
    return s


_CANONICAL: dict[str, str] = {}
for _name, _aliases in CAMERA_ALIASES.items():
    for _n in (_name, *_aliases):
        _CANONICAL[_key(_n)] = _name


def canonical_model(name: str) -> str:
    """Adobe's name for a camera model (``"Canon EOS Kiss X4"`` → ``"Canon EOS 550D"``).

    Case, spacing, punctuation and a repeated maker (``"Canon Canon EOS Kiss X4"``, a file's Make
    and Model joined) do not matter. A name not in :data:`CAMERA_ALIASES` is returned with its
    spacing tidied and a repeated maker removed.
    """
    text = " ".join(str(name).split())
    found = _CANONICAL.get(_key(text))
    if found is not None:
        return found
    words = text.split(" ")
    if len(words) > 1 and words[0].lower() == words[1].lower():
        words = words[1:]
    return " ".join(words)


def same_camera(a: str, b: str) -> bool:
    """Whether two model names are one camera: equal up to case and spacing, the same entry of
    :data:`CAMERA_ALIASES`, or one name ending with the other (``"Canon EOS 550D"`` and
    ``"EOS 550D"``, a Model without its Make; not ``"EOS 5D"`` and ``"EOS 5D Mark II"``). An
    empty name matches nothing."""
    ka, kb = _key(canonical_model(a)), _key(canonical_model(b))
    if not ka or not kb:
        return False
    return ka.endswith(kb) or kb.endswith(ka)
