"""`simbridge msg`: md5/show of unknown names say what is wrong and how to fix it."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from simbridge.cli import main


def test_md5_of_an_unknown_package_says_so_and_how_to_add_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["msg", "md5", "foo_msgs/Bar"]) == 2
    err = capsys.readouterr().err
    assert "unknown message type 'foo_msgs/Bar': package 'foo_msgs' is unknown" in err
    assert "--msg-path DIR" in err
    assert "names look like" not in err


def test_unknown_package_without_close_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "md5", "zz_q/Xy"]) == 2
    err = capsys.readouterr().err
    assert "package 'zz_q' is unknown. Load the package's .msg/.srv files with --msg-path" in err


def test_unknown_package_suggests_close_names(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "show", "geometry_msg/Pose"]) == 2
    err = capsys.readouterr().err
    assert "package 'geometry_msg' is unknown; did you mean geometry_msgs/Pose," in err
    assert "--msg-path" in err


def test_unknown_type_in_a_known_package(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "md5", "sensor_msgs/Imagee"]) == 2
    err = capsys.readouterr().err
    assert "sensor_msgs has no 'Imagee'; did you mean sensor_msgs/Image" in err
    assert "--msg-path" not in err


def test_malformed_name_still_shows_the_spelling(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["msg", "md5", "Imu"]) == 2
    assert "(names look like pkg/Type)" in capsys.readouterr().err


def test_the_advice_works(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "foo_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "foo_msgs" / "msg" / "Bar.msg").write_text("int32 x\n")
    assert main(["msg", "md5", "foo_msgs/Bar", "--msg-path", str(tmp_path)]) == 0
    assert capsys.readouterr().out == hashlib.md5(b"int32 x").hexdigest() + "\n"
    # The package went into a private registry, not the shared one.
    assert main(["msg", "md5", "foo_msgs/Bar"]) == 2
