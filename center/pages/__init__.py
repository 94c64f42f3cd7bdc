"""The burn center's browser face, for consultants: incoming cases by urgency, the case page with the clinic's
record, 3D viewer, photos and report, and the advice that travels back to the clinic. Thin controllers over the
center's services (center/cases.py); templates in center/pages/templates beside the shared ones."""

from __future__ import annotations

from pathlib import Path

from base.web.pages.rendering import NavItem
from schemas.accounts import Role

TEMPLATES = Path(__file__).resolve().parent / "templates"
SITE_NAME = "Burn center"
NAV = [
    NavItem("Cases", "/cases", frozenset({Role.consultant.value})),
    NavItem("Clinics", "/clinics", frozenset({Role.admin.value})),
    NavItem("Admin", "/admin", frozenset({Role.admin.value})),
]


def page_controllers() -> list:
    from base.web.pages.admin import AdminPages
    from base.web.pages.sign_in import SignInController
    from center.pages.cases import CasePages
    from center.pages.clinics import ClinicPages

    return [SignInController, CasePages, ClinicPages, AdminPages]
