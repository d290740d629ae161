"""Pairing target highlights with their cast shadows (the paper's Algorithm 1)."""

from perception.shadows.pairing.pair import Pair, PairingConfig, pair_regions

__all__ = [
    "Pair",
    "PairingConfig",
    "pair_regions",
]
