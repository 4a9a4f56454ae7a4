"""Variants of the progressive renderer named in ``--renderers``: ``progressive:<option>[+<option>…]``.

Each option sets :class:`~compare.progressive.ProgressiveRenderer` keywords, so
the report can show what each departure from the paper's technique costs and
gains against the same ground truth (an ablation):

``paper`` / ``radiometric`` / ``ltc``
    ``area_model``: the paper's isotropic point-light form, the
    radiometric point-on-area form (the default), or the closed-form unshadowed
    light of linearly transformed cosines times a stochastic shadow ratio
    (:mod:`compare.progressive.ltc`).
``probes``
    ``indirect="probes"``: indirect diffuse light from an irradiance volume
    (:mod:`compare.progressive.probes`), with the scene's grid and bounces.
``vsm``
    ``shadow_filter="vsm"``: variance shadow maps instead of hard shadow tests.
``budget<ms>``
    ``frame_budget_ms``: as many samples per frame as fit in ``<ms>``
    milliseconds (:mod:`compare.progressive.budget`), e.g. ``budget16``.
``fullfirst``
    ``first_frame_scale=1``: frame 0 drawn at full size, as the paper's first
    frame, instead of the default half-size preview from 320×240 up
    (:mod:`compare.progressive.first_frame`).

Options combine with ``+``: ``progressive:probes+vsm``.
"""

from __future__ import annotations

import re

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
}
_BUDGET = re.compile(r"budget(\d+(?:\.\d+)?)")


def renderer_options(spec: str) -> dict:
    """ProgressiveRenderer keywords of a renderer spec (``progressive`` gives ``{}``).

    Raises ValueError naming the unknown option and the known ones.
    """
    base, _, text = spec.partition(":")
    if base != "progressive":
        raise ValueError(f"{spec!r} is not a progressive renderer spec")
    if ":" in spec and not text:
        raise ValueError(f"renderer {spec!r}: no option after ':'; expected one of {', '.join(OPTIONS)}")
    kwargs: dict = {}
    for opt in filter(None, text.split("+")) if text else ():
        key, value = _option(spec, opt)
        if key in kwargs:
            raise ValueError(f"renderer {spec!r}: {opt!r} sets {key} twice")
        kwargs[key] = value
    if text and any(not o for o in text.split("+")):
        raise ValueError(f"renderer {spec!r}: empty option between '+' signs")
    return kwargs


def _option(spec: str, opt: str) -> tuple[str, object]:
    if opt in ("paper", "radiometric", "ltc"):
        return "area_model", opt
    if opt == "probes":
        return "indirect", "probes"
    if opt == "vsm":
        return "shadow_filter", "vsm"
    if opt == "fullfirst":
        return "first_frame_scale", 1.0
    m = _BUDGET.fullmatch(opt)
    if m:
        ms = float(m.group(1))
        if ms <= 0:
            raise ValueError(f"renderer {spec!r}: the frame budget must be positive, got {opt!r}")
        return "frame_budget_ms", ms
    raise ValueError(f"renderer {spec!r}: unknown option {opt!r}; expected "
                     + ", ".join(f"{k} ({v})" for k, v in OPTIONS.items()))


def describe(spec: str) -> str:
    """A short label of a spec's options for reports, e.g. ``"probes, VSM"`` (empty for ``progressive``)."""
    words = []
    for key, value in renderer_options(spec).items():
        if key == "area_model":
            words.append(str(value))
        elif key == "indirect":
            words.append("irradiance probes")
        elif key == "shadow_filter":
            words.append("VSM")
        elif key == "frame_budget_ms":
            words.append(f"{value:g} ms frame budget")
        elif key == "first_frame_scale":
            words.append("full-size first frame")
    return ", ".join(words)
