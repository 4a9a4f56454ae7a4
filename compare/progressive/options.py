"""Variants of the progressive renderer named in ``--renderers``: ``progressive:<option>[+<option>…]``.

Each option sets :class:`~compare.progressive.rasterizer.Rasterizer` keywords, so
the report can show what each departure from the paper's technique costs and
gains against the same ground truth (an ablation):

``paper`` / ``radiometric`` / ``ltc``
    ``area_model``: the paper's isotropic point-light form, the
    radiometric point-on-area form (the default), or the closed-form unshadowed
    light of linearly transformed cosines times a stochastic shadow ratio
    (:mod:`compare.progressive.lights.ltc`).
``probes``
    ``indirect="probes"``: indirect diffuse light from an irradiance volume
    (:mod:`compare.progressive.indirect.probes`), with the scene's grid and bounces.
``vsm``
    ``shadow_filter="vsm"``: variance shadow maps instead of hard shadow tests.
``budget<ms>``
    ``frame_budget_ms``: as many samples per frame as fit in ``<ms>``
    milliseconds (:mod:`compare.progressive.schedule.budget`), e.g. ``budget16``.
``fullfirst``
    ``first_frame_scale=1``: frame 0 drawn at full size, as the paper's first
    frame, instead of the default half-size preview from 320×240 up
    (:mod:`compare.progressive.first_frame`).

Options combine with ``+``: ``progressive:probes+vsm``.
"""

from __future__ import annotations

from compare.renderers.options import parse_spec

__all__ = ["OPTIONS", "describe", "renderer_options"]

#: Options and what they mean (for messages and ``--help``).
OPTIONS = {
    "paper": "the paper's point-light area model",
    "radiometric": "the radiometric point-on-area model (default)",
    "ltc": "closed-form unshadowed area light (linearly transformed cosines) times a shadow ratio",
    "probes": "indirect diffuse light from an irradiance volume",
    "vsm": "variance shadow maps",
    "budget<ms>": "a per-frame time budget in milliseconds, e.g. budget16",
    "fullfirst": "frame 0 at full size (the paper's first frame)",
    "envshadows": "environment shadow maps: luminance-sampled directions, a shadow ratio of the split sum",
    "sun": "the environment's brightest compact region as a directional light with its own shadow map",
}
#: What each option sets among the rasterizer's keywords (None: the number written with it), and its words
#: in a report's label ("{}" takes that number).
_KEYWORDS = {
    "paper": ("area_model", "paper", "paper"),
    "radiometric": ("area_model", "radiometric", "radiometric"),
    "ltc": ("area_model", "ltc", "ltc"),
    "probes": ("indirect", "probes", "irradiance probes"),
    "vsm": ("shadow_filter", "vsm", "VSM"),
    "budget<ms>": ("frame_budget_ms", None, "{:g} ms frame budget"),
    "fullfirst": ("first_frame_scale", 1.0, "full-size first frame"),
    "envshadows": ("env_occlusion", "shadows", "environment shadow maps"),
    "sun": ("sun", True, "the environment's sun as a light"),
}


def renderer_options(spec: str) -> dict:
    """Rasterizer keywords of a renderer spec (``progressive`` gives ``{}``).

    Raises ValueError naming the unknown option and the known ones.
    """
    if spec.partition(":")[0] != "progressive":
        raise ValueError(f"{spec!r} is not a progressive renderer spec")
    kwargs: dict = {}
    for word, number in parse_spec(spec, OPTIONS):
        key, value, _ = _KEYWORDS[word]
        if key in kwargs:
            raise ValueError(f"renderer {spec!r}: {word!r} sets {key} twice")
        kwargs[key] = number if value is None else value
    return kwargs


def describe(spec: str) -> str:
    """A short label of a spec's options for reports, e.g. ``"probes, VSM"`` (empty for ``progressive``)."""
    renderer_options(spec)  # the same checks (an option twice) as the keywords
    return ", ".join(_KEYWORDS[word][2].format(number) for word, number in parse_spec(spec, OPTIONS))
