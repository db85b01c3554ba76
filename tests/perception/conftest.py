"""Fixtures of the perception tests: the truth scene's frame 0, made once per module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from simbridge.perception import Frame, FrameMaker
from tests.perception.scenes import truth_scene


@pytest.fixture(scope="module", params=[4, 0], ids=["msaa4", "msaa0"])
def truth(
    tmp_path_factory: pytest.TempPathFactory, request: pytest.FixtureRequest
) -> Iterator[tuple[FrameMaker, Frame]]:
    """The truth scene's frame maker and its frame 0 (the sim posed as that frame), with
    and without the renderer's anti-aliasing: labels are the same geometry either way."""
    maker = FrameMaker(truth_scene(tmp_path_factory.mktemp("truth"), request.param))
    try:
        yield maker, maker.make(0)
    finally:
        maker.close()
