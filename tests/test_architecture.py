"""The layers of pyproject.toml's import-linter contracts hold: app over diagnosis over generator |
verifier | machines over the contract over fitting over the models over physics over recordings over
the base, and the verifier never imports the generator. The repository maps each folder to a subpackage (setuptools package-dir),
which import-linter cannot follow in place, so the test lays the package out as an installed
copy would be and lints that."""
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _installed_layout(into: Path) -> Path:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))
    for package, folder in config["tool"]["setuptools"]["package-dir"].items():
        target = into.joinpath(*package.split("."))
        target.mkdir(parents=True, exist_ok=True)
        for source in (ROOT / folder).glob("*.py"):
            shutil.copy(source, target / source.name)
    shutil.copy(ROOT / "pyproject.toml", into / "pyproject.toml")
    return into


def test_the_import_contracts_hold(tmp_path):
    tree = _installed_layout(tmp_path)
    linter = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run([str(linter), "--config", "pyproject.toml", "--no-cache"], cwd=tree, capture_output=True,
                            text=True, env={**os.environ, "PYTHONPATH": str(tree)}, stdin=subprocess.DEVNULL)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Contracts: 3 kept, 0 broken." in result.stdout


def test_a_broken_arrow_is_caught(tmp_path):
    """The check can fail: a verifier module that imports the generator breaks both contracts."""
    tree = _installed_layout(tmp_path)
    (tree / "thermoplc" / "verifier" / "leak.py").write_text("from thermoplc.generator.lower import lower\n")
    linter = Path(sys.executable).with_name("lint-imports")
    result = subprocess.run([str(linter), "--config", "pyproject.toml", "--no-cache"], cwd=tree, capture_output=True,
                            text=True, env={**os.environ, "PYTHONPATH": str(tree)}, stdin=subprocess.DEVNULL)
    assert result.returncode != 0 and "thermoplc.verifier.leak -> thermoplc.generator.lower" in result.stdout


def test_every_package_folder_is_installed():
    """A folder with an __init__.py that pyproject.toml does not list is missing from `pip install .`
    (an editable install still finds it, so only a real install would fail)."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["tool"]["setuptools"]
    folders = {ROOT / folder for folder in config["package-dir"].values()}
    found = {init.parent for folder in folders for init in folder.rglob("__init__.py")
             if "__pycache__" not in init.parts}
    assert found == folders, sorted(str(f.relative_to(ROOT)) for f in found ^ folders)
    assert set(config["packages"]) == set(config["package-dir"])


def test_a_cluster_worker_digests_every_installed_package():
    """base/cluster.environment() refuses a worker whose thermoplc sources differ: it must read every package."""
    from thermoplc.base.cluster import PACKAGES
    config = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["tool"]["setuptools"]
    assert set(PACKAGES) == set(config["packages"])
