"""Error types of the suite.

Every error a user can cause (a bad scene file, a bad image, a missing system
component) is raised as one of these, with a message that names the file and
field or the missing component and how to install it.
"""


class CompareError(Exception):
    """Base class of every error the suite raises on purpose."""


class SceneError(CompareError, ValueError):
    """A scene file is malformed; the message starts with ``file: field:``."""


class ImageError(CompareError, ValueError):
    """An image is unreadable, has the wrong shape, or holds NaN/Inf."""


class MissingComponentError(CompareError, RuntimeError):
    """A system component (LLVM, OpenGL/EGL, bpy) is missing; says how to install it."""


class OutputError(CompareError, ValueError):
    """An output path is refused before any work: it would overwrite an input or another
    output, has the wrong kind, or cannot be written; the message names it."""
