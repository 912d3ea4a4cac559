"""The main job runs and prints the Puma summary."""

from symdyn import cli


def test_run_prints_gravity_at_book_poses(capsys):
    assert cli.main(["run"]) == 0
    out = capsys.readouterr().out
    for pose in ("qz", "qr", "qs", "qn"):
        assert f"{pose} =" in out
