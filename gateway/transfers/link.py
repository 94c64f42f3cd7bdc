"""Linking the clinic to a burn center from the Burn center page, by the clinic's administrator: this clinic's
keys made, the center's public keys enrolled after the fingerprints were compared by phone, and the link (the
center's address, on or off) set. The next sync round uses it: no console, no restart."""

from __future__ import annotations

import re
from dataclasses import dataclass

from base.accounts.permissions import Principal, require_admin
from base.folders import keys_dir
from base.storage import audit
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import Conflict, InvalidInput, MissingKeys
from schemas.transfer import ZENOH_ENDPOINT_PATTERN, LinkSettings, Peer, SiteIdentity, SiteRole
from sync import peers
from sync.keys import fingerprint, init_keys, load_keys
from sync.link_card import confirmed_card, read_card
from sync.service import SyncService

ACTION = "link_sites"


@dataclass(frozen=True)
class LinkView:
    """What the administrator's part of the Burn center page shows."""

    identity: SiteIdentity | None
    """This clinic's public keys; None before they are made."""
    fingerprint: str | None
    center: Peer | None
    """The burn center enrolled here and not unlinked."""
    settings: LinkSettings | None
    suggested_site_id: str


def suggested_site_id(clinic_name: str) -> str:
    """A site id from the clinic's name ("Kasese Field Clinic" -> "kasese-field-clinic")."""
    words = re.sub(r"[^a-z0-9]+", "-", clinic_name.casefold()).strip("-")[:63]
    return words if len(words) >= 2 else "clinic"


def parse_endpoints(text: str) -> list[str]:
    """The center's addresses, one per line or separated by commas; each checked with a message a person can act
    on."""
    endpoints = [e.strip() for e in re.split(r"[\s,]+", text) if e.strip()]
    for endpoint in endpoints:
        if not re.match(ZENOH_ENDPOINT_PATTERN, endpoint):
            raise InvalidInput(
                f"{endpoint!r} is not an address the burn center listens on: write it as its page shows it, "
                'protocol/host:port, e.g. "tcp/203.0.113.5:7447"'
            )
    return endpoints


class LinkService:
    def __init__(self, db: Database, config: Config, sync: SyncService):
        self.db = db
        self.config = config
        self.sync = sync

    def view(self, who: Principal) -> LinkView:
        require_admin(who, ACTION)
        try:
            identity = load_keys(keys_dir(self.config)).identity
        except MissingKeys:
            identity = None
        return LinkView(
            identity=identity,
            fingerprint=fingerprint(identity) if identity else None,
            center=self._center(),
            settings=self.sync.link_settings(),
            suggested_site_id=suggested_site_id(self.config.report.clinic_name),
        )

    def make_keys(self, who: Principal, site_id: str, name: str) -> SiteIdentity:
        require_admin(who, ACTION)
        if not name.strip():
            raise InvalidInput("give the clinic's name, as the burn center will see it")
        keys = init_keys(keys_dir(self.config), site_id.strip(), SiteRole.clinic, name.strip())
        with self.db.write() as conn:
            audit.append(
                conn,
                action="site.keys",
                user_id=who.user_id,
                device_id=who.device_id,
                kind="site",
                record_id=keys.site_id,
                detail=f"keys made on the Burn center page, fingerprint {fingerprint(keys.identity)}",
            )
        return keys.identity

    def read_center(self, who: Principal, upload: bytes) -> SiteIdentity:
        """The burn center's public keys from its keys file or a photo of its QR code (nothing is stored)."""
        require_admin(who, ACTION)
        return read_card(upload, SiteRole.center)

    def enrol_center(self, who: Principal, card: str, compared: bool) -> Peer:
        require_admin(who, ACTION)
        identity = confirmed_card(card, SiteRole.center, compared)
        current = self._center()
        if current is not None and current.identity.site_id != identity.site_id:
            raise Conflict(
                f"this clinic is linked to {current.identity.name} ({current.identity.site_id}): unlink it first"
            )
        # The fingerprints were compared: new keys of the same center (it made them again) replace the old.
        return peers.enrol(self.db, identity, by=who.username, replace=True)

    def unlink_center(self, who: Principal, reason: str) -> Peer:
        require_admin(who, ACTION)
        current = self._center()
        if current is None:
            raise InvalidInput("no burn center is linked")
        if not reason.strip():
            raise InvalidInput("say why the burn center is unlinked")
        return peers.revoke(self.db, current.identity.site_id, reason=reason.strip(), by=who.username)

    def set_link(self, who: Principal, enabled: bool, endpoints_text: str) -> LinkSettings:
        require_admin(who, ACTION)
        endpoints = parse_endpoints(endpoints_text)
        if enabled and not endpoints:
            raise InvalidInput("give the burn center's address before switching the link on")
        if enabled and self._center() is None:
            raise InvalidInput("enrol the burn center's keys (step 2) before switching the link on")
        settings = LinkSettings(enabled=enabled, center_endpoints=endpoints, set_by=who.username, set_at=iso(utcnow()))
        self.sync.set_link(settings, who.user_id, who.device_id)
        return settings

    def _center(self) -> Peer | None:
        wanted = self.config.sync.center_id
        centers = [
            p
            for p in peers.list_peers(self.db)
            if p.identity.role is SiteRole.center
            and p.revoked_at is None
            and (not wanted or p.identity.site_id == wanted)
        ]
        return centers[0] if centers else None
