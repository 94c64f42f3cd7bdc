"""Consultant advice on the clinic's pages until someone reads it: a count in the header, a panel and a badge per
patient on the patient list, a "new" mark on the encounter (opening the encounter marks its advice as read)."""

from __future__ import annotations

from base.accounts.permissions import Principal
from base.web.pages.rendering import HeaderNotice
from gateway.dependencies import Services
from gateway.storage.advice import UnreadAdvice


def advice_notice(services: Services, principal: Principal) -> HeaderNotice | None:
    unread = services.transfers.unread_advice(principal)
    return HeaderNotice("New advice", len(unread), "/patients#new-advice") if unread else None


def by_patient(unread: list[UnreadAdvice]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for advice in unread:
        counts[advice.patient_id] = counts.get(advice.patient_id, 0) + 1
    return counts


def read_on_opening(services: Services, principal: Principal, encounter_id: str) -> set[str]:
    """The encounter's advice new to the clinic (shown marked "new" this once), now recorded as read."""
    return services.transfers.mark_advice_read(principal, encounter_id)
