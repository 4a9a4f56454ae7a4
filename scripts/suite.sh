#!/usr/bin/env bash
# One entry point for a fresh machine: set everything up, then run a job.
#
#   scripts/suite.sh main    set up what it runs, then evaluate the Cornell box (results.json + HTML report)
#   scripts/suite.sh test    set up, then run the default test suite
#   scripts/suite.sh slow    set up, then run the slow tests only
#   scripts/suite.sh setup   set up only
#
# Set-up is idempotent: system packages are installed only when missing, and the
# virtual environment (.venv) is rebuilt only when pyproject.toml changes.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
VENV="$ROOT/.venv"

log() { printf '[suite] %s\n' "$*" >&2; }

find_python() {
    for py in python3.11 python3; do
        if command -v "$py" >/dev/null 2>&1 && "$py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
            command -v "$py"; return 0
        fi
    done
    log "Python 3.11 is required (bpy 5.0.1 and the pinned wheels are cp311); install it and retry"
    exit 1
}

have_llvm() {  # a libLLVM new enough for Dr.Jit 1.5 (>= 16)
    ls /usr/lib/*/libLLVM*.so* /usr/lib/llvm-*/lib/libLLVM*.so* 2>/dev/null |
        grep -Eq 'libLLVM[-.]?(1[6-9]|[2-9][0-9])|libLLVM\.so\.(1[6-9]|[2-9][0-9])'
}

have_egl() {  # EGL plus Mesa's software rasterizer (llvmpipe)
    ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' || return 1
    local f
    for f in /usr/lib/*/dri/swrast_dri.so /usr/lib/*/libgallium*.so; do
        [ -e "$f" ] && return 0
    done
    return 1
}

apt_install() {
    if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
        log "cannot install $* here (needs root and apt-get); install them by hand"
        return 1
    fi
    if [ -z "${_APT_UPDATED:-}" ]; then
        apt-get update -qq >/dev/null 2>&1 || log "apt-get update failed; trying the install anyway"
        _APT_UPDATED=1
    fi
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

setup_system() {
    if ! ldconfig -p 2>/dev/null | grep -q 'libatomic.so.1'; then
        log "installing libatomic1 (Dr.Jit's native extension links it; a minimal Debian lacks it)"
        apt_install libatomic1 || log "WARNING: no libatomic1: Mitsuba and Dr.Jit will not import"
    fi
    if ! have_llvm; then
        log "installing libllvm19 (Dr.Jit's LLVM backend crashes with Debian's default LLVM 14/15)"
        apt_install libllvm19 ||
            log "WARNING: no libLLVM >= 16: Mitsuba will fall back to the slow scalar_rgb variant"
    fi
    if ! have_egl; then
        log "installing EGL and Mesa (headless OpenGL for the progressive rasterizer)"
        apt_install libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 ||
            log "WARNING: no EGL/Mesa: the progressive rasterizer and its tests will not run"
    fi
}

setup_python() {
    local stamp="$VENV/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
    if [ -f "$stamp" ]; then return 0; fi
    if [ -x "$VENV/bin/python" ] && ! "$VENV/bin/python" -m pip --version >/dev/null 2>&1; then
        log "removing $VENV: an earlier attempt left it without pip"
        rm -rf "$VENV"
    fi
    if [ ! -x "$VENV/bin/python" ]; then
        local py; py=$(find_python)
        if ! "$py" -c 'import ensurepip' >/dev/null 2>&1; then  # Debian splits venv's pip bootstrap off
            log "installing python3-venv (python -m venv needs its ensurepip)"
            apt_install python3-venv ||
                { log "python -m venv cannot run here: install python3-venv (Debian) and retry"; exit 1; }
        fi
        log "creating $VENV with $py (a few minutes the first time)"
        "$py" -m venv "$VENV" || { rm -rf "$VENV"; log "python -m venv failed (output above)"; exit 1; }
    fi
    log "installing the package and its test tools into $VENV"
    "$VENV/bin/python" -m pip install -q --upgrade pip 2>&1 | grep -v '^WARNING: Location' >&2 || true
    "$VENV/bin/python" -m pip install -q -e ".[dev]" 2>&1 | grep -v '^WARNING: Location' >&2 || true
    "$VENV/bin/python" -c 'import compare, mitsuba, moderngl, OpenEXR, flip_evaluator, skimage' ||
        { log "the Python install failed; see the pip output above"; exit 1; }
    rm -f "$VENV"/.installed-*
    touch "$stamp"
}

have_chromium() { command -v chromium >/dev/null 2>&1; }

# The web engines (compare/web/renderer.py): Debian's Chromium, driven by Playwright (a dev
# dependency), and three.js, three-gpu-pathtracer, Babylon.js and PlayCanvas from npm, pinned by
# web/package-lock.json.
# Optional: without them the web engines say what is missing and their tests skip with the reason.
setup_web() {
    if ! have_chromium; then
        log "installing Chromium (the web engines and the report's browser test)"
        apt_install chromium || log "WARNING: no Chromium: the web engines and browser tests will skip"
    fi
    local stamp="web/node_modules/.installed-$(sha256sum web/package-lock.json | cut -c1-16)"
    if [ ! -f "$stamp" ]; then
        if command -v npm >/dev/null 2>&1; then
            log "installing the web engines' npm packages (npm ci --prefix web)"
            if npm ci --prefix web --no-audit --no-fund --loglevel=error >&2; then
                touch "$stamp"
            else
                log "WARNING: npm ci failed: the web engines will say so and their tests will skip"
            fi
        else
            log "WARNING: no npm: the web engines will say so and their tests will skip"
        fi
    fi
}

BLENDER_VENV="$ROOT/.venv-blender"
BLENDER_LIBS="libx11-6 libxext6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6 libgl1"

# The blender extra (bpy 5.0.1) in an environment of its own: it pins numpy < 2, which the main
# one does not. Measured here: 25 s to install (374 MB download, 1 GB on disk), after which the
# Blender tests of the default run take about 15 s, so the test command sets it up and the Cycles
# and EEVEE checks run in CI. Optional: when it cannot be installed those tests skip with the reason.
setup_blender() {
    if [ -n "${COMPARE_BLENDER_PYTHON:-}" ]; then return 0; fi  # the caller named one
    if [ "${COMPARE_NO_BLENDER:-}" = 1 ]; then return 0; fi
    local pin stamp missing="" lib py
    pin=$(grep -o 'bpy==[0-9.]*' pyproject.toml | head -n 1)
    stamp="$BLENDER_VENV/.installed-$pin"
    if command -v dpkg >/dev/null 2>&1; then  # elsewhere the import below says whether bpy loads
        for lib in $BLENDER_LIBS; do
            dpkg -s "$lib" >/dev/null 2>&1 || missing="$missing $lib"
        done
    fi
    if [ -n "$missing" ]; then
        log "installing the X11/GL libraries bpy loads:$missing"
        # shellcheck disable=SC2086
        apt_install $missing || { log "WARNING: without them bpy cannot load: the Blender tests will skip"; return 0; }
    fi
    if [ ! -f "$stamp" ]; then
        log "installing the blender extra ($pin) into $BLENDER_VENV (about 30 s, 1 GB)"
        py=$(find_python) || { log "WARNING: no Python 3.11 for bpy: the Blender tests will skip"; return 0; }
        rm -rf "$BLENDER_VENV"
        if ! { "$py" -m venv "$BLENDER_VENV" &&
               "$BLENDER_VENV/bin/python" -m pip install -q "$pin" 2>&1 | grep -v '^WARNING: Location' >&2;
               "$BLENDER_VENV/bin/python" -c 'import bpy' >/dev/null 2>&1; }; then
            log "WARNING: bpy could not be installed: the Blender tests will skip"
            rm -rf "$BLENDER_VENV"
            return 0
        fi
        touch "$stamp"  # only a complete install counts: an interrupted one is redone
    fi
    export COMPARE_BLENDER_PYTHON="$BLENDER_VENV/bin/python"
    # recorded for `compare` run from anywhere, without the variable (compare/util/installed.py)
    "$VENV/bin/python" - "$BLENDER_VENV/bin/python" <<'PY'
import json, sys
from pathlib import Path
record = Path(sys.prefix) / "compare-environment.json"
data = json.loads(record.read_text()) if record.is_file() else {}
data["blender_python"] = sys.argv[1]
tmp = record.with_suffix(".json.part")
tmp.write_text(json.dumps(data, indent=1) + "\n")
tmp.replace(record)
PY
}

# Each set-up step with its wall time in the log (where a fresh machine's minutes go).
timed() {
    local t0=$SECONDS
    "$@"
    log "$1: $((SECONDS - t0)) s"
}

setup() { timed setup_system; timed setup_python; timed setup_web; }

job="${1:-}"
shift || true
case "$job" in
    setup) setup ;;
    main)
        # only what the main job runs: the web engines' Chromium and npm packages come with `setup`/`test`
        # (a web renderer that is asked for without them says so, with that command)
        timed setup_system; timed setup_python
        out="reports/cornell"
        # the ground truth renders until its own noise is below the stated target (--spp auto: 512 spp here)
        "$VENV/bin/compare" run --scenes scenes/cornell.toml --size 320x240 --frames 128 --spp auto \
            --renderer-config examples/renderers.toml \
            --renderers mitsuba,progressive,progressive:paper,progressive:ltc,numpy-raycaster -o "$out" "$@"
        log "report: $ROOT/$out/index.html"
        ;;
    test)
        setup
        timed setup_blender
        log "ruff (syntax errors, undefined and unused names)"
        "$VENV/bin/ruff" check --quiet compare tools tests scenes examples scripts notebooks/make_notebooks.py
        # the slowest tests are listed at the end: where the default run's time goes; one worker per
        # core (pytest-xdist; the caches are content-keyed and shared), each test to whichever is free
        exec "$VENV/bin/python" -m pytest -n auto --dist worksteal --durations=25 "$@"
        ;;
    slow)
        setup
        timed setup_blender
        exec "$VENV/bin/python" -m pytest -n auto --dist worksteal -m slow "$@"
        ;;
    *)
        echo "usage: scripts/suite.sh {main|test|slow|setup} [extra arguments]" >&2
        exit 2
        ;;
esac
