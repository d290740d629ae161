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
    valid = np.isfinite(raster.intensity)
    top = float(np.percentile(raster.intensity[valid], 99.5)) if valid.any() else 1.0
    shown = np.ma.masked_invalid(raster.intensity)
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
