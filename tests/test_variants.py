"""Renderer variants of ``--renderers`` (compare.progressive.options): parsing, messages, labels."""

from __future__ import annotations

import pytest

from compare.renderers.registry import Registry
from compare.progressive.options import describe, renderer_options


def test_options_map_to_renderer_keywords():
    assert renderer_options("progressive") == {}
    assert renderer_options("progressive:paper") == {"area_model": "paper"}
    assert renderer_options("progressive:ltc+probes") == {"area_model": "ltc", "indirect": "probes"}
    assert describe("progressive:ltc+probes") == "ltc, irradiance probes"
    assert renderer_options("progressive:probes+vsm") == {"indirect": "probes", "shadow_filter": "vsm"}
    assert renderer_options("progressive:fullfirst") == {"first_frame_scale": 1.0}
    assert describe("progressive:fullfirst+paper") == "full-size first frame, paper"
    assert renderer_options("progressive:budget16") == {"frame_budget_ms": 16.0}
    assert renderer_options("progressive:paper+budget8.5") == {"area_model": "paper", "frame_budget_ms": 8.5}
    assert describe("progressive:probes+budget16") == "irradiance probes, 16 ms frame budget"
    assert describe("progressive") == ""


@pytest.mark.parametrize("spec, match", [
    ("progressive:ssao", "unknown option 'ssao'.*probes"),
    ("progressive:paper+radiometric", "area_model twice"),
    ("progressive:ltc+paper", "area_model twice"),
    ("progressive:budget0", "positive"),
    ("progressive:budget", "unknown option 'budget'"),
    ("progressive:vsm++probes", "empty option"),
])
def test_bad_options_are_named(spec, match):
    with pytest.raises(ValueError, match=match):
        renderer_options(spec)
    with pytest.raises(ValueError):
        Registry().parse(f"mitsuba,{spec}")


def test_variants_pass_through_the_registry_parser():
    specs = "mitsuba,progressive,progressive:probes,progressive:vsm,progressive:budget16"
    assert Registry().parse(specs) == specs.split(",")
