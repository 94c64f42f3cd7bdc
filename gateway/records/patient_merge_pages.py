"""Merging two records of the same person from the patient's page: find the other record, compare the two side by
side, confirm with a reason. The record whose page it is stays; the other is withdrawn, its encounters and wounds
moved (gateway/records/merge.py)."""

from __future__ import annotations

import msgspec
from litestar import Controller, get, post
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, posted_text
from base.web.pages.rendering import page, patient_name
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from gateway.pages.common import posted_version
from gateway.records.merge import merge_patients
from gateway.records.patient_pages import Search, matches
from schemas.errors import Conflict, InvalidInput
from schemas.records import Record, RecordKind


class Side(msgspec.Struct, frozen=True, kw_only=True):
    """One record as the comparison shows it."""

    record: Record
    name: str
    encounters: int
    wounds: int


def _side(services, who, record: Record) -> Side:
    encounters = services.records.list_records(who, RecordKind.encounter, parent_id=record.meta.id, limit=None)
    wounds = services.records.list_records(who, RecordKind.wound, parent_id=record.meta.id, limit=None)
    return Side(record=record, name=patient_name(record.data), encounters=len(encounters), wounds=len(wounds))


class PatientMergePages(Controller):
    path = "/patients/{patient_id:str}/merge"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def choose(self, patient_id: IdPath, request: AuthedRequest, services: ServicesDep, q: Search = "") -> Template:
        """The other records to choose from: every live patient but this one, or those matching the search."""
        keep = services.records.get(request.user, RecordKind.patient, patient_id)
        others = services.records.list_records(request.user, RecordKind.patient, limit=None)
        others = [p for p in others if p.meta.id != patient_id and (not q.strip() or matches(p, q))]
        others.sort(key=lambda r: patient_name(r.data).casefold())
        return page(
            request, "patient_merge.html", keep=keep, name=patient_name(keep.data), others=others, q=q, pair=None
        )

    @get("/{other_id:str}", sync_to_thread=False)
    def compare(self, patient_id: IdPath, other_id: IdPath, request: AuthedRequest, services: ServicesDep) -> Template:
        return self._compare(request, services, patient_id, other_id, {}, 200)

    @post("/{other_id:str}", sync_to_thread=True, status_code=303)
    def merge(
        self, patient_id: IdPath, other_id: IdPath, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        reason = posted_text(data, "reason").strip()
        try:
            if not reason:
                raise InvalidInput(
                    "Say why these are the same person (for example “same name, date of birth and MRN”)."
                )
            merge_patients(
                services.db, services.config, request.user, patient_id, other_id, reason, posted_version(data)
            )
            return Redirect(path=f"/patients/{patient_id}", status_code=303)
        except Conflict as exc:  # a withdrawn record, or the other one changed meanwhile
            return self._compare(request, services, patient_id, other_id, {"": exc.detail}, 409, reason)
        except InvalidInput as exc:
            return self._compare(request, services, patient_id, other_id, {"": exc.detail}, 422, reason)

    def _compare(self, request, services, patient_id: str, other_id: str, errors: dict, status: int, reason=""):
        who = request.user
        keep = services.records.get(who, RecordKind.patient, patient_id)
        other = services.records.get(who, RecordKind.patient, other_id)
        if other_id == patient_id and not errors:
            errors, status = {"": "This is the same record: choose the person's other record."}, 422
        return page(
            request,
            "patient_merge.html",
            status,
            keep=keep,
            name=patient_name(keep.data),
            pair=(_side(services, who, keep), _side(services, who, other)),
            errors=errors,
            reason=reason,
        )
