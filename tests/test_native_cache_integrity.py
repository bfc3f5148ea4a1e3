"""A damaged entry of the fast engine's cache is judged unusable and compiled again, never loaded into a crash
(issue 48: a cached library cut to 4000 bytes killed every later verify with SIGBUS until deleted by hand).
Each case damages the kalman block's entry and runs `verify --engine fast` as a user would."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import golden_block, golden_twin_csv, GOLDEN
from thermoplc.verifier.engines import native, native_cache

pytestmark = [pytest.mark.skipif(native._compiler() is None, reason="no C compiler: the fast engine cannot be built"),
              pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the cache is used on Linux only")]

REPLAY_SPEED = re.compile(r"^  replay: .*$", re.MULTILINE)  # the one line that differs between two runs


class Setup:
    """A folder with the twin data, the cache those runs filled, the verdict and the two blocks' entries."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.cache = folder / "cache"
        self.env = {"THERMOPLC_CACHE_DIR": str(self.cache), "THERMOPLC_NATIVE_CACHE": "on"}
        self.csv = golden_twin_csv(folder)
        other = self._entry_of("mlr")
        self.other = other.read_bytes()
        self.verdict = self.verify().stdout
        self.entry = next(path for path in self.cache.glob("*.so") if path != other)
        self.key = self.entry.stem
        self.good = self.entry.read_bytes()

    def verify(self, kind: str = "kalman") -> subprocess.CompletedProcess:
        result = thermoplc("verify", golden_block(kind, "tia"), "--model", GOLDEN / f"{kind}.json", "--data", self.csv,
                           "--engine", "fast", cwd=self.folder, env=self.env)
        assert "fast engine (compiled C)" in result.stdout and "Traceback" not in result.stderr, result.stderr
        return result

    def _entry_of(self, kind: str) -> Path:
        self.verify(kind)
        (entry,) = self.cache.glob("*.so")
        return entry


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> Setup:
    return Setup(tmp_path_factory.mktemp("integrity"))


def _intact(entry: Path, key: str) -> bool:
    data = entry.read_bytes()
    size = len(data) - native_cache.RECORD_SIZE
    return size > 0 and data[size:] == native_cache._record(key, data[:size])


def _libc() -> str:
    with open("/proc/self/maps") as maps:
        return next(line.split()[-1] for line in maps if re.search(r"/libc[.-][^/]*$", line.strip()))


def _recorded(setup: Setup, library: bytes) -> bytes:
    """`library` followed by a record that is right for this block's key: only its contents can fail."""
    return library + native_cache._record(setup.key, library)


def _without_functions(setup: Setup) -> bytes:
    source = setup.folder / "empty.c"
    source.write_text("int not_a_block = 1;\n")
    built = setup.folder / "empty.so"
    subprocess.run([*native._compiler(), "-shared", "-fPIC", "-o", str(built), str(source)], check=True)
    return _recorded(setup, built.read_bytes())


DAMAGE = {
    "cut to 4000 bytes": lambda setup: setup.good[:4000],
    "zero length": lambda setup: b"",
    "a foreign program (/bin/true)": lambda setup: Path("/bin/true").read_bytes(),
    "a foreign library (libc)": lambda setup: Path(_libc()).read_bytes(),
    "random bytes": lambda setup: os.urandom(len(setup.good)),
    "a garbage record": lambda setup: setup.good[:-40] + os.urandom(40),
    "an older thermoplc's entry (no record)": lambda setup: setup.good[:-native_cache.RECORD_SIZE],
    "another block's entry under this name": lambda setup: setup.other,
    "recorded, but no ELF (the loader refuses it)": lambda setup: _recorded(setup, os.urandom(len(setup.good))),
    "recorded, ours, without the block's functions": _without_functions,
}


@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_entry_is_compiled_again(setup, damage):
    setup.entry.write_bytes(DAMAGE[damage](setup))
    os.chmod(setup.entry, 0o700)
    result = setup.verify()
    assert REPLAY_SPEED.sub("", result.stdout) == REPLAY_SPEED.sub("", setup.verdict)
    assert _intact(setup.entry, setup.key), f"{damage}: the entry was not repaired"


def test_a_sound_entry_is_loaded_as_it_is(setup):
    """The check passes what store wrote: a healthy entry is neither removed nor written again."""
    assert _intact(setup.entry, setup.key)
    before = os.stat(setup.entry)
    setup.verify()
    after = os.stat(setup.entry)
    assert (before.st_ino, before.st_mtime_ns) == (after.st_ino, after.st_mtime_ns)


def test_a_missing_entry_is_written_again(setup):
    shutil.rmtree(setup.cache)
    setup.verify()
    assert _intact(setup.entry, setup.key)
