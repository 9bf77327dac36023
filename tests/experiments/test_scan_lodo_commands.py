"""scan_lodo.py's command lines: every command's --help, lodo's --shrinks."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def scan_lodo(load_experiment):
    return load_experiment("scan_lodo")


@pytest.mark.parametrize("command", ["classical", "lodo", "release", "official", "time", "density", "holes"])
def test_every_command_prints_its_help(scan_lodo, command, capsys):
    with pytest.raises(SystemExit) as info:
        scan_lodo.COMMANDS[command](["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "--per-drive" in out
    if command in ("lodo", "density"):
        assert "50 % points" in out  # the density labels, their % printed as it is
