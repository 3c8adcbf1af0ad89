"""The optional compiled kernels' loader refuses a module built from another source.

Oracle: the module's recorded SHA-256 (``source_sha256``, set at build by ``setup.py``) against
hashlib's digest of the C file beside it.  A stale editable build (a C file changed by a pull,
the extension not rebuilt) once ended a campaign in ``TypeError: function takes exactly 32
arguments (33 given)``; now the numpy form runs with one warning.
"""

import hashlib
import types

import pytest

from rcsim.spacecraft import optional_kernel as ok


def _module(tmp_path, source: bytes, built_from: bytes) -> types.ModuleType:
    (tmp_path / "_kern.c").write_bytes(source)
    m = types.ModuleType("pkg._kern")
    m.__file__ = str(tmp_path / "_kern.cpython-311-x86_64-linux-gnu.so")
    m.source_sha256 = hashlib.sha256(built_from).hexdigest()
    return m


def test_a_module_built_from_its_source_is_used(tmp_path):
    assert not ok.is_stale(_module(tmp_path, b"int f(void);", b"int f(void);"))


def test_a_module_built_from_an_older_source_is_stale(tmp_path):
    assert ok.is_stale(_module(tmp_path, b"int f(int);", b"int f(void);"))


def test_without_a_digest_or_a_source_there_is_nothing_to_compare(tmp_path):
    m = _module(tmp_path, b"x", b"y")
    del m.source_sha256
    assert not ok.is_stale(m)
    m = _module(tmp_path, b"x", b"y")
    (tmp_path / "_kern.c").unlink()
    assert not ok.is_stale(m)


def test_a_stale_kernel_falls_back_to_numpy_with_one_warning(tmp_path, monkeypatch):
    stale = _module(tmp_path, b"int f(int);", b"int f(void);")
    monkeypatch.setattr(ok.importlib, "import_module", lambda name: stale)
    with pytest.warns(RuntimeWarning, match="older source"):
        kernel = ok.optional_kernel("pkg._kern")
    assert kernel.module is None and not kernel.available()


def test_the_installed_kernels_match_their_sources():
    """The kernels this checkout runs were built from the C files beside them (a fresh install
    builds them; the suite would otherwise test the numpy forms under the compiled names)."""
    from rcsim.lookup import step_kernel
    from rcsim.spacecraft import cycle_kernel

    for kernel in (step_kernel._KERNEL, cycle_kernel._KERNEL):
        if kernel.module is not None:
            assert not ok.is_stale(kernel.module)
