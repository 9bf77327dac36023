"""experiments/_common.py: the commands of a script of several, and their exit status."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def common(load_experiment):
    return load_experiment("_common")


def test_run_command_passes_the_rest_of_the_line_to_the_named_command(common):
    commands = {"a": lambda argv: ("a", argv), "b": lambda argv: ("b", argv)}
    assert common.run_command("x.py", commands, ["b", "--flag", "1"]) == ("b", ["--flag", "1"])


@pytest.mark.parametrize("argv, says", [([], "no command given"), (["c"], "no command 'c'")])
def test_run_command_refuses_a_missing_or_unknown_command_naming_the_choices(common, argv, says):
    with pytest.raises(SystemExit) as exc:
        common.run_command("x.py", {"a": print, "b": print}, argv)
    assert says in str(exc.value) and "{a,b}" in str(exc.value)


def test_help_prints_the_commands_and_exits_0(common, capsys):
    with pytest.raises(SystemExit) as exc:
        common.run_command("x.py", {"a": print}, ["--help"])
    assert exc.value.code == 0 and "python experiments/x.py {a}" in capsys.readouterr().out


def test_exit_status_is_an_int_result_or_0_for_a_table(common):
    assert [common.exit_status(r) for r in (0, 1, [{"row": 1}], {"a": 1}, None, True)] == [0, 1, 0, 0, 0, 0]
