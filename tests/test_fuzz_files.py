"""Issue 15: structure-aware fuzzing of model files and command-line options. A model file with any
field replaced by any JSON value loads, lowers and prints, or is refused with a UserError; never
another exception. Every numeric option with any text is parsed or refused by argparse (exit 2)."""
import json
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from thermoplc.cli import build_parser
from thermoplc.base.errors import UserError
from thermoplc.generator.ir import GenerationError
from thermoplc.generator.lower import lower, prove
from thermoplc.generator.printer import render
from thermoplc.models.modelfile import load_model
from thermoplc.models.safety import Limits
from tests.golden_models import GOLDEN

EXAMPLES = int(os.environ.get("THERMOPLC_FUZZ_EXAMPLES", "150"))
KINDS = sorted(p.stem for p in GOLDEN.glob("*.json"))
DOCS = {kind: json.loads((GOLDEN / f"{kind}.json").read_text()) for kind in KINDS}
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-10 ** 6, 10 ** 6) | st.floats(allow_nan=False) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12)


def _paths(node, prefix=()):
    """Every place in a document where a value can be replaced (coefficient maps kept short)."""
    if isinstance(node, dict):
        for key, value in list(node.items())[:12]:
            yield prefix + (key,)
            yield from _paths(value, prefix + (key,))
    elif isinstance(node, list):
        for i, value in enumerate(node[:4]):
            yield prefix + (i,)
            yield from _paths(value, prefix + (i,))


PATHS = [(kind, path) for kind in KINDS for path in _paths(DOCS[kind]) if path[0] not in ("metrics", "fit", "training")]


@given(st.sampled_from(PATHS), JSON_VALUES)
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_a_model_file_with_any_field_replaced_loads_or_is_refused_clearly(tmp_path, where, value):
    kind, path = where
    doc = json.loads(json.dumps(DOCS[kind]))
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    (tmp_path / "m.json").write_text(json.dumps(doc))
    try:
        model = load_model(tmp_path / "m.json")
        block = lower(model)
        render(block, "tia")
        prove(model, block, Limits())
    except (UserError, GenerationError):
        pass


NUMERIC_OPTIONS = [("fit", "--population"), ("fit", "--generations"), ("fit", "--bins"), ("fit", "--precision-um"),
                   ("fit", "--lags"), ("fit", "--lag-step"), ("fit", "--train-until"), ("fit", "--train-rows"),
                   ("fit", "--seed"), ("generate", "--max-offset-um"), ("generate", "--max-step-um"),
                   ("generate", "--temp-range"), ("generate", "--settle-calls"), ("twin", "--hours"), ("twin", "--dt"),
                   ("select-sensors", "--max-groups"), ("select-sensors", "--threshold")]
BASE = {"fit": ["fit", "--data", "d.csv", "--target", "E", "--temps", "T", "-o", "m.json"],
        "generate": ["generate", "m.json", "-o", "b.scl"], "twin": ["twin", "-o", "t.csv"],
        "select-sensors": ["select-sensors", "--data", "d.csv", "--target", "E"]}


@given(st.sampled_from(NUMERIC_OPTIONS), st.one_of(st.text(max_size=12), st.floats().map(repr),
                                                   st.integers(-10 ** 12, 10 ** 12).map(str)))
@settings(max_examples=EXAMPLES, deadline=None)
def test_every_numeric_option_is_parsed_or_refused_by_name(option, text):
    command, name = option
    argv = [*BASE[command], name, text]
    if command == "fit" and name not in ("--train-until", "--train-rows"):
        argv += ["--train-rows", "100"]
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:
        assert exc.code == 2
        return
    value = getattr(args, name.lstrip("-").replace("-", "_"))
    values = value if isinstance(value, tuple) else (value,)
    assert all(v == v and abs(v) < 1e13 for v in values)  # finite and bounded
