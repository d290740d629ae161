"""Property tests: damaged frame files (.npz) and ARIS recordings through the readers and the CLI.

A reader returns frames or raises :class:`~perception.errors.FrameFormatError` (or an
OSError) naming the file; ``info``, ``heights`` and ``convert`` exit 0, or 2 with one
stderr line naming the file (tests/fuzz.py). Mutations: random bytes, byte-level damage,
and arrays replaced by others of any dtype (complex, object, bool...) and shape.
"""

from __future__ import annotations

import io
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from perception.errors import FrameFormatError
from perception.sonar_io.aris.format import FILE_HEADER_FIELDS, FILE_HEADER_SIZE, FRAME_HEADER_FIELDS
from perception.sonar_io.readers import open_recording
from tests.conftest import DATA_DIR
from tests.fuzz import assert_contract, mutated_bytes, run_cli

EXAMPLES = Path(str(resources.files("planner").joinpath("data", "examples")))
NPZ_BYTES = (EXAMPLES / "paper_tank_0.50m.npz").read_bytes()
NPZ_ARRAYS = dict(np.load(EXAMPLES / "paper_tank_0.50m.npz"))
ARIS_BYTES = (DATA_DIR / "aris" / "sample.aris").read_bytes()
#: A failing example of these 100 kB files is too large for hypothesis to print without a warning.
pytestmark = pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning")
FAST = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SOAK = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])

_DTYPES = st.sampled_from([np.uint8, np.uint16, np.int64, np.float32, np.float64, np.complex128, np.bool_])
_ARRAYS = hnp.arrays(_DTYPES, hnp.array_shapes(min_dims=0, max_dims=3, max_side=6))


def read_all(path: Path) -> None:
    """Open a recording and read every frame: frames, or the reader's narrow errors naming the file."""
    try:
        with open_recording(path) as recording:
            for _ in recording:
                pass
    except (FrameFormatError, OSError) as exc:
        assert str(path) in str(exc), str(exc)


@st.composite
def mutated_arrays(draw: Any) -> bytes:
    """The example frame with arrays replaced, dropped or added, saved as a .npz."""
    arrays = dict(NPZ_ARRAYS)
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.sampled_from(sorted(arrays) + ["extra"]))
        if draw(st.integers(0, 4)) == 0:
            arrays.pop(key, None)
        else:
            arrays[key] = draw(_ARRAYS | st.sampled_from([np.array(["a", "b"]), np.array([1, None], dtype=object),
                                                           np.array(np.nan), np.array(-0.5), np.array(1e308),
                                                           NPZ_ARRAYS["range_m"][::-1]]))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _frames_case(data: bytes, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"frames{suffix}"
        path.write_bytes(data)
        read_all(path)
        code, _, err = run_cli(["info", str(path)])
        assert_contract(code, err, [str(path)])
        other = EXAMPLES / "paper_tank_0.60m.npz"
        code, _, err = run_cli(["heights", str(path), str(other)])
        assert_contract(code, err, [str(path), str(other)])
        out = Path(tmp) / "out.npz"
        code, _, err = run_cli(["convert", str(path), str(out), "--frames", "0:2"])
        assert_contract(code, err, [str(path)])


@FAST
@given(data=mutated_bytes(NPZ_BYTES) | st.binary(max_size=64))
def test_damaged_npz_bytes(data: bytes) -> None:
    _frames_case(data, ".npz")


@FAST
@given(data=mutated_arrays())
def test_npz_with_foreign_arrays(data: bytes) -> None:
    _frames_case(data, ".npz")


@FAST
@given(data=mutated_bytes(ARIS_BYTES[:1024 + 2 * (1024 + 96_000)], max_ops=3))
def test_damaged_aris_bytes(data: bytes) -> None:
    _frames_case(data, ".aris")


#: Byte offsets of the header fields the reader uses: the file header's and frame 0's.
FIELD_OFFSETS = sorted({off for off, _ in FILE_HEADER_FIELDS.values()}
                       | {FILE_HEADER_SIZE + off for off, _ in FRAME_HEADER_FIELDS.values()})
OFFSETS = st.sampled_from(FIELD_OFFSETS) | st.integers(0, 2047)


def _header_case(offset: int, value: bytes) -> None:
    """Two frames of the sample recording with 4 bytes at ``offset`` replaced."""
    data = bytearray(ARIS_BYTES[:1024 + 2 * (1024 + 96_000)])
    data[offset:offset + 4] = value
    _frames_case(bytes(data), ".aris")


@FAST
@given(offset=OFFSETS, value=st.binary(min_size=4, max_size=4))
def test_aris_header_field_damage(offset: int, value: bytes) -> None:
    """Any 4 bytes of the file header or frame 0's header replaced, mostly at the fields used."""
    _header_case(offset, value)


@pytest.mark.soak
@SOAK
@given(data=mutated_arrays() | mutated_bytes(NPZ_BYTES))
def test_soak_damaged_npz(data: bytes) -> None:
    _frames_case(data, ".npz")


@pytest.mark.soak
@SOAK
@given(offset=OFFSETS, value=st.binary(min_size=4, max_size=4))
def test_soak_aris_header_field_damage(offset: int, value: bytes) -> None:
    _header_case(offset, value)
