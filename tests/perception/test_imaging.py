"""perception.imaging: the one module importing OpenCV, its contracts, its results."""

from __future__ import annotations

import ast
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception import imaging

PERCEPTION = Path(imaging.__file__).resolve().parent


def _imports_cv2(path: Path) -> bool:
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "cv2" for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "cv2":
            return True
    return False


def test_only_imaging_imports_opencv() -> None:
    users = sorted(str(p.relative_to(PERCEPTION)) for p in PERCEPTION.rglob("*.py") if _imports_cv2(p))
    assert users == ["imaging.py"]


def test_contracts_name_the_wrong_dtype_and_shape() -> None:
    with pytest.raises(TypeError, match="image must be float32, got float64"):
        imaging.gaussian_blur(np.zeros((4, 4)), 1.0)
    with pytest.raises(ValueError, match="image must be 2-D"):
        imaging.gaussian_blur(np.zeros((4, 4, 3), np.float32), 1.0)
    with pytest.raises(TypeError, match="mask must be uint8"):
        imaging.morph_open(np.zeros((4, 4), bool), 3)
    with pytest.raises(ValueError, match=r"table must have shape \(1, 256\)"):
        imaging.lookup(np.zeros((2, 2), np.uint8), np.zeros((1, 255)))
    maps = imaging.fixed_point_maps(np.zeros((3, 3), np.float32), np.zeros((3, 3), np.float32), nearest=True)
    with pytest.raises(ValueError, match="out must be"):
        imaging.remap_fixed_point(np.zeros((3, 3), np.uint8), *maps, nearest=True, fill=0,
                                  out=np.zeros((2, 3), np.uint8))


def test_results_are_opencvs(rng: np.random.Generator) -> None:
    image = rng.random((40, 30), dtype=np.float32)
    grey = (image * 255).astype(np.uint8)
    assert np.array_equal(imaging.gaussian_blur(image, 2.0), cv2.GaussianBlur(image, (0, 0), 2.0))
    assert np.array_equal(imaging.box_mean(image, 3, 3), cv2.blur(image, (3, 3)))
    assert np.array_equal(imaging.log(image + 1), cv2.log(image + 1))
    assert np.array_equal(imaging.translate(image, 1.5, -2.25),
                          cv2.warpAffine(image, np.array([[1.0, 0, 1.5], [0, 1.0, -2.25]]), (30, 40),
                                         flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0))
    padded = imaging.pad_bottom_right(image, 45, 32)
    assert padded.shape == (45, 32) and np.array_equal(padded[:40, :30], image) and not padded[40:].any()
    table = np.arange(256, dtype=np.float64)[None, :] * 0.5
    assert np.array_equal(imaging.lookup(grey, table), table[0][grey])
    assert np.array_equal(imaging.transpose(grey), grey.T)
    assert np.array_equal(imaging.rotate_clockwise(grey), np.rot90(grey, -1))
    mask = (grey > 128).astype(np.uint8)
    labels = np.zeros(mask.shape, np.int32)
    n = imaging.label_components(mask, labels)
    assert n == labels.max() + 1
    assert imaging.optimal_dft_size(97) == 100
    png = imaging.encode_png(np.dstack([grey, grey, grey, grey]))
    assert np.array_equal(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)[..., 0], grey)


def test_box_sum_replicate_is_the_exact_integer_sum(rng: np.random.Generator) -> None:
    counts = rng.integers(0, 65535 // 5, (23, 17)).astype(np.uint16)
    for width in (3, 5):
        half = width // 2
        padded = np.pad(counts.astype(np.int64), ((0, 0), (half, half)), mode="edge")
        expected = sum(padded[:, k : k + counts.shape[1]] for k in range(width)).astype(np.float32)
        assert np.array_equal(imaging.box_sum_replicate(counts, width, 1), expected)
    with pytest.raises(TypeError, match="image must be uint16"):
        imaging.box_sum_replicate(counts.astype(np.uint8), 3, 1)


@settings(max_examples=60, deadline=None)
@given(m=st.integers(0, 40), n=st.integers(1, 300), seed=st.integers(0, 2**32 - 1))
def test_column_cumsum_is_numpys_cumulative_sum_bit_for_bit(m: int, n: int, seed: int) -> None:
    """The edges' column sums (OpenCV's integral, 128 beams a call) are numpy's additions in
    numpy's order: the same bits, for any shape (more beams than one call takes included)."""
    rng = np.random.default_rng(seed)
    values = rng.exponential(1.0, (m, n)) * 10.0 ** rng.uniform(-6, 6, (m, n))
    got = imaging.column_cumsum(values)
    want = np.concatenate([np.zeros((1, n)), np.cumsum(values, axis=0)])
    assert got.shape == (m + 1, n) and got.flags.c_contiguous
    assert got.tobytes() == want.tobytes()
