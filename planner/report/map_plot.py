"""The 2.5D map as a picture: the seabed mosaic with every target's height on it."""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: files only, never a window
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import colors, patheffects  # noqa: E402

from perception.atomic_file import atomic_write  # noqa: E402
from perception.mapping.heights_layer import MappedTarget  # noqa: E402
from perception.mapping.products import MapRaster  # noqa: E402

#: Mosaic cells drawn per inch of the figure, at most (a field-scale mosaic has tens of
#: millions of 1 cm cells; the figure shows 150 pixels an inch).
DISPLAY_PX_PER_INCH = 300


def display_image(intensity: np.ndarray, max_px: int) -> np.ndarray:
    """``intensity`` block-averaged (NaN cells left out) to at most ``max_px`` cells a side,
    float32; unchanged when it is small enough."""
    n_rows, n_cols = intensity.shape
    k = max(1, math.ceil(max(n_rows, n_cols) / max(max_px, 1)))
    if k == 1:
        return intensity
    rows, cols = math.ceil(n_rows / k), math.ceil(n_cols / k)
    total = np.zeros((rows, cols), dtype=np.float64)
    count = np.zeros((rows, cols), dtype=np.float64)
    for r0 in range(0, n_rows, k * 64):  # a band at a time: no full-size temporaries
        band = np.asarray(intensity[r0:r0 + k * 64], dtype=np.float32)
        pad_r = (-band.shape[0]) % k
        pad_c = (-n_cols) % k
        band = np.pad(band, ((0, pad_r), (0, pad_c)), constant_values=np.nan)
        blocks = band.reshape(band.shape[0] // k, k, cols, k)
        finite = np.isfinite(blocks)
        i0 = r0 // k
        total[i0:i0 + blocks.shape[0]] += np.where(finite, blocks, 0.0).sum(axis=(1, 3), dtype=np.float64)
        count[i0:i0 + blocks.shape[0]] += finite.sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan).astype(np.float32)


def render_map_png(
    path: Path,
    raster: MapRaster,
    targets: Sequence[MappedTarget],
    *,
    title: str = "Seabed mosaic with target heights",
    truth: Sequence[tuple[float, float, float]] = (),
    dpi: int = 150,
) -> Path:
    """Write a PNG of the mosaic (north up, local metres) with height labels.

    Parameters
    ----------
    raster : MapRaster
        The mosaic, north up.
    targets : sequence of MappedTarget
        Targets to mark; solved ones are coloured by height and labelled
        ``h ± std cm``; unsolved ones are drawn hollow.
    truth : sequence of (north_m, east_m, height_m), optional
        Simulator truth, drawn as small crosses with the true height (simulation only).
    """
    n_rows, n_cols = raster.intensity.shape
    extent = (
        raster.west_m,
        raster.west_m + n_cols * raster.resolution_m,
        raster.north_m - n_rows * raster.resolution_m,
        raster.north_m,
    )
    width_in = 10.0
    height_in = max(4.0, min(14.0, width_in * n_rows / max(n_cols, 1)))
    fig, ax = plt.subplots(figsize=(width_in, height_in), constrained_layout=True)
    image = display_image(raster.intensity, int(DISPLAY_PX_PER_INCH * max(width_in, height_in)))
    valid = np.isfinite(image)
    top = float(np.percentile(image[valid], 99.5)) if valid.any() else 1.0
    shown = np.ma.masked_invalid(image)
    ax.set_facecolor("#1b2a3a")
    ax.imshow(shown, cmap="copper", vmin=0, vmax=top, extent=extent, origin="upper", interpolation="nearest")
    solved = [t for t in targets if math.isfinite(t.height_m)]
    norm = colors.Normalize(vmin=0.0, vmax=max([t.height_m * 100 for t in solved] + [5.0]))
    cmap = plt.get_cmap("viridis")
    outline = [patheffects.withStroke(linewidth=3, foreground="black")]
    for t in targets:
        solved_t = math.isfinite(t.height_m)
        colour = cmap(norm(t.height_m * 100)) if solved_t else "white"
        if len(t.footprint_ne_m) >= 3:
            ring = np.array(t.footprint_ne_m + (t.footprint_ne_m[0],))
            ax.plot(ring[:, 1], ring[:, 0], color=colour, lw=1.5)
        ax.scatter([t.east_m], [t.north_m], s=40, facecolors=colour if solved_t else "none",
                   edgecolors="white", linewidths=0.8, zorder=3)
        label = (
            f"#{t.target_id}  {t.height_m * 100:.1f} ± {t.height_std_m * 100:.1f} cm"
            if solved_t
            else f"#{t.target_id}  no height"
        )
        ax.annotate(label, (t.east_m, t.north_m), xytext=(6, 6), textcoords="offset points", color="white",
                    fontsize=8, path_effects=outline, zorder=4)
    for north, east, height in truth:
        ax.scatter([east], [north], marker="x", s=30, color="#ff5050", zorder=3)
        ax.annotate(f"true {height * 100:.1f} cm", (east, north), xytext=(6, -12), textcoords="offset points",
                    color="#ff9090", fontsize=7, path_effects=outline, zorder=4)
    if solved:
        bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.7)
        bar.set_label("target height (cm)")
    ax.set_xlabel("east of origin (m)")
    ax.set_ylabel("north of origin (m)")
    ax.set_title(f"{title}\n{len(solved)} of {len(targets)} targets with a height; "
                 f"{raster.resolution_m * 100:.0f} cm cells")
    ax.set_aspect("equal")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    plt.close(fig)
    return atomic_write(Path(path), lambda h: h.write(buffer.getvalue()))
