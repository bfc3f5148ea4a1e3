"""The fast engine's private cache of compiled blocks: a block compiled once is loaded by the next process,
and a library anyone else could have planted is never loaded (verifier/engines/native_cache.py)."""
from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest

from tests.golden_models import golden_block
from thermoplc.verifier.engines import native, native_cache
from thermoplc.verifier.engines.native import NativeBlock
from thermoplc.verifier.reading.block_file import parse_file

pytestmark = [pytest.mark.skipif(native._compiler() is None, reason="no C compiler: the fast engine cannot be built"),
              pytest.mark.skipif(not os.sys.platform.startswith("linux"), reason="the cache is used on Linux only")]

PLANTED = r"""
#include <stdio.h>
#include <stdint.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen("MARKER", "w"); if (f) { fputs("loaded", f); fclose(f); }
}
int64_t state_size(void) { return 4096; }
void state_init(void *state) { (void)state; }
int64_t run(void *s, int64_t rows, void *a, void *b, void *c) { (void)s; (void)a; (void)b; (void)c; return rows; }
"""
COLUMNS = {"T_MOTOR": np.linspace(20, 40, 50, dtype=np.float32), "T_BEARING": np.linspace(20, 30, 50, dtype=np.float32),
           "N_RPM": np.full(50, 1500, np.float32), "T_ENV": np.full(50, 20, np.float32)}


@pytest.fixture
def program():
    return parse_file(golden_block("kalman", "tia"))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "private" / "native"
    monkeypatch.setenv("THERMOPLC_CACHE_DIR", str(folder))
    monkeypatch.delenv("THERMOPLC_NATIVE_CACHE", raising=False)
    monkeypatch.setattr(native, "_LOADED", {})  # as a new process: nothing loaded yet
    return folder


def _outputs(program) -> dict:
    block = NativeBlock(program)
    outputs, _ = block.run({k: v for k, v in COLUMNS.items() if k in {d.name.upper() for d in block.inputs}}, 50)
    return {name: np.asarray(values).view(np.uint32 if np.asarray(values).dtype == np.float32 else np.uint8)
            for name, values in outputs.items()}


def _built(monkeypatch) -> list:
    calls = []
    build = native._build
    monkeypatch.setattr(native, "_build", lambda *args: calls.append(args[3]) or build(*args))
    return calls


def test_a_block_compiled_once_is_loaded_from_the_cache_next_time(program, cache, monkeypatch):
    calls = _built(monkeypatch)
    first = _outputs(program)
    assert len(calls) == 1 and (cache / f"{calls[0]}.so").is_file()
    assert oct(cache.stat().st_mode & 0o777) == oct(0o700)
    monkeypatch.setattr(native, "_LOADED", {})
    again = _outputs(program)
    assert len(calls) == 1  # no second compile
    assert first.keys() == again.keys() and all(np.array_equal(first[k], again[k]) for k in first)


def _planted(tmp_path, marker) -> str:
    source = tmp_path / "planted.c"
    source.write_text(PLANTED.replace("MARKER", str(marker)))
    library = tmp_path / "planted.so"
    subprocess.run([*native._compiler(), "-shared", "-fPIC", "-o", str(library), str(source)], check=True)
    return str(library)


def _plant(how: str, cache, key: str, library: str) -> None:
    target = cache / f"{key}.so"
    target.unlink()
    if how == "symlink":
        target.symlink_to(library)
        return
    shutil.copy(library, target)
    if how == "writable by others":
        os.chmod(target, 0o777)
    elif how == "folder open to others":
        os.chmod(cache, 0o777)
    elif how == "folder above writable by others":
        os.chmod(cache.parent, 0o777)
    elif how == "owned by another user":
        os.chown(target, 65534, 65534)


HOW = ["symlink", "writable by others", "folder open to others", "folder above writable by others",
       "owned by another user"]


@pytest.mark.parametrize("how", HOW)
def test_a_planted_library_is_never_loaded(program, cache, monkeypatch, tmp_path, how):
    if how == "owned by another user" and os.geteuid() != 0:
        pytest.skip("only root can give a file to another user")
    calls = _built(monkeypatch)
    expected = _outputs(program)
    marker = tmp_path / "planted-was-loaded"
    _plant(how, cache, calls[0], _planted(tmp_path, marker))
    monkeypatch.setattr(native, "_LOADED", {})
    got = _outputs(program)
    assert not marker.exists(), f"a planted library ({how}) was loaded"
    assert len(calls) == 2  # compiled again instead
    assert all(np.array_equal(expected[k], got[k]) for k in expected)


def test_the_cache_can_be_switched_off(program, cache, monkeypatch):
    monkeypatch.setenv("THERMOPLC_NATIVE_CACHE", "off")
    calls = _built(monkeypatch)
    _outputs(program)
    monkeypatch.setattr(native, "_LOADED", {})
    _outputs(program)
    assert len(calls) == 2 and not cache.exists()


def test_a_shared_folder_is_never_the_cache(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o777)  # writable by anyone, not sticky
    monkeypatch.setenv("THERMOPLC_CACHE_DIR", str(shared / "native"))
    monkeypatch.delenv("THERMOPLC_NATIVE_CACHE", raising=False)
    assert native_cache.folder() is None


def test_two_cached_blocks_in_one_process_are_two_libraries(cache, monkeypatch):
    """The dynamic loader knows a library by its name: both must not come back as the first one."""
    programs = [parse_file(golden_block(kind, "tia")) for kind in ("kalman", "mlr")]
    first = [_outputs(p) for p in programs]
    for _ in range(2):  # from the cache, twice (a name loaded before is not opened again)
        monkeypatch.setattr(native, "_LOADED", {})
        again = [_outputs(p) for p in programs]
        for before, after in zip(first, again):
            assert before.keys() == after.keys() and all(np.array_equal(before[k], after[k]) for k in before)


def test_a_symlink_on_the_way_does_not_hide_a_shared_folder(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    (shared / "mine").mkdir(parents=True)
    os.chmod(shared, 0o777)  # writable by anyone, not sticky
    os.chmod(shared / "mine", 0o700)
    (tmp_path / "home").mkdir()
    (tmp_path / "home" / ".cache").symlink_to(shared / "mine")  # ~/.cache on a scratch disk
    monkeypatch.delenv("THERMOPLC_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.delenv("THERMOPLC_NATIVE_CACHE", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert native_cache.folder() is None
    assert not (shared / "mine" / "thermoplc").exists()  # nothing created where it is refused


def test_no_home_means_no_cache_not_a_crash(monkeypatch):
    monkeypatch.delenv("THERMOPLC_CACHE_DIR", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.delenv("THERMOPLC_NATIVE_CACHE", raising=False)
    monkeypatch.setattr(native_cache.Path, "home", classmethod(lambda cls: (_ for _ in ()).throw(
        RuntimeError("Could not determine home directory."))))
    assert native_cache.folder() is None


def test_a_relative_xdg_cache_home_is_ignored(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("THERMOPLC_CACHE_DIR", raising=False)
    monkeypatch.delenv("THERMOPLC_NATIVE_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "relcache")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    assert native_cache.folder() == (tmp_path / "home" / ".cache" / "thermoplc" / "native").resolve()
    assert not (tmp_path / "relcache").exists()
