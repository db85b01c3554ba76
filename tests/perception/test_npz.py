"""simbridge's .npz writer against Python's zipfile writing the same members (the bytes
datasets had before it) and against np.load."""

from __future__ import annotations

import io
import zipfile
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from numpy.typing import NDArray

from simbridge.errors import PerceptionError
from simbridge.perception.npz import write_npz_to

dtypes = st.sampled_from([np.float32, np.uint16, np.uint8, np.bool_, np.int32, np.float64])
arrays = dtypes.flatmap(lambda dtype: hnp.arrays(dtype, hnp.array_shapes(min_dims=1, max_dims=3)))


def _zipfile_npz(members: dict[str, NDArray[Any]]) -> bytes:
    """The archive as zipfile writes it, streamed member by member, with fixed dates."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for name, array in members.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            with archive.open(info, "w") as member:
                np.lib.format.write_array(member, np.ascontiguousarray(array), allow_pickle=False)
    return buffer.getvalue()


def _ours(members: dict[str, NDArray[Any]]) -> bytes:
    buffer = io.BytesIO()
    write_npz_to(buffer, members)
    return buffer.getvalue()


@settings(max_examples=80, deadline=None)
@given(st.dictionaries(st.sampled_from(["depth", "instance", "semantic", "x"]), arrays, max_size=3))
def test_the_bytes_are_zipfiles_and_np_load_reads_them_back(
    members: dict[str, NDArray[Any]],
) -> None:
    data = _ours(members)
    assert data == _zipfile_npz(members)
    with np.load(io.BytesIO(data)) as loaded:
        assert sorted(loaded.files) == sorted(members)
        for name, array in members.items():
            assert loaded[name].dtype == array.dtype
            assert np.array_equal(loaded[name], array, equal_nan=True)


def test_a_frames_label_arrays_and_a_transposed_view() -> None:
    rng = np.random.default_rng(4)
    members: dict[str, NDArray[Any]] = {
        "depth": rng.random((480, 640), dtype=np.float32),
        "instance": rng.integers(0, 30, (640, 480), dtype=np.uint16).T,  # not C-contiguous
    }
    assert _ours(members) == _zipfile_npz(members)


def test_a_scalar_array_reads_back_as_a_scalar() -> None:
    with np.load(io.BytesIO(_ours({"s": np.array(2.5, dtype=np.float32)}))) as loaded:
        assert loaded["s"].shape == ()
        assert loaded["s"] == np.float32(2.5)


def test_objects_and_names_beyond_ascii_are_refused() -> None:
    with pytest.raises(PerceptionError, match="objects"):
        _ours({"bad": np.array([{"a": 1}], dtype=object)})
    with pytest.raises(PerceptionError, match="not ASCII"):
        _ours({"tiefe": np.zeros(2), "größe": np.zeros(2)})
