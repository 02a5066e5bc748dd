"""A re-export keeps the user's work: the user's HAL file is written once and never replaced; a
generated file edited since the export (told by the checksum on its first line) or made by hand
is refused, or with --replace-edited kept as a .bak copy; a missing parent folder is refused."""

import hashlib

from stewart_jax._cli import main as cli_main
from stewart_jax._files import generated_state, stamp_generated

ARGS = ["export", "rubin_m2", "--format", "linuxcnc", "--stroke-limits-mm=-10,10"]


def test_stamp_round_trip(tmp_path):
    p = tmp_path / "a.ini"
    p.write_text(stamp_generated("x = 1\n"))
    first = p.read_text().splitlines()[0]
    assert first.endswith(hashlib.sha256(b"x = 1\n").hexdigest())  # independent digest
    assert generated_state(p) == "unedited"
    p.write_text(p.read_text().replace("x = 1", "x = 2"))
    assert generated_state(p) == "edited"
    p.write_text("x = 1\n")
    assert generated_state(p) == "foreign"
    assert generated_state(tmp_path / "none") == "absent"


def test_reexport_keeps_the_users_hal_and_refuses_an_edited_file(tmp_path, capsys):
    out = tmp_path / "cfg"
    assert cli_main([*ARGS, "--out", str(out)]) == 0
    hal, user, ini = out / "hexapod.hal", out / "hexapod_user.hal", out / "hexapod.ini"
    assert "source hexapod_user.hal" in hal.read_text()
    assert "net j0-pos" in user.read_text() and "net j0-pos" not in hal.read_text()
    # the user wires the drives in the user's HAL file; a re-export (unedited generated files)
    # succeeds and leaves that file byte for byte
    user.write_text(user.read_text().replace("joint.0.motor-pos-fb", "hm2.0.encoder.00.position"))
    mine = user.read_bytes()
    assert cli_main([*ARGS, "--out", str(out)]) == 0
    assert user.read_bytes() == mine
    # an edit of the generated INI: refused, naming the file, and nothing is written
    ini.write_text(ini.read_text().replace("DISPLAY = axis", "DISPLAY = gmoccapy"))
    edited = ini.read_bytes()
    capsys.readouterr()
    assert cli_main([*ARGS, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "hexapod.ini (edited since the export)" in err and "--replace-edited" in err
    assert ini.read_bytes() == edited
    # asked to: replaced, the edited file kept beside it
    assert cli_main([*ARGS, "--out", str(out), "--replace-edited"]) == 0
    assert (out / "hexapod.ini.bak").read_bytes() == edited
    assert generated_state(ini) == "unedited"
    assert "hexapod.ini.bak" in capsys.readouterr().err


def test_a_hand_made_file_is_never_replaced(tmp_path, capsys):
    out = tmp_path / "cfg"
    out.mkdir()
    (out / "hexapod.hal").write_text("# my own HAL\n")
    assert cli_main([*ARGS, "--out", str(out)]) == 2
    assert "not written by stewart_jax" in capsys.readouterr().err
    assert (out / "hexapod.hal").read_text() == "# my own HAL\n"
    assert not (out / "hexapod.ini").exists()


def test_a_missing_parent_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "no" / "such" / "cfg"
    assert cli_main([*ARGS, "--out", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()
