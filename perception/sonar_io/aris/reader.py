"""Read and write Sound Metrics ARIS recordings (``.aris``) as :class:`SonarFrame` sequences.

The format, the range formulas and the pose mapping are described once, in
:mod:`perception.sonar_io.aris.format`; its public names are re-exported here.

- :class:`ArisRecording` reads lazily (memory map): opening costs two header reads
  whatever the file size, and frame i costs one header and one sample block.
- :func:`write_aris` (from :mod:`perception.sonar_io.aris.writer`) writes frames as a recording the
  reader and the SDK's layout accept, so the simulator can store what it renders as a
  real ``.aris``; :func:`aris_grid` gives the range grid such frames must use.
"""

from __future__ import annotations

import math
import mmap
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, overload

import numpy as np

from perception.errors import FrameFormatError
from perception.sonar_io.aris.format import (
    ARIS_SIGNATURE,
    DEFAULT_ELEVATION_APERTURE_RAD,
    FILE_HEADER_FIELDS,
    FILE_HEADER_SIZE,
    FRAME_HEADER_FIELDS,
    FRAME_HEADER_SIZE,
    SOUND_SPEED_LIMITS_M_S,
    Header,
    beam_table_for,
    beams_from_ping_mode,
    describe_sonar,
    frame_from_header,
    pose_from_header,
    sample_ranges_m,
    unpack_fields,
    window_edges_m,
)
from perception.sonar_io.aris.writer import PING_MODE_FOR_BEAMS, aris_grid, write_aris
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.sniff import file_kind
from perception.sonar_io.validate import MAX_RANGE_M

__all__ = [
    "ARIS_SIGNATURE",
    "DEFAULT_ELEVATION_APERTURE_RAD",
    "FILE_HEADER_SIZE",
    "FRAME_HEADER_SIZE",
    "ArisLayout",
    "ArisRecording",
    "PING_MODE_FOR_BEAMS",
    "aris_grid",
    "beams_from_ping_mode",
    "describe_sonar",
    "frame_from_header",
    "pose_from_header",
    "sample_ranges_m",
    "window_edges_m",
    "write_aris",
]


@dataclass(frozen=True)
class ArisLayout:
    """What frame 0 fixes for the whole file.

    Attributes
    ----------
    n_beams, n_samples : int
        Beams (from PingMode) and samples per beam.
    frame_size : int
        Bytes per frame including its header.
    first_frame_index : int
        ``FrameIndex`` of frame 0; frame i must carry ``first_frame_index + i``.
    """

    n_beams: int
    n_samples: int
    frame_size: int
    first_frame_index: int

    @property
    def data_size(self) -> int:
        """Sample bytes per frame."""
        return self.n_beams * self.n_samples


class ArisRecording:
    """A lazily read ``.aris`` recording: a sequence of :class:`SonarFrame`.

    Opening maps the file into memory and reads only the file header and frame 0's header;
    ``len()`` comes from the file size. ``recording[i]`` reads frame i's header and samples.
    A partial trailing frame is not counted; :attr:`truncation` says what is cut off.
    Use as a context manager or call :meth:`close`.

    Parameters
    ----------
    path : path-like
        The ``.aris`` file.
    elevation_aperture_rad : float, optional
        Full elevation opening of the lens, rad (the file does not record it).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    FrameFormatError
        When the file header or frame 0's header is unusable (names file and field).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        elevation_aperture_rad: float = DEFAULT_ELEVATION_APERTURE_RAD,
    ):
        self.path = Path(path)
        self.elevation_aperture_rad = float(elevation_aperture_rad)
        self._map: mmap.mmap | None = None
        with open(self.path, "rb") as handle:  # the map keeps its own descriptor
            self.file_size = os.fstat(handle.fileno()).st_size
            if self.file_size:
                self._map = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            self.file_header = self._read_file_header()
            self.layout, self.truncation = self._read_layout()
        except BaseException:
            self.close()
            raise

    # -- opening -------------------------------------------------------------------------
    def _error(self, message: str, *, key: str | None = None, frame: int | None = None) -> FrameFormatError:
        return FrameFormatError(message, path=str(self.path), key=key, frame_index=frame)

    def _read_file_header(self) -> dict[str, Any]:
        values, cut = unpack_fields(self._buffer, 0, FILE_HEADER_FIELDS, self.file_size)
        if self.file_size < FILE_HEADER_SIZE:
            raise self._error(
                f"file is {self.file_size} bytes, shorter than the 1024-byte file header"
                + (f" (cut at field {cut})" if cut else ""),
                key="FileHeader",
            )
        if values["Version"] != ARIS_SIGNATURE:
            hint = " (it is a .npz frame file: give it the .npz suffix)" if file_kind(self.path) == "npz" else ""
            raise self._error(
                f"file signature is 0x{values['Version']:08x}, not 0x{ARIS_SIGNATURE:08x}; not an ARIS recording{hint}",
                key="Version",
            )
        return values

    def _read_layout(self) -> tuple[ArisLayout | None, str | None]:
        available = self.file_size - FILE_HEADER_SIZE
        header, cut = unpack_fields(self._buffer, FILE_HEADER_SIZE, FRAME_HEADER_FIELDS, available)
        if available == 0:
            return None, None
        if cut is not None or available < FRAME_HEADER_SIZE:
            return None, self._truncation_message(0, available, cut)
        self._check_header(header, 0, None)
        n_beams = beams_from_ping_mode(int(header["PingMode"]))
        n_samples = int(header["SamplesPerBeam"])
        layout = ArisLayout(
            n_beams=n_beams,
            n_samples=n_samples,
            frame_size=FRAME_HEADER_SIZE + n_beams * n_samples,
            first_frame_index=int(header["FrameIndex"]),
        )
        n_complete, rest = divmod(available, layout.frame_size)
        if rest == 0:
            return layout, None
        rest_header, rest_cut = unpack_fields(
            self._buffer,
            FILE_HEADER_SIZE + n_complete * layout.frame_size,
            FRAME_HEADER_FIELDS,
            rest,
        )
        del rest_header
        if rest < FRAME_HEADER_SIZE:
            return layout, self._truncation_message(n_complete, rest, rest_cut)
        got = rest - FRAME_HEADER_SIZE
        return layout, (
            f"frame {n_complete}, field SampleData: file ends after {got} of the frame's "
            f"{layout.data_size} sample bytes"
        )

    @staticmethod
    def _truncation_message(frame: int, available: int, cut: str | None) -> str:
        where = f"at field {cut}" if cut else "after the last known field"
        return (
            f"frame {frame}, field {cut or 'FrameHeader'}: file ends {available} bytes into the "
            f"1024-byte frame header ({where})"
        )

    @property
    def _buffer(self) -> Any:
        if self._map is not None:
            return self._map
        if self.file_size:
            raise ValueError(f"{self.path}: recording is closed")
        return b""

    # -- checks --------------------------------------------------------------------------
    def _check_header(self, header: Header, index: int, layout: ArisLayout | None) -> None:
        def bad(key: str, message: str) -> FrameFormatError:
            return self._error(message, key=key, frame=index)

        if header["Version"] != ARIS_SIGNATURE:
            raise bad(
                "Version",
                f"frame signature 0x{header['Version']:08x} is not 0x{ARIS_SIGNATURE:08x}",
            )
        try:
            n_beams = beams_from_ping_mode(int(header["PingMode"]))
        except ValueError as exc:
            raise bad("PingMode", str(exc)) from None
        if header["ReorderedSamples"] == 0:
            raise bad(
                "ReorderedSamples",
                "samples are in the sonar's raw order (ReorderedSamples 0); "
                "only recordings with reordered samples are supported",
            )
        if header["SamplesPerBeam"] < 2:
            raise bad("SamplesPerBeam", f"SamplesPerBeam {header['SamplesPerBeam']} < 2")
        if header["SamplePeriod"] == 0:
            raise bad("SamplePeriod", "SamplePeriod is 0 us")
        speed = header["SoundSpeed"]
        low, high = SOUND_SPEED_LIMITS_M_S
        if not (math.isfinite(speed) and low <= speed <= high):
            raise bad("SoundSpeed", f"SoundSpeed {speed} m/s is not a finite value in [{low}, {high}]")
        try:
            beam_table_for(header)
        except ValueError as exc:
            raise bad("TheSystemType", str(exc)) from None
        _, window_end_m = window_edges_m(header)
        if window_end_m > MAX_RANGE_M:
            raise bad(
                "SampleStartDelay",
                f"the range window (SampleStartDelay {header['SampleStartDelay']} us, SamplePeriod "
                f"{header['SamplePeriod']} us x {header['SamplesPerBeam']} samples at {speed:.1f} m/s) reaches "
                f"{window_end_m / 1000:,.1f} km, beyond the {MAX_RANGE_M:g} m any sonar sees: a corrupt header",
            )
        if layout is None:
            return
        if n_beams != layout.n_beams:
            raise bad(
                "PingMode",
                f"PingMode {header['PingMode']} gives {n_beams} beams; frame 0 has {layout.n_beams}",
            )
        if header["SamplesPerBeam"] != layout.n_samples:
            raise bad(
                "SamplesPerBeam",
                f"SamplesPerBeam {header['SamplesPerBeam']} differs from frame 0's {layout.n_samples}",
            )
        if header["FrameIndex"] != layout.first_frame_index + index:
            raise bad(
                "FrameIndex",
                f"FrameIndex {header['FrameIndex']}, expected {layout.first_frame_index + index}",
            )

    # -- access --------------------------------------------------------------------------
    def __len__(self) -> int:
        if self.layout is None:
            return 0
        return (self.file_size - FILE_HEADER_SIZE) // self.layout.frame_size

    def _index(self, index: int) -> int:
        n = len(self)
        i = index + n if index < 0 else index
        if not 0 <= i < n:
            extra = f"; {self.truncation}" if self.truncation and i == n else ""
            raise IndexError(f"{self.path}: frame {index} out of range for {n} frames{extra}")
        return i

    def header(self, index: int) -> dict[str, Any]:
        """Frame ``index``'s header fields by SDK name, checked against frame 0.

        Raises
        ------
        IndexError
            For an index outside the complete frames.
        FrameFormatError
            When the header is corrupt; names the file, frame and field.
        """
        i = self._index(index)
        assert self.layout is not None  # len() > 0 implies a layout
        offset = FILE_HEADER_SIZE + i * self.layout.frame_size
        header, _ = unpack_fields(self._buffer, offset, FRAME_HEADER_FIELDS, FRAME_HEADER_SIZE)
        self._check_header(header, i, self.layout)
        return header

    def _frame(self, index: int) -> SonarFrame:
        header = self.header(index)
        i = self._index(index)
        assert self.layout is not None
        start = FILE_HEADER_SIZE + i * self.layout.frame_size + FRAME_HEADER_SIZE
        # Slicing the map copies the block: no view of the map outlives this call, so
        # close() always succeeds.
        block = self._buffer[start : start + self.layout.data_size]
        samples = np.frombuffer(block, dtype=np.uint8)
        try:
            return frame_from_header(header, samples, elevation_aperture_rad=self.elevation_aperture_rad)
        except FrameFormatError as exc:
            raise self._error(exc.detail, key=exc.key, frame=i) from exc

    @overload
    def __getitem__(self, index: int) -> SonarFrame: ...

    @overload
    def __getitem__(self, index: slice) -> list[SonarFrame]: ...

    def __getitem__(self, index: int | slice) -> SonarFrame | list[SonarFrame]:
        if isinstance(index, slice):
            return [self._frame(i) for i in range(len(self))[index]]
        return self._frame(int(index))

    def __iter__(self) -> Iterator[SonarFrame]:
        for i in range(len(self)):
            yield self._frame(i)

    def close(self) -> None:
        """Release the memory map; frames already read stay valid. Idempotent."""
        if self._map is not None:
            self._map.close()
            self._map = None

    def __enter__(self) -> ArisRecording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
