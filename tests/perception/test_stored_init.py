"""perception.stored_init: a hand-written __init__ that drifts from its fields stops the import."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from perception.shadows.measurement.measure import ShadowMeasurement
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.grid import Region
from perception.shadows.segmentation.result import Segmentation
from perception.stored_init import check_init_takes_fields


def test_the_results_built_many_times_a_frame_take_exactly_their_fields() -> None:
    for cls in (Region, Pair, Segmentation, ShadowMeasurement):
        check_init_takes_fields(cls)  # what their modules do when they load


@pytest.mark.parametrize("init", [
    "def __init__(self, x, y=2, z=0): self.__dict__.update(x=x, y=y)",  # a parameter too many
    "def __init__(self, y, x=2): self.__dict__.update(x=x, y=y)",  # reordered
    "def __init__(self, x, y=3): self.__dict__.update(x=x, y=y)",  # another default
    "def __init__(self, x, y): self.__dict__.update(x=x, y=y)",  # the default lost
])
def test_an_init_that_drifted_from_the_fields_is_refused(init: str) -> None:
    namespace: dict = {}
    exec(init, namespace)

    @dataclass(frozen=True)
    class Drifted:
        x: int
        y: int = 2

    Drifted.__init__ = namespace["__init__"]  # type: ignore[method-assign]
    with pytest.raises(TypeError, match="Drifted.__init__ must take exactly its fields"):
        check_init_takes_fields(Drifted)
