"""Shadow start and end per beam, at sub-sample precision, from range zero."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.heights.pipeline import detect_shadows
from perception.shadows.measurement.measure import MeasureConfig, measure_pair
from perception.shadows.pairing.pair import pair_regions
from perception.shadows.segmentation.segment import segment
from tests.perception.shadows.shadow_synth import Box, SynthConfig, edges_at, render

BOX = Box(1.2, 0.0, 0.10, 0.05, 0.039)


def _errors_in_samples(frame, box: Box, altitude_m: float) -> np.ndarray:
    """(r_top, r_end) errors of every measured beam against the exact edges, in samples."""
    (m,) = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    out = []
    for j, top, end in zip(m.columns, m.r_top_per_beam_m, m.r_end_per_beam_m, strict=True):
        exact = edges_at(box, float(frame.beam_azimuth_rad[j]), altitude_m)
        assert exact is not None
        out.append(((top - exact[0]), (end - exact[1])))
    return np.array(out) / frame.range_resolution_m


def test_noise_free_edges_are_sub_sample(rng: np.random.Generator) -> None:
    frame, _, _ = render(SynthConfig(boxes=(BOX,), speckle_looks=0), rng=rng)
    errors = _errors_in_samples(frame, BOX, 0.5)
    assert len(errors) >= 3
    assert np.abs(errors).max() < 0.15  # a tenth of a sample, far below the 1-sample grid


@given(
    x0=st.floats(1.0, 1.6),
    y=st.floats(-0.2, 0.2),
    height=st.floats(0.02, 0.08),
    altitude=st.floats(0.45, 0.6),
)
@settings(max_examples=15, deadline=None, derandomize=True)
def test_noise_free_edges_anywhere(x0: float, y: float, height: float, altitude: float) -> None:
    box = Box(x0, y, 0.06, 0.05, height)
    config = SynthConfig(boxes=(box,), speckle_looks=0, altitude_m=altitude, window_m=(0.9, 2.4))
    frame, _, truths = render(config, rng=np.random.default_rng(0))
    if not truths[0].in_band:
        return
    errors = _errors_in_samples(frame, box, altitude)
    # The pair's beams share one fitted offset from their whole-sample alignment, so a beam's
    # own edge is good to about half a sample (a beam crossing a corner of the box, worse);
    # the beams' median edges stay within 0.4 of a sample.
    assert np.abs(np.median(errors, axis=0)).max() < 0.4
    assert np.percentile(np.abs(errors), 75) < 0.7


def test_speckled_edges_are_unbiased_within_a_fraction_of_a_sample(
    rng: np.random.Generator,
) -> None:
    errors = np.concatenate(
        [_errors_in_samples(render(SynthConfig(boxes=(BOX,)), rng=rng)[0], BOX, 0.5) for _ in range(6)]
    )
    assert np.abs(errors.mean(axis=0)).max() < 0.35
    assert errors.std(axis=0).max() < 0.7


@pytest.mark.parametrize("offset_m", [-0.3, 0.25, 1.0])
def test_ranges_are_read_from_range_zero_not_the_window(
    rng: np.random.Generator, offset_m: float
) -> None:
    # The same image on a shifted range axis: every measured range shifts by the offset.
    frame, _, _ = render(SynthConfig(boxes=(BOX,)), rng=rng)
    seg = segment(frame.image, range_m=frame.range_m)
    (pair,) = pair_regions(seg)
    a = measure_pair(seg, pair, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    b = measure_pair(
        seg, pair, range_m=frame.range_m + offset_m, beam_azimuth_rad=frame.beam_azimuth_rad
    )
    assert b.r_top_m - a.r_top_m == pytest.approx(offset_m, abs=1e-9)
    assert b.r_end_m - a.r_end_m == pytest.approx(offset_m, abs=1e-9)
    # and the absolute values match the truth, which is from range zero
    exact = edges_at(BOX, a.azimuth_rad, 0.5)
    assert exact is not None
    assert a.r_top_m == pytest.approx(exact[0], abs=2 * frame.range_resolution_m)


def test_measurement_fields(rng: np.random.Generator) -> None:
    frame, _, truths = render(SynthConfig(boxes=(BOX,)), rng=rng)
    (m,) = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.usable and not m.truncated and m.reason is None
    assert m.r_top_m == pytest.approx(float(np.mean(m.r_top_per_beam_m)))
    assert m.r_end_m == pytest.approx(float(np.mean(m.r_end_per_beam_m)))
    assert m.azimuth_rad == pytest.approx(float(np.mean(frame.beam_azimuth_rad[list(m.columns)])))
    assert abs(m.azimuth_rad - truths[0].azimuth_rad) < math.radians(0.5)
    assert 0 < m.sigma_r_m < frame.range_resolution_m
    assert m.highlight_range_m < m.r_top_m < m.r_end_m


def test_measure_config_is_validated() -> None:
    with pytest.raises(ValueError, match="central_fraction"):
        MeasureConfig(central_fraction=0.0)
    with pytest.raises(ValueError, match="min_beams"):
        MeasureConfig(min_beams=0)
    with pytest.raises(ValueError, match="smooth_m"):
        MeasureConfig(smooth_m=0.0)
    with pytest.raises(ValueError, match="cut_contrast_sigmas"):
        MeasureConfig(cut_contrast_sigmas=math.inf)
