"""What every web engine shares: the page, the local server, the browser and the render loop.

The scene goes to the page as the job an external renderer receives
(:mod:`compare.renderers.job`: the glTF, the rectangular lights, the environment
EXR, the camera), served from local files by a server on 127.0.0.1 that the page
cannot leave (every other request is aborted). ``page/index.html`` (or the engine's own
page, :attr:`WebRenderer.HTML`, where its import map differs) loads the engine's own script
(:attr:`WebRenderer.SCRIPT`), which builds the scene in that engine and renders into float
render targets; the pixels come back as float32, never through an 8-bit screenshot, except
from an engine that shows only 8-bit sRGB: its set-up answer says ``output: "display"`` and
the rendering's metadata carries it (:data:`compare.renderers.base.OUTPUT_KEY`), so the suite
measures it with its LDR metrics only. Every engine's script defines the same three functions:

* ``await compareSetup({job, engine, options})`` builds the scene and compiles its
  shaders (set-up);
* ``await compareStep(n)`` renders up to step ``n`` and returns the cumulative
  milliseconds of the steps, each ending in a one-pixel readback that waits for
  the GPU;
* ``compareImage()`` returns the float32 RGBA pixels, bottom row first, in base64.

The browser is Debian's Chromium, driven by Playwright; WebGL 2 runs on SwiftShader
without a GPU (``--use-angle=swiftshader``) and on the GPU where there is one
(``COMPARE_CHROMIUM_ARGS`` replaces the flags).
"""

from __future__ import annotations

import base64
import http.server
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path
from typing import ClassVar

import numpy as np

from compare.renderers.base import (DEFAULT_TIMEOUT_S, DISPLAY_OUTPUT, OUTPUT_KEY, Checkpoint, RenderContext, Renderer,
                                    RendererError, Rendering)
from compare.renderers.options import parse_spec
from compare.util.files import sha256_bytes

__all__ = ["CHROMIUM_ARGS", "INSTALL", "PAGE", "WebRenderer", "chromium_path", "web_root"]

CHROMIUM_ARGS = ("--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist")
INSTALL = ("scripts/suite.sh setup installs all of it: Debian's chromium (apt-get install chromium), "
           "the npm packages (npm ci --prefix web) and Playwright (pip install playwright)")
#: The page (``index.html`` and each engine's script): package data beside this module.
PAGE = Path(__file__).resolve().with_name("page")
#: The page files the engines share (its own script aside): a change to one is a change to every engine's key.
SHARED_SCRIPTS = ("index.html", "page-script.js", "common.js", "three-mean.js")


def web_root() -> Path:
    """The folder of the npm packages the page imports (``package-lock.json``, ``node_modules``):
    ``$COMPARE_WEB_MODULES``, else the checkout's ``web/`` (where ``npm ci --prefix web`` installs them)."""
    env = os.environ.get("COMPARE_WEB_MODULES")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "web"


def chromium_path() -> str | None:
    """Chromium's executable: ``$COMPARE_CHROMIUM``, else ``chromium`` on PATH."""
    return os.environ.get("COMPARE_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")


class _Timeout(Exception):
    """The page gave no answer before the render's deadline (what it was doing is the message)."""


class _Handler(http.server.SimpleHTTPRequestHandler):
    """Serves ``/web/`` from the page folder, ``/web/node_modules/`` from the npm packages and ``/job/``
    from the job's folder; nothing else."""

    roots: dict[str, Path] = {}

    def translate_path(self, path: str) -> str:
        path = path.split("?", 1)[0].split("#", 1)[0]
        for prefix, root in self.roots.items():
            if path.startswith(prefix):
                target = (root / path[len(prefix):]).resolve()
                if target == root or root in target.parents:
                    return str(target)
        return str(Path(tempfile.gettempdir()) / "compare-no-such-file")

    def log_message(self, *args) -> None:  # quiet: the suite reports what matters
        pass


class _Browser:
    """Playwright and one Chromium for every render of a run (started once: about 2 s)."""

    def __init__(self):
        from playwright.sync_api import sync_playwright

        self._pw = sync_playwright().start()
        args = os.environ.get("COMPARE_CHROMIUM_ARGS")
        try:
            self.browser = self._pw.chromium.launch(executable_path=chromium_path(),
                                                    args=args.split() if args else list(CHROMIUM_ARGS))
        except Exception:
            self._pw.stop()
            raise
        self.version = self.browser.version

    def new_page(self):
        """A fresh page (tab) of this browser."""
        return self.browser.new_page()

    def close(self) -> None:
        try:
            self.browser.close()
        finally:
            self._pw.stop()


class WebRenderer(Renderer):
    """One web engine in headless Chromium: a subclass names its family, page script, npm packages and
    options; this class serves the job, drives the page and reads the pixels back."""

    #: The renderer family (the spec's name before ':').
    ENGINE: ClassVar[str] = ""
    #: The engine's page script in ``page/``.
    SCRIPT: ClassVar[str] = ""
    #: The npm packages (folders of ``web/node_modules``) the script imports.
    PACKAGES: ClassVar[tuple[str, ...]] = ()
    #: Metadata keys the page's set-up answer adds (the engine's version).
    VERSION_KEY: ClassVar[str] = "version"
    #: The page (in ``page/``) that loads :attr:`SCRIPT`: its import map names the packages' files.
    HTML: ClassVar[str] = "index.html"

    def __init__(self, spec: str):
        family = spec.partition(":")[0]
        if family != self.ENGINE:
            raise ValueError(f"{type(self).__name__} renders {self.ENGINE!r}, not {family!r}")
        opts = [word for word, _ in parse_spec(spec, self.OPTIONS)]
        self.name = spec
        self.engine = family
        self.options = {o: True for o in opts}
        self.variant_of = family if opts else None
        self.variant_note = "; ".join(self.OPTIONS[o] for o in opts)
        self.label = self.describe(opts)

    #: The text of the ``shadows`` option that three.js and Babylon.js share (their area lights alike).
    SPOT_SHADOWS = "shadow-mapped spot lights of the area lights' L·A instead of RectAreaLight (which casts no shadow)"

    def describe(self, opts: list[str]) -> str:
        """The label of this engine with ``opts``."""
        return self.ENGINE + (f" ({', '.join(opts)})" if opts else "")

    def available(self) -> tuple[bool, str]:
        try:
            import playwright  # noqa: F401
        except ImportError:
            return False, f"Playwright is not installed; {INSTALL}"
        exe = chromium_path()
        if exe is None:
            return False, f"no Chromium (chromium on PATH or $COMPARE_CHROMIUM); {INSTALL}"
        if not (Path(exe).is_file() and os.access(exe, os.X_OK)):
            return False, f"Chromium {exe} ($COMPARE_CHROMIUM) is not an executable file; {INSTALL}"
        modules = web_root() / "node_modules"
        for package in self.PACKAGES:
            if not (modules / package / "package.json").is_file():
                return False, f"the npm package {package} is not in {modules}; {INSTALL}"
        return True, ""

    def key(self, scene, settings) -> list:
        files = [PAGE / f for f in (*SHARED_SCRIPTS, self.HTML, self.SCRIPT)] + [web_root() / "package-lock.json"]
        return ["web", self.engine, sorted(self.options),
                [(f.name, sha256_bytes(f.read_bytes())) for f in files if f.is_file()]]

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        from compare.renderers.job import write_job

        who = f"renderer {self.name!r}"
        ok, why = self.available()
        if not ok:
            raise RendererError(f"{who}: {why}")
        from playwright.sync_api import TimeoutError as PlaywrightTimeout
        try:
            browser = context.resource("chromium", _Browser, lambda b: b.close())
        except Exception as exc:  # noqa: BLE001 - Playwright's launch errors, whatever their type
            raise RendererError(f"{who}: Chromium did not start ({chromium_path()}): {str(exc).splitlines()[0]}; "
                                f"{INSTALL}") from None
        folder = Path(tempfile.mkdtemp(prefix=f"compare-{self.engine}-"))
        server = None
        page = None
        console: list[str] = []
        try:
            t0 = time.perf_counter()
            write_job(scene, folder, renderer=self.name, unit=self.unit, checkpoints=checkpoints, seed=seed,
                      output_dir=folder, cache_dir=context.cache_dir or None)
            self.write_files(scene, folder, context)
            handler = type("Handler", (_Handler,), {"roots": {"/web/node_modules/": (web_root() / "node_modules").resolve(),
                                                              "/web/": PAGE,
                                                              "/job/": folder.resolve()}})
            server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
            threading.Thread(target=server.serve_forever, daemon=True).start()
            origin = f"http://127.0.0.1:{server.server_address[1]}"
            page = browser.new_page()
            limit = context.timeout if context.timeout is not None else DEFAULT_TIMEOUT_S
            deadline = t0 + limit

            def call(name: str, arg, what: str):
                """``await window[name](arg)`` in the page, bounded by the render's deadline (Playwright's
                evaluate waits for a promise forever: a page that waits on an image would never return)."""
                left = deadline - time.perf_counter()
                if left <= 0:
                    raise _Timeout(what)
                page.evaluate("([name, arg]) => { window.__compareDone = undefined; window.__compareError = undefined;"
                              " Promise.resolve().then(() => window[name](arg)).then("
                              "r => { window.__compareDone = {r: r}; },"
                              " e => { window.__compareError = String((e && e.stack) || e); }); }", [name, arg])
                try:
                    page.wait_for_function("window.__compareDone !== undefined || window.__compareError !== undefined",
                                           timeout=left * 1000.0, polling=20)
                except PlaywrightTimeout:
                    raise _Timeout(what) from None
                error = page.evaluate("() => window.__compareError || null")
                if error:
                    raise RendererError(f"{who}: the page failed: {error.splitlines()[0]}")
                return page.evaluate("() => window.__compareDone.r")

            page.set_default_timeout(max(limit, 1.0) * 1000.0)
            page.on("console", lambda m: console.append(f"{m.type}: {m.text}") if m.type in ("error", "warning")
                    else None)
            page.on("pageerror", lambda e: console.append(f"page error: {e}"))
            # nothing leaves this machine: only the local server answers
            page.route("**/*", lambda route: route.continue_() if route.request.url.startswith(origin)
                       else route.abort())
            try:
                page.goto(f"{origin}/web/{self.HTML}?script={self.SCRIPT}")
                page.wait_for_function("window.compareReady === true || window.compareFailed !== undefined")
            except PlaywrightTimeout:
                raise _Timeout("loading the page") from None
            failed = page.evaluate("() => window.compareFailed || null")
            if failed:
                raise RendererError(f"{who}: the page did not load: {failed}")
            info = call("compareSetup", {"job": f"{origin}/job/job.json", "engine": self.engine,
                                         "options": self.options}, "setting up the scene")
            setup = time.perf_counter() - t0
            w, h = scene.camera.resolution
            out = []
            for step in checkpoints:
                r = call("compareStep", int(step), f"rendering step {step}")
                raw = base64.b64decode(page.evaluate("() => window.compareImage()"))
                rgba = np.frombuffer(raw, dtype=np.float32).reshape(h, w, 4)
                out.append(Checkpoint(int(step), float(r["ms"]) / 1000.0, np.ascontiguousarray(rgba[::-1, :, :3])))
            meta = {"compile_seconds": round(float(info.get("warm") or 0) / 1000, 3),
                    "webgl_renderer": info.get("gl_renderer"), self.VERSION_KEY: info.get("version"),
                    "chromium": browser.version, "engine": self.engine, "options": "+".join(sorted(self.options))}
            if info.get("output") == DISPLAY_OUTPUT:
                meta[OUTPUT_KEY] = DISPLAY_OUTPUT
            if console:
                meta["console"] = " | ".join(console[-5:])
            return Rendering(out, setup, meta)
        except _Timeout as exc:
            said = "--timeout" if context.timeout is not None else "the web engines' limit, --timeout to change it"
            tail = ("; the page's console: " + " | ".join(console[-5:])) if console else ""
            raise RendererError(f"{who}: no answer from the page within {limit:g} s ({said}) while {exc}; its tab "
                                f"was closed{tail}") from None
        except RendererError:
            raise
        except Exception as exc:  # noqa: BLE001 - a failure in the page comes as Playwright's Error
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            tail = ("; the page's console: " + " | ".join(console[-5:])) if console else ""
            raise RendererError(f"{who}: the page failed: {text}{tail}") from None
        finally:
            if page is not None:
                page.close()
            if server is not None:
                server.shutdown()
                server.server_close()
            shutil.rmtree(folder, ignore_errors=True)

    def write_files(self, scene, folder: Path, context: RenderContext) -> None:
        """Write what the page needs beside the job (``job.json``, ``scene.gltf``, ``environment.exr``) into
        ``folder``, which the page reads as ``/job/``; default: nothing."""

    def facts(self, metadata: dict) -> dict[str, str]:
        g = metadata.get("webgl_renderer")
        return {"webgl_renderer": g} if isinstance(g, str) else {}
