"""The HTML report in a real browser: Debian's headless Chromium driven by Playwright.

The test opens the report from ``file://`` exactly as a person would (the same
library and browser drive the web engines, compare.web.renderer), and checks that

* every image loads (``naturalWidth > 0``) and nothing is fetched from outside
  the report folder;
* the browser console has no errors;
* moving the swipe and exposure controls (keyboard on the range inputs,
  a pointer drag on the image) changes the canvas, and the canvas pixels equal
  :func:`compare.image.tonemap.to_ldr` of the embedded HDR data to within one 8-bit
  step, so the page's ACES matches the suite's;
* a scene named ``<script>alert(1)</script>`` shows as text and runs nothing;
* the scenario table of a run of ``compare run --scenarios`` has a row per scenario (those not rendered saying
  why) and a cell per renderer (an excluded one saying so), its images load, and its buttons sort the rows.

Full-page screenshots land in the tests' tmp folders (``report.png``, ``fidelity.png``).

Needs Debian's ``chromium`` (``apt-get install -y chromium``) and Playwright (a dev
dependency); skips without them.
"""

from __future__ import annotations

import base64
import json
import re
import time
from pathlib import Path

import numpy as np
import pytest

from compare.image.tonemap import to_ldr
from compare.report.results import Results
from tests.helpers import (CORNELL, EVIL, FIDELITY_RENDERERS, FIDELITY_SCENARIOS, cornell_named, fidelity_report,
                           synthetic_report)

CHROMIUM = Path("/usr/bin/chromium")
#: A hermetic headless browser: no GPU, no network chatter, a fresh profile per session.
CHROMIUM_FLAGS = ["--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage"]
KEYS = {"\ue011": "Home", "\ue010": "End"}  # the WebDriver key codes the tests speak


def _playwright() -> bool:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return False
    return True


pytestmark = [
    pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium: apt-get install -y chromium"),
    pytest.mark.skipif(not _playwright(), reason="no Playwright: pip install playwright (a dev dependency)"),
]


# --------------------------------------------------------------------------- the browser, through Playwright


class Browser:
    """Headless Chromium (Debian's) driven by Playwright, with the few calls the tests need."""

    def __init__(self, profile: Path | None = None, *, tab_of: "Browser | None" = None):
        """A browser with a fresh ``profile``, or (``tab_of``) another tab of a browser already started: the
        Playwright of one thread drives one browser."""
        from playwright.sync_api import sync_playwright

        self._owner = tab_of is None
        if tab_of is not None:
            self._pw, self._context = tab_of._pw, tab_of._context
        else:
            self._pw = sync_playwright().start()
            try:
                self._context = self._pw.chromium.launch_persistent_context(
                    str(profile), executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_FLAGS,
                    viewport={"width": 1400, "height": 1000})
            except BaseException:
                self._pw.stop()
                raise
        self.page = self._context.new_page()
        self._console: list[dict] = []
        self._dialogs: list[str] = []
        self.page.on("console", lambda m: self._console.append(
            {"level": "SEVERE" if m.type == "error" else m.type.upper(), "message": m.text}))
        self.page.on("pageerror", lambda e: self._console.append({"level": "SEVERE", "message": str(e)}))
        self.page.on("dialog", lambda d: (self._dialogs.append(d.message), d.dismiss()))

    def open(self, url: str) -> None:
        self.page.goto(url)

    def js(self, script: str, *args):
        """Run ``script`` as a function body (``arguments[i]`` are ``args``) and return its value."""
        return self.page.evaluate("(args) => (function () { " + script + " }).apply(null, args)", list(args))

    def find(self, css: str):
        return self.page.locator(css).first

    def keys(self, element, text: str) -> None:
        for ch in text:
            element.press(KEYS.get(ch, ch))

    def drag(self, element, x0: int, x1: int) -> None:
        """Press the mouse at x0 and release it at x1 (pixels from the element's centre)."""
        box = element.bounding_box()
        cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        self.page.mouse.move(cx + x0, cy)
        self.page.mouse.down()
        self.page.mouse.move(cx + x1, cy, steps=5)
        self.page.mouse.up()

    def console(self) -> list[dict]:
        """Browser console entries since the last call."""
        entries, self._console = self._console, []
        return entries

    def alert_open(self) -> bool:
        return bool(self._dialogs)

    def screenshot(self, path: Path) -> None:
        path.write_bytes(self.page.screenshot(full_page=True))

    def close(self) -> None:
        if not self._owner:
            self.page.close()
            return
        try:
            self._context.close()
        finally:
            self._pw.stop()


# --------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A synthetic two-scene report (48×36): the Cornell box and one with a hostile name."""
    tmp = tmp_path_factory.mktemp("browser")
    evil = cornell_named(tmp, EVIL)
    res = synthetic_report(tmp / "report", [CORNELL, evil])
    return tmp / "report", res


def _opened(b: Browser, index: Path) -> None:
    """Open a report and wait until its script has started the viewers."""
    b.open(index.as_uri())
    deadline = time.monotonic() + 30
    while b.js("return document.body && document.body.dataset.viewersReady || null") is None:
        if time.monotonic() > deadline:
            raise AssertionError("the report's viewers did not start within 30 s")
        time.sleep(0.1)


@pytest.fixture(scope="module")
def browser(tmp_path_factory, report):
    b = Browser(tmp_path_factory.mktemp("profile"))
    try:
        _opened(b, report[0] / "index.html")
        yield b
    finally:
        b.close()


@pytest.fixture(scope="module")
def fidelity(tmp_path_factory, browser):
    """The report of a run of four scenarios (two not rendered) with the synthetic renderers, open in a tab of
    the browser."""
    out = fidelity_report(tmp_path_factory.mktemp("fidelity"))
    b = Browser(tab_of=browser)
    try:
        _opened(b, out / "index.html")
        yield b, out
    finally:
        b.close()


def _hdr(report_dir: Path, scene_id: str) -> tuple[dict, dict[str, np.ndarray]]:
    """The viewer's embedded HDR images, decoded as the page decodes them."""
    text = (report_dir / "data" / f"{scene_id}.js").read_text()
    body = json.loads(re.search(r"\] = (\{.*\});\s*$", text, re.S).group(1))
    h, w = body["height"], body["width"]
    images = {img["key"]: np.frombuffer(base64.b64decode(img["data"]), dtype="<f2").reshape(h, w, 3)
              .astype(np.float32) for img in body["images"]}
    return body, images


def _canvas(b: Browser, scene_id: str) -> np.ndarray:
    w, h, data = b.js("""
        const c = document.querySelector(`.viewer[data-scene="${arguments[0]}"] canvas.view`);
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        return [c.width, c.height, Array.from(d)];""", scene_id)
    return np.asarray(data, dtype=np.int16).reshape(h, w, 4)[..., :3]


def _expected(image: np.ndarray, exposure: float) -> np.ndarray:
    return np.round(to_ldr(image, exposure=exposure) * 255.0).astype(np.int16)


# --------------------------------------------------------------------------- tests


def test_report_loads_every_image_without_errors(browser, report, tmp_path):
    out, res = report
    images = browser.js("return Array.from(document.images).map(i => [i.getAttribute('src'), i.complete, i.naturalWidth])")
    assert len(images) > 20
    broken = [src for src, complete, width in images if not (complete and width > 0)]
    assert broken == [], f"images that did not load: {broken}"
    assert browser.js("return document.body.dataset.viewersReady") == str(len(res.scenes))
    # Every resource the page names resolves to a file inside the report folder (no network, no CDN).
    # (Resource Timing does not record file:// loads, so the resolved URLs are checked instead.)
    urls = browser.js("""return [...document.images].map(e => e.src)
        .concat([...document.scripts].map(e => e.src), [...document.querySelectorAll('link')].map(e => e.href))""")
    root = out.resolve().as_uri() + "/"
    assert len(urls) > 20 and [u for u in urls if not u.startswith(root)] == []
    errors = [e for e in browser.console() if e.get("level") == "SEVERE"]
    assert errors == [], errors
    browser.screenshot(tmp_path / "report.png")
    assert (tmp_path / "report.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_hostile_scene_name_is_text_not_script(browser, report):
    _, res = report
    evil = next(s for s in res.scenes if s.name == EVIL)
    heading = browser.js("return document.querySelector(`section[id='${arguments[0]}'] h2`).textContent", evil.id)
    assert EVIL in heading
    assert not browser.alert_open()
    assert browser.js("return Array.from(document.scripts).every(s => s.src && !s.textContent.trim())")
    assert browser.js("return document.querySelectorAll('section.scene script').length") == 0


def test_swipe_and_exposure_change_the_canvas(browser, report):
    out, res = report
    for scene in res.scenes:
        sid = scene.id
        body, hdr = _hdr(out, sid)
        ref, prog = _expected(hdr["reference"], 1.0), _expected(hdr["progressive"], 1.0)
        sel = f'.viewer[data-scene="{sid}"]'
        browser.js(f"document.querySelector('{sel}').scrollIntoView({{block: 'center'}})")

        start = _canvas(browser, sid)
        split = round(500 / 1000 * body["width"])
        # Left of the swipe line: the ground truth; right: the progressive image, each tone-mapped
        # in the page exactly as compare.image.tonemap.to_ldr does (within one 8-bit step).
        assert np.abs(start[:, :split] - ref[:, :split]).max() <= 1
        assert np.abs(start[:, split:] - prog[:, split:]).max() <= 1

        swipe = browser.find(f"{sel} input.swipe")
        browser.keys(swipe, "\ue011")  # Home: the swipe line to the left edge, all right image
        home = _canvas(browser, sid)
        assert not np.array_equal(home, start)
        assert np.abs(home - prog).max() <= 1
        browser.keys(swipe, "\ue010")  # End: all left image
        assert np.abs(_canvas(browser, sid) - ref).max() <= 1

        ev = browser.find(f"{sel} input.ev")
        browser.keys(ev, "\ue010")  # End: EV +8
        bright = _canvas(browser, sid)
        assert bright.mean() > home.mean() + 20
        assert np.abs(bright - _expected(hdr["reference"], 2.0 ** 8)).max() <= 1
        assert browser.js(f"return document.querySelector('{sel} .ev-value').textContent").startswith("EV +8.0")
        browser.keys(ev, "\ue011")  # Home: EV -8
        dark = _canvas(browser, sid)
        assert dark.mean() < bright.mean() and np.abs(dark - _expected(hdr["reference"], 2.0 ** -8)).max() <= 1

        # Dragging on the image moves the swipe line to the pointer.
        stage = browser.find(f"{sel} .stage")
        width = browser.js(f"return document.querySelector('{sel} canvas.view').getBoundingClientRect().width")
        browser.drag(stage, 0, -int(width * 0.25))
        value = int(browser.js(f"return document.querySelector('{sel} input.swipe').value"))
        assert 200 <= value <= 300, value
        assert not np.array_equal(_canvas(browser, sid), dark)
    assert [e for e in browser.console() if e.get("level") == "SEVERE"] == []


def test_console_errors_are_seen(browser):
    """Guard for the checks above: an error on the page does reach the console log we read."""
    browser.console()  # drain
    browser.js("console.error('deliberate test error')")
    assert any("deliberate test error" in e.get("message", "") for e in browser.console())


def test_inline_script_is_refused_by_the_content_security_policy(browser):
    """Defence in depth: even markup that escaped escaping could not run inline script."""
    browser.console()  # drain
    ran = browser.js("""
        const s = document.createElement('script');
        s.textContent = 'window.__inlineRan = true;';
        document.body.appendChild(s);
        return window.__inlineRan === true;""")
    assert ran is False
    assert any("Content Security Policy" in e.get("message", "") for e in browser.console())


# --------------------------------------------------------------------------- the scenario table


def _rows(b: Browser) -> list[str]:
    """The scenario table's rows, top to bottom, by scenario name."""
    return b.js("return [...document.querySelectorAll('#fidelity tbody tr')]"
                ".map(tr => tr.querySelector('th').firstChild.textContent.trim())")


def _sort(b: Browser, column: int, key: str) -> list[str]:
    """Click the sort button ``key`` of ``column`` (0: the scenarios, 1: the ground truth, 2...: the renderers)."""
    selector = (f"#fidelity thead button.sort[data-col='{column}'][data-key='{key}']" if column
                else "#fidelity thead button.sort[data-key='order']")
    b.find(selector).click()
    return _rows(b)


def test_the_scenario_table_has_a_row_per_scenario_and_a_cell_per_renderer(fidelity, tmp_path):
    b, out = fidelity
    res = Results.load(out / "results.json")
    names = [s["name"] for s in FIDELITY_SCENARIOS]
    assert _rows(b) == names  # the file's order, those not rendered too
    n = len(FIDELITY_RENDERERS)
    assert b.js("return document.querySelectorAll('#fidelity thead th').length") == 2 + n
    cells = b.js("return [...document.querySelectorAll('#fidelity tbody tr')].map(tr => tr.cells.length)")
    assert cells == [2 + n, 2 + n, 2, 2]  # scenario, ground truth, one per renderer; or one cell saying why not
    texts = b.js("return [...document.querySelectorAll('#fidelity tbody tr')]"
                 ".map(tr => [...tr.cells].slice(1).map(c => c.textContent.replace(/\\s+/g, ' ').trim()))")
    assert texts[2] == ["not rendered: model file 'models/gone.glb' not found"]
    assert texts[3] == ["not rendered: lighting 'env/sky.jpg' is not an .exr or .hdr file"]
    # Cycles, which "side" excludes by model-viewer's name for it, is marked so (not blank); rendered elsewhere
    cycles = 2 + FIDELITY_RENDERERS.index("cycles") - 1
    assert texts[1][cycles] == "excluded by the scenario (exclude: blender-cycles)"
    assert texts[0][cycles].startswith("FLIP ")
    # each rendered cell: its image, FLIP and model-viewer dB of the final image, the seconds to it
    for scene, row in zip(res.scenes, texts[:2]):
        for spec, text in zip(FIDELITY_RENDERERS, row[1:]):
            run = scene.run(spec)
            if run is None:
                continue
            m = run.final.metrics
            assert f"FLIP {m['flip']:.3g} · {m['mv_rms_db']:.1f} dB" in text, (spec, text)
    images = b.js("return [...document.querySelectorAll('#fidelity img')].map(i => [i.getAttribute('src'), "
                  "i.complete, i.naturalWidth])")
    assert len(images) == 2 + 2 * n - 1  # two ground truths, every run but the excluded one
    assert [src for src, complete, width in images if not (complete and width > 0)] == []
    assert [e for e in b.console() if e.get("level") == "SEVERE"] == []
    b.js("document.querySelector('#fidelity').scrollIntoView()")
    b.screenshot(tmp_path / "fidelity.png")


def test_the_scenario_table_sorts_by_a_column(fidelity):
    b, out = fidelity
    res = Results.load(out / "results.json")
    flip = {s.name: s.run("progressive").final.metrics["flip"] for s in res.scenes}
    assert flip["front"] != flip["side"]
    lowest = sorted(flip, key=flip.get)
    column = 2 + FIDELITY_RENDERERS.index("progressive")
    assert _sort(b, column, "flip") == [*lowest, "lost", "ldr"]  # rows without the number last
    assert b.js(f"return document.querySelector('#fidelity thead tr').cells[{column}].getAttribute('aria-sort')") \
        == "ascending"
    assert _sort(b, column, "flip") == [*lowest[::-1], "lost", "ldr"]  # again: the other way
    # Cycles' seconds: "side" excludes it, so it has none and goes after "front" either way
    cycles = 2 + FIDELITY_RENDERERS.index("cycles")
    assert _sort(b, cycles, "seconds") == ["front", "side", "lost", "ldr"]
    assert _sort(b, cycles, "seconds") == ["front", "side", "lost", "ldr"]
    assert _sort(b, 0, "order") == ["front", "side", "lost", "ldr"]
    assert _sort(b, 0, "order") == ["ldr", "lost", "side", "front"]
    assert [e for e in b.console() if e.get("level") == "SEVERE"] == []
