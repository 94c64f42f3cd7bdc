"""Patient and encounter: who was burned, and the visit at which they were seen."""

from __future__ import annotations

import datetime as dt
import enum
from typing import Annotated

import msgspec

from schemas.base import AGE_MAX_YEARS, HeightCm, Id, Message, ShortText, Timestamp, WeightKg


class Sex(enum.StrEnum):
    female = "female"
    male = "male"
    other = "other"
    unknown = "unknown"


class WeightSource(enum.StrEnum):
    """Where a weight came from: resuscitation volumes are only as good as this."""

    measured = "measured"
    reported = "reported"
    estimated = "estimated"


class Patient(Message):
    """Demographics of one patient. Either date_of_birth or age_estimate_years is needed for %TBSA."""

    id: Id
    given_name: ShortText = ""
    family_name: ShortText = ""
    temporary_label: ShortText | None = None
    """For a patient whose name and record number are not known yet (unconscious, brought in alone): a label the
    team uses until they are, e.g. "Unknown man, bay 3". A patient needs a name, a record number or this."""
    date_of_birth: dt.date | None = None
    age_estimate_years: Annotated[float, msgspec.Meta(ge=0, le=AGE_MAX_YEARS)] | None = None
    """Used when the date of birth is unknown (common in field clinics)."""
    sex: Sex = Sex.unknown
    weight_kg: WeightKg | None = None
    weight_source: WeightSource | None = None
    height_cm: HeightCm | None = None
    medical_record_number: ShortText | None = None
    pregnant: bool | None = None
    merged_into: Id | None = None
    """Set only on a withdrawn duplicate: the patient (the same person's other record) its encounters and wounds
    were moved to when the two records were merged (gateway/records/merge.py)."""


class PatientMerge(Message):
    """Merge another record of the same person into this patient (POST /api/v1/patients/{id}/merge): its
    encounters and wounds move here, and it is withdrawn with the reason."""

    duplicate_id: Id
    """The other record of the same person: withdrawn by the merge, pointing at this one."""
    reason: Annotated[str, msgspec.Meta(min_length=1, max_length=200)]
    """Why the two records are the same person (e.g. "same MRN, registered twice")."""


class EncounterMode(enum.StrEnum):
    emergency = "emergency"
    consultation = "consultation"


class SharingConsent(enum.StrEnum):
    """Whether the record and its pictures may be sent to a burn center for advice (telemedicine consent: the
    consent process is recorded; a signature is not required)."""

    given = "given"
    """The patient agreed, told what is sent and to whom."""
    given_by_guardian = "given_by_guardian"
    """A parent, guardian or the person legally able to agree did."""
    not_possible = "not_possible"
    """Could not be asked (the patient cannot answer and no one can answer for them): sent on the clinician's
    judgement in the patient's interest."""
    refused = "refused"
    """The patient refused: the case is not sent."""


class Encounter(Message):
    """One visit. The resuscitation clock runs from time_of_injury, not time_of_arrival."""

    id: Id
    patient_id: Id
    mode: EncounterMode
    time_of_arrival: Timestamp
    time_of_injury: Timestamp | None = None
    clinician: ShortText = ""
    """Name of the responsible clinician as written on the chart."""
    facility: ShortText | None = None
    weight_kg: WeightKg | None = None
    """Weight at this visit: the calculations for this visit (fluid volumes, body surface area) use it instead of the
    weight on the patient's record."""
    sharing_consent: SharingConsent | None = None
    """Whether the patient agreed to this visit's record and pictures being sent to a burn center for advice (also
    asked when the case is sent)."""


def display_name(data: dict) -> str:
    """How people name a patient from the stored record: given and family name; else the unknown patient's
    temporary label; else the record number; "Unnamed patient" only for records stored before one was required."""
    name = " ".join(p for p in (data.get("given_name", ""), data.get("family_name", "")) if p)
    if name:
        return name
    if label := data.get("temporary_label"):
        return f"{label} (unknown patient)"
    if number := data.get("medical_record_number"):
        return f"Record {number}"
    return "Unnamed patient"
