"""Tests of compare.image.exr: pixel and metadata round trips, failures that name the file."""

from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

import compare
from compare.util.errors import ImageError
from compare.image.exr import METADATA_PREFIX, read_exr, write_exr


@pytest.fixture
def image() -> np.ndarray:
    rng = np.random.default_rng(7)
    img = rng.lognormal(0.0, 3.0, size=(24, 32, 3)).astype(np.float32)
    img[0, 0] = [0.0, -0.0, 1e-40]  # zero, negative zero, a float32 denormal
    img[0, 1] = [-2.5, 3.0e38, 1.0e-30]  # negative and huge values are legal in EXR
    return img


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def test_float32_round_trip_is_bit_exact(tmp_path, image):
    path = write_exr(tmp_path / "a.exr", image)
    back, md = read_exr(path)
    assert back.dtype == np.float32 and back.shape == image.shape and back.flags.c_contiguous
    assert np.array_equal(_bits(back), _bits(image))
    assert md == {"compare_version": compare.__version__}


def test_non_contiguous_input_round_trips(tmp_path, image):
    # OpenEXR 3.5 scrambles non-C-contiguous arrays silently; write_exr must not.
    wide = np.ascontiguousarray(np.repeat(image, 2, axis=1))
    for view in (np.asfortranarray(image), wide[:, ::2]):
        assert not view.flags.c_contiguous
        back, _ = read_exr(write_exr(tmp_path / "v.exr", view))
        assert np.array_equal(_bits(back), _bits(image))


def test_float64_input_is_stored_as_float32(tmp_path, image):
    back, _ = read_exr(write_exr(tmp_path / "d.exr", image.astype(np.float64)))
    assert np.array_equal(_bits(back), _bits(image))
    with pytest.raises(ImageError, match="exceeds the float32 maximum"):
        write_exr(tmp_path / "big.exr", np.full((2, 2, 3), 1e300))


def test_half_round_trip_and_range(tmp_path, image):
    small = np.clip(image, -1000, 1000)
    back, _ = read_exr(write_exr(tmp_path / "h.exr", small, half=True))
    assert back.dtype == np.float32
    assert np.array_equal(back, small.astype(np.float16).astype(np.float32))
    with pytest.raises(ImageError, match="half=False"):
        write_exr(tmp_path / "h2.exr", np.full((2, 2, 3), 1e5, np.float32), half=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.exr"]


def test_metadata_round_trip_keeps_types(tmp_path, image):
    md = {
        "renderer": "mitsuba",
        "variant": "llvm_ad_rgb",
        "spp": 1024,
        "seed": 2**32 - 1,  # uint32 Mitsuba seed: too wide for an EXR int
        "offset": -(2**40),
        "seconds": 0.1,  # not representable in float32: must come back exactly
        "tiny": 5e-324,
        "unicode": "héllo ✓",
        "empty": "",
        "scene_hash": "ab" * 32,
        "np_int": np.int64(3),
        "np_float": np.float64(2.5),
        "compare_version": "0.0.0-stale",  # overwritten by the writer
    }
    _, back = read_exr(write_exr(tmp_path / "m.exr", image, metadata=md))
    expected = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in md.items()}
    expected["compare_version"] = compare.__version__
    assert back == expected
    for k, v in back.items():
        assert type(v) is type(expected[k]), k


def test_metadata_visible_to_other_tools_under_prefix(tmp_path, image):
    path = write_exr(tmp_path / "m.exr", image, metadata={"renderer": "rasterizer", "spp": 8})
    with OpenEXR.File(str(path), header_only=True) as f:
        # Copy inside the block: File.__exit__ empties the dict it returned.
        h = dict(f.header())
    assert h[METADATA_PREFIX + "renderer"] == "rasterizer"
    assert h[METADATA_PREFIX + "spp"] == 8
    assert h["compression"] == OpenEXR.ZIP_COMPRESSION


@pytest.mark.parametrize(
    "md, match",
    [
        ({"flag": True}, "bool"),
        ({"x": None}, "unsupported type"),
        ({"x": [1, 2]}, "unsupported type"),
        ({"_private": 1}, "reserved"),
        ({"": 1}, "non-empty"),
        ({"k" * 300: 1}, "too long"),
    ],
)
def test_bad_metadata_refused_before_writing(tmp_path, image, md, match):
    with pytest.raises(ValueError, match=match):
        write_exr(tmp_path / "m.exr", image, metadata=md)
    assert list(tmp_path.iterdir()) == []


def test_nan_refused_and_nothing_left_behind(tmp_path, image):
    image[5, 7, 2] = np.nan
    image[9, 1, 0] = np.inf
    target = tmp_path / "out" / "nan.exr"
    with pytest.raises(ImageError) as err:
        write_exr(target, image)
    msg = str(err.value)
    assert "2 non-finite" in msg and "1 NaN, 1 Inf" in msg
    assert "row 5, col 7, channel 2" in msg
    assert str(target) in msg
    assert not target.exists()
    assert not target.parent.exists() or list(target.parent.iterdir()) == []


def test_failed_overwrite_keeps_old_file(tmp_path, image):
    path = write_exr(tmp_path / "keep.exr", image, metadata={"run": 1})
    bad = image.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ImageError):
        write_exr(path, bad, metadata={"run": 2})
    back, md = read_exr(path)
    assert md["run"] == 1 and np.array_equal(_bits(back), _bits(image))
    assert [p.name for p in tmp_path.iterdir()] == ["keep.exr"]


def test_atomic_write_leaves_no_temp_files(tmp_path, image):
    for i in range(3):
        write_exr(tmp_path / "a.exr", image + i, metadata={"i": i})
    write_exr(tmp_path / "b.exr", np.clip(image, 0, 1), half=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "b.exr"]
    assert read_exr(tmp_path / "a.exr")[1]["i"] == 2


@pytest.mark.parametrize("shape", [(8, 8), (8, 8, 4), (0, 8, 3), (8,)])
def test_wrong_shape_refused(tmp_path, shape):
    with pytest.raises(ImageError, match=r"\(H, W, 3\)"):
        write_exr(tmp_path / "s.exr", np.zeros(shape, np.float32))


# --------------------------------------------------------------------------- unreadable files


def _corrupt(tmp_path, name: str, data: bytes):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def test_unreadable_files_raise_image_error_naming_path(tmp_path, image, capfd):
    good = write_exr(tmp_path / "good.exr", image).read_bytes()
    cases = {
        tmp_path / "missing.exr": "no such file",
        _corrupt(tmp_path, "text.exr", b"this is not an image\n" * 20): "not an OpenEXR file",
        _corrupt(tmp_path, "empty.exr", b""): "empty file",
        _corrupt(tmp_path, "header_cut.exr", good[:100]): "unreadable|truncated",
        _corrupt(tmp_path, "half_cut.exr", good[: len(good) // 2]): "truncated",
        _corrupt(tmp_path, "tail_cut.exr", good[:-8]): "truncated",
        tmp_path: "not a regular file",
    }
    for path, match in cases.items():
        with pytest.raises(ImageError, match=match) as err:
            read_exr(path)
        assert str(path) in str(err.value), err.value
    # The binding's own stdout warning is captured into the error, not printed.
    assert "Warning" not in capfd.readouterr().out


# --------------------------------------------------------------------------- files from other writers


def test_separate_and_mixed_type_channels(tmp_path, image):
    p = tmp_path / "sep.exr"
    channels = {"R": image[..., 0].copy(), "G": image[..., 1].copy(), "B": image[..., 2].astype(np.float16),
                "A": np.ones(image.shape[:2], np.float32), "Z": image[..., 0].copy()}
    OpenEXR.File({"compression": OpenEXR.PIZ_COMPRESSION}, channels).write(str(p))
    back, md = read_exr(p)
    assert md == {}
    assert np.array_equal(back[..., :2], image[..., :2])
    assert np.array_equal(back[..., 2], image[..., 2].astype(np.float16).astype(np.float32))


def test_luminance_only_file_is_broadcast(tmp_path, image):
    p = tmp_path / "y.exr"
    OpenEXR.File({}, {"Y": image[..., 1].copy()}).write(str(p))
    back, _ = read_exr(p)
    assert back.shape == image.shape
    for c in range(3):
        assert np.array_equal(back[..., c], image[..., 1])


def test_single_layer_file(tmp_path, image):
    p = tmp_path / "layer.exr"
    OpenEXR.File({}, {f"ViewLayer.Combined.{c}": image[..., i].copy() for i, c in enumerate("RGB")}).write(str(p))
    assert np.array_equal(read_exr(p)[0], image)


def test_file_without_colour_channels(tmp_path, image):
    p = tmp_path / "rg.exr"
    OpenEXR.File({}, {"R": image[..., 0].copy(), "G": image[..., 1].copy()}).write(str(p))
    with pytest.raises(ImageError, match=r"no R, G, B or Y channels.*\['G', 'R'\]") as err:
        read_exr(p)
    assert str(p) in str(err.value)


def test_integer_channels_refused(tmp_path):
    p = tmp_path / "u.exr"
    u = np.zeros((4, 4), np.uint32)
    OpenEXR.File({}, {"R": u, "G": u, "B": u}).write(str(p))
    with pytest.raises(ImageError, match="integer pixel type"):
        read_exr(p)


def test_written_files_get_the_usual_permissions(tmp_path, image):
    """Atomic writes go through a private temporary file; the finished file is not left 0600 but gets
    what any new file gets (0666 less the umask), so outputs and reports can be shared."""
    import os

    from compare.util.files import write_text_atomic
    from compare.image.tonemap import write_png

    old = os.umask(0o022)
    try:
        write_exr(tmp_path / "a.exr", image)
        write_png(tmp_path / "a.png", image)
        write_text_atomic(tmp_path / "a.json", "{}")
        os.umask(0o077)
        write_text_atomic(tmp_path / "private.json", "{}")
    finally:
        os.umask(old)
    for name in ("a.exr", "a.png", "a.json"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o644, name
    assert (tmp_path / "private.json").stat().st_mode & 0o777 == 0o600  # a stricter umask is kept
