"""A patient's wounds: created and listed under the patient, and their healing.

Wounds are versioned records of their own kind (`wound`, parent the patient), so the record service stores them:
every write is one transaction with its audit entry, checked by gateway/wounds/rules.py; read, update, withdraw and
history go straight to it (gateway/records/record_routes.py). This service adds what a wound's addresses need: a
wound is created and listed under its patient, and its healing is read from its own analyses.
"""

from __future__ import annotations

from base.accounts.permissions import Principal, require_read, require_write
from gateway.jobs.healing import patient_healing, wound_healing
from gateway.records.service import RecordService, WriteOutcome
from gateway.records.validation import bad_field
from schemas.records import Record, RecordKind
from schemas.wound import Wound
from schemas.wound_healing import PatientHealing, WoundHealing

KIND = RecordKind.wound


class WoundService:
    def __init__(self, records: RecordService):
        self.records = records

    def create(self, principal: Principal, patient_id: str, wound: Wound) -> WriteOutcome:
        """Create a wound of the patient in the address (the client made its id; retrying is safe)."""
        require_write(principal, KIND)
        if wound.patient_id != patient_id:
            raise bad_field(
                "$.patient_id", f"patient_id {wound.patient_id} does not match the patient {patient_id} in the address"
            )
        return self.records.create(principal, KIND, wound.id, wound)

    def of_patient(self, principal: Principal, patient_id: str, *, include_deleted: bool = False) -> list[Record]:
        """The patient's wounds, oldest first; withdrawn ones only when asked for. 404 for an unknown patient."""
        self.records.get(principal, RecordKind.patient, patient_id)
        return self.records.list_records(
            principal, KIND, parent_id=patient_id, include_deleted=include_deleted, limit=None
        )

    def healing(self, principal: Principal, wound_id: str) -> WoundHealing:
        """The wound's track from its own analyses, and its measured share of the body beside the chart."""
        require_read(principal, RecordKind.burn_analysis)
        wound = self.records.get(principal, KIND, wound_id)
        with self.records.db.read() as conn:
            return wound_healing(conn, self.records.config, wound)

    def patient_healing(self, principal: Principal, patient_id: str) -> PatientHealing:
        """One section per wound of the patient (and one for analyses of no wound, if any)."""
        require_read(principal, RecordKind.burn_analysis)
        wounds = self.of_patient(principal, patient_id)
        with self.records.db.read() as conn:
            return patient_healing(conn, self.records.config, patient_id, wounds)
