"""Argument handling of ``stewart-jax fast`` through the command line's entry point (the
scenario itself is tested in test_cable_robot_coupled.py; running it here would compile it
again)."""

import pytest

from stewart_jax._cli import build_parser, main


def test_defaults_and_position():
    args = build_parser().parse_args(["fast", "--position", "30,0,142.8", "--json", "out.json"])
    assert args.position == (30.0, 0.0, 142.8)
    assert args.json == "out.json" and args.duration == 2.0 and args.dt == 1e-3
    assert args.start == "momentum" and args.method == "verlet" and callable(args.func)


@pytest.mark.parametrize("bad", ["1,2", "a,b,c", "1,2,nan", "1,2,3,4"])
def test_bad_position_is_rejected(bad, capsys):
    with pytest.raises(SystemExit):
        main(["fast", "--position", bad])
    assert "--position" in capsys.readouterr().err


def test_bad_step_is_rejected():
    assert main(["fast", "--dt", "0", "--duration", "1"]) == 2
