"""Shared pytest set-up: the cache folder, the OpenGL context, scene files and fuzzing sizes.

* ``$COMPARE_CACHE`` is a fresh folder per test run (removed at the end), never the user's
  cache; ``COMPARE_TEST_CACHE=<folder>`` runs the tests on that folder instead and keeps it.
* ``gl_ctx`` hands out one headless OpenGL context per session, checked after each test for GL
  errors and leaked GL objects; every test that uses it is marked ``gl``.
* ``make_scene`` writes a scene TOML file into the test's temporary folder.
* Hypothesis sizes come from a profile: ``default`` (a few dozen cases, the default run) or ``slow``
  (many more), chosen by ``HYPOTHESIS_PROFILE=<name>`` or by selecting slow tests (``-m slow``).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import textwrap
import weakref
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings
from hypothesis.internal.detection import is_hypothesis_test

# ----------------------------------------------------------------------------- the cache folder

_CACHE_KEY = "compare_cache"


def pytest_configure(config):
    # In os.environ, not monkeypatch: subprocesses (the CLI, executors, notebooks) must inherit it.
    mine = os.environ.get("COMPARE_TEST_CACHE")
    if mine:
        folder, owned = mine, False
    elif hasattr(config, "workerinput"):  # an xdist worker shares its controller's folder
        folder, owned = config.workerinput[_CACHE_KEY], False
    else:
        folder, owned = tempfile.mkdtemp(prefix="compare-test-cache-"), True
    config.stash[_CACHE] = (folder, owned, os.environ.get("COMPARE_CACHE"))
    os.environ["COMPARE_CACHE"] = folder
    settings.load_profile(_hypothesis_profile(config))


def pytest_unconfigure(config):
    folder, owned, before = config.stash.get(_CACHE, (None, False, None))
    if folder is None:
        return
    if before is None:
        os.environ.pop("COMPARE_CACHE", None)
    else:
        os.environ["COMPARE_CACHE"] = before
    if owned:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """pytest-xdist: workers use the controller's cache folder (content-keyed, written atomically)."""
    node.workerinput[_CACHE_KEY] = node.config.stash[_CACHE][0]


_CACHE = pytest.StashKey[tuple]()

# ----------------------------------------------------------------------------- hypothesis profiles

settings.register_profile("default", max_examples=30, deadline=None, derandomize=True,
                          suppress_health_check=list(HealthCheck))
settings.register_profile("slow", max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))


def _selects_slow(config) -> bool:
    """Whether ``-m`` selects tests marked slow (``-m slow``, ``-m ''``; not the default ``not slow``)."""
    from _pytest.mark.expression import Expression

    expr = config.option.markexpr
    if not expr:
        return True
    return Expression.compile(expr).evaluate(lambda name, **kwargs: name == "slow")


def _hypothesis_profile(config) -> str:
    return os.environ.get("HYPOTHESIS_PROFILE") or ("slow" if _selects_slow(config) else "default")


# ----------------------------------------------------------------------------- markers from fixtures

#: Fixtures that hand out the OpenGL context: a test that uses one (directly or through another
#: fixture) is marked ``gl``.
GL_FIXTURES = {"gl_ctx", "gl_session_ctx"}


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(config, items):
    slow_run = _selects_slow(config)
    for item in items:
        if GL_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.gl)
        # A property is written once: in a run of slow tests it is one of them, with the slow profile.
        if slow_run and is_hypothesis_test(getattr(item, "obj", None)):
            item.add_marker(pytest.mark.slow)


_CALL_REPORT = pytest.StashKey[pytest.TestReport]()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.when == "call":
        item.stash[_CALL_REPORT] = report
    return report


# ----------------------------------------------------------------------------- the OpenGL context

#: Context methods that make a GL object the caller owns (detect_framebuffer and the external_*
#: ones wrap objects made elsewhere).
_FACTORIES = ("buffer", "texture", "texture3d", "texture_array", "texture_cube", "depth_texture",
              "depth_texture_cube", "framebuffer", "simple_framebuffer", "empty_framebuffer", "renderbuffer",
              "depth_renderbuffer", "program", "vertex_array", "simple_vertex_array", "sampler",
              "compute_shader", "scope")


class _Tracked:
    """Records every object the context's factories make, weakly, so that a test's leftovers can be
    listed without scanning the heap."""

    def __init__(self, ctx):
        self.made: weakref.WeakSet = weakref.WeakSet()
        for name in _FACTORIES:
            setattr(ctx, name, self._recording(getattr(ctx, name)))

    def _recording(self, factory):
        def make(*args, **kwargs):
            obj = factory(*args, **kwargs)
            self.made.add(obj)
            return obj

        return make


@pytest.fixture(scope="session")
def gl_session_ctx():
    """One headless OpenGL context for the whole session; skips when none can be made.

    Tests take :func:`gl_ctx`; only fixtures wider than a function (which outlive one test's
    checks) take this one.
    """
    from compare.progressive.context import create_context
    from compare.util.errors import MissingComponentError

    try:
        ctx = create_context()
    except MissingComponentError as exc:
        pytest.skip(f"no OpenGL 3.3+ context: {exc}")
    # Objects dropped without release() are queued on ctx.objects (instead of vanishing with their
    # GL names still allocated), so that gl_ctx can name and free them.
    ctx.gc_mode = "context_gc"
    ctx.extra = {"tracked": _Tracked(ctx), "viewport": ctx.viewport}
    yield ctx
    ctx.release()


def _reset_state(ctx) -> None:
    """OpenGL's initial state for what the passes set (they set all they need; this keeps a test from
    depending on the one before it)."""
    ctx.enable_only(ctx.NOTHING)
    ctx.blend_func = ctx.DEFAULT_BLENDING
    ctx.blend_equation = ctx.FUNC_ADD
    ctx.depth_func = "<"
    ctx.front_face = "ccw"
    ctx.cull_face = "back"
    ctx.wireframe = False
    ctx.polygon_offset = (0.0, 0.0)
    ctx.line_width = ctx.point_size = 1.0
    ctx.scissor = None
    ctx.viewport = ctx.extra["viewport"]
    ctx.fbo = None  # as made: the context has no default framebuffer (surfaceless EGL)
    ctx.clear_samplers(0, -1)


def _gl_errors(ctx) -> list[str]:
    errors = []
    for _ in range(8):  # one flag per kind of error; glGetError clears one each call
        error = ctx.error
        if error == "GL_NO_ERROR":
            break
        errors.append(error)
    return errors


def _dropped(ctx) -> list:
    """Objects garbage-collected without release() since the last call; frees them."""
    import moderngl

    leaked = []
    while ctx.objects:
        mglo = ctx.objects.popleft()
        if not isinstance(mglo, moderngl.InvalidObject):  # released ones queue an InvalidObject
            mglo.release()
            leaked.append(type(mglo).__name__)
    return leaked


@pytest.fixture
def gl_ctx(gl_session_ctx, request):
    """The session's OpenGL context, reset to OpenGL's initial state; after the test it must hold no
    GL error and the test must have released every GL object it made.

    moderngl queries have no release() (they go with the context), so they are not counted.
    """
    ctx = gl_session_ctx
    pending, dropped = _gl_errors(ctx), _dropped(ctx)
    if pending or dropped:
        pytest.fail(f"left by a fixture set up before the test: GL errors {pending}, objects never released "
                    f"{dropped}", pytrace=False)
    _reset_state(ctx)
    tracked = ctx.extra["tracked"]
    tracked.made.clear()
    yield ctx
    errors, dropped = _gl_errors(ctx), _dropped(ctx)
    live = sorted(type(o).__name__ for o in tracked.made if not isinstance(o.mglo, _invalid()))
    tracked.made.clear()
    problems = ([f"GL error(s) {', '.join(errors)}"] if errors else []) + (
        [f"GL objects garbage-collected without release(): {', '.join(dropped)}"] if dropped else []) + (
        [f"GL objects still alive and not released: {', '.join(live)}"] if live else [])
    if not problems:
        return
    call = request.node.stash.get(_CALL_REPORT, None)
    if call is not None and not call.passed:  # its traceback holds the test's objects: report, don't fail
        request.node.add_report_section("teardown", "gl_ctx", "; ".join(problems))
        return
    pytest.fail(f"{request.node.nodeid}: " + "; ".join(problems), pytrace=False)


def _invalid():
    import moderngl

    return moderngl.InvalidObject


# ----------------------------------------------------------------------------- scene files


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML value for {type(v).__name__}")


def _toml_tables(name: str, value) -> str:
    """``value`` as TOML under ``name``: a dict of dicts as ``[name.key]`` tables, a dict as a
    ``[name]`` table, a list of dicts as ``[[name]]`` tables."""
    if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
        return "".join(_toml_tables(f"{name}.{key}", v) for key, v in value.items())
    if isinstance(value, dict):
        return f"\n[{name}]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in value.items())
    if isinstance(value, (list, tuple)) and all(isinstance(v, dict) for v in value):
        return "".join(f"\n[[{name}]]\n" + "".join(f"{k} = {_toml_value(x)}\n" for k, x in v.items())
                       for v in value)
    raise TypeError(f"{name}: a table is a dict, a dict of dicts or a list of dicts")


@pytest.fixture
def make_scene(tmp_path):
    """``make_scene(*texts, name="scene.toml", folder=None, **tables) -> Path``: write a scene file.

    Each text is TOML as written in the test (dedented, joined in order); each keyword is a table
    after them, e.g. ``camera={"position": [0, 1, 3], ...}``, ``materials={"grey": {...}}``,
    ``meshes=[{...}, ...]``. The file goes into ``folder`` (default: the test's ``tmp_path``).
    """

    def make(*texts: str, name: str = "scene.toml", folder: Path | None = None, **tables) -> Path:
        path = Path(folder or tmp_path) / name
        path.write_text("".join(textwrap.dedent(t) for t in texts)
                        + "".join(_toml_tables(k, v) for k, v in tables.items()))
        return path

    return make
