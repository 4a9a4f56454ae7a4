"""Scenarios in the format of model-viewer's render-fidelity tools, as scenes of the suite.

google/model-viewer's fidelity page (``packages/render-fidelity-tools``) describes each of its
test images by a *scenario* in ``test/config.json``: ``scenarios[]`` with ``name``, ``model`` (a
glTF file), ``lighting`` (an equirectangular HDR), ``dimensions`` {width, height}, ``target``
{x, y, z}, ``orbit`` {theta, phi, radius}, ``verticalFoV``, ``renderSkybox`` and ``exclude``
(the names of renderers that skip it). :func:`load_scenarios` reads such a file as published
(paths relative to the file; the published ones leave its folder, ``../../../shared-assets/…``),
:meth:`Scenario.unavailable` says, without reading them, whether a scenario's files can be rendered here
(there, and lighting the suite reads), and :meth:`Scenario.scene` builds the suite's
:class:`~compare.scene.model.Scene` of one.

What each field means, from model-viewer's source (paths in google/model-viewer):

* Defaults: ``packages/render-fidelity-tools/src/config-reader.ts``, ``defaultScenario`` and
  ``ConfigReader.scenarioConfig``: lighting ``../../../shared-assets/environments/lightroom_14b.hdr``,
  dimensions 768 × 768, target (0, 0, 0) (the origin of the model's coordinates, not the centre of
  its bounds), orbit theta 0, phi 90, radius 1, verticalFoV 45, renderSkybox false. The scenario's
  own fields replace them one by one, and inside ``dimensions``, ``target`` and ``orbit`` key by key
  (``Object.assign`` of each nested object over its default).
* Types: ``packages/render-fidelity-tools/src/common.ts``, ``ScenarioConfig``: theta, phi and
  radius are numbers; ``exclude`` an optional array of renderer names.
* Units: the model-viewer renderer page ``packages/render-fidelity-tools/test/renderers/model-viewer/
  index.html`` sets ``cameraOrbit = `${theta}deg ${phi}deg ${radius}m```, ``min/maxCameraOrbit =
  `auto auto ${radius}m``` (the radius held fixed), ``cameraTarget = `${x}m ${y}m ${z}m```,
  ``fieldOfView = `${verticalFoV}deg```, ``environmentImage = lighting`` and ``skyboxImage =
  renderSkybox ? lighting : null``: degrees, degrees, metres, metres, a vertical field of view in
  degrees. There is no "auto" or percent form in a scenario: the page appends the unit to the number.
* The camera: ``packages/model-viewer/src/three-components/SmoothControls.ts``, ``moveCamera``: the
  position is three.js's ``Spherical`` (``setFromSpherical``, after ``makeSafe``, which keeps phi in
  [1e-6, π − 1e-6]) about the target, ``target + radius · (sin φ sin θ, cos φ, sin φ cos θ)``, and the
  orientation ``Euler(φ − π/2, θ, 0, 'YXZ')``, which looks along ``−(sin φ sin θ, cos φ, sin φ cos θ)``
  with up ``(−cos φ sin θ, sin φ, −cos φ cos θ)``, whatever the radius: a radius of 0 puts the camera
  on the target looking outward along that direction (``khronos-Sponza``: theta 90 looks along −X).
  ``packages/model-viewer/src/three-components/ModelScene.ts``, ``setTarget``/``getTarget``: the target
  is a point in the model's coordinates (the model is moved by −target; the camera orbits the origin).
* Near and far planes: ``packages/model-viewer/src/features/controls.ts``, ``[$updateCameraForRadius]``:
  near 0 and far ``2 · max(boundingSphere.radius, radius)``; ``SmoothControls.updateNearFar``: a far of 0
  becomes 2 and near becomes ``max(near, far / 1000)``; ``ModelScene.updateFraming``: the bounding
  sphere is centred on the target, its radius the largest distance of a vertex from it.
  (``three-gpu-pathtracer-viewer.ts`` of the fidelity tools uses the same formula, with the sphere of
  the model's bounding box.) The suite's cameras have no clip planes (a path tracer needs none), so
  these are reported (:meth:`Scenario.framed_camera`), not applied.
* Image size: ``dimensions`` are CSS pixels; ``packages/render-fidelity-tools/src/artifact-creator.ts``
  (``captureScreenshot``, ``analyze``) captures them at ``DEVICE_PIXEL_RATIO`` (2, ``common.ts``), so
  the page's images are twice as wide and high. The suite renders ``dimensions`` as pixels
  (``--size`` changes it for every scenario).
* Environment orientation: model-viewer lights with three.js, whose equirectangular lookup
  (``equirectUv`` in three's shader chunk ``common``) is ``u = atan2(z, x) / 2π + ½``: the suite's u
  (Mitsuba's, :mod:`compare.scene.equirect`) plus ¼, so the scene's environment turns by 90° about +Y.

Background: ``renderSkybox: false`` hides the environment behind the model in model-viewer (it still
lights the model); the scene gets ``[environment] background = false`` (camera rays that hit nothing see
black), and ``renderSkybox: true`` keeps the environment seen there. A renderer that cannot hide it says
so in its run (the feature ``hidden_background``, docs/scenarios.md).

What the suite does not reproduce: the ``<model-viewer>`` element itself clamps
phi to [22.5°, 157.5°] (``minCameraOrbitIntrinsics``/``maxCameraOrbitIntrinsics`` of ``controls.ts``)
and adjusts its field of view to the model (``ModelScene.adjustedFoV``, the min/max field of view of
``controls.ts``); the scenario's other renderers take theta, phi and verticalFoV as given
(``three-gpu-pathtracer-viewer.ts``: ``camera.fov = verticalFoV``), and so does the suite; a phi
outside the element's range gets a note. See ``docs/scenarios.md``.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from compare.util.errors import SceneError

__all__ = ["DEFAULTS", "RENDERER_NAMES", "Scenario", "ScenarioCamera", "load_scenarios", "suite_renderers"]

#: config-reader.ts ``defaultScenario``: what a scenario leaves out.
DEFAULTS: dict[str, Any] = {
    "lighting": "../../../shared-assets/environments/lightroom_14b.hdr",
    "dimensions": {"width": 768, "height": 768},
    "target": {"x": 0.0, "y": 0.0, "z": 0.0},
    "orbit": {"theta": 0.0, "phi": 90.0, "radius": 1.0},
    "verticalFoV": 45.0,
    "renderSkybox": False,
}

#: Renderer names of model-viewer's fidelity page → the suite's renderer of the same engine. The page's
#: others (dspbr-pt, stellar, rhodonite, vray, ...) have none here.
RENDERER_NAMES = {
    "model-viewer": "model-viewer",  # the <model-viewer> element itself (compare.web.model_viewer)
    "three-gpu-pathtracer": "threejs-pathtracer",
    "babylon": "babylon",
    "blender-cycles": "cycles",
    "gltf-sample-viewer": "gltf-sample-viewer",  # the Khronos glTF Sample Viewer (compare.web.sample_viewer)
    "filament": "filament",  # Filament's web build (compare.web.filament)
}

#: Fields of a scenario (common.ts ``ScenarioConfig``); ``pt`` (path-tracer samples) and ``clearColor``
#: are the page's own and do not change the scene.
_FIELDS = {"name", "model", "lighting", "dimensions", "target", "orbit", "verticalFoV", "renderSkybox", "exclude"}
_IGNORED = {"pt", "clearColor"}
#: three.js ``Spherical.makeSafe``: phi stays this far inside (0, π).
_SAFE_EPS = 1e-6
#: The <model-viewer> element's phi limits of its 'auto' min/max camera orbit (controls.ts): π/8, π − π/8.
_ELEMENT_PHI = (22.5, 157.5)
#: Environment rotation (degrees about +Y) that makes the suite's map lookup three.js's (see above).
ENVIRONMENT_ROTATION = 90.0


@dataclass(frozen=True)
class ScenarioCamera:
    """The camera model-viewer places for a scenario: position, viewing direction, up, vertical field
    of view (degrees), and the near and far planes model-viewer derives (metres)."""

    position: tuple[float, float, float]
    forward: tuple[float, float, float]
    up: tuple[float, float, float]
    fov: float
    near: float | None = None
    far: float | None = None


@dataclass(frozen=True)
class Scenario:
    """One scenario of a render-fidelity ``config.json``, with model-viewer's defaults filled in."""

    name: str
    model: Path
    """The glTF file, resolved against the config file's folder."""
    lighting: Path
    """The environment map (equirectangular), resolved likewise."""
    width: int
    height: int
    target: tuple[float, float, float]
    orbit: tuple[float, float, float]
    """theta (degrees), phi (degrees), radius (metres)."""
    vertical_fov: float
    render_skybox: bool
    exclude: tuple[str, ...]
    """Renderer names as the file gives them (model-viewer's names)."""
    source: Path
    """The config file."""
    index: int
    """The scenario's position in ``scenarios[]``."""
    given: tuple[str, str] = ("", "")
    """``model`` and ``lighting`` as the file writes them (for messages)."""

    @property
    def where(self) -> str:
        """``config.json: scenarios[3] (name)``: how messages name this scenario."""
        return f"{self.source}: scenarios[{self.index}] ({self.name})"

    def camera(self, bounding_radius: float | None = None) -> ScenarioCamera:
        """The camera of this scenario, as model-viewer's ``SmoothControls.moveCamera`` places it; with
        ``bounding_radius`` (the largest distance of the model's vertices from the target) also its near
        and far planes (``controls.ts``, ``[$updateCameraForRadius]``)."""
        theta, phi, radius = self.orbit
        t = math.radians(theta)
        p = min(max(math.radians(phi), _SAFE_EPS), math.pi - _SAFE_EPS)
        offset = np.array([math.sin(p) * math.sin(t), math.cos(p), math.sin(p) * math.cos(t)])
        up = np.array([-math.cos(p) * math.sin(t), math.sin(p), -math.cos(p) * math.cos(t)])
        position = np.asarray(self.target, dtype=np.float64) + radius * offset
        near = far = None
        if bounding_radius is not None:
            far = 2.0 * max(float(bounding_radius), radius)
            far = far if far > 0 else 2.0
            near = far / 1000.0
        vec = lambda v: tuple(float(x) for x in v)  # noqa: E731
        return ScenarioCamera(vec(position), vec(-offset), vec(up), self.vertical_fov, near, far)  # type: ignore[arg-type]

    def framed_camera(self, scene) -> ScenarioCamera:
        """:meth:`camera` with the near and far planes of ``scene`` (this scenario's :meth:`scene`): its
        bounding sphere about the target reaches the farthest vertex (of the meshes and of the emissive
        rectangles the scene made lights of), as ``ModelScene.updateFraming`` measures it."""
        target = np.asarray(self.target, dtype=np.float64)
        reach = 0.0
        for m in scene.meshes:
            p = m.triangles().positions
            if len(p):
                reach = max(reach, float(np.linalg.norm(p - target, axis=1).max()))
        for light in scene.lights:
            reach = max(reach, float(np.linalg.norm(light.corners() - target, axis=1).max()))
        return self.camera(reach)

    def suite_excluded(self, known: Iterable[str]) -> tuple[str, ...]:
        """The suite's renderer names this scenario excludes (:func:`suite_renderers`)."""
        return suite_renderers(self.exclude, known)

    def scene(self):
        """The suite's :class:`~compare.scene.model.Scene` of this scenario: the model as an include
        (its own cameras unused), the lighting as the environment, model-viewer's camera, the size of
        ``dimensions``; named after the scenario, its path the config file.

        Raises
        ------
        SceneError
            One message naming the scenario and what is wrong (a missing file, lighting in a format the
            suite does not read, a model the reader refuses).
        """
        from compare.scene.loader import parse_scene

        self.check_files()
        cam = self.camera()
        look_at = np.add(cam.position, cam.forward) if self.orbit[2] == 0 else self.target
        folder = self.source.parent.resolve()
        data = {
            "name": self.name,
            "include": {"file": os.path.relpath(self.model, folder), "camera": False},
            # the page's skyboxImage: the lighting seen behind the model, or nothing there (the field only
            # where it is false, so that the scenes of renderSkybox true keep their hashes)
            "environment": {"file": os.path.relpath(self.lighting, folder), "rotation": ENVIRONMENT_ROTATION,
                            **({} if self.render_skybox else {"background": False})},
            "camera": {"position": list(cam.position), "target": [float(x) for x in look_at], "up": list(cam.up),
                       "fov": cam.fov, "resolution": [self.width, self.height]},
        }
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                scene = parse_scene(data, self.source)
            except SceneError as exc:
                raise SceneError(self._rename(str(exc))) from None
        for w in caught:  # the notes of reading the model, named by scenario
            warnings.warn(self._rename(str(w.message)), stacklevel=2)
        return scene

    @property
    def lighting_readable(self) -> bool:
        """Whether the lighting is a file the suite reads as an environment (linear radiance: .exr, .hdr), by
        its name; model-viewer's pages also take LDR images."""
        return self.lighting.suffix.lower() in _env_suffixes()

    def unavailable(self) -> str | None:
        """Why this scenario cannot be rendered here, known without reading its files, in a few words
        (``model file '…' not found``; ``lighting '…' is not an .exr or .hdr file``), or None. A file that
        is there but that the reader refuses is :meth:`scene`'s error, not this."""
        problem = self._problem()
        if problem is None:
            return None
        field, given, _, kind = problem
        if kind == "format":
            return f"{field} {given!r} is not an {' or '.join(_env_suffixes())} file"
        return f"{field} file {given!r} not found"

    def check_files(self) -> None:
        """Raise :meth:`unavailable`'s reason as one :class:`SceneError` naming the scenario, the field and the
        path (as given, and where it was looked for); return where the files are there.

        Raises
        ------
        SceneError
            The model or lighting file not found, or lighting in a format the suite does not read.
        """
        problem = self._problem()
        if problem is None:
            return
        field, given, path, kind = problem
        if kind == "format":
            raise SceneError(f"{self.where}: {field}: {given!r}: the suite reads environments from "
                             f"{' or '.join(_env_suffixes())} files (linear radiance); convert the map or leave "
                             "the scenario out")
        raise SceneError(f"{self.where}: {field}: file {given!r} not found (looked for {path})")

    def _problem(self) -> tuple[str, str, Path, str] | None:
        """(field, path as given, path resolved, ``format`` or ``missing``) of the first of: lighting in a
        format the suite does not read (no download fixes that), the model not found, the lighting not
        found."""
        if not self.lighting_readable:
            return "lighting", self.given[1], self.lighting, "format"
        for field, path, given in (("model", self.model, self.given[0]), ("lighting", self.lighting, self.given[1])):
            if not path.is_file():
                return field, given, path, "missing"
        return None

    def _rename(self, message: str) -> str:
        """A message of the scene loader about this scenario's synthesized scene, in the file's terms."""
        head = f"{self.source}: "
        body = message[len(head):] if message.startswith(head) else message
        for field, ours in (("include.file: ", "model: "), ("include: ", "model: "),
                            ("environment.file: ", "lighting: ")):
            if body.startswith(field):
                body = ours + body[len(field):]
                break
        return f"{self.where}: {body}"


def suite_renderers(names: Iterable[str], known: Iterable[str]) -> tuple[str, ...]:
    """The suite's renderer names of model-viewer's renderer ``names``: :data:`RENDERER_NAMES`, or a name
    the suite knows itself (``known``: the registry's names, which the scene layer does not see); other
    names are dropped."""
    known = set(known)
    out: list[str] = []
    for n in names:
        mapped = RENDERER_NAMES.get(n, n)
        if mapped in known and mapped not in out:
            out.append(mapped)
    return tuple(out)


def load_scenarios(path: str | os.PathLike) -> list[Scenario]:
    """Read a render-fidelity ``config.json`` (model-viewer's format) into its scenarios, defaults filled
    in as model-viewer's config reader fills them (:data:`DEFAULTS`). Files are not opened here.

    Raises
    ------
    SceneError
        The file cannot be read, is not such a config, or a scenario has a field of the wrong type or
        range; one message naming the file, the scenario and the field.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{path}: scenario file not found") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read scenario file: {exc.strerror or exc}") from None
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SceneError(f"{path}: not a JSON document: {exc}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("scenarios"), list):
        raise SceneError(f"{path}: scenarios: expected a render-fidelity config, an object with a "
                         "'scenarios' array (model-viewer's packages/render-fidelity-tools/test/config.json)")
    if not doc["scenarios"]:
        raise SceneError(f"{path}: scenarios: the array is empty")
    out: list[Scenario] = []
    seen: dict[str, int] = {}
    ignored: set[str] = set()
    for k, raw_sc in enumerate(doc["scenarios"]):
        sc = _scenario(path, k, raw_sc, ignored)
        if sc.name in seen:
            raise SceneError(f"{path}: scenarios[{k}].name: {sc.name!r} is also scenarios[{seen[sc.name]}]'s "
                             "(the name keys its results)")
        seen[sc.name] = k
        out.append(sc)
    _notes(path, out, ignored)
    return out


def _notes(path: Path, scenarios: list[Scenario], ignored: set[str]) -> None:
    """Say once per file what of the scenarios the suite does not reproduce."""
    for s in scenarios:
        phi = s.orbit[1]
        if not _ELEMENT_PHI[0] <= phi <= _ELEMENT_PHI[1]:
            warnings.warn(f"{s.where}: orbit.phi {phi:g}° is outside the <model-viewer> element's range "
                          f"[{_ELEMENT_PHI[0]:g}°, {_ELEMENT_PHI[1]:g}°] (its own image clamps it); the suite "
                          "uses it as given, as the page's other renderers do", stacklevel=3)
    if ignored:
        warnings.warn(f"{path}: field(s) {', '.join(sorted(ignored))} of the scenarios ignored (they do not "
                      "change the scene)", stacklevel=3)


def _scenario(path: Path, k: int, raw: Any, ignored: set[str]) -> Scenario:
    where = f"{path}: scenarios[{k}]"
    if not isinstance(raw, dict):
        raise SceneError(f"{where}: expected an object, got {_kind(raw)}")
    name = raw.get("name")
    if not isinstance(name, str) or not name:
        raise SceneError(f"{where}.name: expected a non-empty string, got {_kind(name)}")
    where = f"{where} ({name})"
    unknown = sorted(set(raw) - _FIELDS - _IGNORED)
    if unknown:
        raise SceneError(f"{where}: {unknown[0]}: unknown field (allowed: {', '.join(sorted(_FIELDS | _IGNORED))})")
    ignored.update(set(raw) & _IGNORED)
    if "model" not in raw:
        raise SceneError(f"{where}: model: missing required field")
    folder = path.parent.resolve()
    given_model, model = _file(where, "model", raw["model"], folder)
    # a lighting image the suite does not read (model-viewer's pages also take LDR JPEGs) is this scenario's
    # Scenario.unavailable(), not the file's error: the other scenarios stay readable
    given_light, lighting = _file(where, "lighting", raw.get("lighting", DEFAULTS["lighting"]), folder)
    dims = _merged(where, "dimensions", raw, ("width", "height"))
    size = []
    for key in ("width", "height"):
        v = dims[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not float(v).is_integer() or v < 1:
            raise SceneError(f"{where}: dimensions.{key}: expected a positive integer (CSS pixels), got {_kind(v)}")
        size.append(int(v))
    target = _merged(where, "target", raw, ("x", "y", "z"))
    orbit = _merged(where, "orbit", raw, ("theta", "phi", "radius"))
    for field, table, keys in (("target", target, "xyz"), ("orbit", orbit, ("theta", "phi", "radius"))):
        for key in keys:
            if not _finite(table[key]):
                unit = "metres" if field == "target" or key == "radius" else "degrees"
                raise SceneError(f"{where}: {field}.{key}: expected a number ({unit}; the page appends the unit, "
                                 f"so there is no 'auto' or percent form), got {_kind(table[key])}")
    if orbit["radius"] < 0:
        raise SceneError(f"{where}: orbit.radius: expected metres >= 0, got {orbit['radius']!r}")
    fov = raw.get("verticalFoV", DEFAULTS["verticalFoV"])
    if not _finite(fov) or not 0 < fov < 180:
        raise SceneError(f"{where}: verticalFoV: expected degrees in (0, 180), got {_kind(fov)}")
    skybox = raw.get("renderSkybox", DEFAULTS["renderSkybox"])
    if not isinstance(skybox, bool):
        raise SceneError(f"{where}: renderSkybox: expected true or false, got {_kind(skybox)}")
    exclude = raw.get("exclude", [])
    if not isinstance(exclude, list) or not all(isinstance(n, str) for n in exclude):
        raise SceneError(f"{where}: exclude: expected an array of renderer names, got {_kind(exclude)}")
    return Scenario(name=name, model=model, lighting=lighting, width=size[0], height=size[1],
                    target=tuple(float(target[c]) for c in "xyz"),  # type: ignore[arg-type]
                    orbit=(float(orbit["theta"]), float(orbit["phi"]), float(orbit["radius"])),
                    vertical_fov=float(fov), render_skybox=skybox, exclude=tuple(exclude), source=path, index=k,
                    given=(given_model, given_light))


def _file(where: str, field: str, v: Any, folder: Path) -> tuple[str, Path]:
    """A file path of the scenario, resolved against the config file's folder (it may leave it)."""
    if not isinstance(v, str) or not v:
        raise SceneError(f"{where}: {field}: expected a file path (string), got {_kind(v)}")
    if "://" in v:
        raise SceneError(f"{where}: {field}: {v!r} is a URL; give a file path relative to the config file")
    return v, (folder / v).resolve()


def _merged(where: str, field: str, raw: dict, keys: tuple[str, ...] | str) -> dict:
    """The scenario's object ``field`` over its default, key by key (config-reader.ts's Object.assign)."""
    given = raw.get(field, {})
    if not isinstance(given, dict):
        raise SceneError(f"{where}: {field}: expected an object, got {_kind(given)}")
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise SceneError(f"{where}: {field}.{unknown[0]}: unknown field (allowed: {', '.join(keys)})")
    return {**DEFAULTS[field], **given}


def _env_suffixes() -> tuple[str, ...]:
    """The environment files the suite reads (the scene model's list)."""
    from compare.scene.model import ENV_FILE_SUFFIXES

    return tuple(ENV_FILE_SUFFIXES)


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _kind(v: Any) -> str:
    """A value as a message quotes it."""
    if isinstance(v, (dict, list)):
        return "an object" if isinstance(v, dict) else f"an array {json.dumps(v)[:60]}"
    return json.dumps(v)
