"""Variant choice and libLLVM discovery."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from clothscope.core.runtime import find_libllvm, resolve_variant, runtime_metadata


def test_a_working_libllvm_is_found():
    path = find_libllvm()
    assert path is not None and "LLVM" in path


def test_auto_variant_is_cuda_only_with_a_gpu():
    from clothscope.core.runtime import cuda_available

    assert resolve_variant("auto") == ("cuda_ad_rgb" if cuda_available() else "llvm_ad_rgb")
    assert resolve_variant("scalar_rgb") == "scalar_rgb"


def test_unknown_variant_is_refused():
    with pytest.raises(ValueError, match="unknown Mitsuba variant"):
        resolve_variant("llvm_ad_spectral_polarized")


def test_metadata_records_variant():
    from clothscope.core.runtime import mitsuba_for

    meta = runtime_metadata(mitsuba_for("llvm_ad_rgb", threads=2))
    assert meta["mitsuba_variant"] == "llvm_ad_rgb" and meta["mitsuba_version"] == "3.9.1"


def test_exr_io_after_a_one_thread_job_does_not_hang(tmp_path):
    """A second fit in one process reads and writes EXR after the first set 1 Dr.Jit thread."""
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(f"""
        import numpy as np, drjit as dr
        from clothscope.core.imageio import decode_exr, read_exr, write_exr
        from clothscope.core.runtime import mitsuba_for
        mitsuba_for("llvm_ad_rgb", threads=1)
        write_exr({str(tmp_path / 'a.exr')!r}, np.full((64, 64, 3), 0.25, np.float32))
        assert read_exr({str(tmp_path / 'a.exr')!r}).shape == (64, 64, 3)
        assert decode_exr({str(tmp_path / 'a.exr')!r}, 16, 1.0).rgb.mean() == np.float32(0.25)
        assert dr.thread_count() == 1
        print("ok")
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


SPY = """
import os, sys
os.environ.pop("DRJIT_LIBLLVM_PATH", None)
seen = []

class Spy:  # records DRJIT_LIBLLVM_PATH at the moment drjit is first imported
    def find_spec(self, name, path=None, target=None):
        if name == "drjit" and not seen:
            seen.append(os.environ.get("DRJIT_LIBLLVM_PATH", ""))

sys.meta_path.insert(0, Spy())
import clothscope.fit.jobs, clothscope.features.table, clothscope.core.imageio
print(seen[0] if seen else "never imported")
"""


def test_libllvm_is_chosen_before_drjit_is_first_imported():
    """drjit reads DRJIT_LIBLLVM_PATH on import, so importing clothscope sets it first."""
    expected = find_libllvm()
    if expected is None:
        pytest.skip("no libLLVM >= 16 on this machine")
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    out = subprocess.run([sys.executable, "-c", SPY], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == expected
