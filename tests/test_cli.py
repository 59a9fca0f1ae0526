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


def _take_options(argv):
    from hullcap._take import TakeOptions

    return TakeOptions.from_arguments(build_parser().parse_args(["track", "SEQ", "--out", "OUT", *argv]))


def test_the_live_preset_sets_its_settings_and_flags_given_with_it_override_them():
    from hullcap._tracking_options import TrackerOptions

    accurate, live = _take_options([]).tracking, _take_options(["--preset", "live"]).tracking
    assert accurate == TrackerOptions()
    assert (live.voxel_size, live.fit.iterations, live.learned_every) == (0.02, 6, 3)
    assert live == TrackerOptions.preset("live")
    # a flag given with the preset wins, even one given at the default's value
    mixed = _take_options(["--preset", "live", "--voxel-size", "0.01", "--no-wrists"]).tracking
    assert (mixed.voxel_size, mixed.fit.iterations, mixed.wrists) == (0.01, 6, False)


def test_an_unknown_preset_is_refused_with_the_choices(capsys):
    from hullcap._tracking_options import TrackerOptions
    from hullcap.errors import OptionsError

    with pytest.raises(OptionsError, match="preset must be 'accurate' or 'live', got 'fast'"):
        TrackerOptions.preset("fast")
    with pytest.raises(SystemExit):
        main(["track", "SEQ", "--out", "OUT", "--preset", "fast"])
    assert "--preset: must be 'accurate' or 'live', got 'fast'" in capsys.readouterr().err
