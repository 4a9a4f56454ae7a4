"""Variants of the progressive renderer named in ``--renderers``: ``progressive:<option>[+<option>…]``.

Each option sets :class:`~compare.progressive.rasterizer.Rasterizer` keywords, so
the report can show what each departure from the paper's technique costs and
gains against the same ground truth (an ablation). The options, from :data:`WORDS`:

{words}

Options combine with ``+``: ``progressive:probes+vsm``.
"""

from __future__ import annotations

from dataclasses import dataclass

from compare.renderers.options import parse_spec

__all__ = ["OPTIONS", "WORDS", "SpecWord", "describe", "renderer_options", "setup_variants"]


@dataclass(frozen=True)
class SpecWord:
    """One option word of ``progressive:<option>``."""

    word: str
    """As written; ``<ms>`` stands for the number that follows it (``budget16``)."""
    keyword: str
    """The :class:`~compare.progressive.config.RasterizerOptions` field it sets."""
    value: object
    """The value it sets; None: the number written with it."""
    label: str
    """Its words in a report's label (``{}`` takes the number)."""
    text: str
    """What it does, for messages and ``--help``."""
    module: str = ""
    """The module that says more, if any."""
    example: str = ""
    """A complete word for a word that takes a number (``budget16``)."""


#: Every option word: the one source of the keywords, labels, messages and this module's notes.
WORDS = (
    SpecWord("paper", "area_model", "paper", "paper", "the paper's point-light area model",
             "compare.progressive.lights.direct"),
    SpecWord("radiometric", "area_model", "radiometric", "radiometric",
             "the radiometric point-on-area model (default)", "compare.progressive.lights.direct"),
    SpecWord("ltc", "area_model", "ltc", "ltc",
             "closed-form unshadowed area light (linearly transformed cosines) times a shadow ratio",
             "compare.progressive.lights.ltc"),
    SpecWord("probes", "indirect", "probes", "irradiance probes", "indirect diffuse light from an irradiance volume",
             "compare.progressive.indirect.probes"),
    SpecWord("vsm", "shadow_filter", "vsm", "VSM", "variance shadow maps", "compare.progressive.lights.shadow"),
    SpecWord("budget<ms>", "frame_budget_ms", None, "{:g} ms frame budget",
             "a per-frame time budget in milliseconds, e.g. budget16", "compare.progressive.schedule.budget",
             "budget16"),
    SpecWord("fullfirst", "first_frame_scale", 1.0, "full-size first frame",
             "frame 0 at full size (the paper's first frame)", "compare.progressive.first_frame"),
    SpecWord("envshadows", "env_occlusion", "shadows", "environment shadow maps",
             "environment shadow maps: luminance-sampled directions, a shadow ratio of the split sum",
             "compare.progressive.environment.env_shadows"),
    SpecWord("sun", "sun", True, "the environment's sun as a light",
             "the environment's brightest compact region as a directional light with its own shadow map",
             "compare.progressive.environment.sun"),
)
_BY_WORD = {w.word: w for w in WORDS}
#: Options and what they mean (for messages and ``--help``).
OPTIONS = {w.word: w.text for w in WORDS}


def _notes() -> str:
    """The options as this module's docstring lists them."""
    out = []
    for w in WORDS:
        value = "<ms>" if w.value is None else f'"{w.value}"' if isinstance(w.value, str) else repr(w.value)
        more = f"; see :mod:`{w.module}`" if w.module else ""
        out.append(f"``{w.word}``\n    ``{w.keyword}={value}``: {w.text}{more}.")
    return "\n".join(out)


if __doc__ is not None:  # python -OO
    __doc__ = __doc__.replace("{words}", _notes())


def renderer_options(spec: str) -> dict:
    """Rasterizer keywords of a renderer spec (``progressive`` gives ``{}``).

    Raises ValueError naming the unknown option and the known ones.
    """
    if spec.partition(":")[0] != "progressive":
        raise ValueError(f"{spec!r} is not a progressive renderer spec")
    kwargs: dict = {}
    for word, number in parse_spec(spec, OPTIONS):
        w = _BY_WORD[word]
        if w.keyword in kwargs:
            raise ValueError(f"renderer {spec!r}: {word!r} sets {w.keyword} twice")
        kwargs[w.keyword] = number if w.value is None else w.value
    return kwargs


def setup_variants() -> list[str]:
    """Every variant whose set-up differs, from :data:`WORDS`: ``progressive``, each word alone (a number's
    word as its example; not a word that sets the default), and every switch together (the words that
    alone set their keyword: the variant that builds the most passes)."""
    from compare.progressive.config import RasterizerOptions

    default = RasterizerOptions()
    alone = [w.example or w.word for w in WORDS
             if not (w.value is not None and getattr(default, w.keyword) == w.value)]
    per_keyword: dict[str, list[SpecWord]] = {}
    for w in WORDS:
        per_keyword.setdefault(w.keyword, []).append(w)
    switches = [w.word for w in WORDS if w.value is not None and len(per_keyword[w.keyword]) == 1]
    return ["progressive", *(f"progressive:{word}" for word in alone), f"progressive:{'+'.join(switches)}"]


def describe(spec: str) -> str:
    """A short label of a spec's options for reports, e.g. ``"probes, VSM"`` (empty for ``progressive``)."""
    renderer_options(spec)  # the same checks (an option twice) as the keywords
    return ", ".join(_BY_WORD[word].label.format(number) for word, number in parse_spec(spec, OPTIONS))
