"""Wounds: the gateway's first domain package, its controller, service and rules together.

A patient often has several burns; a wound is the unit that is photographed, measured and tracked. Its records are
versioned, audited records of the kind `wound` (parent: the patient), stored by the record service with the checks
in `rules` (handed in by gateway.dependencies, so phones' pushes pass them too). Storage of its own, when a wound
needs a table, goes into `gateway/wounds/storage/`.
"""

from __future__ import annotations

from gateway.wounds.rules import check_wound
from schemas.records import RecordKind

CHECKS = {RecordKind.wound: check_wound}
"""The record service's checks for the kinds this package keeps."""
