"""The progressive rasterizer: Otto, Limberger & Döllner (Web3D 2020) in moderngl.

Physically based environment and area lighting accumulated over frames: per
frame a jittered G-buffer and the split-sum environment light
(:mod:`compare.ibl`), per light sample a shadow atlas (five faces of a half
cube) and a full-screen lighting pass with the shared BRDF, per environment
sample a screen-space occlusion test, and running means in RGBA32F. Each pass
is a module with its shader beside it; :mod:`.rasterizer` builds the pass graph
(:func:`~compare.progressive.rasterizer.render_progressive`,
:class:`~compare.progressive.rasterizer.Rasterizer`), :mod:`.distributor` is the
sample distributor, :mod:`.renderer` the suite's renderer ``progressive`` and
:mod:`.options` its ``:<option>`` words.
"""
