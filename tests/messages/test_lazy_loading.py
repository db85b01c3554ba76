"""User packages loaded lazily: parsed at first use, same md5s, bounded work per type."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from rosbags.typesys import get_types_from_msg

import simbridge.messages.registry as registry_module
from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry


def _package(root: Path) -> Path:
    msg = root / "lazy_msgs" / "msg"
    srv = root / "lazy_msgs" / "srv"
    msg.mkdir(parents=True)
    srv.mkdir(parents=True)
    (msg / "Inner.msg").write_text("int32 a\nstring b\n")
    (msg / "Outer.msg").write_text("Header header\nInner[] items\ngeometry_msgs/Pose pose\n")
    (srv / "Ask.srv").write_text("Outer question\n---\nbool ok\n")
    (msg / "Huge.msg").write_text("".join(f"float64 f{i}\n" for i in range(20_000)))
    return root


def test_lazy_types_match_eager_ones(tmp_path: Path) -> None:
    root = _package(tmp_path)
    (root / "lazy_msgs" / "msg" / "Huge.msg").unlink()
    eager, lazy = MessageRegistry(), MessageRegistry()
    eager.load_packages(root)
    assert "lazy_msgs/Outer" in lazy.load_packages(root, lazy=True)
    assert "lazy_msgs/Outer" in lazy.names()
    assert "lazy_msgs/Ask" in lazy.service_names()
    assert lazy.md5("lazy_msgs/Outer") == eager.md5("lazy_msgs/Outer")
    assert lazy.service("lazy_msgs/Ask").md5 == eager.service("lazy_msgs/Ask").md5
    assert lazy.definition("lazy_msgs/Outer") == eager.definition("lazy_msgs/Outer")
    assert lazy.has("lazy_msgs/Inner")


def test_huge_definition_costs_nothing_until_used_then_fails_clearly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = _package(tmp_path)
    reg = MessageRegistry()
    parsed: list[str] = []
    real_parse = get_types_from_msg

    def parse(text: str, name: str) -> Any:
        parsed.append(name)
        return real_parse(text, name)

    monkeypatch.setattr(registry_module, "get_types_from_msg", parse)
    reg.load_packages(root, lazy=True)
    assert parsed == []  # nothing parsed at load (20,000 fields would take seconds)
    assert "lazy_msgs/Huge" in reg.names()
    with pytest.raises(MessageError, match=r"lazy_msgs/Huge .* at most"):
        reg.resolve("lazy_msgs/Huge")
    assert reg.md5("lazy_msgs/Inner")  # the others still load


def test_eager_load_refuses_definitions_past_the_bound(tmp_path: Path) -> None:
    root = _package(tmp_path)
    with pytest.raises(MessageError, match="lazy_msgs/Huge"):
        MessageRegistry().load_packages(root)
