"""Algorithm 1's pairing: edge cases on exact synthetic frames."""

from __future__ import annotations

import numpy as np
import pytest

from perception.shadows.measurement.measure import measure_pair
from perception.shadows.pairing.pair import PairingConfig, pair_regions
from perception.shadows.segmentation.segment import segment
from tests.perception.shadows.shadow_synth import Box, SynthConfig, render


def _pairs(config: SynthConfig, rng: np.random.Generator, *, image: np.ndarray | None = None):
    frame, _, truths = render(config, rng=rng)
    seg = segment(frame.image if image is None else image, range_m=frame.range_m)
    return frame, seg, pair_regions(seg), truths


def test_each_shadow_is_right_behind_its_highlight(rng: np.random.Generator) -> None:
    boxes = (Box(1.2, 0.0, 0.10, 0.05, 0.039), Box(1.3, 0.3, 0.05, 0.04, 0.047))
    frame, seg, pairs, truths = _pairs(SynthConfig(boxes=boxes), rng)
    assert len(pairs) == 2
    for pair in pairs:
        assert pair.inside_fov
        assert pair.overlap >= 0.5
        assert set(pair.columns) <= set(range(pair.shadow.col_start, pair.shadow.col_stop))
        # In each beam the target's echo ends where its shadow starts (to a grid step).
        h_first, h_last, h_there = seg.column_extents(pair.highlight)
        s_first, _, s_there = seg.column_extents(pair.shadow)
        for c in pair.columns:
            i, j = c - pair.highlight.col_start, c - pair.shadow.col_start
            if 0 <= i < h_there.size and h_there[i] and s_there[j]:
                assert h_last[i] <= s_first[j] + seg.row_step
    azimuths = sorted(float(np.mean(frame.beam_azimuth_rad[list(p.columns)])) for p in pairs)
    assert azimuths == pytest.approx(sorted(t.azimuth_rad for t in truths), abs=np.radians(1.0))


def test_two_targets_in_one_beam_get_their_own_shadows(rng: np.random.Generator) -> None:
    near, far = Box(1.0, 0.0, 0.05, 0.06, 0.03), Box(1.5, 0.0, 0.05, 0.06, 0.04)
    frame, seg, pairs, truths = _pairs(SynthConfig(boxes=(near, far), window_m=(0.9, 2.2)), rng)
    assert len(pairs) == 2
    pairs = sorted(pairs, key=lambda p: p.highlight.row_start)
    for pair, truth in zip(pairs, sorted(truths, key=lambda t: t.r_top_m), strict=True):
        shadow_start_m = frame.range_m[pair.shadow.row_start]
        assert shadow_start_m == pytest.approx(truth.r_top_m, abs=0.01)
    # the near target's shadow ends before the far target's highlight begins
    assert pairs[0].shadow.row_stop <= pairs[1].highlight.row_start


def test_shadow_cut_by_the_fan_edge_is_flagged(rng: np.random.Generator) -> None:
    edge_box = Box(1.2, -0.33, 0.06, 0.06, 0.04)  # partly beyond the -15 deg beam
    frame, seg, pairs, _ = _pairs(SynthConfig(boxes=(edge_box,)), rng)
    assert len(pairs) == 1
    assert "first_beam" in pairs[0].fov_flags and not pairs[0].inside_fov
    m = measure_pair(seg, pairs[0], range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.truncated and not m.usable
    assert m.reason is not None and "edge of the fan" in m.reason


def test_shadow_beyond_the_band_is_truncated(rng: np.random.Generator) -> None:
    # Band's far edge at 0.5 / sin(13 deg) = 2.22 m; this shadow would end at 2.49 m.
    tall = Box(1.9, 0.0, 0.05, 0.08, 0.10)
    frame, seg, pairs, truths = _pairs(SynthConfig(boxes=(tall,), window_m=(0.9, 2.6)), rng)
    assert truths[0].r_end_m > 2.3
    assert len(pairs) == 1
    m = measure_pair(seg, pairs[0], range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.truncated and not m.usable
    assert m.reason is not None and "band" in m.reason


def test_shadow_cut_by_the_window_is_truncated(rng: np.random.Generator) -> None:
    box = Box(1.3, 0.0, 0.05, 0.08, 0.08)  # shadow to 1.68 m, window ends at 1.6 m
    frame, seg, pairs, truths = _pairs(SynthConfig(boxes=(box,), window_m=(0.9, 1.6)), rng)
    assert truths[0].r_end_m > 1.6
    assert len(pairs) == 1
    m = measure_pair(seg, pairs[0], range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.truncated and m.reason is not None and "window" in m.reason


def test_a_target_with_no_shadow_is_not_paired(rng: np.random.Generator) -> None:
    box = Box(1.2, 0.0, 0.10, 0.05, 0.039)
    frame, _, _ = render(SynthConfig(boxes=(box,)), rng=rng)
    image = frame.image.copy()
    image[300:330, 90:100] = 250  # a flat bright patch: highlight, no shadow behind it
    seg = segment(image, range_m=frame.range_m)
    assert len(seg.highlights) == 2
    pairs = pair_regions(seg)
    assert len(pairs) == 1
    assert pairs[0].highlight.col_start < 80


def test_shadows_without_a_highlight_are_targets_unless_asked_not(rng: np.random.Generator) -> None:
    # A low-contrast box: its echo no brighter than the seabed, its shadow as dark as any.
    box = Box(1.2, 0.0, 0.10, 0.05, 0.039)
    config = SynthConfig(boxes=(box,), top_level=5e4, face_level=1e4)
    frame, seg, pairs, truths = _pairs(config, rng)
    assert seg.highlights == () and len(pairs) == 1
    (pair,) = pairs
    assert pair.highlight is None and pair.overlap == 0.0
    m = measure_pair(seg, pair, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.usable and not m.has_highlight
    assert 0.5 * (m.r_end_m - m.r_top_m) / m.r_end_m == pytest.approx(box.height_m, abs=0.002)
    assert pair_regions(seg, config=PairingConfig(shadow_only=False)) == []


def test_pairing_config_is_validated() -> None:
    with pytest.raises(ValueError, match="max_gap_m"):
        PairingConfig(max_gap_m=-0.1)
    with pytest.raises(ValueError, match="min_run_beams"):
        PairingConfig(min_run_beams=0)


def test_merged_shadows_of_neighbours_are_shared_by_beam(rng: np.random.Generator) -> None:
    # Two boxes side by side in azimuth at different ranges: one shadow region, two pairs.
    boxes = (Box(1.15, -0.03, 0.05, 0.05, 0.06), Box(1.3, 0.02, 0.05, 0.05, 0.04))
    config = SynthConfig(boxes=boxes, tilt_deg=25.0)
    frame, seg, pairs, truths = _pairs(config, rng)
    assert len(seg.shadows) == 1 and len(pairs) == 2
    assert pairs[0].shadow is pairs[1].shadow
    assert not set(pairs[0].columns) & set(pairs[1].columns)
    for pair in pairs:
        m = measure_pair(seg, pair, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
        truth = min(truths, key=lambda t: abs(t.azimuth_rad - m.azimuth_rad))
        assert m.usable
        height = 0.5 * (m.r_end_m - m.r_top_m) / m.r_end_m
        assert height == pytest.approx(truth.box.height_m, abs=0.002)


def test_neighbours_merged_side_by_side_are_told_apart(rng: np.random.Generator) -> None:
    # Two boxes touching in azimuth, far edges at one range: one highlight and one shadow
    # region; the shadows end at different ranges (3 and 6 cm high), so two targets.
    boxes = (Box(1.2, -0.03, 0.08, 0.06, 0.03), Box(1.2, 0.03, 0.08, 0.06, 0.06))
    frame, seg, pairs, truths = _pairs(SynthConfig(boxes=boxes), rng)
    assert len(seg.highlights) == 1 and len(seg.shadows) == 1
    assert len(pairs) == 2
    assert not set(pairs[0].columns) & set(pairs[1].columns)
    for pair in pairs:
        m = measure_pair(seg, pair, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
        truth = min(truths, key=lambda t: abs(t.azimuth_rad - m.azimuth_rad))
        assert m.usable
        assert abs(m.azimuth_rad - truth.azimuth_rad) < np.radians(0.5)
        height = 0.5 * (m.r_end_m - m.r_top_m) / m.r_end_m
        assert height == pytest.approx(truth.box.height_m, abs=0.002)


def test_a_highlight_broken_in_two_is_one_target(rng: np.random.Generator) -> None:
    # The target's echo is at seabed level in a few beams through its middle: two
    # highlights in front of one shadow, still one target.
    box = Box(1.2, 0.0, 0.10, 0.05, 0.039)
    frame, _, truths = render(SynthConfig(boxes=(box,)), rng=rng)
    image = frame.image.copy()
    whole = segment(image, range_m=frame.range_m)
    (hl,) = whole.highlights
    mid = (hl.col_start + hl.col_stop) // 2
    seabed = np.round(whole.background[hl.row_start : hl.row_stop, None]).astype(np.uint8)
    image[hl.row_start : hl.row_stop, mid - 1 : mid + 2] = seabed
    seg = segment(image, range_m=frame.range_m)
    assert len(seg.highlights) == 2 and len(seg.shadows) == 1
    (pair,) = pair_regions(seg)
    assert min(pair.columns) < mid - 1 and max(pair.columns) > mid + 1
    m = measure_pair(seg, pair, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert m.usable and abs(m.azimuth_rad - truths[0].azimuth_rad) < np.radians(0.5)
    assert 0.5 * (m.r_end_m - m.r_top_m) / m.r_end_m == pytest.approx(box.height_m, abs=0.002)


def test_pair_extents_are_the_regions_column_extents(rng: np.random.Generator) -> None:
    # pair_regions builds the extents itself (one presence test for all labels): they must
    # stay those of Segmentation.column_extents.
    boxes = (Box(1.15, -0.03, 0.05, 0.05, 0.06), Box(1.3, 0.02, 0.05, 0.05, 0.04), Box(1.2, 0.3, 0.05, 0.04, 0.047))
    _, seg, pairs, _ = _pairs(SynthConfig(boxes=boxes, tilt_deg=25.0), rng)
    assert len(pairs) == 3
    for pair in pairs:
        for region, extents in ((pair.highlight, pair.highlight_extents), (pair.shadow, pair.shadow_extents)):
            for got, want in zip(extents, seg.column_extents(region), strict=True):
                assert got.dtype == want.dtype
                np.testing.assert_array_equal(got, want)
