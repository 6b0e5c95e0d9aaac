"""load_kernels says when numba compiles, and only then."""

import sys

from plotgate.service.kernels import load_kernels

KERNEL_MODULE = """
import numba


@numba.njit("float64(float64)")
def twice(x):
    return 2.0 * x
"""


def test_a_compilation_is_announced_once_and_timed(tmp_path, monkeypatch):
    (tmp_path / "fresh_kernels.py").write_text(KERNEL_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "fresh_kernels", raising=False)
    announced = []
    seconds = load_kernels(lambda: announced.append(True), "fresh_kernels")
    assert announced == [True]
    assert seconds is not None and seconds >= 0
    assert sys.modules["fresh_kernels"].twice(2.0) == 4.0


def test_kernels_already_loaded_are_not_announced():
    announced = []
    load_kernels(lambda: announced.append(True))  # the suite may have loaded them already
    assert load_kernels(lambda: announced.append(True)) is None
    assert len(announced) <= 1
