"""make book: the course website, built from the student edition and read in a real browser.

The site is built once (tools/course_book.py: MkDocs + mkdocs-jupyter, offline), served by
Python's http.server and opened in Debian's headless Chromium (the setup of the notebooks'
browser test): three pages are opened, the navigation is followed (the index to chapter 01,
then "next" to 02, and the site's own footer to 03), a drawn figure is checked to have loaded
and a formula to have been typeset by the local MathJax. Without the browser the test is skipped
— unless LABKIT_REQUIRE_BROWSER=1, when it fails instead.
"""

from __future__ import annotations

import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

from tests.browser.test_notebooks_in_browser import _free_port, _need_browser, chromium

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))
import course_book  # noqa: E402
from course_navigation import load_chapters  # noqa: E402


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    return course_book.build(tmp_path_factory.mktemp("book"))


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.hrefs = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "a" and a.get("href"):
            self.hrefs.append(a["href"])


def test_every_chapter_has_a_page_and_every_local_link_a_target(site):
    for ch in load_chapters():
        assert (site / ch["file"].replace(".ipynb", ".html")).is_file(), ch["file"]
    broken = []
    for page in sorted(site.glob("*.html")):
        parser = _Links()
        parser.feed(page.read_text(encoding="utf-8"))
        for href in parser.hrefs:
            if re.match(r"[a-z]+:|#|/", href):
                continue
            if not (page.parent / href.split("#")[0].split("?")[0]).exists():
                broken.append(f"{page.name}: {href}")
    assert not broken, "links to nothing:\n" + "\n".join(broken)


def test_the_site_is_the_student_edition(site):
    # a hand-picked answer of chapter 23 and the appendices' heading are not published
    text = (site / "23-laser-safety-and-materials.html").read_text(encoding="utf-8")
    assert "OD 4 is NOT enough" not in text and "Appendix — for researchers" not in text
    assert "your answer here" in text


@pytest.fixture(scope="module")
def served(site):
    port = _free_port()
    server = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1",
                               "--directory", str(site)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    import time
    import urllib.request

    for _ in range(100):
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/index.html", timeout=1)
            break
        except OSError:
            time.sleep(0.1)
    yield f"http://127.0.0.1:{port}"
    server.terminate()
    server.wait(10)


@pytest.fixture(scope="module")
def browser(served, tmp_path_factory):
    _need_browser()
    driver = chromium(tmp_path_factory.mktemp("chromium-book"))
    yield driver
    driver.quit()


def _click_link(driver, href_end: str, within: str = "article"):
    from selenium.webdriver.common.by import By

    links = [a for a in driver.find_elements(By.CSS_SELECTOR, f"{within} a")
             if (a.get_attribute("href") or "").endswith(href_end)]
    assert links, f"no link to {href_end} on {driver.current_url}"
    driver.execute_script("arguments[0].scrollIntoView(); arguments[0].click();", links[0])


def test_three_pages_navigation_a_figure_and_a_formula(browser, served):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    wait = WebDriverWait(browser, 60)
    # 1: the home page, its chapter list links to chapter 01's page
    browser.get(f"{served}/index.html")
    assert "labkit" in browser.title
    _click_link(browser, "/01-gcode-basics.html")
    wait.until(lambda d: d.current_url.endswith("/01-gcode-basics.html"))
    assert "01 · G-code basics" in browser.find_element(By.TAG_NAME, "h1").text
    # a figure the chapter drew (a PNG output) has loaded with a size
    images = browser.find_elements(By.CSS_SELECTOR, "article img")
    assert images and wait.until(lambda d: all(
        d.execute_script("return arguments[0].complete && arguments[0].naturalWidth > 0", im) for im in images))
    # 2: the chapter's own "next" link, generated from chapters.toml
    _click_link(browser, "/02-arcs-ijk-vs-r.html")
    wait.until(lambda d: d.current_url.endswith("/02-arcs-ijk-vs-r.html"))
    # 3: the site's footer navigation to the following page
    _click_link(browser, "/03-bezier-de-casteljau.html", within="footer")
    wait.until(lambda d: d.current_url.endswith("/03-bezier-de-casteljau.html"))
    # a formula typeset by the local MathJax (chapter 16 writes the dose model in TeX)
    browser.get(f"{served}/16-cut-width-characterisation.html")
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "span.MathJax"))     # HTML-CSS output
    typeset = browser.find_elements(By.CSS_SELECTOR, "span.MathJax")
    assert any(el.size["width"] > 0 for el in typeset)
