"""Every texture unit of the rasterizer's programs, in one table.

A program reads a texture through a unit: the texture is bound to the unit, and the sampler
uniform holds the unit's number. Two inputs of one program on one unit would read the same
texture, so each program's inputs take disjoint ranges of units. :data:`PROGRAM_UNITS` is the
table: for every program (a ``.glsl`` file that :func:`~compare.progressive.gl.shaders.load_program`
compiles) the range of each input, by role; a pass takes its units from its program's row, and a new
input takes a free range of that row. Three groups have the same range in every program that reads
them, because one helper binds them for all: :data:`GBUFFER` (:meth:`GBuffer.bind
<compare.progressive.frame.gbuffer.GBuffer.bind>`), :data:`MAPS` and :data:`LAYERS`
(:class:`~compare.progressive.frame.gpu_scene.GpuScene`). :func:`check_units` refuses two ranges
of one program that overlap, a shared group out of its place and a unit beyond what OpenGL 3.3
guarantees; it runs on import.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Iterator, Mapping

import numpy as np

from compare.progressive.gl.shaders import set_uniform

__all__ = ["GBUFFER", "LAYERS", "MAPS", "MAX_UNITS", "PROGRAM_UNITS", "SHARED", "Units", "bind", "bind_array",
           "check_units", "units_of"]

#: Texture units an OpenGL 3.3 context guarantees (GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS).
MAX_UNITS = 48


@dataclass(frozen=True)
class Units:
    """``count`` consecutive texture units from ``first`` on: one input, or an array's or a group's elements."""

    first: int
    count: int = 1

    def __post_init__(self):
        if self.first < 0 or self.count < 1:
            raise ValueError(f"texture units: expected first >= 0 and count >= 1, got {self.first}, {self.count}")

    @property
    def stop(self) -> int:
        """One past the last unit."""
        return self.first + self.count

    def __getitem__(self, k: int) -> int:
        """The unit of element ``k``."""
        if not 0 <= k < self.count:
            raise IndexError(f"texture unit {k} of a range of {self.count} (units {self.first} … {self.stop - 1})")
        return self.first + k

    def __iter__(self) -> Iterator[int]:
        return iter(range(self.first, self.stop))

    def __len__(self) -> int:
        return self.count

    def overlaps(self, other: "Units") -> bool:
        return self.first < other.stop and other.first < self.stop

    def __str__(self) -> str:
        return str(self.first) if self.count == 1 else f"{self.first} … {self.stop - 1}"


#: The G-buffer's four targets in GBuffer.NAMES order: position, normal, material, emission (the probe
#: bake's cube-face G-buffer has the same four; ``gbuffer_inputs.glsl`` declares their samplers).
GBUFFER = Units(0, 4)
#: The material maps in GpuScene's order (frame.gpu_scene.MAP_SLOTS): base colour, metallic-roughness,
#: emission, occlusion, normal, then the extensions' seven maps.
MAPS = Units(24, 12)
#: The sheen albedo table, then the G-buffer's layer targets (frame.gpu_scene.LAYER_TARGETS).
LAYERS = Units(20, 4)
#: The groups whose range is the same in every program (one helper binds each).
SHARED = MappingProxyType({"gbuffer": GBUFFER, "maps": MAPS, "layers": LAYERS})

#: Four units: the map, the prefiltered atlas, the irradiance and the split-sum table
#: (EnvironmentLighting.bind).
_ENVIRONMENT = 4
#: Three units: the SH coefficients, the distance moments and the split-sum table (ProbeVolume.bind).
_PROBES = 3
#: The most lights one draw of punctual.glsl shades, a shadow map each (lights.punctual.MAX_BATCH): with
#: the G-buffer's three, the previous mean and the four of the layers, the 16 samplers a fragment
#: shader of OpenGL 3.3 is guaranteed.
_PUNCTUAL_BATCH = 8


def _row(**roles) -> Mapping[str, Units]:
    return MappingProxyType({name: r if isinstance(r, Units) else Units(*r) for name, r in roles.items()})


#: Program → role → units. A role of a shared group names it; other roles belong to the row alone.
PROGRAM_UNITS: Mapping[str, Mapping[str, Units]] = MappingProxyType({
    # frame/
    "gbuffer.glsl": _row(maps=MAPS),
    "depth_only.glsl": _row(maps=MAPS),
    "accumulate.glsl": _row(gbuffer=GBUFFER, previous=(4,), previous_env=(5,), environment=(6, _ENVIRONMENT),
                            layers=LAYERS),
    # the display's sources, in ComposePass.SOURCES order
    "compose.glsl": _row(sources=(0, 11)),
    # lights/
    "shadow.glsl": _row(maps=MAPS),
    "vsm_blur.glsl": _row(source=(0,)),
    "direct.glsl": _row(gbuffer=GBUFFER, shadow=(4,), previous=(5,), partial=(6,), ltc_specular=(7,),
                        spec_lut=(8,), ltc=(9,), layers=LAYERS),
    "ltc_light.glsl": _row(gbuffer=GBUFFER, spec_lut=(4,), ltc=(5,), layers=LAYERS),
    "ltc_compose.glsl": _row(diffuse=(0,), specular=(1,), ratio=(2,)),
    "punctual.glsl": _row(gbuffer=GBUFFER, previous=(4,), shadow_maps=(5, _PUNCTUAL_BATCH), layers=LAYERS),
    # environment/
    "env_occlusion.glsl": _row(gbuffer=GBUFFER, previous=(4, 2), environment=(6, _ENVIRONMENT), layers=LAYERS),
    "env_shadows.glsl": _row(gbuffer=GBUFFER, shadow=(4,), environment=(5, _ENVIRONMENT), layers=LAYERS),
    # indirect/
    "indirect.glsl": _row(gbuffer=GBUFFER, previous=(4,), probes=(5, _PROBES)),
    "probes_gbuffer.glsl": _row(instances=(0,), maps=MAPS),
    "probes_direct.glsl": _row(gbuffer=GBUFFER, shadow=(4,)),
    "probes_punctual.glsl": _row(gbuffer=GBUFFER, shadow=(4,)),
    "probes_shade.glsl": _row(gbuffer=GBUFFER, direct=(4,), probes=(5, _PROBES), environment=(8, _ENVIRONMENT)),
    # the forward passes (frame 0, the blended meshes): the G-buffer's position only (the blend pass)
    # the glass pass (glass.py) also reads the opaque image and the glass's back faces
    "first_frame.glsl": _row(gbuffer=GBUFFER, spec_lut=(4,), ltc=(5,), environment=(6, _ENVIRONMENT), maps=MAPS,
                             opaque=(16,), glass_back=(17,), glass_share=(18,), layers=LAYERS),
    "glass_back.glsl": _row(maps=MAPS),
    "blend_fold.glsl": _row(previous=(0,), frame=(1,)),
    # gl/
    "srgb_probe.glsl": _row(codes=(0,)),
})


def check_units(table: Mapping[str, Mapping[str, Units]] = PROGRAM_UNITS) -> None:
    """Raise ValueError naming the program and the roles when two ranges of one program overlap, a shared
    group (:data:`SHARED`) is not at its place, or a unit is beyond :data:`MAX_UNITS`."""
    for program, row in table.items():
        roles = list(row.items())
        for i, (a, ua) in enumerate(roles):
            if a in SHARED and ua != SHARED[a]:
                raise ValueError(f"{program}: {a} takes units {ua}; every program has it at {SHARED[a]}")
            if ua.stop > MAX_UNITS:
                raise ValueError(f"{program}: {a} takes units {ua}, beyond the {MAX_UNITS} OpenGL 3.3 guarantees")
            for b, ub in roles[i + 1:]:
                if ua.overlaps(ub):
                    raise ValueError(f"{program}: {a} (units {ua}) and {b} (units {ub}) overlap")


def units_of(program: str) -> Mapping[str, Units]:
    """The row of ``program`` (a ``.glsl`` name): role → :class:`Units`."""
    try:
        return PROGRAM_UNITS[program]
    except KeyError:
        raise KeyError(f"{program}: no row in compare.progressive.gl.units.PROGRAM_UNITS") from None


def bind(program, uniform: str, texture, units: Units, k: int = 0) -> None:
    """Bind ``texture`` to element ``k`` of ``units`` and point sampler ``uniform`` of ``program`` at it."""
    unit = units[k]
    texture.use(location=unit)
    set_uniform(program, uniform, unit)


def bind_array(program, uniform: str, textures, units: Units) -> None:
    """Bind ``textures`` to the first elements of ``units`` and point sampler array ``uniform`` at them."""
    if len(textures) > len(units):
        raise ValueError(f"{uniform}: {len(textures)} textures for a range of {len(units)} units ({units})")
    for k, texture in enumerate(textures):
        texture.use(location=units[k])
    set_uniform(program, uniform, np.arange(units.first, units.first + len(textures), dtype=np.int32).tobytes())


check_units()
