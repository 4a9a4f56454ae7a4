"""Texture files a scene names, checked when it is loaded (not when a renderer first reads them).

A texture holds reflectances or roughness/metal factors: every value must be a finite number
at least 0. PNG and JPEG are read with Pillow (a matplotlib dependency), EXR with
:func:`compare.image.exr.read_exr`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["coverage_map", "emission_map", "factor_map", "glossiness_roughness_map", "load_alpha", "load_texels8",
           "load_texture", "normal_map", "opacity_map", "split_metallic_roughness", "texture_problem"]

#: Pillow's modes of a 16-bit grey PNG (converting them to RGB would clip every value above 255 to white).
SIXTEEN_BIT_MODES = {"I;16", "I;16B", "I;16L", "I"}
#: Pillow modes whose samples are 8 bits: what a GPU takes as RGB(A)8 texels as they are.
EIGHT_BIT_MODES = {"1", "L", "LA", "La", "P", "PA", "RGB", "RGBA", "RGBa", "RGBX", "CMYK", "YCbCr"}


def texture_problem(path: Path) -> str | None:
    """What is wrong with the texture file ``path`` (one sentence), or None if it is usable."""
    from compare.util.errors import ImageError

    if path.suffix.lower() == ".exr":
        from compare.image.exr import read_exr

        try:
            image, _ = read_exr(path)
        except ImageError as exc:
            return str(exc).replace(f"{path}: ", "", 1)
        bad = ~np.isfinite(image)
        if bad.any():
            r, c, _ = np.argwhere(bad)[0]
            return f"{int(bad.sum())} NaN or infinite value(s) (first at row {r}, col {c})"
        if float(image.min(initial=0.0)) < 0.0:
            r, c, _ = np.argwhere(image < 0)[0]
            return (f"{int((image < 0).sum())} negative value(s) (first at row {r}, col {c}: "
                    f"{float(image[r, c].min()):g}); texture values are reflectances and factors >= 0")
        return None
    import warnings

    from compare.image.pillow import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            # Pillow warns of an image over its decompression-bomb limit and refuses one over twice it; both
            # are decided on the header, before anything is decoded
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                im.verify()  # the file's structure and checksums
            with Image.open(path) as im:
                im.load()  # and its pixels
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        return f"refused before decoding: its header claims more pixels than a map may have ({exc})"
    except (OSError, UnidentifiedImageError, SyntaxError, ValueError) as exc:
        return f"unreadable image ({exc})"
    return None


def _rgba(im):
    """Any 8-bit layout (grey, grey + alpha, palette with or without tRNS, RGB, RGBA) as RGBA, the one way
    every map is decoded for every renderer: a palette goes through RGBA so that its transparency is kept
    (Pillow's direct palette-to-RGB drops it, with a warning)."""
    return im.convert("RGBA")


def load_texture(path: Path, *, srgb: bool) -> np.ndarray:
    """A texture file as linear float32 (H, W, 3), row 0 at the top of the image.

    ``srgb``: 8-bit PNG/JPEG values are sRGB-encoded colours (a base-colour map) and are
    decoded with the exact sRGB curve, as Mitsuba's ``bitmap`` with ``raw = False`` does;
    otherwise (factors: a metallic-roughness map) they are taken as they are, / 255. EXR
    values are linear either way.
    """
    from compare.image.tonemap import srgb_decode

    path = Path(path)
    if path.suffix.lower() == ".exr":
        from compare.image.exr import read_exr

        return np.ascontiguousarray(read_exr(path)[0], dtype=np.float32)
    from compare.image.pillow import Image

    with Image.open(path) as im:
        if im.mode in SIXTEEN_BIT_MODES:  # 16-bit grey: the full range, as Mitsuba's bitmap reads it
            grey = np.asarray(im, dtype=np.float64) / 65535.0
            data = np.repeat(np.clip(grey, 0.0, 1.0)[..., None], 3, axis=2)
        else:
            data = np.asarray(_rgba(im), dtype=np.float64)[..., :3] / 255.0
    return np.ascontiguousarray(srgb_decode(data) if srgb else data, dtype=np.float32)


def load_texels8(path: Path, *, alpha: bool) -> np.ndarray | None:
    """An 8-bit map file's texels as they are stored, uint8 (H, W, 3), or (H, W, 4) with ``alpha`` (its
    alpha channel, 255 where it has none); None for a file that is not 8 bits per sample (EXR, 16-bit or
    float PNG), which :func:`load_texture` reads as floats. Row 0 is the top of the image. The values
    are the file's codes: an sRGB map is decoded by whoever samples it (an sRGB texture)."""
    path = Path(path)
    if path.suffix.lower() == ".exr":
        return None
    from compare.image.pillow import Image

    with Image.open(path) as im:
        if im.mode not in EIGHT_BIT_MODES:
            return None
        texels = np.asarray(_rgba(im), dtype=np.uint8)
        return np.ascontiguousarray(texels if alpha else texels[..., :3])


def load_alpha(path: Path) -> np.ndarray:
    """The alpha channel of a texture file as float32 (H, W) in [0, 1], row 0 at the top; 1 where the
    file has none (8-bit alpha / 255, linear; an EXR's ``A`` channel)."""
    path = Path(path)
    if path.suffix.lower() == ".exr":
        import OpenEXR

        from compare.image.exr import read_exr

        shape = read_exr(path)[0].shape[:2]  # read_exr first: it checks the file and names what is wrong
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = f.channels()
            if "A" in channels:
                return np.clip(np.asarray(channels["A"].pixels, dtype=np.float32).reshape(shape), 0.0, 1.0)
        return np.ones(shape, dtype=np.float32)
    from compare.image.pillow import Image

    with Image.open(path) as im:
        if "A" not in im.getbands() and "transparency" not in im.info:
            return np.ones((im.height, im.width), dtype=np.float32)
        return np.asarray(_rgba(im), dtype=np.float32)[..., 3] / np.float32(255.0)


def coverage_map(path: Path | None, alpha: float, cutoff: float) -> np.ndarray:
    """glTF's alpha mask as 0/1 float32 (H, W): 1 where ``alpha`` × the map's alpha is at least
    ``cutoff`` (a 1 × 1 map without ``path``)."""
    a = np.float32(alpha) * (np.ones((1, 1), dtype=np.float32) if path is None else load_alpha(path))
    return (a >= np.float32(cutoff)).astype(np.float32)


def opacity_map(path: Path, alpha: float, cutoff: float) -> Path:
    """:func:`coverage_map` of the base-colour map ``path`` as a grey linear EXR in the cache, for a
    renderer that takes the mask as an opacity texture (Mitsuba's ``mask``). The test is applied per
    texel, before filtering: a path tracer's opacity is a probability, so bilinear filtering then gives
    a sub-texel soft edge where the rasterizer thresholds the filtered alpha."""
    return _derived(path, "opacity", (float(alpha), float(cutoff)),
                    lambda: np.repeat(coverage_map(path, alpha, cutoff)[..., None], 3, axis=2))


def blend_map(path: Path, alpha: float) -> Path:
    """glTF's BLEND coverage, ``alpha`` × the base-colour map's alpha, as a grey linear EXR in the cache
    (Mitsuba's ``mask`` opacity: stochastic coverage)."""
    return _derived(path, "blend", (float(alpha),),
                    lambda: np.repeat((np.float32(alpha) * load_alpha(path))[..., None], 3, axis=2))


def _derived(path: Path, what: str, params, make) -> Path:
    """A map derived from the texture file ``path`` as a linear EXR in the cache, named by the file's
    content, ``what`` and ``params``, written once: ``make()`` gives its (H, W, 3) values, or those and
    an (H, W) alpha."""
    from compare.util.cache import default_cache_dir
    from compare.image.exr import write_exr
    from compare.util.files import sha256_bytes

    key = sha256_bytes(Path(path).read_bytes(), repr(params))[:32]
    out = default_cache_dir() / "textures" / f"{key}-{what}.exr"
    if not out.is_file():
        values = make()
        rgb, alpha = values if isinstance(values, tuple) else (values, None)
        write_exr(out, rgb, alpha=alpha, metadata={"what": f"{what} map of {Path(path).name}"})
    return out


def factor_map(path: Path, factor, *, srgb: bool) -> Path:
    """The map ``path`` times a per-channel ``factor`` (linear) as a linear EXR in the cache, with the
    file's alpha channel: what glTF's factor × texture is, for a scene model whose map replaces its
    factor (the glTF import bakes a factor other than 1 into its map this way)."""
    f = np.asarray(factor, dtype=np.float64).reshape(3)
    return _derived(path, "factor", (f.tolist(), bool(srgb)),
                    lambda: (load_texture(path, srgb=srgb) * f, load_alpha(path)))


def glossiness_roughness_map(path: Path, glossiness: float) -> Path:
    """A ``KHR_materials_pbrSpecularGlossiness`` specularGlossinessTexture as a glTF metallic-roughness map,
    a linear EXR in the cache: roughness (G) = 1 − ``glossiness`` × the map's alpha (linear; 1 where it has
    none), metallic (B) 0, R 0 (the conversion of glTF-Transform's ``metalRough()``, in floats)."""
    def make():
        a = load_alpha(path).astype(np.float64)
        out = np.zeros((*a.shape, 3), dtype=np.float32)
        out[..., 1] = 1.0 - float(glossiness) * a
        return out

    return _derived(path, "gloss-roughness", (float(glossiness),), make)


def split_metallic_roughness(path: Path) -> tuple[Path, Path]:
    """A glTF metallic-roughness map (G = roughness, B = metallic) as two grey EXRs, (metallic,
    roughness), in the cache: a renderer whose texture lookups return one value per texel (Mitsuba's
    ``eval_1``) reads each from its own."""
    def channel(c: int):
        return lambda: np.repeat(load_texture(path, srgb=False)[..., c:c + 1], 3, axis=2)

    return _derived(path, "metallic", (), channel(2)), _derived(path, "roughness", (), channel(1))


def alpha_map(path: Path) -> Path:
    """The GGX α = roughness² of a glTF metallic-roughness map (G), at least 1e-4, as a grey EXR in the cache:
    a rough dielectric's ``alpha`` per texel."""
    return _derived(path, "alpha", (), lambda: np.repeat(
        np.maximum(load_texture(path, srgb=False)[..., 1:2] ** 2, 1e-4), 3, axis=2))


def channel_map(path: Path, channel: str, factor) -> Path:
    """One channel ("r", "g", "b" or "a") of a linear map times ``factor``, as a grey EXR in the cache: a
    glTF extension's map (transmission in R, a coat's weight in R and roughness in G) times its factor.
    Channel "rgb": an sRGB colour map times an RGB ``factor`` (a sheen's or a specular colour)."""
    if channel == "rgb":
        f = np.asarray(factor, dtype=np.float64).reshape(3)
        return _derived(path, "rgb-x", f.tolist(), lambda: load_texture(path, srgb=True)[..., :3] * f)
    if channel == "a":
        return _derived(path, "alpha-x", (float(factor),),
                        lambda: np.repeat((load_alpha(path) * float(factor))[..., None], 3, axis=2))
    c = "rgb".index(channel)
    return _derived(path, f"{channel}-x", (float(factor),),
                    lambda: np.repeat(load_texture(path, srgb=False)[..., c:c + 1] * float(factor), 3, axis=2))


def specular_f0_map(path: Path, color, ior: float) -> Path:
    """glTF's dielectric F0 per texel, ``min(((ior − 1)/(ior + 1))² × colour × map, 1)`` (the sRGB
    specularColorTexture times its factor), as a linear EXR in the cache."""
    f = np.asarray(color, dtype=np.float64).reshape(3)
    f0 = ((float(ior) - 1.0) / (float(ior) + 1.0)) ** 2
    return _derived(path, "specular-f0", [*f.tolist(), float(ior)],
                    lambda: np.minimum(f0 * load_texture(path, srgb=True)[..., :3] * f, 1.0))


def sqrt_colour_map(path: Path) -> Path:
    """The square root of a base-colour map (sRGB-decoded, clamped to [0, 1]) as a linear EXR in the cache:
    Cycles' glass tints each of a ray's two interfaces by √(base colour)."""
    return _derived(path, "sqrt-colour", (), lambda: np.sqrt(np.clip(load_texture(path, srgb=True)[..., :3], 0.0, 1.0)))


def emission_map(path: Path, emission) -> Path:
    """An emission map (sRGB) times the material's ``emission`` as a linear EXR in the cache: the
    radiance a renderer emits per texel."""
    factor = np.asarray(emission, dtype=np.float64).reshape(3)
    return _derived(path, "emission", factor.tolist(), lambda: load_texture(path, srgb=True) * factor)


def normal_map(path: Path, scale: float, *, flip_y: bool) -> Path:
    """A glTF normal map with its ``scale`` applied (x, y × scale, normalised) as a linear EXR in the
    cache, encoded back to [0, 1] (n + 1) / 2; ``flip_y`` negates y, for a renderer whose tangent frame's
    second axis points down the image where glTF's points up."""
    def make():
        n = load_texture(path, srgb=False).astype(np.float64) * 2.0 - 1.0
        n[..., :2] *= float(scale)
        if flip_y:
            n[..., 1] = -n[..., 1]
        n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-12)
        return (n + 1.0) / 2.0

    return _derived(path, "normal", (float(scale), bool(flip_y)), make)
