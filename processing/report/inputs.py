"""What is the report's own about its inputs: its layout version, and the digest of the record versions it is made
from (the snapshot itself is schemas/encounter_snapshot.py)."""

from __future__ import annotations

import hashlib
import json

from schemas.clinical_results import InputRef

REPORT_FORMAT = "burnedge-report-2"
"""Changes when the report's layout changes, so a cached report of the old layout is made again."""


def versions_digest(refs: list[InputRef]) -> str:
    """SHA-256 over the record versions a report is made from (the footer's figure)."""
    rows = sorted((r.kind, r.id, r.version) for r in refs)
    return hashlib.sha256(json.dumps([REPORT_FORMAT, rows]).encode()).hexdigest()
