"""The measured visits: the painted surface, two photos with their overlays, the figures; then healing over time."""

from __future__ import annotations

import logging
import tempfile
from pathlib import Path

import cv2

from processing.report.figures import DIGITS, figure, hours
from processing.report.layout import GREY, URGENT, ReportPDF
from processing.report.surface_render import render_surface
from schemas.analysis import DISCLAIMER, AnalysisStatus, ConfidenceRecord
from schemas.encounter_snapshot import AnalysisVisit, EncounterSnapshot
from schemas.errors import InvalidInput

log = logging.getLogger(__name__)

SURFACE = Path("surface") / "burn_surface.npz"
RELIEF_IS_GEOMETRY = "Surface relief is geometry measured from the photos, not the clinical burn depth."


def analyses(pdf: ReportPDF, r: EncounterSnapshot, scratch: Path) -> None:
    if not r.analyses:
        pdf.heading("3D analysis")
        pdf.para("No 3D analysis of this patient's burn has finished: no measured area, relief or volume.", colour=GREY)
        return
    for page in r.analyses:
        pdf.add_page()
        _analysis(pdf, page, scratch)


def _analysis(pdf: ReportPDF, page: AnalysisVisit, scratch: Path) -> None:
    record = page.analysis.value
    result = record.result
    pdf.heading(f"3D analysis — {page.visit}", new_page_if_below=0)
    pdf.para(
        f"Analysis {record.job_id} · photos {record.captured.at if record.captured else 'time not recorded'} · "
        f"finished {record.completed_at}",
        colour=GREY,
    )
    if result.provisional or result.provisional is None:
        why = "taken under 72 h after the injury" if result.provisional else "time since injury unknown"
        pdf.para(
            f"PROVISIONAL: {why}; burns evolve over the first days, measure again later.", bold=True, colour=URGENT
        )
    if result.status is AnalysisStatus.failed:
        pdf.para(f"No measurement: {result.reason}", bold=True)
        return
    y = pdf.get_y()
    width = pdf.epw
    surface = page.folder / SURFACE
    if surface.is_file():
        try:
            image = scratch / f"{record.job_id}-surface.jpg"
            rgb = render_surface(surface, scaled=result.status is AnalysisStatus.ok)
            cv2.imwrite(str(image), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
            pdf.image(str(image), x=pdf.l_margin, y=y, w=width * 0.5, h=width * 0.5 * 0.78)
        except (OSError, ValueError, InvalidInput) as exc:  # an unreadable surface must not stop the report
            log.warning("analysis %s: surface not rendered: %s", record.job_id, exc)
            pdf.set_xy(pdf.l_margin, y + 10)
            pdf.cell(width * 0.5, 5, "surface could not be drawn")
    seg = page.folder / "segmentation"
    overlays = [seg / v.overlay for v in result.views if v.overlay and (seg / v.overlay).is_file()]
    for i, overlay in enumerate(_two_views(overlays)):
        small = _small_jpeg(overlay, scratch / f"{record.job_id}-{i}.jpg")
        if small is not None:
            pdf.image(str(small), x=pdf.l_margin + width * 0.52, y=y + i * width * 0.25, h=width * 0.24)
    pdf.set_y(y + max(width * 0.5 * 0.78, width * 0.5) + 2)
    pdf.para(
        "Left: the reconstructed surface with the burn painted (magenta). Right: two of the photos with the burn "
        "the model found outlined.",
        colour=GREY,
        size=7.5,
    )
    m = result.metrics
    scaled = result.status is AnalysisStatus.ok
    rows = [
        ("Area", figure(m.area_cm2, "area_cm2")),
        ("Perimeter", figure(m.perimeter_cm, "perimeter_cm")),
        ("Relief (deepest)", figure(m.relief_max_mm, "relief_max_mm") + " below the healthy-skin reference"),
        ("Relief (mean)", figure(m.relief_mean_mm, "relief_mean_mm")),
        ("Raised (highest)", figure(m.raised_max_mm, "raised_max_mm")),
        ("Volume", figure(m.volume_cm3, "volume_cm3") + " (a proxy, not tissue loss)"),
        ("Share of body surface", figure(m.tbsa_percent, "tbsa_percent")),
    ]
    if not scaled:
        rows = [
            (
                "Figures",
                "The photos gave no scale (no marker found): nothing is given in cm or mm. "
                "Place the printed marker beside the burn and photograph again.",
            )
        ]
    scale = result.scale
    if scale is not None and scale.method != "none":
        unc = figure(scale.uncertainty_percent, "scale_uncertainty_percent", "%")
        rows.append(("Scale", f"{scale.method}, ±{unc} (1 σ)"))
    else:
        rows.append(("Scale", "none"))
    conf = result.confidence
    if conf is not None:
        rows.append(
            (
                "Confidence",
                f"{conf.level} ({conf.score:.{DIGITS['confidence']}f}); {conf.views_used} photos "
                f"placed, {conf.views_seeing_burn} see the burn",
            )
        )
    rows.append(("Outline drawn by", _outline_source(conf)))
    rows.append(("Time since injury", hours(result.hours_since_injury)))
    pdf.facts(rows)
    if conf is not None and conf.reasons:
        pdf.subheading("Why the confidence is not higher")
        pdf.bullets(conf.reasons, colour=GREY)
    if result.notes:
        pdf.bullets(result.notes, colour=GREY)
    pdf.para(RELIEF_IS_GEOMETRY, bold=True)
    pdf.para(DISCLAIMER, colour=GREY, size=7.5)


def _outline_source(conf: ConfidenceRecord | None) -> str:
    """The model section: which model outlined the burn, and its held-out accuracy on this skin tone."""
    e = conf.outline if conf else None
    if e is None:
        return "a clinician, on every photo used" if conf and conf.clinician_masks else "not recorded"
    words = f"segmentation model {e.model_version or '(unversioned)'}"
    if e.model_architecture:
        words += f" ({e.model_architecture})"
    if e.skin_tone_group is None:
        return words + "; the skin tone around the burn could not be estimated"
    words += f"; skin around the burn estimated {e.skin_tone_group} (ITA {e.skin_tone_ita:.0f}°)"
    if e.group_dice is None:
        return words + "; the model has no held-out score for this skin tone"
    interval = (
        f", 95 % CI {e.group_dice_ci95[0]:.2f}–{e.group_dice_ci95[1]:.2f}"
        if e.group_dice_ci95
        else ", too few to give an interval"
    )
    return (
        words + f"; held-out Dice on real wound photos of this tone {e.group_dice:.2f} ({e.group_images} photos"
        f"{interval}). Fairness table by skin tone: docs/segmentation-model.md and GET /api/v1/segmentation-model"
    )


def _small_jpeg(source: Path, target: Path, longest: int = 900) -> Path | None:
    """A copy small enough for print at this size: phone photos are 12 MP, the report shows them 6 cm wide."""
    image = cv2.imread(str(source), cv2.IMREAD_COLOR)
    if image is None:
        log.warning("overlay %s could not be read", source)
        return None
    scale = longest / max(image.shape[:2])
    if scale < 1:
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    cv2.imwrite(str(target), image, [cv2.IMWRITE_JPEG_QUALITY, 85])
    return target


def _two_views(overlays: list[Path]) -> list[Path]:
    """The first and a middle photo: two different angles of the burn."""
    if len(overlays) <= 2:
        return overlays
    return [overlays[0], overlays[len(overlays) // 2]]


def scratch_dir() -> tempfile.TemporaryDirectory:
    return tempfile.TemporaryDirectory(prefix="burnedge-report-")
