"""The one grammar of renderer specs: ``<name>[:<option>[+<option>…]]``.

A renderer class declares its options (:attr:`compare.renderers.base.Renderer.OPTIONS`:
word → what it changes); a word written ``budget<ms>`` takes a number right after it
(``budget16``). :func:`parse_spec` checks a spec against those declarations, and every
message, listing and ``--help`` text about options is made from the same declarations
(:func:`describe_options`).
"""

from __future__ import annotations

import re
from typing import Mapping

__all__ = ["describe_options", "parse_spec", "split_spec"]

_NUMERIC = re.compile(r"(\w+)<(\w+)>")
_NUMBER = r"(\d+(?:\.\d+)?)"


def split_spec(spec: str) -> tuple[str, str]:
    """``(name, options text)`` of a spec (``"progressive:probes+vsm"`` → ``("progressive", "probes+vsm")``)."""
    name, _, text = spec.partition(":")
    return name, text


def describe_options(options: Mapping[str, str]) -> str:
    """``word (what it does), …`` for messages and help."""
    return ", ".join(f"{k} ({v})" for k, v in options.items())


def parse_spec(spec: str, options: Mapping[str, str]) -> list[tuple[str, float | None]]:
    """The options of ``spec`` as ``(word, number or None)`` in the order written, checked against the
    declared ``options``.

    Raises
    ------
    ValueError
        Naming the spec and what is wrong: options where none are declared, an empty option, an
        unknown word (with the declared ones), a number that is not positive, a word given twice.
    """
    name, text = split_spec(spec)
    if ":" not in spec:
        return []
    if not options:
        raise ValueError(f"unknown renderer {spec!r}: {name} takes no ':' options")
    if not text or any(not o for o in text.split("+")):
        raise ValueError(f"renderer {spec!r}: an empty option; expected one of {describe_options(options)}")
    out: list[tuple[str, float | None]] = []
    for word in text.split("+"):
        got = _match(word, options)
        if got is None:
            raise ValueError(f"renderer {spec!r}: unknown option {word!r}; expected one of "
                             f"{describe_options(options)}")
        key, number = got
        if number is not None and number <= 0:
            raise ValueError(f"renderer {spec!r}: {word!r}: the number after {key!r} must be positive")
        if any(k == key for k, _ in out):
            raise ValueError(f"renderer {spec!r}: option {key!r} given twice")
        out.append((key, number))
    return out


def _match(word: str, options: Mapping[str, str]) -> tuple[str, float | None] | None:
    for declared in options:
        m = _NUMERIC.fullmatch(declared)
        if m is None:
            if word == declared:
                return declared, None
            continue
        n = re.fullmatch(re.escape(m.group(1)) + _NUMBER, word)
        if n is not None:
            return declared, float(n.group(1))
    return None
