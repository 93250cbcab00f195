"""Variant choice and libLLVM discovery."""
from __future__ import annotations

import pytest

from clothscope.runtime import find_libllvm, resolve_variant, runtime_metadata


def test_a_working_libllvm_is_found():
    path = find_libllvm()
    assert path is not None and "LLVM" in path


def test_auto_variant_is_cuda_only_with_a_gpu():
    from clothscope.runtime import cuda_available

    assert resolve_variant("auto") == ("cuda_ad_rgb" if cuda_available() else "llvm_ad_rgb")
    assert resolve_variant("scalar_rgb") == "scalar_rgb"


def test_unknown_variant_is_refused():
    with pytest.raises(ValueError, match="unknown Mitsuba variant"):
        resolve_variant("llvm_ad_spectral_polarized")


def test_metadata_records_variant():
    from clothscope.runtime import mitsuba_for

    meta = runtime_metadata(mitsuba_for("llvm_ad_rgb", threads=2))
    assert meta["mitsuba_variant"] == "llvm_ad_rgb" and meta["mitsuba_version"] == "3.9.1"
