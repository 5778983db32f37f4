"""Exported kernels (``multimorph.rom._exported``): a jitted kernel traced once is read back
by later processes and called without tracing, with the same results; anything that could
make a kept file wrong (another kernel, other argument types, other sources, a damaged
file) traces again."""

from __future__ import annotations

import os
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from multimorph.rom import _exported
from multimorph.rom._notice import announced

pytestmark = pytest.mark.skipif(not _exported._serialisable(),
                                reason="JAX serialisation needs the flatbuffers package")


@pytest.fixture(autouse=True)
def _keep_every_kernel(monkeypatch) -> None:
    """The kernels here trace in milliseconds: keep them all (as a slow tracer would be)."""
    monkeypatch.setattr(_exported, "MIN_TRACE_SECONDS", 0.0)


def _kernel(traced: list[int]):
    """A small jitted kernel with a loop and a dict argument, as the path tracer has; each
    trace of its Python body is counted in ``traced``."""

    def body(q0, theta, p):
        traced.append(1)

        def step(carry):
            i, q = carry
            return i + 1, q - 0.5 * (q * q * theta["a"] - p) / (q * theta["a"])

        _, q = jax.lax.while_loop(lambda c: c[0] < 30, step, (0, q0))
        return {"q": q, "r": q * q * theta["a"] - p + theta["b"] * 0.0}

    return jax.jit(body)


def _args(n: int = 3, p: float = 2.0):
    return (jnp.ones(n), {"a": jnp.asarray(1.5), "b": jnp.asarray(0.25)}, jnp.asarray(p))


def _files(folder: Path) -> list[Path]:
    return sorted((folder / _exported.EXPORT_FOLDER).glob("*.bin"))


def test_a_kernel_exported_once_is_called_without_tracing_with_the_same_results(
        tmp_path: Path) -> None:
    traced: list[int] = []
    plain = _kernel([])(*_args())
    first = _exported.exported(_kernel(traced), "k", lambda: str(tmp_path))
    out1 = first(*_args())
    assert len(traced) == 1 and len(_files(tmp_path)) == 1
    # a new process: the kernel built again, nothing traced in it
    later: list[int] = []
    second = _exported.exported(_kernel(later), "k", lambda: str(tmp_path))
    out2 = second(*_args(p=3.0))
    out2b = second(*_args())
    assert later == []
    for k in plain:
        np.testing.assert_array_equal(np.asarray(out1[k]), np.asarray(plain[k]))
        np.testing.assert_array_equal(np.asarray(out2b[k]), np.asarray(plain[k]))
    # Newton's root of a q² = p: the exported kernel computes, it does not replay
    np.testing.assert_allclose(np.asarray(out2["q"]), np.sqrt(3.0 / 1.5), rtol=1e-12)


def test_other_types_keys_or_sources_trace_again(tmp_path: Path, monkeypatch) -> None:
    traced: list[int] = []
    fn = _exported.exported(_kernel(traced), "k", lambda: str(tmp_path))
    fn(*_args())
    fn(*_args(n=4))                       # another shape: its own export
    assert len(traced) == 2 and len(_files(tmp_path)) == 2
    other: list[int] = []
    _exported.exported(_kernel(other), "k2", lambda: str(tmp_path))(*_args())
    assert len(other) == 1 and len(_files(tmp_path)) == 3
    # a change of multimorph's sources: nothing kept before is used
    monkeypatch.setattr(_exported, "source_digest", lambda: "another version")
    edited: list[int] = []
    _exported.exported(_kernel(edited), "k", lambda: str(tmp_path))(*_args())
    assert len(edited) == 1 and len(_files(tmp_path)) == 4


def test_a_damaged_file_is_traced_again_and_rewritten(tmp_path: Path) -> None:
    _exported.exported(_kernel([]), "k", lambda: str(tmp_path))(*_args())
    (f,) = _files(tmp_path)
    f.write_bytes(b"not a kernel")
    traced: list[int] = []
    out = _exported.exported(_kernel(traced), "k", lambda: str(tmp_path))(*_args())
    assert len(traced) == 1 and f.stat().st_size > 100
    np.testing.assert_allclose(np.asarray(out["q"]), np.sqrt(2.0 / 1.5), rtol=1e-12)


def test_without_a_cache_folder_nothing_is_kept_and_the_kernel_is_plain_jit(
        tmp_path: Path, monkeypatch) -> None:
    traced: list[int] = []
    fn = _exported.exported(_kernel(traced), "k", lambda: None)
    fn(*_args())
    fn(*_args())
    assert len(traced) == 1 and not (tmp_path / _exported.EXPORT_FOLDER).exists()
    # MULTIMORPH_JAX_EXPORT=0: the same, with a cache folder
    monkeypatch.setenv("MULTIMORPH_JAX_EXPORT", "0")
    off: list[int] = []
    _exported.exported(_kernel(off), "k", lambda: str(tmp_path))(*_args())
    assert len(off) == 1 and not (tmp_path / _exported.EXPORT_FOLDER).exists()
    # a plain Python function (no .lower) is returned as it is
    def py(x):
        return x
    assert _exported.exported(py, "k", lambda: str(tmp_path)) is py


def test_announced_kernels_go_through_their_export(tmp_path: Path) -> None:
    traced: list[int] = []
    announced(_kernel(traced), "k", cache=lambda: str(tmp_path))(*_args())
    later: list[int] = []
    out = announced(_kernel(later), "k", cache=lambda: str(tmp_path))(*_args())
    assert len(traced) == 1 and later == [] and len(_files(tmp_path)) == 1
    np.testing.assert_allclose(np.asarray(out["q"]), np.sqrt(2.0 / 1.5), rtol=1e-12)


def test_a_kernel_quick_to_trace_is_not_kept(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(_exported, "MIN_TRACE_SECONDS", 60.0)
    traced: list[int] = []
    fn = _exported.exported(_kernel(traced), "k", lambda: str(tmp_path))
    out = fn(*_args())
    fn(*_args())
    assert _files(tmp_path) == [] and len(traced) in (1, 2)   # plain jit from here on
    np.testing.assert_allclose(np.asarray(out["q"]), np.sqrt(2.0 / 1.5), rtol=1e-12)
    # a later process goes straight to jit: no export, one trace
    monkeypatch.setattr(_exported, "_export", lambda *a: pytest.fail("exported again"))
    later: list[int] = []
    _exported.exported(_kernel(later), "k", lambda: str(tmp_path))(*_args())
    assert len(later) == 1 and _files(tmp_path) == []
    assert len(list((tmp_path / _exported.EXPORT_FOLDER).glob("*.cheap"))) == 1


def test_beyond_max_kept_the_least_recently_used_kernels_go(tmp_path: Path,
                                                             monkeypatch) -> None:
    monkeypatch.setattr(_exported, "MAX_KEPT", 2)
    fns = {n: _exported.exported(_kernel([]), "k", lambda: str(tmp_path)) for n in (3, 4)}
    for n, fn in fns.items():
        fn(*_args(n=n))
    first, second = (_exported.kernel_file(tmp_path, "k", _exported._signature(_args(n=n)))
                     for n in (3, 4))
    os.utime(first, (1, 1))
    os.utime(second, (2, 2))
    # read back in a later process: the n = 3 kernel is now the most recently used
    _exported.exported(_kernel([]), "k", lambda: str(tmp_path))(*_args(n=3))
    _exported.exported(_kernel([]), "k", lambda: str(tmp_path))(*_args(n=5))
    assert set(_files(tmp_path)) == {first, _exported.kernel_file(
        tmp_path, "k", _exported._signature(_args(n=5)))}


def test_the_source_digest_covers_the_package_code() -> None:
    d = _exported.source_digest()
    assert len(d) == 64 and d == _exported.source_digest()
    f = _exported.kernel_file("/c", "k", "sig")
    assert f.parent == Path("/c") / _exported.EXPORT_FOLDER and f.suffix == ".bin"
    assert _exported.kernel_file("/c", "k", "sig2") != f
