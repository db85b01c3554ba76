"""Fixtures of the perception tests: the truth scene's frame 0, made once per module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from simbridge.perception import Frame, FrameMaker
from tests.perception.scenes import truth_scene


@pytest.fixture(scope="module")
def truth(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[FrameMaker, Frame]]:
    """The truth scene's frame maker and its frame 0 (the sim posed as that frame)."""
    maker = FrameMaker(truth_scene(tmp_path_factory.mktemp("truth")))
    try:
        yield maker, maker.make(0)
    finally:
        maker.close()
