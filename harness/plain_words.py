"""Words for machines that must never reach a reader: criterion codes (aba2022.full_thickness) and Lund-Browder
region codes (lower_arm_left_anterior, or the same with spaces), found in a page's visible text or a PDF's text."""

from __future__ import annotations

import re

from schemas.burn_chart import LundBrowderRegion

_SINGLE_WORD = {r.value for r in LundBrowderRegion if "_" not in r.value}  # "genitalia" is also a clinical word
_REGIONS = sorted((r.value for r in LundBrowderRegion if r.value not in _SINGLE_WORD), key=len, reverse=True)
CODES = re.compile(
    r"\baba20\d\d\.[a-z_0-9]+|\b(?:"
    + "|".join(re.escape(c) + "|" + re.escape(c.replace("_", " ")) for c in _REGIONS)
    + r")\b",
    re.IGNORECASE,
)


def internal_codes(text: str) -> list[str]:
    """The codes in `text`, each once, in the order they first appear."""
    return list(dict.fromkeys(m.group(0) for m in CODES.finditer(text)))
