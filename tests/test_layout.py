"""The package's layout holds (issue 53): no import circle between modules, no hand-written module over
500 lines (the parser lark generates, verifier/reading/st_standalone.py, aside), an effect named in at most 4
files outside the tests and the synthetic machines. Imports are counted in the package folder itself, every
one included: inside functions and under TYPE_CHECKING too (two modules that need each other to be read are one
module in two files, wherever the import sits), and the imports a registry makes at run time by name."""
import functools
import io
import json
import os
import shutil
import tokenize
import subprocess
import sys
from pathlib import Path

MAX_LINES = 500
MAX_EFFECT_FILES = 4
ROOT = Path(__file__).resolve().parent.parent
GENERATED = {"st_standalone.py"}
# each module that imports by name at run time (a registry), and how to make it load everything it can
REGISTRIES = {
    "thermoplc.physics.effects": "registry()",
    "thermoplc.models.kinds": "registry()",
    "thermoplc.generator.lower": "lowerings()",
    "thermoplc.generator.lumped_effects": "lowerings()",
    "thermoplc.generator.dialects": "registry()",
    "thermoplc.recordings.formats": "registry()",
    "thermoplc.machines": "[machine(name) for name in MACHINES]",
}
IMPORTS_A_LIBRARY_BY_NAME = {"thermoplc.base.compiled", "thermoplc.base.cluster"}  # numba, numpy: not thermoplc


def static_imports(tree: Path) -> dict[str, list[str]]:
    """Each module of `tree`'s thermoplc and the modules it imports, built by grimp in a fresh process (this
    one has the repository's thermoplc imported already)."""
    script = ("import grimp, json; graph = grimp.build_graph('thermoplc', cache_dir=None); "
              "print(json.dumps({m: sorted(graph.find_modules_directly_imported_by(m)) for m in graph.modules}))")
    result = subprocess.run([sys.executable, "-c", script], cwd=tree, capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(tree)}, stdin=subprocess.DEVNULL, check=True)
    return json.loads(result.stdout)


def runtime_imports(tree: Path) -> dict[str, list[str]]:
    """What each registry imports by name when it loads everything, seen by running it in a fresh process with
    `importlib.import_module` wrapped to note who asked."""
    script = f"""
import importlib, json, sys
seen, plain = {{}}, importlib.import_module
def noting(name, package=None):
    caller = sys._getframe(1).f_globals.get("__name__", "?")
    if name.startswith("thermoplc"):
        seen.setdefault(caller, set()).add(name)
    return plain(name, package)
importlib.import_module = noting
for module, load in {sorted(REGISTRIES.items())!r}:
    exec(load, vars(plain(module)))
print(json.dumps({{k: sorted(v) for k, v in seen.items()}}))
"""
    result = subprocess.run([sys.executable, "-c", script], cwd=tree, capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(tree)}, stdin=subprocess.DEVNULL, check=True)
    return json.loads(result.stdout)


def import_graph(tree: Path) -> dict[str, list[str]]:
    """The static imports and, added to them, the registries' imports at run time."""
    imports = static_imports(tree)
    for module, loaded in runtime_imports(tree).items():
        imports[module] = sorted(set(imports.get(module, [])) | set(loaded))
    return imports


def circles(tree: Path) -> list[list[str]]:
    """The circles of `tree`'s thermoplc, run-time imports of the registries included."""
    return strongly_connected(import_graph(tree))


def _static_circles(tree: Path) -> list[list[str]]:
    return strongly_connected(static_imports(tree))


def strongly_connected(imports: dict[str, list[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module in an import graph."""
    assert "thermoplc.generator.printer" in imports and len(imports) > 100, "grimp read no thermoplc"
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []
    for root in sorted(imports):  # Tarjan's algorithm, iteratively
        if root in index:
            continue
        work = [(root, iter(imports[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    work.append((child, iter(imports[child])))
                elif child in stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop()
                    group.append(member)
                    if member == node:
                        break
                if len(group) > 1:
                    found.append(sorted(group))
    return found


def long_modules(tree: Path) -> list[str]:
    return [f"{path.relative_to(tree)}: {lines} lines" for path in sorted((tree / "thermoplc").rglob("*.py"))
            if path.name not in GENERATED and (lines := len(path.read_text("utf-8").splitlines())) > MAX_LINES]


def test_no_module_imports_itself_through_others():
    assert circles(ROOT) == []


def test_every_import_by_name_is_a_registry_the_graph_runs():
    """A module that imports by name is in REGISTRIES (so the graph has its run-time imports) or imports a
    library; each registry loads modules of thermoplc when run."""
    by_name = {".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
               for path in (ROOT / "thermoplc").rglob("*.py") if "import_module (" in code_of(path)}
    assert by_name == set(REGISTRIES) | IMPORTS_A_LIBRARY_BY_NAME
    loaded = runtime_imports(ROOT)
    assert {module for module in REGISTRIES if loaded.get(module)} == set(REGISTRIES)
    assert "thermoplc.physics.effects.coolant_switching" in loaded["thermoplc.physics.effects"]


def test_no_hand_written_module_is_over_500_lines():
    assert long_modules(ROOT) == []


def _copy(tmp_path: Path) -> Path:
    shutil.copytree(ROOT / "thermoplc", tmp_path / "thermoplc", ignore=shutil.ignore_patterns("__pycache__", "data"))
    return tmp_path


def test_a_circle_and_a_long_module_are_caught(tmp_path):
    """The checks can fail: a circle through a function-level import, and a module of 501 lines."""
    tree = _copy(tmp_path)
    base = tree / "thermoplc" / "base"
    (base / "first.py").write_text("from thermoplc.base import second\n")
    (base / "second.py").write_text("def later():\n    from thermoplc.base import first\n" + "\n" * 499)
    assert ["thermoplc.base.first", "thermoplc.base.second"] in circles(tree)
    assert long_modules(tree) == [f"{Path('thermoplc', 'base', 'second.py')}: 501 lines"]


def test_a_circle_only_the_run_time_sees_is_caught(tmp_path):
    """A dialect module that imports the printer: the printer imports the dialects' package, whose registry
    loads the module by name. No import statement closes the circle; the registry's run does."""
    tree = _copy(tmp_path)
    (tree / "thermoplc" / "generator" / "dialects" / "leak.py").write_text("from thermoplc.generator import printer\n")
    assert not any("thermoplc.generator.dialects.leak" in group for group in _static_circles(tree))
    assert any({"thermoplc.generator.dialects", "thermoplc.generator.dialects.leak"} <= set(group)
               for group in circles(tree))


@functools.lru_cache(maxsize=None)
def code_of(path: Path) -> str:
    """A module's code without its comments and docstrings: the words it acts on, not the words about it."""
    tokens = [t for t in tokenize.generate_tokens(io.StringIO(path.read_text("utf-8")).readline)
              if t.type not in (tokenize.NL, tokenize.INDENT, tokenize.DEDENT, tokenize.COMMENT)]
    kept = []
    for k, token in enumerate(tokens):
        statement_start = k == 0 or tokens[k - 1].type == tokenize.NEWLINE or tokens[k - 1].string == ":"
        alone = k + 1 == len(tokens) or tokens[k + 1].type in (tokenize.NEWLINE, tokenize.ENDMARKER)
        if not (token.type == tokenize.STRING and statement_start and alone):
            kept.append(token.string)
    return " ".join(kept)


def files_naming(word: str) -> list[str]:
    """The package's modules outside the synthetic machines whose code names `word`."""
    package = ROOT / "thermoplc"
    return sorted(path.relative_to(package).as_posix() for path in package.rglob("*.py")
                  if path.relative_to(package).parts[0] != "machines" and word in code_of(path))


def test_an_effect_lives_in_at_most_four_files():
    """Its record, its lowering, the block's reference and its compiled loop: the simulation, the identified
    model and the diagnosis call the record's hooks and name no effect."""
    from thermoplc.physics.effects import NAMES
    spread = {name: files_naming(name) for name in NAMES}
    assert {name: files for name, files in spread.items() if len(files) > MAX_EFFECT_FILES} == {}
    assert "physics/effects/coolant_switching.py" in spread["coolant_switching"]


def test_code_of_drops_comments_and_docstrings_only(tmp_path):
    module = tmp_path / "module.py"
    module.write_text('"""coolant_switching here"""\nx = 1  # coolant_switching\ny = "coolant_switching"\n')
    code = code_of(module)
    assert code.count("coolant_switching") == 1 and '"coolant_switching"' in code
