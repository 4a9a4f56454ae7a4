"""The per-pixel z-test (compare.metrics.ztest, compare diff --ztest)."""

from __future__ import annotations


import numpy as np
import pytest

from compare.cli.main import main
from compare.image.exr import write_exr
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import load_scene
from compare.metrics.ztest import pass_statistics, z_test
from tests.helpers import CORNELL


@pytest.fixture(scope="module")
def two_references():
    """Two independent sets of 8 Mitsuba passes (512 spp each) of the Cornell box at 32x24 (about 1 % noise
    per pixel)."""
    r = ReferenceRenderer(load_scene(CORNELL).with_resolution(32, 24), cache_dir=False, progress=False)
    return r.independent_passes(8, 512, seed=1), r.independent_passes(8, 512, seed=2)


def _z(a, b, scale=1.0, **kw):
    ma, va, da = pass_statistics(a)
    mb, vb, db = pass_statistics(b)
    return z_test(ma, va, mb * scale, vb * scale**2, dof_a=da, dof_b=db, **kw)


def test_two_independent_references_are_consistent(two_references):
    a, b = two_references
    for block in (1, 4, 8):
        res = _z(a, b, block=block)
        assert res.passed, str(res)
    assert _z(a, b).values == a[0].size
    # with the 8 passes' variances taken as known (the normal in place of Student's t) the tails are
    # too light: at least as many values fall below the level
    ma, va, _ = pass_statistics(a)
    mb, vb, _ = pass_statistics(b)
    assert z_test(ma, va, mb, vb).rejected >= _z(a, b).rejected


def test_a_one_percent_brightness_change_is_rejected(two_references):
    a, b = two_references
    res = _z(a, b, 1.01, block=8)
    assert not res.passed and res.rejected > 0, str(res)
    # per pixel, 1 % hides in 1 % noise per pass; ten times that shows pixel by pixel
    assert _z(a, b, 1.10).rejected > 0


def test_exact_pixels_must_match_exactly():
    img = np.ones((4, 4, 3))
    assert z_test(img, 0.0, img, 0.0).passed
    other = img.copy()
    other[1, 2, 0] += 1e-9
    res = z_test(img, 0.0, other, 0.0)
    assert res.rejected == 1 and res.worst == (1, 2, 0)
    with pytest.raises(ValueError, match="shape"):
        z_test(img, 0.0, np.ones((4, 5, 3)), 0.0)
    with pytest.raises(ValueError, match="independent renders"):
        pass_statistics(img[None])
    with pytest.raises(ValueError, match="block"):
        z_test(img, 0.0, img, 0.0, block=5)


def test_ztest_command(tmp_path, two_references, capsys):
    a, b = two_references
    for name, passes in (("a", a), ("b", b)):
        for k, im in enumerate(passes):
            write_exr(tmp_path / name / f"pass-{k}.exr", im)
    mb, vb, _ = pass_statistics(b)
    write_exr(tmp_path / "b-mean.exr", mb)
    write_exr(tmp_path / "b-var.exr", vb)
    write_exr(tmp_path / "brighter.exr", mb * 1.01)
    write_exr(tmp_path / "brighter-var.exr", vb * 1.01**2)
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b"), "--ztest"]) == 0
    assert "z-test: consistent" in capsys.readouterr().out
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "b-mean.exr"), "--ztest",
                 "--test-variance", str(tmp_path / "b-var.exr")]) == 0
    assert main(["diff", str(tmp_path / "a"), str(tmp_path / "brighter.exr"), "--ztest", "--block", "8",
                 "--test-variance", str(tmp_path / "brighter-var.exr")]) == 1
    assert "NOT consistent" in capsys.readouterr().out
    # neither side has a variance: one clear error, no traceback
    assert main(["diff", str(tmp_path / "b-mean.exr"), str(tmp_path / "brighter.exr"), "--ztest"]) == 2
    assert "needs the variance of at least one side" in capsys.readouterr().err
    (tmp_path / "one").mkdir()
    write_exr(tmp_path / "one" / "x.exr", mb)
    assert main(["diff", str(tmp_path / "one"), str(tmp_path / "b"), "--ztest"]) == 2
    assert "at least two EXRs" in capsys.readouterr().err


def test_reference_ladder_is_consistent_with_its_ground_truth(tmp_path, capsys):
    """The ground truth and the convergence ladder of another seed, each with the per-pixel variance of
    its own passes: consistent; the ground truth 1 % brighter: not (tiles of 8 x 8)."""
    r = ReferenceRenderer(load_scene(CORNELL).with_resolution(32, 24), cache_dir=False, progress=False)
    gt = list(r.iter_checkpoints([4096], seed=0))[-1].image
    gt_var, gt_dof = r.variance
    ladder = r.ladder(4096, seed=1)[-1].image
    ladder_var, ladder_dof = r.variance
    assert gt_dof >= 8 and ladder_dof >= 8  # passes of at most 64 spp: many of them
    res = z_test(gt, gt_var, ladder, ladder_var, dof_a=gt_dof, dof_b=ladder_dof)
    assert res.passed, str(res)
    res = z_test(gt * 1.01, gt_var * 1.01**2, ladder, ladder_var, dof_a=gt_dof, dof_b=ladder_dof, block=8)
    assert not res.passed, str(res)
    # the same through the command line, with the variance image compare run writes beside a ground truth
    write_exr(tmp_path / "gt.exr", gt)
    write_exr(tmp_path / "gt-var.exr", gt_var, metadata={"dof": gt_dof})
    write_exr(tmp_path / "ladder.exr", ladder)
    write_exr(tmp_path / "ladder-var.exr", ladder_var, metadata={"dof": ladder_dof})
    assert main(["diff", str(tmp_path / "gt.exr"), str(tmp_path / "ladder.exr"), "--ztest",
                 "--reference-variance", str(tmp_path / "gt-var.exr"),
                 "--test-variance", str(tmp_path / "ladder-var.exr")]) == 0
