"""Every compiled kernel in core is compiled when its module is imported, and cached."""

from tests.support.kernels import compiled_kernels


def test_the_kernels_are_found():
    assert "plotgate.core.initiation.search._grid_pairs" in compiled_kernels()


def test_every_kernel_is_compiled_at_import_and_cached_on_disk():
    for name, dispatcher in compiled_kernels().items():
        assert dispatcher.signatures, f"{name} compiles on its first call, not at import"
        assert type(dispatcher._cache).__name__ == "FunctionCache", f"{name} is not cached"
