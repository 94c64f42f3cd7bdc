"""What the gateway's pages share: the site's name and menu, the helpers every page controller uses (`common`), the
encounter's header and overview (`encounter_view`), a wound's healing section (`healing_view`) and the shared
templates (macros, the healing track).

Each domain keeps its own page controllers and templates (gateway/records/patient_pages.py and
gateway/records/templates/, gateway/capture/picture_pages.py...); gateway/site.py lists them. This package imports
no domain: the domains import it."""

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
