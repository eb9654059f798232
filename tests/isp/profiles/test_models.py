"""Camera model aliases: one camera under its regional names (EOS 550D = Rebel T2i = Kiss X4)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from isp.profiles.models import CAMERA_ALIASES, canonical_model, same_camera

FAMILIES = [(name, alias) for name, aliases in CAMERA_ALIASES.items() for alias in aliases]


@pytest.mark.parametrize(("name", "alias"), FAMILIES)
def test_aliases_are_one_camera(name, alias):
    assert canonical_model(alias) == name and same_camera(name, alias) and same_camera(alias, name)
    make = alias.split()[0]
    assert same_camera(name, f"{make} {alias}".upper())  # a file's Make + Model, any case


def test_kiss_x4_file_names_the_550d():
    assert canonical_model("Canon Canon EOS Kiss X4") == "Canon EOS 550D"
    assert same_camera("Canon EOS 550D", "Canon EOS REBEL T2i")
    assert same_camera("Canon EOS 550D", "EOS 550D")  # a Model without its Make


@pytest.mark.parametrize(
    ("a", "b"),
    [
        ("Canon EOS 550D", "Canon EOS 600D"),
        ("Canon EOS Kiss X4", "Canon EOS Kiss X5"),
        ("Canon EOS 5D", "Canon EOS 5D Mark II"),
        ("Canon EOS 550D", ""),
        ("Nikon D7000", "Canon EOS 550D"),
    ],
)
def test_different_cameras_differ(a, b):
    assert not same_camera(a, b)


@given(st.sampled_from(sorted(CAMERA_ALIASES)), st.sampled_from(sorted(CAMERA_ALIASES)))
def test_families_are_disjoint(a, b):
    """Two entries of the table never match each other, whichever of their names is used."""
    names_a, names_b = (a, *CAMERA_ALIASES[a]), (b, *CAMERA_ALIASES[b])
    assert all(same_camera(x, y) == (a == b) for x in names_a for y in names_b)


@pytest.mark.parametrize(
    ("model", "warned"),
    [
        ("Canon EOS Kiss X4", False),
        ("Canon EOS REBEL T2i", False),
        ("Canon EOS 550D", False),
        ("Nikon D5100", True),
    ],
)
def test_develop_accepts_a_profile_for_the_same_camera_under_another_name(tmp_path, model, warned):
    """`isp develop --profile` warns only when the DCP is for another camera, not for a regional name."""
    from types import SimpleNamespace

    from isp.cli.develop import _profile_camera_mismatch
    from isp.profiles.dcp import DCPProfile, write_dcp

    cm = np.array([[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]])
    path = write_dcp(tmp_path / "p.dcp", DCPProfile(cm, unique_camera_model="Canon EOS 550D"))
    raw = SimpleNamespace(tags={"UniqueCameraModel": model}, make="", model="")
    assert bool(_profile_camera_mismatch(path, raw)) is warned
