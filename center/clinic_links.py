"""The burn center's side of linking a clinic, for the center's administrator: the center's own public keys and
address to hand over, a clinic's keys enrolled after the fingerprints were compared by phone, and a clinic
unlinked. The Zenoh endpoint checks the enrolled sites on every message: no restart."""

from __future__ import annotations

import re
from dataclasses import dataclass

from base.accounts.permissions import Principal, require_admin
from base.network import lan_address
from base.storage.postgres import AnyDatabase
from schemas.config import CentralConfig
from schemas.errors import Conflict, InvalidInput
from schemas.transfer import Peer, SiteIdentity, SiteRole
from sync import peers
from sync.keys import SiteKeys, fingerprint
from sync.link_card import confirmed_card, read_card

ACTION = "link_sites"
ANY_HOST = re.compile(r"/(0\.0\.0\.0|\[::\]|::):")


@dataclass(frozen=True)
class ClinicsView:
    identity: SiteIdentity
    fingerprint: str
    endpoints: list[str]
    """Where clinics reach this center, as they should type it (a listen-on-all address made concrete)."""
    clinics: list[Peer]


def endpoints_for_clinics(listen: list[str]) -> list[str]:
    """The listen endpoints with "any address" replaced by this machine's address on its network, when known."""
    here = lan_address()
    return [ANY_HOST.sub(f"/{here}:", e) if here else e for e in listen]


class ClinicLinks:
    def __init__(self, db: AnyDatabase, keys: SiteKeys, central: CentralConfig):
        self.db = db
        self.keys = keys
        self.central = central

    def view(self, who: Principal) -> ClinicsView:
        require_admin(who, ACTION)
        identity = self.keys.identity
        clinics = [p for p in peers.list_peers(self.db) if p.identity.role is SiteRole.clinic]
        clinics.sort(key=lambda p: (p.revoked_at is not None, p.identity.name.casefold()))
        return ClinicsView(
            identity=identity,
            fingerprint=fingerprint(identity),
            endpoints=endpoints_for_clinics(self.central.listen_endpoints),
            clinics=clinics,
        )

    def read_clinic(self, who: Principal, upload: bytes) -> SiteIdentity:
        """A clinic's public keys from its keys file or a photo of its QR code (nothing is stored)."""
        require_admin(who, ACTION)
        return read_card(upload, SiteRole.clinic)

    def enrol_clinic(self, who: Principal, card: str, compared: bool) -> Peer:
        require_admin(who, ACTION)
        identity = confirmed_card(card, SiteRole.clinic, compared)
        known = next((p for p in peers.list_peers(self.db) if p.identity.site_id == identity.site_id), None)
        if known is not None and known.revoked_at is None and known.identity != identity:
            raise Conflict(
                f"the site id {identity.site_id} is already enrolled, for {known.identity.name}, with other keys. "
                "If that clinic made new keys, unlink it first, then enrol these; otherwise the new clinic must "
                "choose another site id."
            )
        return peers.enrol(self.db, identity, by=who.username, replace=True)

    def unlink_clinic(self, who: Principal, site_id: str, reason: str) -> Peer:
        require_admin(who, ACTION)
        if not reason.strip():
            raise InvalidInput("say why the clinic is unlinked")
        return peers.revoke(self.db, site_id, reason=reason.strip(), by=who.username)
