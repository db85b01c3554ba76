"""A message type that contains itself is refused when it is added, with the cycle named."""

from __future__ import annotations

import pytest

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry
from simbridge.messages.loader import InterfaceSources


def test_self_recursive_type_is_refused() -> None:
    reg = MessageRegistry()
    with pytest.raises(MessageError, match=r"rec_msgs/Tree is recursive \(rec_msgs/Tree -> "):
        reg.add_message("rec_msgs/Tree", "int32 v\nrec_msgs/Tree[] children\n")
    assert not reg.has("rec_msgs/Tree")


def test_cycle_through_other_types_is_refused_atomically() -> None:
    reg = MessageRegistry()
    sources = InterfaceSources(
        messages={
            "a/A": "a/B b\n",
            "a/B": "std_msgs/Header h\na/C[2] c\n",
            "a/C": "a/A x\n",
        }
    )
    with pytest.raises(MessageError, match=r"a/A -> a/B -> a/C -> a/A"):
        reg.add_sources(sources)
    assert not reg.has("a/B")


def test_diamond_is_not_a_cycle() -> None:
    reg = MessageRegistry()
    reg.add_sources(
        InterfaceSources(
            messages={
                "d/Top": "d/L l\nd/R r\n",
                "d/L": "d/Leaf x\n",
                "d/R": "d/Leaf y\n",
                "d/Leaf": "int8 z\n",
            }
        )
    )
    assert len(reg.md5("d/Top")) == 32
