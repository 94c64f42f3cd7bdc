"""Verifying the gateway's audit trail, against the burn center's newest signed anchor where it has one."""

from __future__ import annotations

from base.accounts.permissions import Principal, require_admin
from base.storage import audit
from gateway.storage.database import Database
from schemas.audit import AuditVerification
from schemas.config import Config
from schemas.errors import BurnedgeError, InvalidInput
from schemas.transfer import SiteIdentity
from sync import peers
from sync.anchor import anchor_path, load_anchor


def verify(db: Database, principal: Principal | None, config: Config) -> AuditVerification:
    """principal None: the command line on the gateway itself. The chain is also checked against the burn center's
    newest anchor, when this gateway has one (signature checked against the enrolled center's key)."""
    if principal is not None:
        require_admin(principal, "read_audit")
    with db.read() as conn:
        try:
            anchor = load_anchor(anchor_path(config), _center(conn, config))
        except InvalidInput as exc:
            return AuditVerification(ok=False, entries=0, first_broken_seq=None, reason=exc.detail)
        return audit.verify(conn, anchor)


def _center(conn, config: Config) -> SiteIdentity | None:
    try:
        return peers.only_center(conn, config.sync.center_id)
    except BurnedgeError:
        return None  # no center enrolled (any more): the anchor's content is still checked, not its signature
