"""Every scenario gives the results it gave before the restructuring (issue 8): the gate of every move.

``tests/data/golden_<case>.npz`` were written by ``tests/scenarios/golden_cases.py`` on the pre-restructure main. In the
numerical environment they were made in (same numpy / scipy / numba / BLAS kernel, ``golden_platform.json``) the
comparison is bit for bit; elsewhere BLAS kernels may round differently, and arrays are compared to 1e-7
relative (a moved formula or a changed draw order still fails by orders of magnitude more).
"""

import json

import numpy as np
import pytest

import golden_cases as gc

STORED_PLATFORM = json.loads((gc.DATA / "golden_platform.json").read_text())
EXACT = gc.platform() == STORED_PLATFORM


def _numbers(node, path=""):
    """Numeric leaves of a JSON document by dotted path (prose such as a ``note`` is not a result)."""
    if isinstance(node, dict):
        return {k: v for key, sub in node.items() for k, v in _numbers(sub, f"{path}.{key}").items()}
    if isinstance(node, list):
        return {k: v for i, sub in enumerate(node) for k, v in _numbers(sub, f"{path}[{i}]").items()}
    return {path: node} if isinstance(node, (int, float)) or node is None else {}


def _compare(name, got, want):
    if name.endswith("_json"):  # bytes of a JSON file: compare its numbers
        got, want = (_numbers(json.loads(bytes(a))) for a in (got, want))
        assert sorted(got) == sorted(want), name
        for k in want:
            _compare(f"{name}{k}", np.asarray(got[k], dtype=float), np.asarray(want[k], dtype=float))
        return
    if name.endswith(".sha256") and not EXACT:
        return
    if EXACT:
        np.testing.assert_array_equal(got, want, err_msg=name, strict=True)
        return
    assert got.shape == want.shape and got.dtype == want.dtype, name
    if got.dtype.kind in "fc":
        scale = float(np.nanmax(np.abs(want))) if want.size and np.any(np.isfinite(want)) else 0.0
        np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-9 * scale, err_msg=name)
    else:
        np.testing.assert_array_equal(got, want, err_msg=name)


@pytest.mark.parametrize("case", sorted(gc.CASES))
def test_results_equal_the_pre_restructure_main(case):
    got = gc.compact(gc.CASES[case]())
    with np.load(gc.path(case)) as z:
        want = {k: z[k] for k in z.files}
    assert sorted(got) == sorted(want)
    for name in sorted(want):
        _compare(name, np.asarray(got[name]), want[name])
