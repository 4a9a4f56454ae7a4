"""The progressive rasterizer: Otto, Limberger & Döllner (Web3D 2020) in moderngl.

Physically based environment and area lighting accumulated over frames: per
frame a jittered G-buffer and the split-sum environment light
(:mod:`compare.ibl`), per light sample a shadow atlas (five faces of a half
cube) and a full-screen lighting pass with the shared BRDF, per environment
sample a screen-space occlusion test, and running means in RGBA32F.

Public API
----------
:func:`render_progressive`
    scene → :class:`ProgressiveResult` (image, seconds, frame_seconds, metadata, checkpoints).
:class:`ProgressiveRenderer`
    frame by frame: ``frames()`` yields (frames done, cumulative seconds), ``image()`` reads back.
:func:`plan`
    the sample distributor (which frame evaluates which sample), inspectable without a GL context.
:func:`create_context`
    a headless EGL context, or :class:`~compare.util.errors.MissingComponentError` saying what to install.

Module map (each pass with its shader): ``distributor`` + ``sampling`` (Algorithm 1,
R2 points), ``budget`` (the adaptive frame budget), ``gpu_scene`` (upload, camera),
``first_frame`` (the forward-shaded cheap frame 0, ``first_frame.glsl``), ``gbuffer``
(``gbuffer.glsl``), ``shadow`` (``shadow.glsl``; variance shadow maps ``vsm.glsl``,
``vsm_blur.glsl``; the shared test ``shadow_test.glsl``), ``direct`` (``direct.glsl``;
the light's math ``area_light.glsl``), ``environment`` (``env_occlusion.glsl``; the
IBL GLSL is ``compare/ibl/ibl.glsl``), ``accumulate`` (``accumulate.glsl``,
``compose.glsl``), ``probes`` + ``indirect`` (the irradiance volume for indirect
diffuse light, ``probes*.glsl``, ``indirect.glsl``; optional), ``readback``, ``renderer``.
"""

from compare.progressive.context import create_context
from compare.progressive.distributor import EnvSample, FramePlan, LightSample, Plan, plan
from compare.progressive.rasterizer import Checkpoint, ProgressiveRenderer, ProgressiveResult, render_progressive

__all__ = [
    "Checkpoint",
    "EnvSample",
    "FramePlan",
    "LightSample",
    "Plan",
    "ProgressiveRenderer",
    "ProgressiveResult",
    "create_context",
    "plan",
    "render_progressive",
]
