"""Each reference's per-call arithmetic exists once (issue 66): every loop over a recording's calls in models/ sits
in one function that numba compiles or Python runs (base/compiled.py's `jit`), never beside a plain-Python copy of
it. tests/test_fast_reference.py proves the two ways to run it give the same bits."""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# What a range over the calls of a recording is written with in models/ (rows, an output's or an input's length).
CALL_COUNTS = ("rows", "len(out)", ".shape[0]", "len(x)", "len(n)", "len(te)", "len(values)", "len(static)")


def _compiled(function: ast.FunctionDef) -> bool:
    return any((isinstance(d, ast.Attribute) and d.attr == "jit") or (isinstance(d, ast.Name) and d.id == "jit")
               for d in function.decorator_list)


def loops_over_calls(source: str) -> list[tuple[str, int, bool]]:
    """(function, line, compiled) of every `for ... in range(...)` over a recording's calls in `source`."""
    found = []
    for function in ast.walk(ast.parse(source)):
        if not isinstance(function, ast.FunctionDef):
            continue
        for node in ast.walk(function):
            if (isinstance(node, ast.For) and isinstance(node.iter, ast.Call)
                    and isinstance(node.iter.func, ast.Name) and node.iter.func.id == "range"
                    and any(mark in ast.unparse(arg) for arg in node.iter.args for mark in CALL_COUNTS)):
                found.append((function.name, node.lineno, _compiled(function)))
    return found


def test_every_loop_over_calls_in_models_is_the_one_compiled_source():
    plain = [(path.name, name, line) for path in sorted((ROOT / "thermoplc" / "models").rglob("*.py"))
             for name, line, compiled in loops_over_calls(path.read_text()) if not compiled]
    assert plain == [], f"a per-call loop written as plain Python beside its compiled copy: {plain}"


def test_each_stateful_kind_has_one_loop():
    for module, loops in (("lumped_kernel", {"_lumped"}), ("kinds/kalman", {"_kalman"}),
                          ("kinds/grey", {"_gm0n", "_gm1n"}), ("kernels", {"_repeats", "_hold", "_limit"})):
        source = (ROOT / "thermoplc" / "models" / f"{module}.py").read_text()
        found = {name for name, _, compiled in loops_over_calls(source)}
        assert found == loops, module


def test_a_plain_copy_is_caught():
    source = ("@compiled.jit\ndef _step(x, out):\n    for j in range(out.shape[0]):\n        out[j] = x[j]\n\n"
              "def predict(x):\n    rows = len(x)\n    for j in range(rows):\n        pass\n")
    assert loops_over_calls(source) == [("_step", 3, True), ("predict", 8, False)]
