"""argparse types of the command line, checked before any work (a leaf: every command imports it)."""

from __future__ import annotations

import argparse

__all__ = ["parse_size", "parse_sizes", "positive_float", "positive_int"]


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
