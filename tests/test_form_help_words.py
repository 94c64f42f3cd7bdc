"""The labels, help and choices of every record form are written for the nurse or clinician who reads them: no
field name from the code ("tetanus_doses"), no code words ("None", "null", "JSON", "enum", "API"), units in words.

The forms are the ones the gateway's record pages render (new patient, new encounter, each encounter part, a burn
chart region), built from their Structs as the pages build them, so a help text added to a schema is checked too.
"""

from __future__ import annotations

import re

import pytest

from base.web.pages.clinic_time import ClinicClock
from base.web.pages.forms import form_fields
from base.web.pages.forms_fields import FormField
from gateway.pages.encounter_view import PART_PAGES
from gateway.records.encounter_pages import SKIP
from gateway.records.patient_pages import ENCOUNTER_SKIP, PATIENT_SKIP
from schemas.burn_chart import RegionCharting
from schemas.patient import Encounter, Patient
from schemas.records import RECORD_TYPES

# The fields the pages fill themselves; the older fields a part form no longer asks are checked too (their label is
# still shown, read-only, where a record holds them).
FORMS = {
    "new patient": (Patient, PATIENT_SKIP),
    "new encounter": (Encounter, ENCOUNTER_SKIP),
    **{f"part {slug}": (RECORD_TYPES[kind], SKIP) for slug, kind in PART_PAGES.items()},
    "burn chart region": (RegionCharting, frozenset()),
}
DEVELOPER_WORDS = {
    "a field name from the code": re.compile(r"\b[a-z][a-z0-9]*_[a-z0-9_]+\b"),
    "a Python or JSON word": re.compile(r"\b(None|null|True|False|JSON|enum|API|Struct|UUID)\b"),
    "an internal id": re.compile(r"\b(ids?|record id|encounter id|patient id)\b", re.IGNORECASE),
    "code quoting": re.compile(r"`"),
    "a unit in a letter": re.compile(r"\((s|min|V)\)"),
}


def _texts(fields: list[FormField]):
    """(input name, what, text) of every label, help and choice label a person reads, depth first."""
    for f in fields:
        yield f.name, "label", f.label
        if f.help:
            yield f.name, "help", f.help
        for _, choice in f.choices:
            yield f.name, "choice", choice
        yield from _texts(f.children)
        for row in f.rows[:1]:
            yield from _texts(row)


@pytest.mark.parametrize("form", FORMS, ids=str)
def test_form_text_has_no_developer_words(form):
    struct_type, skip = FORMS[form]
    clock = ClinicClock.from_setting("Africa/Nairobi", skew_s=300)
    fields = form_fields(struct_type, skip=skip, clock=clock, blank_rows=1)
    found = [
        f"{at} ({what}: {problem}): {text!r}"
        for at, what, text in _texts(fields)
        for problem, pattern in DEVELOPER_WORDS.items()
        if pattern.search(text)
    ]
    assert not found, "\n".join(found)


def test_labels_are_in_sentence_case():
    for form, (struct_type, skip) in FORMS.items():
        for at, what, text in _texts(form_fields(struct_type, skip=skip, blank_rows=1)):
            if what == "label":
                assert text[:1].isupper(), f"{form}: {at}: {text!r}"


def test_the_check_finds_developer_words():
    samples = {
        "When only the year is known; give this or last_tetanus_dose.": "a field name from the code",
        "Whether the account fits; None: not judged.": "a Python or JSON word",
        "Sent as JSON to the API.": "a Python or JSON word",
        "The encounter id.": "an internal id",
        "Duration (s)": "a unit in a letter",
    }
    for text, problem in samples.items():
        assert DEVELOPER_WORDS[problem].search(text), text
    assert not any(
        p.search("Doses of tetanus vaccine the patient has had; unknown if they cannot say.")
        for p in DEVELOPER_WORDS.values()
    )
