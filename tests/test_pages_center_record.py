"""The clinic's whole record on the burn center's case page, over the real center app after a real transfer
(tests/center_pair.py): allergies with reactions, current medications with doses, the tetanus history, the rest of
the history, ABCDE, secondary survey and mechanism, the burn chart drawn and tabled, and every decision-support
recommendation with its state, urgent first. A bundle from an older clinic version still shows, and says what that
version did not send."""

from __future__ import annotations

import html as html_text
import re

import msgspec
import pytest

from schemas.records import RecordKind
from sync import case_snapshot
from sync.bundle import PartData
from tests.center_pair import center_pair
from tests.center_record import NEWER_INTAKE_FIELDS, act, encounter, full_record

WOUND_PARTS = ("wounds.json", "healing.json")


def _as_an_older_clinic(real):
    """The snapshot an older clinic version would send: no decision support, an intake without the newer tetanus
    fields (the record.json of that version), no wounds or their healing."""

    def snapshot(conn, config, encounter, extra=()):
        snap = real(conn, config, encounter, extra)
        parts = {k: v for k, v in snap.record.parts.items() if k is not RecordKind.decision_support}
        intake = parts[RecordKind.intake]
        older = {k: v for k, v in intake.data.items() if k not in NEWER_INTAKE_FIELDS}
        parts[RecordKind.intake] = msgspec.structs.replace(intake, data=older)
        record = msgspec.structs.replace(snap.record, parts=parts)
        encoded = PartData("record.json", msgspec.json.encode(record))
        files = [encoded if p.name == "record.json" else p for p in snap.parts if p.name not in WOUND_PARTS]
        return case_snapshot.Snapshot(encounter=snap.encounter, record=record, parts=files)

    return snapshot


def _stored_before_urgent_first(real):
    """The snapshot of a clinic version whose rules did not sort urgent first: the stored order, urgent last."""

    def snapshot(conn, config, encounter, extra=()):
        snap = real(conn, config, encounter, extra)
        stored = snap.record.parts[RecordKind.decision_support]
        recs = sorted(stored.data["recommendations"], key=lambda r: r["urgent"])
        parts = {
            **snap.record.parts,
            RecordKind.decision_support: msgspec.structs.replace(stored, data={**stored.data, "recommendations": recs}),
        }
        record = msgspec.structs.replace(snap.record, parts=parts)
        encoded = PartData("record.json", msgspec.json.encode(record))
        files = [encoded if p.name == "record.json" else p for p in snap.parts]
        return case_snapshot.Snapshot(encounter=snap.encounter, record=record, parts=files)

    return snapshot


@pytest.fixture(scope="module")
def sent(tmp_path_factory):
    with center_pair(tmp_path_factory.mktemp("pair")) as pair:
        full = full_record(pair)
        support = pair.api.get(f"/api/v1/encounters/{full}/decision-support", "support")["data"]["recommendations"]
        routine = [r["key"] for r in support if not r["urgent"]]
        act(pair, full, routine[0], state="accepted")
        act(pair, full, routine[1], state="declined", reason="Dressing done at the district hospital")
        support = pair.api.get(f"/api/v1/encounters/{full}/decision-support", "support")["data"]["recommendations"]
        urls = {"full": pair.send(full), "none_known": pair.send(encounter(pair, {"no_known_allergies": True}))}
        older = encounter(pair, {"tetanus_status": "up_to_date", "no_known_allergies": True})
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(case_snapshot, "snapshot", _as_an_older_clinic(case_snapshot.snapshot))
            urls["older"] = pair.send(older)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(case_snapshot, "snapshot", _stored_before_urgent_first(case_snapshot.snapshot))
            urls["unsorted"] = pair.send(full)  # the next version of the same case
        with pair.consultant() as client:
            pages = {name: html_text.unescape(client.get(url).text) for name, url in urls.items()}
            yield pages, support


def _panel(page: str, panel_id: str) -> str:
    return page.split(f'id="{panel_id}"', 1)[1].split("</section>", 1)[0]


def test_allergies_medications_tetanus_and_the_history_are_on_the_case_page(sent):
    history = _panel(sent[0]["full"], "history")
    assert "Morphine — reaction: severe itching and vomiting" in history
    assert "Warfarin — dose: 3 mg at night" in history and "Omeprazole — dose: not recorded" in history
    assert "anticoagulant" not in history  # named as recorded
    assert "3 or more prior doses of tetanus-toxoid-containing vaccine" in history
    assert "Last dose on 2013-05-20" in history and "Severe immunodeficiency (HIV infection or other): no" in history
    assert "Paraffin stove flared while cooking indoors." in history and "Mechanical mitral valve, 2015." in history
    assert "mechanical heart valve" in history and "lives with husband and two children" in history
    assert "not sent by this clinic's version" not in sent[0]["full"]


def test_no_known_allergies_and_what_was_not_recorded(sent):
    history = _panel(sent[0]["none_known"], "history")
    assert re.search(r"<dt>Allergies</dt><dd>No known allergies</dd>", history)
    assert re.search(r"<dt>Current medications</dt><dd>not recorded</dd>", history)
    assert re.search(r"<dt>Tetanus history</dt><dd>not recorded</dd>", history)
    assert "No primary survey recorded." in sent[0]["none_known"] and "No burn chart recorded" in sent[0]["none_known"]


def test_abcde_secondary_survey_mechanism_and_the_chart_are_on_the_case_page(sent):
    page = sent[0]["full"]
    abcde = _panel(page, "primary-survey")
    assert "patent: yes" in abcde and "hoarse voice" in abcde and "soot in mouth or nose" in abcde
    assert "RR 26/min; SpO₂ 92 %; O₂ 15 L/min" in abcde and "HR 118/min; BP 104/68 mmHg" in abcde
    assert "GCS 15 (E4 V5 M6); AVPU alert" in abcde and "cooled: yes for 20 min" in abcde
    mechanism = _panel(page, "mechanism")
    assert "chest: soot over the upper chest" in mechanism and "other injury: sprained left wrist" in mechanism
    assert "Mechanism: flame; agent: paraffin stove; enclosed space; account fits the injury: yes" in mechanism
    assert "chest movement restricted: no" in abcde
    chart = _panel(page, "burn-chart")
    assert chart.count("<svg") == 1 and 'data-region="upper_arm_left_anterior"' in chart
    rows = re.findall(
        r"<tr><td[^>]*>([^<]+)</td><td[^>]*>([^<]+)</td><td[^>]*>([^<]+)</td><td[^>]*>([^<]+)</td></tr>", chart
    )
    assert ("Left upper arm, front", "deep partial thickness", "100%", "2.00 %") in rows
    assert ("Trunk, front", "superficial partial thickness", "50%", "6.50 %") in rows


@pytest.mark.parametrize("case", ["full", "unsorted"])
def test_every_recommendation_is_shown_with_its_state_urgent_first(sent, case):
    pages, support = sent
    panel = _panel(pages[case], "decision-support")
    shown = re.findall(r'data-key="([^"]+)" data-state="([^"]+)"', panel)
    assert sorted(shown) == sorted((r["key"], r["state"]) for r in support)
    urgent = {r["key"] for r in support if r["urgent"]}
    assert urgent and [k for k, _ in shown[: len(urgent)]] == [r["key"] for r in support if r["urgent"]]
    assert 'badge badge-urgent">urgent' in panel and panel.count('class="recommendation urgent"') == len(urgent)
    assert re.search(r"Accepted by clin at [^<]+</p>", panel)
    assert "Declined by clin at" in panel and "“Dressing done at the district hospital”" in panel
    assert "Not yet confirmed by a clinician at the clinic." in panel  # the urgent ones, still pending
    for r in support:
        assert r["text"] in panel


def test_a_bundle_from_an_older_clinic_version_shows_and_says_what_it_did_not_send(sent):
    page = sent[0]["older"]
    history = _panel(page, "history")
    assert "No known allergies" in history
    assert "Tetanus status (older summary form): up to date (last dose within 5 years)" in history
    assert re.search(r"Not sent by this clinic's version: intake: tetanus doses; intake: last tetanus dose", history)
    support = _panel(page, "decision-support")
    assert "No decision support in this case: not sent by this clinic's version." in support
    assert 'id="wounds"' not in page  # sent before wounds were kept: nothing said of them
    assert "No wounds recorded at the clinic." in _panel(sent[0]["full"], "wounds")
