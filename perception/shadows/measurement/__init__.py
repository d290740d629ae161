"""Where each shadow starts and ends, per beam, to a fraction of a range sample."""

from perception.shadows.measurement.measure import MeasureConfig, ShadowMeasurement, measure_pair, measure_pairs

__all__ = [
    "MeasureConfig",
    "ShadowMeasurement",
    "measure_pair",
    "measure_pairs",
]
