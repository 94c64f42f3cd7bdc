"""Who may do what: one table per role, checked by the services (never by controllers alone)."""

from __future__ import annotations

from dataclasses import dataclass

import msgspec

from schemas.accounts import Role
from schemas.errors import Forbidden
from schemas.records import Record, RecordKind

ALL_KINDS = frozenset(RecordKind)
CLIENT_WRITABLE = ALL_KINDS - {
    RecordKind.assessment,
    RecordKind.burn_analysis,
    RecordKind.consultation,
    RecordKind.decision_support,
}

READ: dict[Role, frozenset[RecordKind]] = {
    Role.clinician: ALL_KINDS,
    Role.nurse: ALL_KINDS,
    Role.consultant: ALL_KINDS,
    # Administrators run the box; they do not read patients' records.
    Role.admin: frozenset(),
}
WRITE: dict[Role, frozenset[RecordKind]] = {
    Role.clinician: CLIENT_WRITABLE,
    # The burn chart drives %TBSA, fluids and referral: a clinician's assessment.
    Role.nurse: CLIENT_WRITABLE - {RecordKind.burn_chart},
    # Consultants advise through consultations (their own channel), not by editing the record.
    Role.consultant: frozenset(),
    Role.admin: frozenset(),
}
DELETE: dict[Role, frozenset[RecordKind]] = {
    Role.clinician: CLIENT_WRITABLE,
    Role.nurse: frozenset(),
    Role.consultant: frozenset(),
    Role.admin: frozenset(),
}
# Nurses record fluid given; choosing the formula is a prescription.
PRESCRIPTION_FIELDS = {RecordKind.resuscitation: ("formula", "custom_ml_per_kg_per_percent")}
# Decision support is acted on (accepted, declined) by the clinician responsible for the patient.
DECIDE = frozenset({Role.clinician})
# Who may upload photos and videos of a burn (and read them back).
CAPTURE = frozenset({Role.clinician, Role.nurse})
ADMIN_ONLY = frozenset({"manage_users", "manage_devices", "read_audit", "link_sites"})


@dataclass(frozen=True, slots=True)
class Principal:
    """The authenticated caller of one request."""

    user_id: str
    username: str
    role: Role
    device_id: str | None
    session_hash: str
    must_change_password: bool = False
    """An administrator reset the password: the session may only change it (base/web/authentication.py)."""


def readable_kinds(principal: Principal) -> frozenset[RecordKind]:
    return READ[principal.role]


def require_read(principal: Principal, kind: RecordKind) -> None:
    if kind not in READ[principal.role]:
        raise Forbidden(f"a {principal.role.value} may not read {kind.label} records")


def require_write(principal: Principal, kind: RecordKind) -> None:
    if kind not in WRITE[principal.role]:
        raise Forbidden(f"a {principal.role.value} may not write {kind.label} records")


def require_delete(principal: Principal, kind: RecordKind) -> None:
    if kind not in DELETE[principal.role]:
        raise Forbidden(f"a {principal.role.value} may not withdraw {kind.label} records")


def require_admin(principal: Principal, action: str) -> None:
    if action not in ADMIN_ONLY or principal.role is not Role.admin:
        raise Forbidden(f"only an administrator may {action.replace('_', ' ')}")


def check_field_rules(principal: Principal, kind: RecordKind, struct, current: Record | None) -> None:
    """Fields only a clinician may change, within a part others may write."""
    fields = PRESCRIPTION_FIELDS.get(kind)
    if not fields or principal.role is Role.clinician:
        return
    # Without a stored version the baseline is the part's defaults (encounter_id is its one required field).
    baseline = current.data if current else msgspec.to_builtins(type(struct)(encounter_id=struct.encounter_id))
    for name in fields:
        if msgspec.to_builtins(getattr(struct, name)) != baseline.get(name):
            raise Forbidden(f"a {principal.role.value} may record fluid given but not change {name.replace('_', ' ')}")


def require_decide(principal: Principal) -> None:
    if principal.role not in DECIDE:
        raise Forbidden(f"a {principal.role.value} may not accept or decline recommendations: a clinician does")


def require_capture(principal: Principal) -> None:
    if principal.role not in CAPTURE:
        raise Forbidden(f"a {principal.role.value} may not upload photos or videos")
