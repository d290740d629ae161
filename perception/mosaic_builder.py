"""Frames in, mosaic out: projection, drift correction and blending in one incremental step."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from perception.frame import SonarFrame
from perception.mosaic import (
    MosaicConfig,
    ProjectedFrame,
    SonarPlacement,
    TiledMosaic,
    placement_from_frame,
    project_frame,
)
from perception.registration import (
    DriftEstimator,
    RegistrationConfig,
    RegistrationResult,
    measure_shift,
)


@dataclass(frozen=True)
class FrameAdded:
    """What :meth:`MosaicBuilder.add_frame` did with one frame.

    ``correction_north_m``/``correction_east_m`` is the drift correction applied to the
    frame's navigation position; ``registration`` the correlation attempt (None when
    registration is off or the mosaic was still empty there).
    """

    used: bool
    correction_north_m: float
    correction_east_m: float
    registration: RegistrationResult | None


class MosaicBuilder:
    """Adds frames to a :class:`~perception.mosaic.TiledMosaic`, correcting navigation drift.

    Parameters
    ----------
    config : MosaicConfig, optional
    registration : RegistrationConfig or None
        None turns the drift correction off.
    """

    def __init__(self, config: MosaicConfig | None = None, registration: RegistrationConfig | None = None):
        self.mosaic = TiledMosaic(config or MosaicConfig())
        self.registration = registration
        self.drift = DriftEstimator(registration) if registration is not None else None
        # Frames are registered against a LAGGED copy of the mosaic, which holds only frames
        # at least ``reference_lag_frames`` old: against the newest frames a frame would
        # only confirm the drift it shares with them.
        self._reference = TiledMosaic(self.mosaic.config) if registration is not None else None
        self._pending: deque[ProjectedFrame] = deque()

    def add_frame(
        self,
        frame: SonarFrame,
        *,
        placement: SonarPlacement | None = None,
        altitude_m: float | None = None,
        exclude_mask: np.ndarray | None = None,
    ) -> FrameAdded:
        """Project ``frame``, register it against the mosaic if enabled, and blend it in.

        Parameters
        ----------
        frame : SonarFrame
        placement : SonarPlacement, optional
            The pose to use; by default the frame's own metadata (see
            :func:`~perception.mosaic.placement_from_frame`), with ``altitude_m`` from the
            altitude filter when given.
        exclude_mask : ndarray of bool, shape (n_samples, n_beams), optional
            Polar samples left out of the blend (shadows).
        """
        if placement is None:
            placement = placement_from_frame(frame, altitude_m=altitude_m)
        d_n = self.drift.north_m if self.drift else 0.0
        d_e = self.drift.east_m if self.drift else 0.0
        corrected = placement.shifted(d_n, d_e)
        cfg = self.mosaic.config
        projected = project_frame(frame, corrected, config=cfg, exclude_mask=exclude_mask)
        if projected is None:
            return FrameAdded(False, d_n, d_e, None)
        result: RegistrationResult | None = None
        due = self.mosaic.frames_added % (self.registration.every_n_frames if self.registration else 1) == 0
        if due and self.drift is not None and self.registration is not None and self._reference is not None:
            result = measure_shift(projected, self._reference, config=self.registration)
            self.drift.update(result)
            if result.accepted:
                d_n, d_e = self.drift.north_m, self.drift.east_m
                projected = project_frame(
                    frame, placement.shifted(d_n, d_e), config=cfg, exclude_mask=exclude_mask
                )
                if projected is None:
                    return FrameAdded(False, d_n, d_e, result)
        self.mosaic.add(projected)
        if self._reference is not None and self.registration is not None:
            self._pending.append(projected)
            while len(self._pending) > self.registration.reference_lag_frames:
                self._reference.add(self._pending.popleft())
        return FrameAdded(True, d_n, d_e, result)
