"""Reading and verifying the audit trail (administrators only)."""

from __future__ import annotations

from gateway.services.permissions import Principal, require_admin
from gateway.storage import audit
from gateway.storage.database import Database
from schemas.audit import AuditEntry, AuditVerification


def list_entries(db: Database, principal: Principal, after: int, limit: int) -> list[AuditEntry]:
    require_admin(principal, "read_audit")
    return list(audit.entries(db.connection(), after_seq=after, limit=limit))


def verify(db: Database, principal: Principal | None) -> AuditVerification:
    """principal None: the command line on the gateway itself."""
    if principal is not None:
        require_admin(principal, "read_audit")
    with db.read() as conn:
        return audit.verify(conn)
