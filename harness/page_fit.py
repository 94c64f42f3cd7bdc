"""Does a page fit the screen it is shown on? Checked in the browser on the page as laid out: the page must not
scroll sideways, and no word in a table cell (or a fact, a paragraph, a heading, a label) may be broken across
lines or stick out of its box, at phone, tablet and desktop widths alike. Long tokens (ids, fingerprints,
addresses) may wrap."""

from __future__ import annotations

LONGEST_WORD = 24
"""Tokens longer than this (hashes, identifiers, URLs) are allowed to wrap; every real word is shorter."""

BOXES = "td, th, dt, dd, li, p, h1, h2, h3, label, legend, summary"
"""Where text is checked: table cells, the facts' terms and values, list items, paragraphs, headings, labels."""

FIT_SCRIPT = """([longest, boxes]) => {
  const problems = [];
  const where = (box) => box.tagName.toLowerCase() + (box.id ? "#" + box.id : "") + (box.className ? "." + box.className : "");
  const over = document.documentElement.scrollWidth - window.innerWidth;
  if (over > 0) problems.push(`the page is ${over} px wider than the screen`);
  for (const cell of document.querySelectorAll(boxes)) {
    if (!cell.getClientRects().length) continue;  // not shown (a closed details)
    const head = cell.closest("thead");
    if (head && getComputedStyle(head).position === "absolute") continue;  // the cards' heads, for screen readers
    const box = cell.getBoundingClientRect();
    const walker = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    for (let node = walker.nextNode(); node; node = walker.nextNode()) {
      // A word with letters may break after its hyphen ("full-/thickness"); a date or a number never does.
      for (const m of node.data.matchAll(/[^\\s-]*[A-Za-z][^\\s-]*-?|[^\\s]+/g)) {
        if (m[0].length > longest) continue;
        const range = document.createRange();
        range.setStart(node, m.index);
        range.setEnd(node, m.index + m[0].length);
        const rects = [...range.getClientRects()].filter((r) => r.width > 0);
        if (!rects.length) continue;
        if (new Set(rects.map((r) => Math.round(r.top))).size > 1) problems.push(`"${m[0]}" is broken inside (${where(cell)})`);
        if (Math.max(...rects.map((r) => r.right)) > box.right + 1) problems.push(`"${m[0]}" sticks out of its box (${where(cell)})`);
      }
    }
  }
  return [...new Set(problems)];
}"""


def fit_problems(page) -> list[str]:
    """What does not fit the page's screen: sideways scrolling, words broken inside or sticking out of cells."""
    return page.evaluate(FIT_SCRIPT, [LONGEST_WORD, BOXES])
