"""The campaign's HTML report in a real headless browser: it renders, every image loads, nothing complains."""

from __future__ import annotations

from pathlib import Path

from ecds_lab.report.sections import anchors

IMAGES = """[...document.images].map(i => ({alt: i.alt, complete: i.complete, width: i.naturalWidth,
                                        height: i.naturalHeight, shown: i.getBoundingClientRect().width}))"""
PAGE = """({title: document.title, sections: document.querySelectorAll('main > section').length,
           headings: [...document.querySelectorAll('h2')].map(h => h.textContent),
           omitted: [...document.querySelectorAll('.omitted')].map(p => p.textContent),
           scripts: document.scripts.length, height: document.documentElement.scrollHeight,
           overflow: document.documentElement.scrollWidth > window.innerWidth + 1})"""


def test_report_renders_in_chromium_with_every_image_and_no_errors(campaign_report, chromium, tmp_path: Path):
    page = chromium.open(campaign_report.path.resolve().as_uri(), width=1280, height=900)
    shot = chromium.screenshot(tmp_path / "report.png")
    print(f"\nscreenshot of the report: {shot}")

    assert page.errors() == []
    assert page.console == []
    foreign = [u for u in page.requests if not u.startswith(("file:", "data:", "about:"))]
    assert foreign == [], "the report must be self-contained"

    info = chromium.evaluate(PAGE)
    assert info["title"].startswith("ECDS lab report")
    assert info["sections"] == len(anchors()) and info["scripts"] == 0
    assert info["headings"][:2] == ["Runs and files", "Inductance against distance and the model fit"]
    assert not info["overflow"], "the page is wider than a 1280 px window"

    images = chromium.evaluate(IMAGES)
    assert len(images) >= 9
    broken = [i["alt"] for i in images if not (i["complete"] and i["width"] > 0 and i["height"] > 0)]
    assert broken == []
    assert all(0 < i["shown"] <= 1280 for i in images)
    assert shot.stat().st_size > 50_000 and shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_browser_harness_sees_console_errors_and_broken_images(chromium, tmp_path: Path):
    """The checks above can fail: a page with a console error and a broken image is caught."""
    page_file = tmp_path / "broken.html"
    page_file.write_text('<!DOCTYPE html><html><head><meta charset="utf-8"><link rel="icon" href="data:,">'
                         "<title>t</title></head><body><img src=\"missing.png\" alt=\"gone\">"
                         "<script>console.error('boom')</script></body></html>")
    page = chromium.open(page_file.as_uri())
    images = chromium.evaluate(IMAGES)
    assert any("boom" in e for e in page.errors())
    assert images[0]["width"] == 0
