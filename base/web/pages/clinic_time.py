"""The clinic's clock as the pages use it: the zone date-time fields are typed and shown in, named beside each
field with its UTC offset, and how far ahead of the clinic clock a typed time may be.

A `<input type=datetime-local>` sends wall time with no zone. The gateway reads it in the clinic's zone
(`[gateway] timezone`, empty: this machine's own) and stores the instant in UTC; a phone set to another zone is
told so next to the field (base/web/static/js/app.js compares its offset with the one written on the page).
"""

from __future__ import annotations

import datetime as dt
import zoneinfo
from dataclasses import dataclass
from pathlib import Path

CLOCK_KEY = "clinic_clock"
"""app.state key: the ClinicClock of the server's pages (absent: this machine's zone, no tolerance named)."""
_LOCALTIME = Path("/etc/localtime")


def offset_text(offset: dt.timedelta | None) -> str:
    """A UTC offset as people read it: "UTC+03:00", "UTC-05:30", "UTC+00:00"."""
    minutes = round((offset or dt.timedelta()).total_seconds() / 60)
    sign = "+" if minutes >= 0 else "-"
    hours, rest = divmod(abs(minutes), 60)
    return f"UTC{sign}{hours:02d}:{rest:02d}"


def machine_zone_name() -> str:
    """This machine's zone as an IANA name where the system says it ("Africa/Nairobi"), else its abbreviation."""
    try:
        target = str(_LOCALTIME.resolve())
    except OSError:
        target = ""
    if "zoneinfo/" in target:
        name = target.split("zoneinfo/", 1)[1]
        try:
            zoneinfo.ZoneInfo(name)
            return name
        except (zoneinfo.ZoneInfoNotFoundError, ValueError):
            pass
    return dt.datetime.now().astimezone().tzname() or "local time"


def zone_named(name: str) -> dt.tzinfo | None:
    """The zone of an IANA name; None for "" (this machine's zone). ValueError names an unknown one."""
    if not name:
        return None
    try:
        return zoneinfo.ZoneInfo(name)
    except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
        raise ValueError(f"{name!r} is not a time zone name (an IANA name such as 'Africa/Nairobi')") from exc


@dataclass(frozen=True)
class ClinicClock:
    """The zone date-time fields are read and shown in, and the tolerance for times ahead of the clinic clock."""

    tz: dt.tzinfo | None = None
    """None: this machine's zone, daylight saving included."""
    name: str = ""
    """What the pages call the zone ("Africa/Nairobi"); empty: worked out from tz or the machine."""
    skew_s: int | None = None
    """How many seconds ahead of the clinic clock a typed time is still accepted (None: not said)."""

    @classmethod
    def from_setting(cls, timezone: str, skew_s: int | None = None) -> ClinicClock:
        """The clock of `[gateway] timezone` ("" : this machine's zone) and `clock_skew_s`."""
        return cls(tz=zone_named(timezone), name=timezone, skew_s=skew_s)

    def zone_name(self) -> str:
        if self.name:
            return self.name
        key = getattr(self.tz, "key", None)
        if key:
            return key
        if self.tz is not None:
            return self.tz.tzname(None) or offset_text(self.tz.utcoffset(None))
        return machine_zone_name()

    def local(self, moment: dt.datetime) -> dt.datetime:
        """An instant as the clinic's wall clock shows it (aware, in the clinic's zone)."""
        return moment.astimezone(self.tz) if self.tz is not None else moment.astimezone()

    def now(self) -> dt.datetime:
        return self.local(dt.datetime.now(dt.UTC))

    def offset(self, at: dt.datetime | None = None) -> dt.timedelta:
        """The clinic's offset from UTC at `at` (None: now)."""
        return self.local(at or dt.datetime.now(dt.UTC)).utcoffset() or dt.timedelta()

    def offset_minutes(self, at: dt.datetime | None = None) -> int:
        """Minutes east of UTC, the sign opposite to JavaScript's Date.getTimezoneOffset()."""
        return round(self.offset(at).total_seconds() / 60)

    def label(self, at: dt.datetime | None = None) -> str:
        """ "Africa/Nairobi, UTC+03:00": what a date-time field's label names."""
        text = offset_text(self.offset(at))
        name = self.zone_name()
        return text if name == text else f"{name}, {text}"

    def now_input(self) -> str:
        """Now, as a datetime-local input shows it: the clinic's wall time to the minute (a form's default)."""
        return self.now().strftime("%Y-%m-%dT%H:%M")

    def tolerance_text(self) -> str:
        """ "Up to 5 minutes ahead of the clinic clock is accepted." ("" when the tolerance is not known)."""
        if self.skew_s is None:
            return ""
        if self.skew_s == 0:
            return "A time ahead of the clinic clock is refused."
        minutes, seconds = divmod(self.skew_s, 60)
        if seconds:
            amount = f"{self.skew_s} seconds"
        else:
            amount = f"{minutes} minute" + ("s" if minutes != 1 else "")
        return f"Up to {amount} ahead of the clinic clock is accepted."

    def help(self) -> str:
        """The help a date-time field gets: which clock to type, and the tolerance."""
        return " ".join(filter(None, [f"Clinic time ({self.zone_name()}).", self.tolerance_text()]))
