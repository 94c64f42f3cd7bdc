"""The clinic's browser face, served by the gateway itself: every domain's page controllers and template folders.

Pages read and write through the domains' services with the signed-in principal, so one permission rule applies to
both. A domain's templates sit in its own templates/ folder; the shared ones (macros, the healing track) in
gateway/pages/templates, and the layout in base/web/templates.
"""

from __future__ import annotations

from pathlib import Path

from gateway.pages import TEMPLATES as SHARED_TEMPLATES

ROOT = Path(__file__).resolve().parent
TEMPLATE_DIRS = [
    ROOT / "records" / "templates",
    ROOT / "capture" / "templates",
    ROOT / "analyses" / "templates",
    ROOT / "documents" / "templates",
    ROOT / "transfers" / "templates",
    ROOT / "phones" / "templates",
    SHARED_TEMPLATES,
]
"""Where the gateway's page templates are, each domain's own first; a name is unique across them."""


def page_controllers() -> list:
    """Every page controller of the gateway, from the domain that owns it."""
    from base.web.pages.admin import AdminPages
    from base.web.pages.sign_in import SignInController
    from gateway.analyses.pages import AnalysisPages
    from gateway.capture.picture_pages import PicturePages
    from gateway.documents.pacs_pages import EncounterPacsPages
    from gateway.documents.pages import ReportPages
    from gateway.phones.setup_pages import PhoneSetupPages
    from gateway.records.burn_chart_pages import BurnChartPages
    from gateway.records.encounter_pages import EncounterPages
    from gateway.records.patient_edit_pages import PatientEditPages
    from gateway.records.patient_merge_pages import PatientMergePages
    from gateway.records.patient_pages import PatientPages
    from gateway.transfers.link_pages import LinkPages
    from gateway.transfers.pages import EncounterSendPages, TransferPages
    from gateway.wounds.pages import WoundPages

    return [
        SignInController,
        PatientPages,
        PatientEditPages,
        PatientMergePages,
        WoundPages,
        EncounterPages,
        BurnChartPages,
        PicturePages,
        AnalysisPages,
        ReportPages,
        EncounterPacsPages,
        EncounterSendPages,
        TransferPages,
        LinkPages,
        AdminPages,
        PhoneSetupPages,
    ]
