"""Page rendering shared by the gateway's and the center's faces: one Jinja2 environment (autoescaping, undefined
names are errors), the layout's context, and HTML error pages for the one error map (base/web/errors.py)."""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jinja2 import Environment, FileSystemLoader, StrictUndefined, select_autoescape
from litestar import Request, Response
from litestar.plugins.jinja import JinjaTemplateEngine
from litestar.response import Redirect, Template
from litestar.template import TemplateConfig
from markupsafe import Markup

from base import __version__
from base.accounts.permissions import Principal
from base.web.pages.clinic_time import CLOCK_KEY, ClinicClock
from base.web.pages.fluid_card import fluid_card
from base.web.pages.forms_fields import errors_in
from base.web.pages.referral_card import TIER_WORDS, referral_card
from base.web.pages.session import request_csrf_token
from schemas.base import counted
from schemas.burn_chart import region_name
from schemas.patient import display_name

BASE_TEMPLATES = Path(__file__).resolve().parents[1] / "templates"
SITE_NAME_KEY = "site_name"
"""app.state key: "Clinic gateway" or "Burn center", shown in every page's header."""
NAV_KEY = "nav"
"""app.state key: the header's links, a list of NavItem."""
NOTICE_KEY = "header_notice"
"""app.state key: a function of the signed-in principal giving the header's notice (a HeaderNotice, or None),
shown beside the menu on every page, e.g. the count of advice not read yet."""


@dataclass(frozen=True)
class HeaderNotice:
    label: str
    count: int
    href: str


@dataclass(frozen=True)
class NavItem:
    label: str
    href: str
    roles: frozenset[str]
    """Role values that see the link (the page itself checks again)."""


def patient_name(data: dict) -> str:
    """How a patient is named on every page (schemas.patient.display_name)."""
    return display_name(data)


def clinic_clock(request: Request) -> ClinicClock:
    """The clock this server's pages read and show times in (app.state[CLOCK_KEY]; absent: this machine's zone)."""
    clock = request.app.state.get(CLOCK_KEY)
    return clock if isinstance(clock, ClinicClock) else ClinicClock()


def local_time(value: dt.datetime | None, with_date: bool = True, clock: ClinicClock | None = None) -> str:
    """A stored instant as the clinic reads it: the clinic's zone (None: the machine's), to the minute."""
    if value is None:
        return "—"
    local = (clock or ClinicClock()).local(value)
    return local.strftime("%Y-%m-%d %H:%M" if with_date else "%H:%M")


def when(value: str | dt.datetime | None, clock: ClinicClock | None = None) -> str:
    """A stored ISO time (text or datetime) in the clinic's zone, to the minute, with the zone named."""
    if not value:
        return "—"
    try:
        moment = value if isinstance(value, dt.datetime) else dt.datetime.fromisoformat(value)
    except ValueError:
        return str(value)
    if moment.tzinfo is None:
        return moment.strftime("%Y-%m-%d %H:%M")
    return (clock or ClinicClock()).local(moment).strftime("%Y-%m-%d %H:%M %Z").strip()


def short_id(record_id: str) -> str:
    """The last 8 hex digits of an id: its random part (ids made in the same millisecond share their first ones)."""
    return record_id.replace("-", "")[-8:]


def size(value: int) -> str:
    """Bytes as people read them: "840 kB", "11.6 MB"."""
    if value < 1_000_000:
        return f"{max(1, round(value / 1000))} kB"
    return f"{value / 1_000_000:.1f} MB"


def number(value: float | None, digits: int = 1, unit: str = "") -> str:
    if value is None:
        return "—"
    text = f"{value:.{digits}f}"
    return f"{text} {unit}".strip()


def environment(directories: Sequence[Path], clock: ClinicClock | None = None) -> Environment:
    """The pages' Jinja2 environment; `clock`: the zone every shown time is in (None: this machine's)."""
    env = Environment(
        loader=FileSystemLoader([*directories, BASE_TEMPLATES]),
        autoescape=select_autoescape(default=True, default_for_string=True),
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["local_time"] = lambda value, with_date=True: local_time(value, with_date, clock)
    env.filters["number"] = number
    env.filters["size"] = size
    env.filters["when"] = lambda value: when(value, clock)
    env.filters["patient_name"] = patient_name
    env.filters["region_name"] = region_name
    env.filters["short_id"] = short_id
    env.filters["counted"] = counted
    env.globals["version"] = __version__
    env.globals["errors_in"] = errors_in
    env.globals["fluid_card"] = fluid_card
    env.globals["referral_card"] = referral_card
    env.globals["tier_words"] = TIER_WORDS
    return env


def template_config(directories: Sequence[Path], clock: ClinicClock | None = None) -> TemplateConfig:
    return TemplateConfig(instance=JinjaTemplateEngine.from_environment(environment(directories, clock)))


def page(request: Request, template: str, status_code: int = 200, **context: Any) -> Template:
    """A full page or, for an htmx request that asks for one, the named fragment template."""
    user = request.scope.get("user")
    principal = user if isinstance(user, Principal) else None
    return Template(
        template_name=template,
        status_code=status_code,
        context={
            "principal": principal,
            "csrf_token": request_csrf_token(request),
            "site_name": request.app.state.get(SITE_NAME_KEY, "burnedge"),
            "path": request.url.path,
            "nav": request.app.state.get(NAV_KEY, []),
            "notice": _notice(request, principal),
            **context,
        },
    )


def _notice(request: Request, principal: Principal | None) -> HeaderNotice | None:
    notice = request.app.state.get(NOTICE_KEY)
    return notice(principal) if notice is not None and principal is not None else None


def svg(markup: str) -> Markup:
    """Mark SVG made by processing/views (which escapes every text it draws) as safe to embed."""
    return Markup(markup)


def error_page(request: Request, status: int, title: str, detail: str) -> Response:
    """The HTML face of a problem: a person reads what happened and what to do."""
    if status == 401:
        target = request.url.path
        if request.url.query:
            target += "?" + request.url.query
        return Redirect(path="/sign-in", query_params={"next": target}, status_code=303)
    return page(request, "error.html", status_code=status, status=status, title=title, detail=detail)
