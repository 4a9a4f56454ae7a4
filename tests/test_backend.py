"""libLLVM discovery and Mitsuba variant choice."""

from __future__ import annotations

import subprocess
import sys

import pytest

from compare.mitsuba import backend
from compare.util.errors import MissingComponentError


@pytest.mark.parametrize("name, major", [
    ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so", 19),
    ("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1", 19),
    ("/usr/lib/x86_64-linux-gnu/libLLVM-14.0.6.so.1", 14),
    ("/usr/lib/llvm-15/lib/libLLVM-15.so.1", 15),
    ("/opt/libfoo.so", None),
])
def test_llvm_major_from_file_name(name, major):
    assert backend.llvm_major(name) == major


def test_old_llvm_is_refused_with_install_hint(monkeypatch, tmp_path):
    old = tmp_path / "libLLVM-14.so.1"
    old.write_bytes(b"")
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(old))
    with pytest.raises(MissingComponentError, match="LLVM 14, which crashes Dr.Jit.*apt-get install libllvm19"):
        backend.configure_llvm()
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "missing.so"))
    with pytest.raises(MissingComponentError, match="does not exist"):
        backend.configure_llvm()


def test_falls_back_to_scalar_with_one_warning():
    """With no usable libLLVM the reference still works, on scalar_rgb, and says how to fix it."""
    code = (
        "import os, warnings\n"
        "os.environ.pop('DRJIT_LIBLLVM_PATH', None)\n"
        "import compare.mitsuba.backend as b\n"
        "b.find_libllvm = lambda: None\n"
        "b._has_cuda = lambda: False\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    mi = b.load_mitsuba()\n"
        "    mi = b.load_mitsuba()\n"
        "print(mi.variant(), len(w), str(w[0].message))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.startswith("scalar_rgb 1 ")
    assert "apt-get install libllvm19" in out


def test_best_variant_here_is_not_scalar():
    """This machine has libLLVM 19 (installed by the set-up script): the fast backend is used."""
    if backend.find_libllvm() is None:
        pytest.skip("no libLLVM >= 16 on this machine")
    mi = backend.load_mitsuba()
    assert mi.variant() in ("llvm_ad_rgb", "cuda_ad_rgb")
