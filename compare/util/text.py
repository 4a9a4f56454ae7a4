"""Text from a user's files on its way out: to a terminal, into Markdown, into XML.

A scene, material or glTF name is data: printed raw, its escape sequences drive the terminal (a window
title, a clipboard write); in a CI step summary its markup is rendered; in JUnit XML its control
characters make the file unreadable. Each function makes such a string inert where it goes, and leaves
ordinary text as it is.
"""

from __future__ import annotations

import re

__all__ = ["markdown_text", "terminal_text", "xml_text"]

_MARKDOWN = re.compile(r"([\\`*_{}\[\]()#+\-.!|~>])")
# XML 1.0's characters: tab, newline, carriage return, and U+0020 on, less the surrogates and U+FFFE/F.
_NOT_XML = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def terminal_text(s: str) -> str:
    """``s`` with every control character other than a newline or tab written as its escape (``\\x1b``)."""
    return "".join(c if c in "\n\t" or c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in str(s))


def markdown_text(s: str) -> str:
    """``s`` as literal Markdown text on one line: markup characters backslash-escaped, HTML's ``&<>`` as
    entities, control characters escaped, line breaks as spaces."""
    s = terminal_text(str(s)).replace("\n", " ").replace("\t", " ")
    s = s.replace("&", "&amp;").replace("<", "&lt;")
    return _MARKDOWN.sub(r"\\\1", s)


def xml_text(s: str) -> str:
    """``s`` without the characters XML 1.0 cannot hold (ElementTree escapes the rest), each as its escape."""
    return _NOT_XML.sub(lambda m: m.group(0).encode("unicode_escape").decode("ascii"), str(s))
