"""The page-fit check (harness/page_fit.py) finds what it is for, on pages laid out by a real Chromium: a page
wider than the screen, a word broken inside a narrow cell, a word sticking out of its cell; and passes the
stylesheet's own tables at phone width."""

from __future__ import annotations

import pytest

from harness.browser import PHONE, browser_missing
from harness.page_fit import fit_problems
from harness.processes import REPO

pytestmark = pytest.mark.skipif(bool(browser_missing()), reason=browser_missing() or "browser present")

CSS = (REPO / "base" / "web" / "static" / "css" / "app.css").read_text()


@pytest.fixture
def page(browser):
    context = browser.new_context(viewport={"width": PHONE[0], "height": PHONE[1]})
    yield context.new_page()
    context.close()


def test_a_page_wider_than_the_screen_is_found(page):
    page.set_content('<div style="width: 900px">wide</div>')
    assert fit_problems(page) == [f"the page is {900 + 8 - PHONE[0]} px wider than the screen"]  # body margin 8 px


def test_a_word_broken_inside_a_cell_is_found(page):
    page.set_content('<table style="width: 40px"><tr><td style="overflow-wrap: anywhere">Sexuality</td></tr></table>')
    assert fit_problems(page) == ['"Sexuality" is broken inside (td)']


def test_a_word_sticking_out_of_its_cell_is_found(page):
    page.set_content('<table style="table-layout: fixed; width: 40px"><tr><td>Sexuality</td></tr></table>')
    assert '"Sexuality" sticks out of its box (td)' in fit_problems(page)


def test_the_stylesheets_tables_fit_a_phone_as_cards(page):
    heads = ["Name", "Record number", "Born / age", "Sex", "Updated"]
    cells = ["Amina Diallo", "MRN-1042", "1984-09-02", "female", "2026-12-06 16:08 UTC"]
    row = "".join(f'<td data-label="{h}">{c}</td>' for h, c in zip(heads, cells, strict=True))
    head = "".join(f"<th>{h}</th>" for h in heads)
    page.set_content(
        f"<style>{CSS}</style><main><section class='panel'><div class='table-wrap'><table class='stack'>"
        f"<thead><tr>{head}</tr></thead><tbody><tr>{row}</tr></tbody></table></div></section></main>"
    )
    assert fit_problems(page) == []
    page.add_style_tag(
        content="table.stack td { overflow-wrap: anywhere; } table.stack tr { grid-template-columns: repeat(5, 1fr); }"
    )
    assert fit_problems(page) != []  # the same table squeezed into five columns breaks words
