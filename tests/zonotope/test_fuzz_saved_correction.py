"""Fuzzing saved corrections: hostile ``.npz`` archives drawn by hypothesis.

The corpus of ``test_hardening.py`` holds one archive per reported case (pickles, NaN matrices,
inflating members, lying headers, truncation); here every draw damages a real saved correction
in one of those ways with random values: a member replaced by an array of another dtype, shape or
with non-finite values, a member dropped or added, the JSON header rewritten, bytes flipped or the
file cut. ``load_correction`` must return a corrector whose estimates are finite, or raise one
ZonotopeError line naming the file — never another exception or a NaN estimate.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zonotope import ZonotopeError

GRID = np.arange(400.0, 701.0, 10.0)
COUNT = {"loaded": 0, "refused": 0}


@pytest.fixture(scope="module", params=["Cheung 2004", "Finlayson 2015"])
def saved(request, tmp_path_factory):
    from zonotope.correct import fit_correction, save_correction

    path = tmp_path_factory.mktemp("saved") / "good.npz"
    save_correction(path, fit_correction("Nikon 5100 (NPL)", method=request.param, shape=GRID))
    with np.load(path) as z:
        members = {name: z[name] for name in z.files}
    return path, members


_special = st.sampled_from([0.0, -1.0, 1e308, -1e308, np.nan, np.inf, -np.inf, 1e-320])


def _array(data, like: np.ndarray) -> np.ndarray:
    how = data.draw(st.sampled_from(["values", "shape", "dtype", "scalar"]))
    if how == "values":  # same shape, some entries hostile
        a = np.array(like, dtype=np.float64, copy=True).reshape(-1)
        if a.size:
            for _ in range(data.draw(st.integers(1, 3))):
                a[data.draw(st.integers(0, a.size - 1))] = data.draw(_special)
        return a.reshape(like.shape)
    if how == "shape":
        shape = tuple(data.draw(st.lists(st.integers(0, 40), min_size=0, max_size=3)))
        return np.full(shape, data.draw(st.floats(-10, 10)))
    if how == "dtype":
        dtype = data.draw(st.sampled_from(["<i8", "<f4", "|b1", "<U5", "<c16", "|u1"]))
        return np.zeros(like.shape, dtype=dtype)
    return np.array(data.draw(st.floats(allow_nan=True, allow_infinity=True)))


_json = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 5) | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
    max_leaves=6,
)


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_saved_correction(saved, tmp_path, data):
    from zonotope.correct.profile import load_correction

    good, members = saved
    path = tmp_path / "hostile.npz"
    kind = data.draw(st.sampled_from(["member", "drop", "extra", "meta", "meta_key", "bytes", "cut"]))
    m = dict(members)
    names = sorted(n for n in m if n != "meta")
    if kind == "member":
        name = data.draw(st.sampled_from(names))
        m[name] = _array(data, m[name])
    elif kind == "drop":
        m.pop(data.draw(st.sampled_from(sorted(m))))
    elif kind == "extra":
        m[data.draw(st.sampled_from(["extra", "param_X", "Phi2"]))] = np.ones(3)
    elif kind == "meta":
        m["meta"] = np.array(json.dumps(data.draw(_json)))
    elif kind == "meta_key":
        meta = json.loads(str(m["meta"]))
        key = data.draw(st.sampled_from([*sorted(meta), "new"]))
        meta[key] = data.draw(_json)
        m["meta"] = np.array(json.dumps(meta))
    if kind in ("bytes", "cut"):
        b = bytearray(good.read_bytes())
        if kind == "cut":
            del b[data.draw(st.integers(0, len(b) - 1)) :]
        else:
            for _ in range(data.draw(st.integers(1, 6))):
                b[data.draw(st.integers(0, len(b) - 1))] = data.draw(st.integers(0, 255))
        path.write_bytes(bytes(b))
    else:
        np.savez(path, **m)
    try:
        corrector = load_correction(path)
    except ZonotopeError as error:
        COUNT["refused"] += 1
        message = str(error)
        assert "\n" not in message and "hostile.npz" in message, message
        return
    COUNT["loaded"] += 1
    c = np.array([[0.2, 0.3, 0.1], [0.9, 0.8, 0.7]])
    out = corrector(c)
    assert out.shape == (2, 3) and np.all(np.isfinite(out)), f"{kind}: {out}"


def test_the_fuzz_reaches_both_outcomes():
    """The draws above both refused and loaded archives (a fuzz that only ever refuses tests nothing)."""
    if COUNT["loaded"] + COUNT["refused"] < 20:
        pytest.skip("run with test_fuzz_saved_correction")
    assert COUNT["loaded"] > 0 and COUNT["refused"] > 0
