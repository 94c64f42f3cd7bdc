"""What the demo shows on the terminal: progress bars while the analyses run, then the summary table."""

from __future__ import annotations

import sys
from typing import TextIO

from schemas.base import counted

WIDTH = 28


class ProgressBar:
    """One line per analysis, redrawn in place on a terminal; a line per stage change otherwise (logs, CI)."""

    def __init__(self, stream: TextIO | None = None):
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.last: dict[str, str] = {}

    def line(self, text: str, final: bool = True) -> None:
        if self.tty:
            self.stream.write("\r\033[K" + text + ("\n" if final else ""))
        elif final:
            self.stream.write(text + "\n")
        self.stream.flush()

    def update(self, label: str, event: dict) -> None:
        fraction = float(event.get("fraction", 0.0))
        filled = int(round(WIDTH * fraction))
        state = event.get("state", "")
        text = f"{label} [{'#' * filled}{'.' * (WIDTH - filled)}] {100 * fraction:3.0f}%  {event.get('message', '')}"
        if state == "queued":
            # A retry says why the try before it ended ('try 1 ended by SIGSEGV in the mesh stage; retrying from mesh').
            waiting = event.get("message") if event.get("error") else "waiting in the queue"
            text = f"{label} [{'#' * filled}{'.' * (WIDTH - filled)}] {100 * fraction:3.0f}%  {waiting}"
        key = f"{state}/{event.get('stage', '')}"
        if self.tty:
            self.line(text, final=False)
        elif self.last.get(label) != key:
            self.line(text)
        self.last[label] = key

    def done(self, label: str, event: dict, history: list[str] = ()) -> None:
        state = event.get("state")
        if state == "done":
            self.line(f"{label} [{'#' * WIDTH}] 100%  finished ({event.get('result_status')})")
        else:
            self.line(f"{label} {state}: {event.get('error') or event.get('message', '')}")
        for line in history:  # tries that crashed before this one: never silent
            self.line(f"{label}   {line}")


def _fmt(value, spec: str = ".2f", unit: str = "") -> str:
    return "-" if value is None else f"{value:{spec}}{unit}"


def _provisional(result: dict) -> str:
    """'yes (3 h)': the pictures were taken under 72 h after the injury; '?' when that time is unknown."""
    hours = result.get("hours_since_injury")
    if result.get("provisional") is None:
        return "?"
    return f"yes ({hours:.0f} h)" if result["provisional"] else "no"


def summary_table(track: dict, jobs: list[dict], results: list[dict]) -> str:
    """Per visit: area, perimeter, relief, volume, confidence, change and alignment; then the trend."""
    rows = [
        (
            "visit",
            "area cm2",
            "perim. cm",
            "relief mm",
            "volume cm3",
            "confidence",
            "provisional",
            "area change",
            "align RMSE",
        )
    ]
    sessions = track.get("sessions", [])
    for i, result in enumerate(results):
        m = result.get("metrics", {})
        conf = result.get("confidence") or {}
        s = sessions[i] if i < len(sessions) else {}
        rows.append(
            (
                f"day {s['day']:.0f}" if isinstance(s.get("day"), (int, float)) else f"#{i + 1}",
                _fmt(m.get("area_cm2")),
                _fmt(m.get("perimeter_cm")),
                _fmt(m.get("relief_max_mm")),
                _fmt(m.get("volume_cm3"), ".3f"),
                f"{conf.get('level', '-')} {conf.get('score', 0):.2f}" if conf else result.get("status", "-"),
                _provisional(result),
                _fmt(s.get("area_change_percent"), "+.1f", " %"),
                _fmt(s.get("registration_rmse_mm"), ".2f", " mm"),
            )
        )
    widths = [max(len(str(r[c])) for r in rows) for c in range(len(rows[0]))]
    lines = [
        "  ".join(str(v).rjust(w) if c else str(v).ljust(w) for c, (v, w) in enumerate(zip(r, widths, strict=True)))
        for r in rows
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    rate = track.get("healing_rate_cm2_per_day")
    closure = track.get("projected_closure_day")
    spread = track.get("projected_closure_range_days")
    lines.append("")
    lines.append(
        f"Healing trend: {_fmt(rate, '.3f')} cm2/day (positive = shrinking), fitted over {len(sessions)} visits"
    )
    if closure is not None:
        extra = f" (95 % range day {spread[0]:.0f} to {spread[1]:.0f})" if spread else ""
        lines.append(f"Projected closure: day {closure:.0f}{extra} (days as in the table)")
    lines.append("Review prompts (decision support, for the clinician):")
    for flag in track.get("stall_flags", []):
        status = "REVIEW" if flag.get("triggered") else ("ok" if flag.get("evaluable") else "n/a")
        lines.append(f"  [{status}] {flag.get('rule')}: {flag.get('detail')}")
        if flag.get("triggered"):
            lines.append(f"           source: {flag.get('citation')}")
    for note in track.get("notes", []):
        lines.append(f"  note: {note}")
    return "\n".join(lines)


def wounds_lines(forearm: dict, shin: dict, shin_healing: dict) -> list[str]:
    """The two wounds side by side: each one's own latest area, its share of the body beside the chart's."""
    lines = ["Two wounds, each tracked on its own (the forearm's visits above; the shin photographed on day 0):"]
    for label, healing, fallback in (("right forearm", forearm, {}), ("left shin", shin_healing, shin)):
        share = healing.get("share") or {}
        sessions = (healing.get("track") or {}).get("sessions", [])
        area = sessions[-1].get("area_cm2") if sessions else (fallback.get("metrics") or {}).get("area_cm2")
        measured, charted = share.get("measured_percent"), share.get("charted_percent")
        lines.append(
            f"  {label:<14} {counted(len(sessions), 'measured visit')}, latest area {_fmt(area)} cm2;"
            f" %TBSA measured in 3D {_fmt(measured, '.3f')} beside the chart's {_fmt(charted, '.3f')}"
            + (f"  CHECK: {share['flag']}" if share.get("flag") else "")
        )
    lines.append("  (3D: area over the Mosteller BSA; chart: Lund-Browder for the wound's regions)")
    return lines
