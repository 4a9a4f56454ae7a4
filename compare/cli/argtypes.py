"""argparse types of the command line, checked before any work (a leaf: every command imports it)."""

from __future__ import annotations

import argparse
import dataclasses

__all__ = ["choices_help", "parse_size", "parse_sizes", "positive_float", "positive_int", "setting"]


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``WIDTHxHEIGHT`` (e.g. ``320x240``)."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 320x240, got {text!r}") from None
    if w < 1 or h < 1 or w * h > 8192 * 8192:
        raise argparse.ArgumentTypeError(f"expected a positive size up to 8192x8192, got {text!r}")
    return w, h


def parse_sizes(text: str) -> list[tuple[int, int]]:
    """``"320x240,1280x720"`` → ``[(320, 240), (1280, 720)]``."""
    return [parse_size(part.strip()) for part in text.split(",") if part.strip()]


def positive_float(text: str) -> float:
    """A positive finite number."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """A positive integer."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def choices_help(lead: str, table: dict[str, str], names=None) -> str:
    """A help text that lists each choice of ``table`` (name → what it is), from the table itself."""
    return f"{lead}: " + "; ".join(f"{name}: {table[name]}" for name in (names or table))


def setting(cls, name: str) -> dict:
    """``default`` and ``help`` of an option read from field ``name`` of settings dataclass ``cls`` (its
    default and its ``metadata["help"]``), so that a default is written once, where the library reads it."""
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return {"default": default, "help": f.metadata.get("help", name.replace("_", " "))}
