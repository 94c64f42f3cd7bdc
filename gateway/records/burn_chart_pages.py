"""The burn chart page: the Lund-Browder body diagram, front and back, whose regions are clicked or tapped to set
the share burned at each depth. Each save stores the next version of the burn chart through the record service,
which recomputes %TBSA, the fluid plan and the referral advice; with htmx the chart and the figures are swapped in
place, without it the page reloads."""

from __future__ import annotations

import datetime as dt
from typing import Annotated

import msgspec
from litestar import Controller, get, post
from litestar.params import QueryParameter
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, form_fields
from base.web.pages.rendering import clinic_clock, page, svg
from base.web.paths import IdPath
from base.web.site import AuthedRequest
from gateway.dependencies import Services, ServicesDep
from gateway.pages.common import may_write, parse_or_errors, posted_version, save_part, saved_first, service_errors
from gateway.pages.encounter_view import encounter_header
from processing.views.body_chart_svg import REGION_LABELS, body_chart_svg, chart_entries, region_label
from schemas.burn_chart import BurnChart, BurnChartEntry, BurnDepth, LundBrowderRegion, RegionCharting
from schemas.clinical_results import Assessment
from schemas.errors import InvalidInput, NotFound, VersionMismatch
from schemas.records import RecordKind

RegionQuery = Annotated[str, QueryParameter(max_length=60, description="The region being edited")]
_DEPTH_FIELDS = {
    BurnDepth.superficial_partial: "superficial_partial_percent",
    BurnDepth.deep_partial: "deep_partial_percent",
    BurnDepth.full_thickness: "full_thickness_percent",
    BurnDepth.superficial: "superficial_percent",
}


def _region(text: str) -> LundBrowderRegion | None:
    if not text:
        return None
    try:
        return LundBrowderRegion(text)
    except ValueError:
        raise NotFound(f"the burn chart has no region {text!r}") from None


def _chart(services: Services, who, encounter_id: str) -> tuple[BurnChart | None, int]:
    try:
        record = services.records.get(who, RecordKind.burn_chart, encounter_id)
    except NotFound:
        return None, 0
    return msgspec.convert(record.data, BurnChart), record.meta.version


def _assessment(services: Services, who, encounter_id: str) -> Assessment | None:
    try:
        record = services.records.get(who, RecordKind.assessment, encounter_id)
    except NotFound:
        return None
    return msgspec.convert(record.data, Assessment)


def region_charting(chart: BurnChart | None, region: LundBrowderRegion) -> RegionCharting:
    values: dict = {}
    for entry in chart.entries if chart else []:
        if entry.region == region:
            values[_DEPTH_FIELDS[entry.depth]] = round(entry.fraction * 100, 1)
            values["circumferential"] = values.get("circumferential", False) or entry.circumferential
    return RegionCharting(**values)


def with_region(
    chart: BurnChart | None, encounter_id: str, region: LundBrowderRegion, form: RegionCharting
) -> BurnChart:
    """The chart with this region's entries replaced by the form's (a depth at 0 % is no entry)."""
    kept = [e for e in (chart.entries if chart else []) if e.region != region]
    for depth, name in _DEPTH_FIELDS.items():
        percent = getattr(form, name)
        if percent > 0:
            kept.append(
                BurnChartEntry(region=region, fraction=percent / 100, depth=depth, circumferential=form.circumferential)
            )
    now = dt.datetime.now(dt.UTC)
    if chart is None:
        return BurnChart(encounter_id=encounter_id, assessed_at=now, entries=kept)
    return msgspec.structs.replace(chart, entries=kept, assessed_at=now)


class BurnChartPages(Controller):
    path = "/encounters/{encounter_id:str}/burn-chart"
    include_in_schema = False

    @get("/", sync_to_thread=False)
    def chart(
        self, encounter_id: IdPath, request: AuthedRequest, services: ServicesDep, region: RegionQuery = ""
    ) -> Template:
        selected = _region(region)
        chart, version = _chart(services, request.user, encounter_id)
        fields = (
            form_fields(RegionCharting, value=region_charting(chart, selected), id_prefix="region") if selected else []
        )
        return self._page(request, services, encounter_id, chart, version, selected, fields, {}, None, 200)

    @post("/regions/{region_name:str}", sync_to_thread=True, status_code=303)
    def set_region(
        self, encounter_id: IdPath, region_name: str, request: AuthedRequest, data: FormBody, services: ServicesDep
    ) -> Template | Redirect:
        selected = _region(region_name)
        version = posted_version(data)
        form, errors = parse_or_errors(RegionCharting, data, {})
        chart, stored_version = _chart(services, request.user, encounter_id)
        conflict = None
        if not errors:
            try:
                record = save_part(
                    services,
                    request.user,
                    RecordKind.burn_chart,
                    encounter_id,
                    with_region(chart, encounter_id, selected, form),
                    version,
                )
                if request.headers.get("HX-Request"):
                    chart, stored_version = msgspec.convert(record.data, BurnChart), record.meta.version
                    fields = form_fields(RegionCharting, value=region_charting(chart, selected), id_prefix="region")
                    return self._page(
                        request,
                        services,
                        encounter_id,
                        chart,
                        stored_version,
                        selected,
                        fields,
                        {},
                        None,
                        200,
                        saved=True,
                    )
                return Redirect(
                    path=f"/encounters/{encounter_id}/burn-chart",
                    query_params={"region": selected.value, "saved": "1"},
                    status_code=303,
                )
            except VersionMismatch as exc:
                conflict = saved_first(exc, clinic_clock(request))
            except InvalidInput as exc:
                errors = service_errors(exc)
        fields = form_fields(RegionCharting, raw=data, errors=errors, id_prefix="region")
        status = 409 if conflict else 422
        return self._page(
            request, services, encounter_id, chart, stored_version, selected, fields, errors, conflict, status
        )

    def _page(
        self, request, services, encounter_id, chart, version, selected, fields, errors, conflict, status, saved=False
    ):
        encounter, patient = encounter_header(services, request.user, encounter_id)
        charted = chart_entries(chart.entries) if chart else {}
        base = f"/encounters/{encounter_id}/burn-chart"
        diagram = body_chart_svg(
            charted, href=lambda r: f"{base}?region={r.value}", selected=selected, title="Burn chart: choose a region"
        )
        rows = sorted(charted.items(), key=lambda item: list(LundBrowderRegion).index(item[0]))
        return page(
            request,
            "burn_chart_fragment.html" if request.headers.get("HX-Request") else "burn_chart.html",
            status,
            encounter=encounter,
            patient=patient,
            tab="burn-chart",
            diagram=svg(diagram),
            selected=selected,
            selected_label=REGION_LABELS[selected] if selected else "",
            fields=fields,
            errors=errors,
            conflict=conflict,
            version=version,
            charted=[(r, region_label(r, rows_)) for r, rows_ in rows],
            assessment=_assessment(services, request.user, encounter_id),
            saved=saved or request.query_params.get("saved") == "1",
            may_chart=may_write(request.user, RecordKind.burn_chart),
        )
