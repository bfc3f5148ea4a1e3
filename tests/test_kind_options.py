"""A kind's own fit options are declared by its record (models/kind.py::KindOption, issue 53): `fit`'s
command line, the request and the refusals are built from the records, and the generic request stores
none of them as a field of its own."""
import argparse
import dataclasses

import pytest

from thermoplc.base.errors import UserError
from thermoplc.commands import fit as fit_command
from thermoplc.fitting.fit import FitRequest
from thermoplc.models import kinds
from thermoplc.models.kind import Kind, KindOption
from tests.cli_runner import thermoplc


def _fit_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="thermoplc")
    fit_command.add_parser(parser.add_subparsers())
    return parser._subparsers._group_actions[0].choices["fit"]


def test_every_kind_option_of_the_command_line_comes_from_a_record():
    parser = _fit_parser()
    groups = {group.title: {action.option_strings[0] for action in group._group_actions}
              for group in parser._action_groups if group.title.endswith("only (refused for any other kind)")}
    declared = {option.flag for option in kinds.options().values()}
    assert set().union(*groups.values()) == declared
    assert groups["kalman and bpnn only (refused for any other kind)"] == {"--seed", "--generations", "--population"}
    assert groups["bayes only (refused for any other kind)"] == {"--bins", "--precision-um", "--unseen", "--time-bins", "--parents"}
    defaults = parser.parse_args(["--model", "mlr", "--target", "E", "--temps", "a", "--train-rows", "20", "-o", "m"])
    assert {field: getattr(defaults, field) for field in kinds.options()} == {
        field: option.default for field, option in kinds.options().items()}


def test_the_generic_request_stores_no_kind_option_as_a_field():
    stored = {field.name for field in dataclasses.fields(FitRequest)}
    assert stored == {"kind", "target", "temps", "speed", "ambient", "train_until", "train_rows", "block_name",
                      "extra_targets", "choose_sensors", "settings", "keep_every_run"}


def test_a_request_reads_an_option_given_or_its_records_default():
    request = FitRequest("bayes", "E", ("a", "b"), settings={"bins": 12})
    assert request.option("bins") == 12
    assert request.option("lags") == 3 and request.option("unseen") == "nearest" and request.option("jump_limit") is None
    assert hash(request) == hash(FitRequest("bayes", "E", ("a", "b"), settings={"bins": 12}))


def test_the_options_are_settings_only():
    """The keywords before the kinds declared their options (bins=, options=FitOptions(...)) are gone (issue 66):
    one way to give an option, and `replace` cannot carry a dropped one back in."""
    for old in ({"bins": 12}, {"options": None}, {"unseen": "frequent"}):
        with pytest.raises(TypeError):
            FitRequest("bayes", "E", ("a",), **old)
    request = FitRequest("bayes", "E", ("a",), settings={"bins": 6, "seed": 4})
    assert dataclasses.replace(request, kind="mlr").settings == request.settings
    assert dataclasses.replace(request, settings={"bins": 5}).option("bins") == 5
    assert dataclasses.replace(request, settings={"bins": 5}).option("seed") == 0
    assert not hasattr(request, "bins") and not hasattr(request, "options")


@pytest.mark.parametrize("settings, message", [
    ({"binz": 3}, "fit option 'binz': no kind reads it"),
    ({"bins": 0}, "--bins: expected intervals from 1 to 4,096, found 0"),
    ({"bins": 2.5}, "--bins: expected an integer, found 2.5"),
    ({"bins": 8.0}, "--bins: expected an integer, found 8.0"),
    ({"bins": True}, "--bins: expected an integer, found True"),
    ({"bins": None}, "--bins: expected a value, found None"),
    ({"bins": float("inf")}, "--bins: expected an integer, found inf"),
    ({"precision_um": float("inf")}, "--precision-um: expected micrometres from 0.001 to 1e+06, found inf"),
    ({"precision_um": "1"}, "--precision-um: expected a number, found '1'"),
    ({"unseen": "guess"}, "--unseen: expected one of nearest, frequent, found 'guess'"),
    ({"lag_step_s": float("nan")}, "--lag-step: expected seconds from 0.001 to 1e+07, found nan"),
    ({"tool_length": 3}, "--tool-length: expected a column name, found 3"),
])
def test_a_value_the_record_refuses_is_refused_naming_the_flag(settings, message):
    with pytest.raises(UserError, match="^" + message.replace("(", r"\(").replace(")", r"\)").replace("+", r"\+")):
        FitRequest("bayes", "E", ("a",), settings=settings)


def test_two_kinds_reading_one_option_must_declare_it_alike(monkeypatch):
    """kalman and bpnn share the GA's records; a kind declaring the same field another way is an error."""
    seed = KindOption("seed", "--seed", 0, "a seed", number=(int, 0, 9, "a seed"))
    other = dataclasses.replace(seed, default=1)
    fake = {"a": Kind("a", 1, "", None, None, options=(seed,)), "b": Kind("b", 2, "", None, None, options=(other,))}
    monkeypatch.setattr(kinds, "registry", lambda: fake)
    with pytest.raises(RuntimeError, match="option 'seed' is declared two ways"):
        kinds.options.__wrapped__()
    fake["b"] = Kind("b", 2, "", None, None, options=(seed,))
    assert kinds.options.__wrapped__() == {"seed": seed}


def test_an_option_for_another_kind_is_refused_from_the_cli(tmp_path, twin_csv):
    """As a user types it: the record says dlag reads --lags, so mlr refuses it, naming the reader."""
    result = thermoplc("fit", "--data", twin_csv, "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor",
                       "--train-until", "14400", "--lags", "5", "-o", "m.json", cwd=tmp_path, check=2)
    assert "--lags is read by --model dlag only; --model mlr does not read it" in result.stderr
    assert not (tmp_path / "m.json").exists()
