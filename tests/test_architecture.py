"""The layers of pyproject.toml's import-linter contracts hold: the CLI over diagnosis over the fit pipeline
over generate's pipeline over generator | verifier | machines over the contract over fitting over the models
over physics over recordings over the base, and the verifier never imports the generator. The package is the
folder thermoplc/ itself, so the linter reads the repository in place: no installed copy."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _lint(tree: Path) -> subprocess.CompletedProcess:
    linter = Path(sys.executable).with_name("lint-imports")
    return subprocess.run([str(linter), "--config", str(ROOT / "pyproject.toml"), "--no-cache"], cwd=tree,
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(tree)},
                          stdin=subprocess.DEVNULL)


def test_the_import_contracts_hold():
    result = _lint(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Contracts: 4 kept, 0 broken." in result.stdout


def test_a_broken_arrow_is_caught(tmp_path):
    """The checks can fail: a verifier module that imports the generator breaks both contracts that forbid it,
    and the ST reader that imports a replay breaks the verifier's own layers."""
    shutil.copytree(ROOT / "thermoplc", tmp_path / "thermoplc", ignore=shutil.ignore_patterns("__pycache__", "data"))
    verifier = tmp_path / "thermoplc" / "verifier"
    (verifier / "leak.py").write_text("from thermoplc.generator.lower import lower\n")
    (verifier / "reading" / "upward.py").write_text("from thermoplc.verifier.replays import replay\n")
    result = _lint(tmp_path)
    assert result.returncode != 0 and "thermoplc.verifier.leak -> thermoplc.generator.lower" in result.stdout
    assert "thermoplc.verifier.reading.upward -> thermoplc.verifier.replays.replay" in result.stdout
    assert "Contracts: 1 kept, 3 broken." in result.stdout


def test_the_package_imports_from_the_repository_without_an_install(tmp_path):
    """`import thermoplc` from the repository root finds the folder thermoplc/, not an installed copy: a child
    Python started in a bare folder with only the repository on its path imports every subpackage from there."""
    code = ("import pkgutil, thermoplc\n"
            "names = [m.name for m in pkgutil.walk_packages(thermoplc.__path__, 'thermoplc.') if m.ispkg]\n"
            "for name in names: __import__(name)\n"
            "import json, sys; print(json.dumps([thermoplc.__file__] + [sys.modules[n].__file__ for n in names]))\n")
    result = subprocess.run([sys.executable, "-I", "-c", f"import sys; sys.path.insert(0, {str(ROOT)!r})\n" + code],
                            cwd=tmp_path, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    assert result.returncode == 0, result.stderr
    top, *subpackages = json.loads(result.stdout)
    assert Path(top) == ROOT / "thermoplc" / "__init__.py"
    assert len(subpackages) >= 15 and all(Path(path).is_relative_to(ROOT / "thermoplc") for path in subpackages)
