"""Pillow as the suite uses it: one limit on the texels of a map for every reader of images.

Pillow refuses an image of more than twice ``Image.MAX_IMAGE_PIXELS`` pixels (and warns above it); the
glTF decoders check the same :data:`MAX_TEXELS` on a compressed texture's header. With one number, a map a
decoder accepted and cached is one every later reader (the loader, ``compare inspect``) accepts too.
"""

from __future__ import annotations

from PIL import Image, UnidentifiedImageError

__all__ = ["MAX_TEXELS", "Image", "UnidentifiedImageError"]

#: The most texels a map may have: 16384², the largest texture a GPU is required to take.
MAX_TEXELS = 16384 * 16384

Image.MAX_IMAGE_PIXELS = MAX_TEXELS  # over it a warning (the loader makes it an error), over 2x an error
