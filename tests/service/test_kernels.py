"""load_kernels says when numba compiles, and only then."""

import os
import subprocess
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


CACHED_MODULE = """
import numba


@numba.njit("float64(float64)", cache=True)
def twice(x):
    return 2.0 * x
"""

LOAD = """
import os
import subprocess
import sys
from plotgate.service import registry
from plotgate.service.kernels import load_kernels

said = []
seconds = load_kernels(
    lambda: said.append("compiling"),
    "cached_kernels",
    repaired=lambda exc, removed: said.append(f"removed {removed}"),
    package="cached_kernels",
)
kept = sys.modules["plotgate.service.registry"] is registry
print(said, seconds is not None, sys.modules["cached_kernels"].twice(2.0), kept)
"""


def test_a_damaged_cache_is_removed_and_compiled_again(tmp_path):
    """numba raises on a cache file cut short; the files go, the kernels compile and are
    cached again, and the next start loads them. Modules loaded before stay the ones the
    running code holds (a replay loads each operation as it meets it). In subprocesses: a
    failed import drops modules from sys.modules."""
    (tmp_path / "cached_kernels").mkdir()
    (tmp_path / "cached_kernels/__init__.py").write_text(CACHED_MODULE)
    cache = tmp_path / "numba-cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(tmp_path)}

    def start() -> str:
        run = subprocess.run(
            [sys.executable, "-c", LOAD], env=env, capture_output=True, text=True, timeout=300
        )
        assert run.returncode == 0, run.stderr
        return run.stdout.strip()

    assert start() == "['compiling'] True 4.0 True"
    assert start() == "[] False 4.0 True"
    data = list(cache.rglob("*.nbc"))
    assert data
    for path in data:
        path.write_bytes(path.read_bytes()[:100])
    assert start() == "['removed 2', 'compiling'] True 4.0 True"
    assert start() == "[] False 4.0 True"
