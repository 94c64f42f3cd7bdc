"""What the patient page shows of one wound's healing: its track's plots, its latest visit's painted surface and
its measured share of the body beside the chart."""

from __future__ import annotations

from dataclasses import dataclass, field

from base.web.pages.rendering import svg
from processing.views.healing_plot_svg import healing_plots_svg
from schemas.longitudinal import TrackSession
from schemas.wound_healing import SHARE_SOURCES, WoundHealing

PAINTED_SURFACE = "surface/burn_surface.glb"
"""The analysis file that holds the burn painted on the 3D surface (glTF binary), shown in the viewer."""


@dataclass(frozen=True)
class WoundSection:
    healing: WoundHealing
    plots: list = field(default_factory=list)
    latest: TrackSession | None = None
    latest_surface: str | None = None
    sources: dict[str, str] = field(default_factory=lambda: dict(SHARE_SOURCES))


def wound_section(healing: WoundHealing) -> WoundSection:
    track = healing.track
    if track is None:
        return WoundSection(healing)
    plots = [(title, svg(markup)) for title, markup in healing_plots_svg(track)]
    measured = [s for s in track.sessions if s.status == "ok" and s.analysis]
    latest = measured[-1] if measured else None
    surface = f"{latest.analysis}/artifacts/{PAINTED_SURFACE}" if latest else None
    return WoundSection(healing, plots, latest, surface)
