"""Where a wound is, coded as DICOM expects: the anatomic region (SNOMED CT body structures, PS3.16 CID 4031) and
laterality (SNOMED CT Left/Right/Bilateral; ImageLaterality L/R/B in an image)."""

from __future__ import annotations

from highdicom.sr import FindingSite
from pydicom.dataset import Dataset
from pydicom.sr.codedict import codes
from pydicom.sr.coding import Code

from processing.fhir.codes import region_parts
from schemas.wound import Wound, WoundSide

REGION: dict[str, Code] = {
    "head": codes.SCT.Head,
    "neck": codes.SCT.Neck,
    "trunk": codes.SCT.Trunk,
    "buttock": codes.SCT.Buttock,
    "genitalia": Code("60944009", "SCT", "Skin of external genitalia"),
    "upper_arm": codes.SCT.UpperArm,
    "lower_arm": codes.SCT.Forearm,
    "hand": codes.SCT.Hand,
    "thigh": codes.SCT.Thigh,
    "lower_leg": codes.SCT.LowerLeg,
    "foot": codes.SCT.Foot,
}
"""By the body part of a Lund-Browder region's name (schemas/burn_chart.py); every code is in pydicom's PS3.16
concept dictionary (docs/dicom.md)."""

LATERALITY: dict[str, tuple[Code, str]] = {
    "left": (codes.SCT.Left, "L"),
    "right": (codes.SCT.Right, "R"),
    "bilateral": (codes.SCT.Bilateral, "B"),
}


def site(wound: Wound | None) -> tuple[Code, tuple[Code, str] | None] | None:
    """The wound's first region as a code and its side (the wound's own, else the region's); None when the wound
    is unknown or has no region. A wound over several regions is coded by its first and named in the text."""
    if wound is None or not wound.regions:
        return None
    part, side, _face = region_parts(wound.regions[0])
    region = REGION.get(part)
    if region is None:
        return None
    if wound.side is WoundSide.midline:
        return region, None
    said = wound.side.value if wound.side is not None else side
    return region, LATERALITY.get(said or "")


def describe_image(ds: Dataset, wound: Wound | None) -> None:
    """Anatomic Region Sequence (one item) and Image Laterality of a photo of `wound`."""
    found = site(wound)
    if found is None:
        return
    region, side = found
    item = Dataset()
    item.CodeValue, item.CodingSchemeDesignator, item.CodeMeaning = (
        region.value,
        region.scheme_designator,
        region.meaning,
    )
    ds.AnatomicRegionSequence = [item]
    if side is not None:
        ds.ImageLaterality = side[1]
    if wound is not None:
        ds.ImageComments = f"{getattr(ds, 'ImageComments', '')} Wound: {wound.label}".strip()[:10240]


def finding_sites(wound: Wound | None) -> list[FindingSite]:
    found = site(wound)
    if found is None:
        return []
    region, side = found
    return [FindingSite(anatomic_location=region, laterality=side[0] if side else None)]
