"""The classes of the suite's Mitsuba plugins, one module per plugin module of :mod:`compare.mitsuba`.

``compare.mitsuba.bsdf``'s ``gltf_pbr`` is :mod:`compare.mitsuba.plugins.bsdf`'s ``GltfPbrBSDF``, and so on for
``coat``, ``sheen``, ``glass``, ``normalmap`` and ``textures``; :mod:`compare.mitsuba.plugins.base` holds what they
share.

Why the modules are bound to a variant. A Mitsuba plugin class subclasses a class of one variant
(``mitsuba.llvm_ad_rgb.BSDF`` is not ``mitsuba.scalar_rgb.BSDF``), and ``mi.register_bsdf`` registers with the
variant active at the call. So a module here subclasses the classes of the variant that is active when it is
executed (:func:`bound_variant`), and is imported only once a variant is set: by the ``register`` of its
public module, which sets the variant first. A variant set later gets its own copy of the module, the same
source executed again with that variant active, under the name ``<module>[<variant>]`` (:func:`for_variant`);
a module that builds on another one's classes takes them from that module's copy for its own variant. Each
copy keeps its variant's types, so an instance keeps working after ``mi.set_variant`` switches to another
variant.

The public modules stay importable without Mitsuba and import these with an import statement (in
``register``): the render keys (:mod:`compare.util.code`) follow import statements, so they hold the classes'
code. A module here therefore never imports its public module (that would close an import circle); what both
need lives in a third module (:mod:`compare.mitsuba.principled`, :mod:`compare.mitsuba.glass_energy`).

:func:`register_plugin` registers a class of these modules with the active variant, once per variant.
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType

__all__ = ["bound_variant", "for_variant", "register_plugin", "registered_variants"]

#: (module name, variant) → the module executed for that variant (the imported one, or its copy).
_MODULES: dict[tuple[str, str], ModuleType] = {}
#: Plugin name → the variants it has been registered with, in order.
_REGISTERED: dict[str, list[str]] = {}


def _active_variant(name: str) -> str:
    mi = sys.modules.get("mitsuba")
    variant = mi.variant() if mi is not None else None
    if not variant:
        raise ImportError(f"{name} subclasses the classes of a Mitsuba variant: it is imported once one is set, "
                          "by the register() of its module in compare.mitsuba")
    return variant


def _base_name(name: str) -> str:
    """A module's name without the ``[<variant>]`` of a copy."""
    return name.partition("[")[0]


def bound_variant(name: str):
    """The variant module (e.g. ``mitsuba.llvm_ad_rgb``) whose classes the module ``name`` (its ``__name__``)
    subclasses: the variant active while it is executed. Raises :class:`ImportError` when none is set."""
    variant = _active_variant(name)
    _MODULES[(_base_name(name), variant)] = sys.modules[name]  # a module imported again after a failure replaces it
    return getattr(sys.modules["mitsuba"], variant)


def for_variant(module: ModuleType) -> ModuleType:
    """``module`` (one of this package, or a copy of one) as executed for the active variant: the module
    itself when it was, else its copy for that variant, executed from the same source the first time."""
    name = _base_name(module.__name__)
    variant = _active_variant(name)
    key = (name, variant)
    if key not in _MODULES:
        spec = importlib.util.spec_from_file_location(f"{name}[{variant}]", module.__file__)
        copy = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = copy
        try:
            spec.loader.exec_module(copy)  # its bound_variant call records it
        except BaseException:
            del sys.modules[spec.name]
            _MODULES.pop(key, None)
            raise
    return _MODULES[key]


def register_plugin(name: str, module: ModuleType, class_name: str, *, kind: str = "bsdf"):
    """Register the class ``class_name`` of ``module`` (taken from its copy for the active variant) as the
    Mitsuba plugin ``name`` of ``kind`` (``"bsdf"`` or ``"texture"``), once per variant; returns ``mitsuba``."""
    variant = _active_variant(module.__name__)
    mi = sys.modules["mitsuba"]
    done = _REGISTERED.setdefault(name, [])
    if variant not in done:
        cls = getattr(for_variant(module), class_name)
        getattr(mi, f"register_{kind}")(name, lambda props, _cls=cls: _cls(props))
        done.append(variant)
    return mi


def registered_variants(name: str) -> tuple[str, ...]:
    """The variants in which the plugin ``name`` has been registered by this process."""
    return tuple(_REGISTERED.get(name, ()))
