"""The built documentation site (issue 27), checked after `make docs` by `make docs-check`
(.ci/run, after the suite): every public name has its anchor in the API reference, every
page of the navigation and every arm's equations were built, and — where Chromium is
installed (`apt-get install chromium`, /usr/bin/chromium, driven by playwright) — a real
headless browser renders the mathematics with MathJax (no TeX errors) and loads every
figure, and leaves screenshots in site-check/ to look at.  It checks the build in
`$SYMDYN_SITE` (make docs-check sets site/) and is skipped without it, so the suite never
checks a stale site."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

from tests.test_docs import ROOT, expected_entries, nav_pages

SITE = Path(os.environ.get("SYMDYN_SITE", ROOT / "site")).resolve()
SHOTS = ROOT / "site-check"
CHROMIUM = os.environ.get("SYMDYN_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")

pytestmark = pytest.mark.skipif(
    not (os.environ.get("SYMDYN_SITE") and (SITE / "index.html").is_file()),
    reason="checks a built site: make docs-check (SYMDYN_SITE=site)",
)


def html(page: str) -> str:
    return (SITE / page).read_text()


def built_arms() -> list[str]:
    return sorted(p.stem for p in (SITE / "equations").glob("*.html") if p.stem != "index")


def test_every_page_of_the_navigation_was_built():
    missing = [
        p
        for p in nav_pages()
        if not (SITE / re.sub(r"(README|index)?\.md$", lambda m: "index.html" if m.group(1) else ".html", p)).is_file()
    ]
    assert missing == []


def test_every_public_name_has_an_anchor_in_the_reference():
    ids = set()
    for page in (SITE / "reference").glob("*.html"):
        ids |= set(re.findall(r'id="([\w.]+)"', page.read_text()))
    # A hand-written entry (`## \`symdyn.__version__\``) gets the heading's slug instead.
    slug = {name: re.sub(r"[^\w]", "", name) for name in expected_entries()}
    assert sorted(n for n in expected_entries() if n not in ids and slug[n] not in ids) == []


def test_the_equations_were_printed_by_the_build():
    arms = built_arms()
    assert "twolink" in arms
    for arm in arms:
        text = html(f"equations/{arm}.html")
        assert "Printed while this site was built" in text, arm
        assert text.count('class="arithmatex"') > 0, arm
    assert "tex-chtml.js" in html("equations/twolink.html")


@pytest.fixture(scope="module")
def server():
    """The site served over HTTP on a free local port, as a reader would get it (search's
    worker and some scripts refuse file:// URLs)."""
    import functools
    import http.server
    import threading

    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(SITE))
    handler.log_message = lambda *args: None
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    httpd.shutdown()


@pytest.fixture(scope="module")
def browser(server):
    if CHROMIUM is None:
        pytest.skip("no Chromium (apt-get install chromium): the browser checks did not run")
    playwright = pytest.importorskip("playwright.sync_api", reason="playwright (the browser extra) drives Chromium")
    SHOTS.mkdir(exist_ok=True)
    with playwright.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield chromium, server
        chromium.close()


def open_page(browser, page: str, width: int = 1400):
    """A tab on `page`, loaded, and the list its script errors and failed requests go to."""
    chromium, server = browser
    tab = chromium.new_page(viewport={"width": width, "height": 1800})
    errors: list[str] = []
    tab.on("pageerror", lambda e: errors.append(str(e)))
    tab.on("requestfailed", lambda r: errors.append(f"{r.url}: {r.failure}"))
    tab.on("response", lambda r: r.status >= 400 and errors.append(f"{r.url}: HTTP {r.status}"))
    tab.goto(server + page, wait_until="load")
    return tab, errors


@pytest.mark.parametrize("arm", ["twolink", "puma560"])
def test_the_browser_renders_the_equations(browser, arm):
    if arm not in built_arms():
        pytest.skip(f"{arm}'s page was not built (SYMDYN_DOCS_ARMS)")
    tab, errors = open_page(browser, f"equations/{arm}.html")
    tab.wait_for_function("() => window.MathJax && MathJax.startup && MathJax.startup.promise", timeout=60_000)
    tab.evaluate("() => MathJax.startup.promise")  # typesetting done
    found = tab.evaluate("""() => ({math: document.querySelectorAll('.arithmatex').length,
        rendered: document.querySelectorAll('.arithmatex mjx-container').length,
        errors: document.querySelectorAll('mjx-merror').length,
        height: Math.max(...[...document.querySelectorAll('mjx-container')].map(e => e.getBoundingClientRect().height))})""")
    tab.screenshot(path=str(SHOTS / f"equations-{arm}.png"))
    tab.close()
    assert errors == []
    assert found["math"] > 0 and found["rendered"] == found["math"], found
    assert found["errors"] == 0 and found["height"] > 10, found


def test_the_browser_loads_every_figure(browser):
    """Every page showing a figure (the gallery, the studies, batched evaluation…): each image loads."""
    pages = sorted(p.relative_to(SITE).as_posix() for p in SITE.rglob("*.html") if 'src="figures/' in p.read_text())
    assert "gallery.html" in pages
    broken, count = [], 0
    for page in pages:
        tab, errors = open_page(browser, page)
        images = tab.evaluate(
            """() => [...document.images].filter(i => i.src.includes('/figures/'))
            .map(i => [i.src.split('/').pop(), i.complete ? i.naturalWidth : 0])"""
        )
        if page == "gallery.html":
            tab.screenshot(path=str(SHOTS / "gallery.png"))
        tab.close()
        count += len(images)
        broken += [f"{page}: {error}" for error in errors] + [f"{page}: {name}" for name, width in images if not width]
    assert count >= 30 and broken == []


def test_the_browser_shows_the_reference_and_the_home_page(browser):
    for page in ("index.html", "reference/symdyn.html"):
        tab, errors = open_page(browser, page)
        tab.screenshot(path=str(SHOTS / page.replace("/", "-").replace(".html", ".png")))
        text = tab.inner_text("article")
        tab.close()
        assert errors == [] and ("make test" in text if page == "index.html" else "symdyn.load" in text)
