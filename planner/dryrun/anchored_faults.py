"""Fault windows counted from an executor state instead of the dive's start (dry-run harness).

A dive's timeline varies by a second or two from run to run (threads meet the lockstep
clock in either order, so the altitude settles a little sooner or later), so a fault meant
for the middle of a lane is placed relative to the executor entering a state, e.g.
``PASS_1``: :class:`AnchoredFaults` is the scenario's :class:`~sim_harness.faults.FaultConfig`
whose windows (link cuts, altimeter dropouts, position loss) start counting once the dry
run sets ``anchor["t0_s"]``; before that no window is open. This is the harness's fault
injection: the controller never sees it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from sim_harness.faults import FaultConfig


@dataclass(frozen=True)
class AnchoredFaults(FaultConfig):
    """``FaultConfig`` with its windows relative to ``anchor["t0_s"]`` (simulated s)."""

    anchor: dict[str, float] = field(default_factory=dict, compare=False, hash=False, repr=False)

    @classmethod
    def of(cls, faults: FaultConfig) -> AnchoredFaults:
        """The same faults, anchored (not yet started)."""
        return cls(**{f.name: getattr(faults, f.name) for f in fields(FaultConfig)})

    def _since(self, t_s: float) -> float:
        t0 = self.anchor.get("t0_s")
        return -math.inf if t0 is None else t_s - t0

    def link_cut(self, t_s: float) -> bool:
        """True while a cut window (counted from the anchor) is open."""
        return super().link_cut(self._since(t_s))

    def altimeter_out(self, t_s: float) -> bool:
        """True during an altimeter dropout window (counted from the anchor)."""
        return super().altimeter_out(self._since(t_s))

    def position_out(self, t_s: float) -> bool:
        """True while a position-loss window (counted from the anchor) is open."""
        return super().position_out(self._since(t_s))
