"""Settings dataclasses that document themselves: each field's help text is written once, in its metadata.

The command line reads a field's default and help from there (:func:`compare.cli.argtypes.setting`), and
:func:`documented` appends the same texts to the class docstring, so neither is restated.
"""

from __future__ import annotations

import dataclasses
from typing import Any

__all__ = ["DEFAULT_FRAMES", "DEFAULT_SPP", "DEFAULT_SPP_CAP", "DEFAULT_SPP_TARGET", "documented", "option"]

#: Frames a progressive renderer accumulates unless told (the paper's frame count, Otto et al. 2020).
DEFAULT_FRAMES = 128
#: The ground truth's samples per pixel unless told (``--spp auto`` measures them instead).
DEFAULT_SPP = 1024
#: ``--spp auto``'s target: the relative standard error of luminance that 95 % of a ground truth's pixels
#: must reach (:mod:`compare.image.convergence`). At 5 % the root mean square over pixels is about half
#: that on the built-in scenes, so the noise floor (relMSE of two such renders, about twice its square)
#: stays under a tenth of the smallest error the rasterizers make there, the report's aim.
DEFAULT_SPP_TARGET = 0.05
#: The most samples per pixel ``--spp auto`` renders (a caustic may never meet the target).
DEFAULT_SPP_CAP = 4096


def option(default: Any = dataclasses.MISSING, help: str = "", *, factory=dataclasses.MISSING) -> Any:
    """A dataclass field with its help text (``metadata["help"]``)."""
    if factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=factory, metadata={"help": help})
    return dataclasses.field(default=default, metadata={"help": help})


def documented(cls):
    """Class decorator: append ``name : help (default …)`` for every field with a help text to the docstring."""
    lines = []
    for f in dataclasses.fields(cls):
        text = f.metadata.get("help")
        if not text:
            continue
        default = f.default if f.default is not dataclasses.MISSING else (
            f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
        lines.append(f"    {f.name} : {text} (default {default!r}).")
    if lines:
        cls.__doc__ = (cls.__doc__ or "").rstrip() + "\n\n    Fields\n    ------\n" + "\n".join(lines) + "\n"
    return cls
