"""The plugin classes of compare.mitsuba.plugins: one module per variant, registered once per variant, an
instance that keeps working after the variant switches, and render keys that hold the classes' code."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest


PLUGIN_MODULES = ("base", "bsdf", "coat", "sheen", "glass", "textures")


@pytest.fixture
def variants(mi_llvm, mi_scalar):
    """Registers every plugin with llvm_ad_rgb and scalar_rgb (mi_llvm and mi_scalar skip where one is
    unavailable, and the module's first test's variant is set again after its last)."""
    from compare.mitsuba import coat, glass, sheen, textures

    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        for module in (coat, sheen, glass, textures):
            module.register(variant)
    return mi_scalar


def _layered(mi):
    return mi.load_dict({"type": "gltf_sheen", "color": {"type": "rgb", "value": [0.5, 0.5, 0.5]}, "roughness": 0.5,
                         "base": {"type": "gltf_coat", "clearcoat": 1.0, "roughness": 0.2,
                                  "base": {"type": "gltf_pbr", "metallic": 0.0, "roughness": 0.5}}})


def _value(mv, bsdf):
    """``bsdf.eval`` at one pair of directions, with the types of the variant module ``mv``."""
    si = mv.SurfaceInteraction3f()
    si.wi = mv.Vector3f(0.0, 0.6, 0.8)
    ctx = sys.modules["mitsuba"].BSDFContext()  # variant-independent, like the flags
    return np.array(bsdf.eval(ctx, si, mv.Vector3f(0.6, 0.0, 0.8), mv.Bool(True))).ravel()


def test_each_variant_has_its_own_classes_and_an_instance_survives_a_switch(variants):
    from compare.mitsuba import bsdf
    from compare.mitsuba.plugins import registered_variants

    mi = variants
    mi.set_variant("llvm_ad_rgb")
    llvm = _layered(mi)
    llvm_value = _value(mi.llvm_ad_rgb, llvm)
    mi.set_variant("scalar_rgb")
    scalar = _layered(mi)
    scalar_value = _value(mi.scalar_rgb, scalar)
    assert isinstance(llvm, mi.llvm_ad_rgb.BSDF) and isinstance(scalar, mi.scalar_rgb.BSDF)
    assert type(llvm) is not type(scalar) and type(llvm).__name__ == type(scalar).__name__ == "GltfSheenBSDF"
    base = {type(b).__mro__[1].__module__ for b in (llvm, scalar)}  # LayeredBSDF: one per variant
    assert len(base) == 2 and all(name.startswith("compare.mitsuba.plugins.base") for name in base)
    # scalar active: the llvm instance still works (its classes keep their variant's types)
    np.testing.assert_array_equal(_value(mi.llvm_ad_rgb, llvm), llvm_value)
    np.testing.assert_allclose(llvm_value, scalar_value, rtol=1e-5)
    mi.set_variant("llvm_ad_rgb")
    np.testing.assert_array_equal(_value(mi.llvm_ad_rgb, llvm), llvm_value)
    for name in ("gltf_pbr", "gltf_coat", "gltf_sheen", "rough_glass", "compare_product", "compare_front_side"):
        assert sorted(registered_variants(name)) == ["llvm_ad_rgb", "scalar_rgb"], name
    bsdf.register("scalar_rgb")  # again: nothing new
    assert sorted(bsdf.registered_variants()) == ["llvm_ad_rgb", "scalar_rgb"]


def test_a_plugin_module_is_imported_only_once_a_variant_is_set():
    code = "import compare.mitsuba.plugins.bsdf"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert "subclasses the classes of a Mitsuba variant: it is imported once one is set" in done.stderr


@pytest.mark.parametrize("module", ["compare.mitsuba.reference", "compare.mitsuba.renderer"])
def test_the_render_keys_hold_the_plugin_classes(module):
    """The classes are imported by their modules' register(), so a change to them changes the reference's
    keys (compare.util.code follows import statements)."""
    from compare.util.code import import_closure

    names = {p.as_posix() for p in import_closure(module)}
    missing = [m for m in PLUGIN_MODULES if not any(n.endswith(f"compare/mitsuba/plugins/{m}.py") for n in names)]
    assert not missing, f"{module}'s key misses compare/mitsuba/plugins/{missing}"
