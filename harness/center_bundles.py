"""Sealed, signed bundles made by hand, as a clinic's gateway would send them, for tests of the center."""

from __future__ import annotations

import json
import uuid

import msgspec

from schemas.transfer import PROTOCOL, BundleManifest, CaseSummary, SiteIdentity, TransferManifest, Urgency
from sync import bundle
from sync.keys import SiteKeys
from sync.sealing import seal

SUMMARY = CaseSummary(
    urgency=Urgency.routine,
    urgency_reasons=[],
    encounter_mode="emergency",
    age_years=30.0,
    tbsa_percent=2.0,
    analyses=0,
    area_cm2=None,
    analysis_confidence=None,
)


def make_bundle(keys: SiteKeys, center: SiteIdentity, encounter_id: str, version: int, chunk_size: int = 4096):
    bundle_id = str(uuid.uuid4())
    parts = [
        bundle.PartData("record.json", json.dumps({"encounter": encounter_id}).encode()),
        bundle.PartData("photos/a.jpg", bytes(range(256)) * 64),
    ]
    manifest = BundleManifest(
        bundle_id=bundle_id,
        site_id=keys.site_id,
        patient_id=str(uuid.uuid4()),
        encounter_id=encounter_id,
        version=version,
        supersedes=None,
        created_at="2026-11-22",
        created_by="clin",
        summary=SUMMARY,
        parts=[p.described for p in parts],
    )
    sealed = seal(bundle.pack(manifest, parts), bytes.fromhex(center.box_key), bundle_id, chunk_size)
    announcement = TransferManifest(
        protocol=PROTOCOL,
        bundle_id=bundle_id,
        site_id=keys.site_id,
        center_id=center.site_id,
        encounter_id=encounter_id,
        version=version,
        created_at="2026-11-22",
        sealed_key=sealed.sealed_key,
        plain_size=0,
        chunks=sealed.refs,
    )
    return bundle_id, msgspec.msgpack.encode(keys.sign("manifest", announcement)), sealed
