"""The root-polynomial regression's per-pixel terms, written into one array as they are computed.

Independent truth: the terms as a list of rows stacked, each computed from its definition.
"""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from zonotope.correct.regressions import _terms_by_row


def _stacked(c: np.ndarray, degree: int) -> np.ndarray:
    """The terms by definition: every channel, then ``(∏ c_i)^(1/d)`` of every multiset of ``d ≤ degree``
    channels that is not one channel repeated, as rows of a stack."""
    ct = np.maximum(np.ascontiguousarray(c.T), 0.0)
    rows = list(ct)
    for d in range(2, degree + 1):
        for combo in itertools.combinations_with_replacement(range(len(ct)), d):
            if len(set(combo)) > 1:
                p = ct[combo[0]] * ct[combo[1]]
                for i in combo[2:]:
                    p = p * ct[i]
                rows.append(np.sqrt(p) if d == 2 else p ** (1.0 / d))
    return np.stack(rows)


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(1, 700),
    k=st.integers(1, 9),
    degree=st.integers(1, 3),
    f32=st.booleans(),
    seed=st.integers(0, 2**31 - 1),
)
def test_terms_equal_the_stacked_definition(n, k, degree, f32, seed):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-0.1, 1.0, (n, k)) * 10.0 ** rng.uniform(-4, 0, (n, 1))
    c = c.astype(np.float32 if f32 else np.float64)
    if n > 3:
        c[1, 0] = np.nan
    got, want = _terms_by_row(c, degree), _stacked(c, degree)
    assert got.dtype == want.dtype and got.flags.c_contiguous
    np.testing.assert_array_equal(got, want)
