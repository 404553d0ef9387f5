"""``report.html`` and ``curves.html`` in a real browser: headless Chromium (Debian's, driven
through its chromedriver by selenium) opens each page, which must log no console error and
show every image; the report leads with the verdict; the curve table sorts by a column heading
and filters by status.

References: a page with a missing image and a ``console.error`` (the checks must see both);
``criticism.json`` (the verdict the report must lead with); ``curves.csv`` (each curve's status
and stiffness, against which the browser's sorted and filtered rows are checked).

Needs ``/usr/bin/chromium`` and ``/usr/bin/chromedriver`` (``apt-get install -y chromium
chromium-driver``, which .ci/run does); skips without them, fails instead when
``TURGORBAYES_BROWSER=required`` (set by .ci/run).
"""

import contextlib
import csv
import io
import json
import math
import os
import shutil
from pathlib import Path

import pytest

from turgorbayes.cli import main

CHROMIUM, CHROMEDRIVER = Path("/usr/bin/chromium"), Path("/usr/bin/chromedriver")
#: A browser that talks to nothing but the pages it is given.
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage",  # a small /dev/shm (containers) must not crash a page
         "--window-size=1200,900"]
#: Tests of the report share the bundled example's fit with tests/docs (conftest.example_fit).
EXAMPLE_FIT = pytest.mark.xdist_group("example_fit")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
        reason = (f"no {CHROMIUM} or {CHROMEDRIVER}: apt-get install -y chromium chromium-driver "
                  "(.ci/run installs them)")
        if os.environ.get("TURGORBAYES_BROWSER") == "required":
            pytest.fail(reason)
        pytest.skip(reason)
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in [*FLAGS, f"--user-data-dir={tmp_path_factory.mktemp('chromium_profile')}"]:
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    driver.set_page_load_timeout(60)
    yield driver
    driver.quit()


def console_errors(driver):
    """The console's errors since the last call (uncaught exceptions, failed loads, console.error)."""
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def broken_images(driver):
    """The ``src`` of every image that did not load, each scrolled into view first (the page's
    thumbnails load lazily, as for a reader scrolling down)."""
    from selenium.webdriver.support.ui import WebDriverWait

    bad = []
    for img in driver.find_elements("tag name", "img"):
        driver.execute_script("arguments[0].scrollIntoView();", img)
        WebDriverWait(driver, 20).until(lambda d, i=img: d.execute_script("return arguments[0].complete;", i))
        if not driver.execute_script("return arguments[0].naturalWidth;", img) > 0:
            bad.append(img.get_attribute("src")[-80:])  # data: URIs are long
    return bad


def open_page(driver, path):
    """Open ``path``; return (console errors, broken images, number of images)."""
    driver.get(Path(path).resolve().as_uri())
    bad = broken_images(driver)
    return console_errors(driver), bad, len(driver.find_elements("tag name", "img"))


def _cli(*args):
    with contextlib.redirect_stdout(io.StringIO()) as out, pytest.raises(SystemExit) as exit_info:
        main(list(args))
    assert exit_info.value.code == 0, out.getvalue()[-3000:]


def test_the_checks_see_a_console_error_and_a_missing_image(browser, tmp_path):
    # reference: a page built to fail both checks (a missing file, an explicit console.error)
    page = tmp_path / "bad.html"
    page.write_text("<!DOCTYPE html><html><body><h1>bad</h1><img src='missing.png' alt='x'>"
                    "<script>console.error('boom')</script></body></html>", encoding="utf-8")
    errors, bad, n = open_page(browser, page)
    assert n == 1 and len(bad) == 1 and "missing.png" in bad[0]
    assert any("boom" in e for e in errors), errors


# ----------------------------------------------------------------------------- report.html
@pytest.fixture(scope="module")
def report_page(example_fit, tmp_path_factory):
    """report.html of the bundled example's fit with a short criticism (one candidate, no
    exact refits: the verdict's place on the page, not its content, is tested here)."""
    fit_dir = shutil.copytree(example_fit[0], tmp_path_factory.mktemp("report") / "fit")
    _cli("criticize", "--out", str(fit_dir / "criticism"), "--effects", "wall_softening",
         "--draws", "400", "--max-refits", "0", "--no-progress")
    _cli("report", str(fit_dir))
    return fit_dir / "report.html"


@pytest.mark.slow
@EXAMPLE_FIT
def test_report_loads_cleanly_and_leads_with_the_verdict(browser, report_page):
    errors, bad, n = open_page(browser, report_page)
    assert errors == [] and bad == []
    assert n == report_page.read_text(encoding="utf-8").count("<img ") >= 5  # every figure shown
    # the verdict is the page's first section, above the diagnostics and everything else
    headings = [h.text for h in browser.find_elements("tag name", "h2")]
    assert headings[0] == "Verdict" and headings.count("Verdict") == 1, headings
    top = {name: browser.find_element("css selector", sel).rect["y"] for name, sel in
           [("verdict", "#verdict"), ("diagnostics", "#warnings"), ("h2 #2", "h2:not(#verdict h2)")]}
    assert top["verdict"] < top["diagnostics"] < top["h2 #2"], top
    crit = json.loads((report_page.parent / "criticism" / "criticism.json").read_text())
    verdict = browser.find_element("css selector", "#verdict").text
    assert crit["verdict"]["status"].upper().replace("_", " ") in verdict
    assert crit["verdict"]["text"][:60] in verdict


# ----------------------------------------------------------------------------- curves.html
@pytest.fixture(scope="module")
def curves_page(tmp_path_factory, table):
    """curves.html of 3 bulged + 2 intact simulated cells (3 curves per cell and target), with
    two curves made to fail: one flattened (no contact), one not a curve file at all."""
    raw = tmp_path_factory.mktemp("curves") / "raw"
    _cli("simulate", "--raw-curves", str(raw), "--n-bulged", "3", "--n-intact", "2",
         "--P-range-kPa", "5", "25", "--seed", "4")
    flat = raw / "curves" / "b001_bulge_1.tab"
    lines = flat.read_text().splitlines()
    # force column -> a constant baseline with +-1 pN alternation: the tip never touches
    data = [i for i, line in enumerate(lines) if line and not line.startswith("#")]
    for n, i in enumerate(data):
        lines[i] = "\t".join([f"{4.2e-10 + (1e-12 if n % 2 else -1e-12):.7e}", *lines[i].split("\t")[1:]])
    flat.write_text("\n".join(lines) + "\n")
    (raw / "bad.tab").write_text("not a force curve\n")
    with open(raw / "manifest.csv", "a") as fh:
        fh.write("bad.tab,i009,cell,540,10,,,simulated\n")  # a cell of its own, then left out
    _cli("curves", str(raw / "manifest.csv"), "--out", str(raw.parent / "cells.csv"), "--no-progress")
    rows = list(csv.DictReader(open(raw.parent / "curves.csv")))
    assert {r["status"] for r in rows} == {"ok", "no_contact", "unreadable_file"}
    return raw.parent / "curves.html", rows


def _shown_rows(driver):
    """(file, status, k key) of the table's rows in their displayed order, visible ones only."""
    return driver.execute_script(
        "return Array.from(document.querySelectorAll('#curves tbody tr')).filter(r => !r.hidden)"
        ".map(r => [r.cells[0].textContent, r.getAttribute('data-status'),"
        " r.cells[5].getAttribute('data-key')]);")


def _click_heading(driver, text):
    (th,) = [h for h in driver.find_elements("css selector", "#curves thead th") if h.text == text]
    th.click()


@pytest.mark.slow
def test_curves_page_loads_cleanly(browser, curves_page):
    page, rows = curves_page
    errors, bad, n = open_page(browser, page)
    assert errors == [] and bad == [] and n >= 1  # the flattened curve's figure at least
    assert [r[0] for r in _shown_rows(browser)] == [r["file"] for r in rows]  # manifest order


@pytest.mark.slow
def test_curves_table_sorts_by_a_column_heading(browser, curves_page):
    page, rows = curves_page
    browser.get(page.resolve().as_uri())
    # reference: curves.csv's stiffnesses sorted here; curves without one (rejected) go last
    k = {r["file"]: float(r["k_N_per_m"]) if r["k_N_per_m"] else math.inf for r in rows}
    up = sorted(k, key=lambda f: k[f])
    _click_heading(browser, "k [mN/m]")
    shown = [r[0] for r in _shown_rows(browser)]
    assert [k[f] for f in shown] == [k[f] for f in up]  # ties may keep either order
    assert math.isinf(k[shown[-1]]) and math.isfinite(k[shown[0]])
    _click_heading(browser, "k [mN/m]")  # again: reversed
    assert [k[f] for f in (r[0] for r in _shown_rows(browser))] == [k[f] for f in reversed(up)]
    _click_heading(browser, "file")
    assert [r[0] for r in _shown_rows(browser)] == sorted(k, key=str.lower)
    assert console_errors(browser) == []


@pytest.mark.slow
def test_curves_table_filters_by_status(browser, curves_page):
    page, rows = curves_page
    browser.get(page.resolve().as_uri())
    from selenium.webdriver.support.ui import Select

    choose = Select(browser.find_element("id", "status-filter"))
    # reference: curves.csv's statuses
    want = {"kind:rejected": [r["file"] for r in rows if r["status"] not in ("ok", "imprecise")],
            "kind:accepted": [r["file"] for r in rows if r["status"] in ("ok", "imprecise")],
            "status:unreadable_file": ["bad.tab"], "status:no_contact": ["curves/b001_bulge_1.tab"],
            "": [r["file"] for r in rows]}
    for value, files in want.items():
        choose.select_by_value(value)
        assert [r[0] for r in _shown_rows(browser)] == files, value
        assert browser.find_element("id", "shown").text == f"{len(files)} of {len(rows)} curves shown"
    assert len(want["kind:rejected"]) == 2
    assert console_errors(browser) == []
