"""ARIS beam-angle tables, shipped with the package.

The tables come from Sound Metrics' public ARIS File SDK (MIT licence, (c) 2015 Sound
Metrics) as CSV: beam, centre, left edge, right edge in degrees. In the SDK beam 0 is the
right-most beam and negative angles are to the right, so in shadowsurvey's convention
(azimuth positive to starboard, increasing with the column index)
``azimuth = -centre`` and the columns are reversed: column j holds SDK beam
``n_beams - 1 - j``.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np

#: Table file stem by (table name); see :func:`table_name_for`.
TABLES = (
    "ARIS1800_1200_48",
    "ARIS1800_96",
    "ARIS3000_128",
    "ARIS3000_64",
    "ARIS_Telephoto_48",
    "ARIS_Telephoto_96",
)


@dataclass(frozen=True)
class BeamTable:
    """One beam table in shadowsurvey's order (azimuth increasing, positive to starboard).

    Attributes
    ----------
    name : str
        Table name, e.g. ``"ARIS3000_128"``.
    azimuth_rad : ndarray, shape (n_beams,)
        Beam axis azimuths, rad, strictly increasing.
    left_rad, right_rad : ndarray, shape (n_beams,)
        Port-side and starboard-side edges of each beam, rad (left < right).
    sdk_beam : ndarray of int, shape (n_beams,)
        The SDK's beam number of each column (beam 0 is the right-most).
    """

    name: str
    azimuth_rad: np.ndarray
    left_rad: np.ndarray
    right_rad: np.ndarray
    sdk_beam: np.ndarray

    @property
    def n_beams(self) -> int:
        """Number of beams."""
        return int(self.azimuth_rad.size)

    @property
    def fan_width_rad(self) -> float:
        """Full azimuth opening from the first beam's left edge to the last's right edge, rad."""
        return float(self.right_rad[-1] - self.left_rad[0])


@cache
def load_beam_table(name: str) -> BeamTable:
    """Load a shipped beam table by name (one of :data:`TABLES`).

    Raises
    ------
    ValueError
        For an unknown table name.
    """
    if name not in TABLES:
        raise ValueError(f"unknown ARIS beam table {name!r}; known: {', '.join(TABLES)}")
    text = (
        resources.files("perception")
        .joinpath("data", "aris_beams", f"BeamWidths_{name}.csv")
        .read_text(encoding="ascii")
    )
    rows = list(csv.DictReader(io.StringIO(text)))
    beam = np.array([int(r["beam"]) for r in rows])
    centre = np.array([float(r["center_deg"]) for r in rows])
    left = np.array([float(r["left_deg"]) for r in rows])
    right = np.array([float(r["right_deg"]) for r in rows])
    order = np.argsort(-centre)
    azimuth = np.deg2rad(-centre[order])
    edges = np.deg2rad(np.stack([-left[order], -right[order]]))
    table = BeamTable(
        name=name,
        azimuth_rad=azimuth,
        left_rad=edges.min(axis=0),
        right_rad=edges.max(axis=0),
        sdk_beam=beam[order],
    )
    for array in (table.azimuth_rad, table.left_rad, table.right_rad, table.sdk_beam):
        array.flags.writeable = False
    return table


def table_name_for(system_type: int, n_beams: int, *, telephoto: bool) -> str:
    """The SDK's choice of beam table for an ARIS system type, beam count and lens.

    ``system_type``: 0 = ARIS 1800, 1 = ARIS 3000, 2 = ARIS 1200 (FileHeader
    ``TheSystemType``). A telephoto lens (``LargeLens``) has its own tables.

    Raises
    ------
    ValueError
        For a combination the SDK has no table for.
    """
    if telephoto:
        if n_beams in (48, 96):
            return f"ARIS_Telephoto_{n_beams}"
    elif system_type == 1 and n_beams in (64, 128):
        return f"ARIS3000_{n_beams}"
    elif system_type in (0, 2) and n_beams == 48:
        return "ARIS1800_1200_48"
    elif system_type == 0 and n_beams == 96:
        return "ARIS1800_96"
    raise ValueError(
        f"no ARIS beam table for system type {system_type}, {n_beams} beams, "
        f"telephoto={telephoto}"
    )


def aris3000_128() -> BeamTable:
    """The ARIS Explorer 3000 128-beam table, the default sonar of shadowsurvey."""
    return load_beam_table("ARIS3000_128")
