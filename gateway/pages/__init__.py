"""The clinic's browser face, served by the gateway itself: thin page controllers over the same services as the API.

Pages read and write through the domains' services with the signed-in principal, so one permission rule applies to
both; the templates are in gateway/pages/templates beside the shared layout (base/web/templates)."""

from __future__ import annotations

from pathlib import Path

from base.web.pages.rendering import NavItem
from schemas.accounts import Role

TEMPLATES = Path(__file__).resolve().parent / "templates"
SITE_NAME = "Clinic gateway"
_CARE = frozenset({Role.clinician.value, Role.nurse.value})
NAV = [
    NavItem("Patients", "/patients", _CARE),
    NavItem("Burn center", "/transfers", _CARE | {Role.admin.value}),
    NavItem("Admin", "/admin", frozenset({Role.admin.value})),
]


def page_controllers() -> list:
    """Every page controller of the gateway (imported here so the app factory names one thing)."""
    from base.web.pages.admin import AdminPages
    from base.web.pages.sign_in import SignInController
    from gateway.pages.analyses import AnalysisPages
    from gateway.pages.burn_chart import BurnChartPages
    from gateway.pages.encounters import EncounterPages
    from gateway.pages.patients import PatientPages
    from gateway.pages.pictures import PicturePages
    from gateway.pages.transfers import TransferPages
    from gateway.pages.wounds import WoundPages

    return [
        SignInController,
        PatientPages,
        WoundPages,
        EncounterPages,
        BurnChartPages,
        PicturePages,
        AnalysisPages,
        TransferPages,
        AdminPages,
    ]
