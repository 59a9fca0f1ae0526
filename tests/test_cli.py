"""The command line's own behaviour: what it refuses and how it says so."""

import pytest
from hullcap._cli import build_parser, main


def test_an_option_is_never_taken_from_a_prefix_of_its_name(capsys):
    """``--frame 10`` is a mistake for ``calib check``'s option, not ``track --frames 10``."""
    with pytest.raises(SystemExit) as e:
        main(["track", "SEQ", "--out", "OUT", "--frame", "10"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "hullcap track: error: unrecognized arguments: --frame 10" in err


@pytest.mark.parametrize("argv, usage", [
    (["track", "SEQ", "--out", "OUT", "--bogus"], "usage: hullcap track "),
    (["calib", "show", "cameras.json", "--bogus"], "usage: hullcap calib show "),
    (["export", "OUT", "--format", "bvh", "--bogus"], "usage: hullcap export "),
])
def test_an_unknown_option_gets_its_subcommands_usage(argv, usage, capsys):
    with pytest.raises(SystemExit):
        main(argv)
    err = capsys.readouterr().err
    assert err.startswith(usage) and "unrecognized arguments: --bogus" in err


def test_every_parser_refuses_abbreviations():
    parser = build_parser()
    stack = [parser]
    while stack:
        p = stack.pop()
        assert p.allow_abbrev is False, p.prog
        for action in p._actions:
            stack.extend(getattr(action, "choices", None).values() if hasattr(action, "add_parser") else [])
