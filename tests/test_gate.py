"""``compare check --baseline``: the statistics, the whole gate with a small external renderer, baselines as files,
the outputs for CI systems and ``compare history``."""

from __future__ import annotations

import json
import math
import re
import os
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from compare.cli.main import main
from compare.metrics.regression import coefficient_of_variation, holm, image_test, paired, welch
from tests.helpers import GATE_SEEDS, ROOT, gate_run


# --------------------------------------------------------------------------- the statistics


def test_welch_matches_scipy_and_its_interval_covers():
    from scipy.stats import ttest_ind

    rng = np.random.default_rng(1)
    a, b = rng.normal(1.0, 0.1, 6), rng.normal(1.1, 0.2, 5)
    w = welch(a, b, level=0.99)
    ref = ttest_ind(b, a, equal_var=False, alternative="greater")
    assert w.p == pytest.approx(ref.pvalue, rel=1e-10)
    assert w.diff == pytest.approx(b.mean() - a.mean()) and w.low < w.diff < w.high
    # the interval of the difference covers the true difference at its level (here 0.1, in 95 % of draws)
    covered = 0
    for _ in range(400):
        x, y = rng.normal(0.0, 1.0, 5), rng.normal(0.1, 2.0, 4)
        v = welch(x, y, level=0.95)
        covered += v.low <= 0.1 <= v.high
    assert 0.92 <= covered / 400 <= 0.98
    # without spread the difference is known exactly
    assert welch([1, 1], [1, 1]).p == 1.0 and welch([1, 1], [2, 2]).p == 0.0 and welch([2, 2], [1, 1]).p == 1.0
    # equal values are without spread though their float variance is not 0 (1e-34 for three 0.1s)
    assert welch([0.1] * 3, [0.1] * 3).p == 1.0 and paired([0.1] * 3, [0.2] * 3).p == 0.0
    with pytest.raises(ValueError, match="at least 2"):
        welch([1.0], [1.0, 2.0])


def test_paired_matches_scipy_and_sees_through_the_seeds_noise():
    from scipy.stats import ttest_rel

    rng = np.random.default_rng(3)
    seed_noise = rng.normal(0.0, 1.0, 6)  # what each seed puts into both sides
    a = 10 + seed_noise + rng.normal(0, 0.002, 6)
    b = 10.02 + seed_noise + rng.normal(0, 0.002, 6)
    p = paired(a, b, level=0.99)
    assert p.p == pytest.approx(ttest_rel(b, a, alternative="greater").pvalue, rel=1e-10)
    assert p.p < 0.01 and p.low > 0 and welch(a, b).p > 0.3  # Welch cannot see 0.02 under the seeds' spread of 1
    assert paired([1, 2, 3], [1, 2, 3]).p == 1.0 and paired([1, 2, 3], [1.5, 2.5, 3.5]).p == 0.0
    with pytest.raises(ValueError, match="3 baseline values but 2"):
        paired([1, 2, 3], [1, 2])


def test_holm_and_the_coefficient_of_variation():
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([]) == [] and holm([0.5]) == [0.5] and holm([0.6, 0.9]) == [1.0, 1.0]
    assert coefficient_of_variation([1.0, 1.0]) == 0.0
    assert coefficient_of_variation([1.0, 3.0]) == pytest.approx(math.sqrt(2) / 2)
    assert coefficient_of_variation([1.0]) == math.inf


def test_image_test_is_calibrated_and_sees_a_small_brightness_change():
    """Under the null (two stacks of one noisy image) the image test rejects at about its level; a 5 %
    brightness change it cannot see per pixel it sees in 8x8 tiles, whose variance comes from the seeds
    (noise correlated between pixels would fool a variance divided by the tile's area)."""
    rng = np.random.default_rng(2)
    truth = rng.uniform(0.2, 0.8, (24, 32, 3))
    false = 0
    for _ in range(100):
        a = truth + rng.normal(0, 0.05, (5, 24, 32, 3))
        b = truth + rng.normal(0, 0.05, (5, 24, 32, 3))
        false += image_test(a, b).p <= 0.05
    assert false <= 12  # binomial(100, 0.05): more than 12 has probability < 0.2 %
    a = truth + rng.normal(0, 0.05, (5, 24, 32, 3))
    b = 0.95 * (truth + rng.normal(0, 0.05, (5, 24, 32, 3)))
    assert image_test(a, b).p > 0.01
    assert image_test(a, b, block=8).p < 0.01
    # noise shared by every pixel of a render (one light sample for the whole frame): per-seed offsets
    offsets = rng.normal(0, 0.02, (5, 1, 1, 1)), rng.normal(0, 0.02, (5, 1, 1, 1))
    a = truth + offsets[0] + rng.normal(0, 0.05, (5, 24, 32, 3))
    b = truth + offsets[1] + rng.normal(0, 0.05, (5, 24, 32, 3))
    assert image_test(a, b, block=8).p > 1e-3
    same = np.stack([truth] * 3)
    assert image_test(same, same).p == 1.0 and image_test(same, same * 1.01).p == 0.0
    # paired by seed: the seeds' own noise cancels, and an unchanged deterministic render differs by nothing
    a = truth + rng.normal(0, 0.05, (5, 24, 32, 3))
    assert image_test(a, a, pair=True).p == 1.0 and image_test(a, 0.999 * a, pair=True).p < 1e-4
    assert image_test(a, a + rng.normal(0, 0.01, a.shape), pair=True).p > 0.01
    with pytest.raises(ValueError, match="block"):
        image_test(a, b, block=25)


# --------------------------------------------------------------------------- the whole gate


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """The baseline and five candidates: a rerun of the same code with the same seeds, and four whose salt gives
    them noise independent of the baseline's (as a renderer whose noise is not reproducible would have)."""
    root = tmp_path_factory.mktemp("gate")
    return {name: gate_run(root / name, **kw) for name, kw in [
        ("base", {}), ("rerun", {}), ("same", {"salt": 1}), ("darker", {"bright": 0.95, "salt": 2}),
        ("slower", {"slow": 1.3, "salt": 3}), ("noisy", {"jitter": 0.5, "salt": 4})]}


@pytest.fixture(scope="module")
def baseline(runs, tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("baseline") / "bl"
    assert main(["baseline", "save", str(folder), "--results", str(runs["base"])]) == 0
    return folder


def check(results: Path, baseline: Path, *more: str, capsys) -> tuple[int, dict]:
    status = main(["check", str(results), "--baseline", str(baseline), "--json", *more])
    return status, json.loads(capsys.readouterr().out)


def by_kind(report: dict) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for g in report["gates"]:
        out.setdefault(g["kind"], []).append(g["status"])
    return out


def test_the_gate_passes_the_same_code_and_fails_a_darker_and_a_slower_renderer(runs, baseline, tmp_path, capsys):
    """The whole gate, run twice (baseline, then candidate) with a small external renderer: the same code
    passes; 5 % darker fails on error (and its image changed); 30 % slower fails on time; timings whose
    spread is too large are inconclusive, which is reported and does not fail."""
    status, rerun = check(runs["rerun"], baseline, capsys=capsys)
    assert status == 0 and {(g["kind"], g["p"]) for g in rerun["gates"] if g["kind"] in ("error", "image", "bias")} == {
        ("error", 1.0), ("image", 1.0), ("bias", 1.0)}  # the same seeds: exactly the same images
    assert {g["status"] for g in rerun["gates"] if g["kind"] == "seed"} == {"pass"}

    status, same = check(runs["same"], baseline, capsys=capsys)
    kinds = by_kind(same)
    assert status == 0 and not same["failed"]
    assert len(kinds["error"]) == 4 and len(kinds["time"]) == 4 and kinds["image"] == ["pass"]
    assert set(kinds["error"]) == {"pass"} and "slower" not in kinds["time"]
    assert set(kinds["seed"]) == {"pass"} and kinds["bias"] == ["pass"]

    status, darker = check(runs["darker"], baseline, capsys=capsys)
    kinds = by_kind(darker)
    assert status == 1 and darker["failed"]
    assert kinds["error"] == ["regression"] * 4 and kinds["image"] == ["changed"] and kinds["bias"] == ["regression"]
    assert "slower" not in kinds["time"]
    final = next(g for g in darker["gates"] if g["kind"] == "error" and g["step"] == 8)
    assert final["candidate"] > final["baseline"] and final["low"] > 0 and final["p_holm"] <= 0.01

    status, slower = check(runs["slower"], baseline, capsys=capsys)
    kinds = by_kind(slower)
    assert status == 1 and "slower" in kinds["time"] and set(kinds["error"]) == {"pass"}
    final = next(g for g in slower["gates"] if g["kind"] == "time" and g["step"] == 8)
    assert final["status"] == "slower" and final["ratio"] >= 1.15

    status, noisy = check(runs["noisy"], baseline, capsys=capsys)
    kinds = by_kind(noisy)
    assert status == 0 and set(kinds["time"]) == {"inconclusive"} and set(kinds["error"]) == {"pass"}
    assert all("too noisy" in g["note"] for g in noisy["gates"] if g["kind"] == "time")
    assert noisy["counts"]["inconclusive"] == 4

    # the ratio bound and the level are settings, as in Babylon.js' performance tests
    status, loose = check(runs["slower"], baseline, "--time-ratio", "1.5", capsys=capsys)
    assert status == 0 and "slower" not in by_kind(loose)["time"]
    status, _ = check(runs["noisy"], baseline, "--max-cv", "5", capsys=capsys)  # judged now, and equal in the mean
    status_text = main(["check", str(runs["darker"]), "--baseline", str(baseline)])
    table = capsys.readouterr().out
    assert status_text == 1 and "REGRESSION" in table and "changed" in table and "error relmse" in table


def test_error_by_the_image_z_test_and_in_tiles(runs, baseline, capsys):
    """--error-test ztest judges the final checkpoint's error by the image z-test; --block tests tiles."""
    status, darker = check(runs["darker"], baseline, "--error-test", "ztest", "--block", "4", capsys=capsys)
    final = next(g for g in darker["gates"] if g["kind"] == "error" and g["step"] == 8)
    image = next(g for g in darker["gates"] if g["kind"] == "image")
    assert status == 1 and final["status"] == "regression" and "z-test" in final["note"]
    assert image["status"] == "changed" and "(4x4 tiles)" in image["note"]
    status, same = check(runs["same"], baseline, "--error-test", "ztest", "--block", "4", capsys=capsys)
    assert status == 0 and not same["failed"]
    assert main(["check", str(runs["same"]), "--baseline", str(baseline), "--block", "64"]) == 2
    assert "larger than the 32x24 image" in capsys.readouterr().err
    for bad in (["--alpha", "1.5"], ["--time-ratio", "0.9"], ["--metric", "nope"]):
        with pytest.raises(SystemExit):
            main(["check", str(runs["same"]), "--baseline", str(baseline), *bad])


def test_outputs_for_ci_systems(runs, baseline, tmp_path, capsys):
    junit, summary, page = tmp_path / "junit.xml", tmp_path / "summary.md", tmp_path / "page"
    summary.write_text("# earlier step\n")
    status = main(["check", str(runs["darker"]), "--baseline", str(baseline), "--junit", str(junit),
                   "--summary", str(summary), "--report", str(page), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert status == 1
    root = ET.parse(junit).getroot()
    cases = root.findall("./testsuite/testcase")
    assert len(cases) == len(report["gates"]) == int(root.get("tests"))
    failures = [c for c in cases if c.find("failure") is not None]
    failing = [g for g in report["gates"] if g["status"] in ("regression", "slower", "missing")]
    assert {g["kind"] for g in failing} == {"error", "seed", "bias"}  # darker: the errors, its seeds, its mean
    assert len(failures) == len(failing) == int(root.get("failures"))
    assert all(any(k in c.get("name") for k in ("error relmse", "seed relmse", "bias mean")) for c in failures)
    text = summary.read_text()
    assert text.startswith("# earlier step\n\n## ") and "## ❌ Regression gate" in text and "| REGRESSION |" in text
    html = (page / "index.html").read_text()
    assert "Images that changed" in html and "style=" not in html and "<script" not in html
    assert (page / "static" / "report.css").is_file() and len(list((page / "plots").glob("*.png"))) == 1
    changed = next((page / "images").iterdir())
    assert {p.name for p in changed.iterdir()} == {"baseline.png", "candidate.png", "z.png"}
    # the page is replaced on the next run; another folder is never overwritten
    assert main(["check", str(runs["same"]), "--baseline", str(baseline), "--report", str(page)]) == 0
    assert "Images that changed" not in (page / "index.html").read_text()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    assert main(["check", str(runs["same"]), "--baseline", str(baseline), "--report", str(tmp_path / "mine")]) == 2
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"
    capsys.readouterr()
    # the outputs belong to the gate
    assert main(["check", str(runs["same"]), "--junit", str(junit)]) == 2
    assert "give --baseline" in capsys.readouterr().err


def test_a_baseline_from_another_machine_compares_errors_and_images_only(runs, baseline, tmp_path, capsys):
    other = tmp_path / "other"
    shutil.copytree(baseline, other)
    for name in ("results.json", "baseline.json"):
        d = json.loads((other / name).read_text())
        d["machine"]["cpu"] = "Some Other CPU"
        (other / name).write_text(json.dumps(d))
    status, report = check(runs["slower"], other, capsys=capsys)
    assert status == 0 and set(by_kind(report)["time"]) == {"skipped"}
    assert "Some Other CPU" in report["machine"]
    status, report = check(runs["darker"], other, capsys=capsys)
    assert status == 1 and set(by_kind(report)["error"]) == {"regression"}
    main(["check", str(runs["slower"]), "--baseline", str(other)])
    assert "timings not compared: the baseline is from another machine (CPU 'Some Other CPU'" in capsys.readouterr().out


def test_a_run_missing_from_the_candidate_fails(runs, baseline, tmp_path, capsys):
    d = json.loads(runs["same"].read_text())
    d["scenes"][0]["name"] = "Renamed"
    renamed = runs["same"].parent / "renamed.json"
    renamed.write_text(json.dumps(d))
    status, report = check(renamed, baseline, capsys=capsys)
    assert status == 1 and report["counts"]["missing"] == 1
    assert any("new, not in the baseline" in n for n in report["notes"])


def test_bad_input_is_one_error_naming_the_file_and_field(runs, baseline, tmp_path, capsys):
    def error(*argv) -> str:
        assert main(list(argv)) == 2
        err = capsys.readouterr().err
        assert err.startswith("compare: error: ") and "Traceback" not in err and err.count("\n") == 1
        return err

    assert "no such baseline folder" in error("check", str(runs["same"]), "--baseline", str(tmp_path / "none"))
    broken = tmp_path / "broken"
    shutil.copytree(baseline, broken)
    index = json.loads((broken / "baseline.json").read_text())
    (broken / "baseline.json").write_text(json.dumps({**index, "schema": 7}))
    assert "baseline.json: schema: 7 is not supported" in error("check", str(runs["same"]), "--baseline", str(broken))
    (broken / "baseline.json").write_text(json.dumps({k: v for k, v in index.items() if k != "runs"}))
    assert "missing field 'runs'" in error("check", str(runs["same"]), "--baseline", str(broken))
    (broken / "baseline.json").write_text(json.dumps(index))
    (broken / index["runs"][0]["images"][1]).unlink()
    assert f"runs[0].images[1]: {broken / index['runs'][0]['images'][1]} is missing" in error(
        "check", str(runs["same"]), "--baseline", str(broken))
    (tmp_path / "bad.json").write_text("{")
    assert "bad.json: not valid JSON" in error("check", str(tmp_path / "bad.json"), "--baseline", str(baseline))
    assert "no such file" in error("baseline", "save", str(tmp_path / "b2"), "--results", str(tmp_path / "x.json"))
    assert not (tmp_path / "b2").exists() and not list(tmp_path.glob(".b2*"))


def test_baseline_save_and_update(runs, baseline, tmp_path, capsys):
    index = json.loads((baseline / "baseline.json").read_text())
    (run,) = index["runs"]
    assert len(run["images"]) == GATE_SEEDS and run["dof"] == GATE_SEEDS - 1 and index["machine"]["cores"] >= 1
    files = [p for p in baseline.rglob("*") if p.is_file()]
    assert sum(p.stat().st_size for p in files) < 300_000  # small enough to commit or cache
    kept = {p.relative_to(baseline).as_posix() for p in files}
    assert kept == {"baseline.json", "results.json", run["mean"], run["variance"], run["preview"], *run["images"]}
    # paths are relative: the folder moves
    moved = tmp_path / "moved"
    shutil.copytree(baseline, moved)
    assert main(["check", str(runs["same"]), "--baseline", str(moved)]) == 0
    # save refuses an existing folder; update refuses a folder that is not a baseline and replaces one that is
    assert main(["baseline", "save", str(moved), "--results", str(runs["same"])]) == 2
    (tmp_path / "plain").mkdir()
    assert main(["baseline", "update", str(tmp_path / "plain"), "--results", str(runs["same"])]) == 2
    capsys.readouterr()
    assert main(["baseline", "update", str(moved), "--results", str(runs["darker"])]) == 0
    assert "baseline of 1 run(s)" in capsys.readouterr().out
    assert main(["check", str(runs["darker"]), "--baseline", str(moved)]) == 0  # the accepted change is the baseline
    assert sorted(p.name for p in tmp_path.iterdir()) == ["moved", "plain"]  # no temporary folder left
    # the per-pixel variance of the mean is what `compare diff --ztest` reads
    index = json.loads((moved / "baseline.json").read_text())
    r = index["runs"][0]
    assert main(["diff", "--ztest", str(moved / r["mean"]), str(moved / r["mean"]),
                 "--reference-variance", str(moved / r["variance"])]) == 0


def test_history_page(runs, tmp_path, capsys):
    out = tmp_path / "history"
    assert main(["history", str(runs["base"]), str(runs["same"]), str(runs["darker"]), "-o", str(out),
                 "--labels", "a1,b2,c3"]) == 0
    html = (out / "index.html").read_text()
    assert "History of 3 runs" in html and "style=" not in html and "<script" not in html
    assert html.count("<tr><td>") == 3 and "c3" in html and len(list((out / "plots").glob("*.png"))) == 1
    from compare.report.history import series
    from compare.report.results import Results

    (s,) = series([Results.load(p) for p in (runs["base"], runs["darker"])])
    (m0, lo0, hi0), (m1, lo1, hi1) = s.error
    assert lo0 < m0 < hi0 and hi0 < lo1 < m1  # the darker renderer's band lies above the baseline's
    assert main(["history", str(runs["base"]), "-o", str(out), "--labels", "a,b"]) == 2
    assert "1 results file" in capsys.readouterr().err


# --------------------------------------------------------------------------- the CI example

WORKFLOW = ROOT / "examples" / "ci" / "render-gate.yml"


def workflow_commands() -> list[list[str]]:
    """Every ``compare`` command of the example workflow, as argv (its variables given values)."""
    import shlex

    import yaml

    flow = yaml.safe_load(WORKFLOW.read_text(encoding="utf-8"))
    env = {**flow["env"], "GITHUB_STEP_SUMMARY": "summary.md"}
    out = []
    for step in flow["jobs"]["gate"]["steps"]:
        for line in str(step.get("run", "")).splitlines():
            argv = shlex.split(line)
            if argv and argv[0] == ".venv/bin/compare":
                out.append([re.sub(r"\$(\w+)", lambda m: env[m.group(1)], a) for a in argv[1:]])
    return out


def test_the_ci_example_caches_both_folders_and_runs_valid_commands():
    import yaml

    from compare.cli.main import _build_parser

    flow = yaml.safe_load(WORKFLOW.read_text(encoding="utf-8"))
    steps = flow["jobs"]["gate"]["steps"]
    cached = {s["with"]["path"] for s in steps if str(s.get("uses", "")).startswith("actions/cache")}
    assert cached == {".compare-cache", "ci-baseline"} and flow["env"]["COMPARE_CACHE"].endswith(".compare-cache")
    commands = workflow_commands()
    assert [c[0] for c in commands] == ["run", "check", "baseline"]
    parser = _build_parser()
    parsed = [parser.parse_args(c) for c in commands]
    run, check_, save = parsed
    assert run.seeds >= 2 and str(run.output) == flow["env"]["RUN"]
    assert check_.results == save.results == run.output / "results.json"
    assert check_.baseline == save.dir and check_.junit and check_.summary and check_.report


@pytest.mark.slow
def test_the_ci_example_runs_locally(tmp_path, monkeypatch, capsys):
    """The workflow's commands as written, in order: a push to main (render, save the baseline), then a pull
    request of the same code (render, gate). Same code and seeds: errors and images are exactly equal."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / ".compare-cache"))
    (tmp_path / "scenes").symlink_to(ROOT / "scenes")
    run, check_, save = workflow_commands()
    assert main(run) == 0 and main(save) == 0
    shutil.rmtree(tmp_path / "reports")
    assert main(run) == 0
    capsys.readouterr()
    status = main(check_ + ["--json"])
    report = json.loads(capsys.readouterr().out)
    assert status in (0, 1)  # timings may differ between two runs on a shared machine; the rest may not
    assert {g["status"] for g in report["gates"] if g["kind"] != "time"} == {"pass"}
    assert (tmp_path / "reports/ci/junit.xml").is_file() and (tmp_path / "reports/ci/gate/index.html").is_file()
    assert "Regression gate" in (tmp_path / "summary.md").read_text()


@pytest.mark.slow
def test_false_alarm_rate_of_same_code_pairs(tmp_path):
    """20 pairs of same-code runs whose noise is independent (each run its own salt): the gate fails at most
    one of them at its level 0.01 (a gate calibrated at 0.01 fails two or more of 20 with probability 1.7 %;
    one failing at 0.1 would, with 61 %)."""
    from compare.report.baseline import save_baseline
    from compare.report.gate import run_gate

    failed, tests = [], 0
    for i in range(20):
        base = gate_run(tmp_path / f"b{i}", salt=100 + 2 * i)
        save_baseline(base, tmp_path / f"b{i}" / "baseline")
        report = run_gate(gate_run(tmp_path / f"c{i}", salt=101 + 2 * i), tmp_path / f"b{i}" / "baseline")
        tests += sum(g.p is not None for g in report.gates)
        if report.failed:
            failed.append([g.name for g in report.gates if g.failed(report.settings)])
        shutil.rmtree(tmp_path / f"b{i}" / "out" / "runs")
    assert tests >= 20 * 5 and len(failed) <= 1, failed  # the image and four error tests of each pair at least


def test_a_gate_that_judged_nothing_has_not_passed():
    """Runs of one seed give no noise estimate: when every test is inconclusive the exit status stays 0 (an
    inconclusive test does not fail) but the verdict is "inconclusive", not "passed", in every output."""
    from compare.report.gate import Gate, GateReport, GateSettings

    def report(*statuses):
        gates = [Gate("Cornell box", "32x24", "mine", 8, "error", "relmse", status=s) for s in statuses]
        return GateReport(GateSettings(), gates, "", [], "new/results.json", "bl")

    nothing = report("inconclusive", "inconclusive", "skipped")
    assert not nothing.failed and nothing.verdict == "inconclusive"
    assert nothing.summary_line().startswith("gate inconclusive:") and "⚠️" in nothing.markdown()
    assert nothing.to_json()["verdict"] == "inconclusive"
    assert report("pass", "inconclusive").verdict == "passed"
    assert report("regression", "inconclusive").verdict == "failed"


def test_baselines_keep_what_is_not_theirs_and_sweep_what_a_kill_left(runs, baseline, tmp_path, capsys):
    """update keeps a README and a .git the user keeps in the baseline folder; the parts a killed save or
    update left beside it are swept by the next baseline command, and a baseline moved aside just before the
    kill is put back; links out of the baseline or the run's folder are refused, never copied or published."""
    folder = tmp_path / "bl"
    shutil.copytree(baseline, folder)
    (folder / "README.md").write_text("our baseline, see the wiki\n")
    (folder / ".git").mkdir()
    (folder / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    assert main(["baseline", "update", str(folder), "--results", str(runs["darker"])]) == 0
    assert (folder / "README.md").read_text() == "our baseline, see the wiki\n"
    assert (folder / ".git" / "HEAD").is_file() and (folder / "baseline.json").is_file()
    # a SIGKILL mid-save: a half-written part; mid-update, between its renames: the old baseline aside
    (tmp_path / ".bl.part-abc").mkdir()
    (tmp_path / ".bl.part-abc" / "baseline.json").write_text("{")
    aside = tmp_path / ".bl.old.part-def"
    aside.mkdir()
    os.replace(folder, aside / "x")
    capsys.readouterr()
    assert main(["check", str(runs["darker"]), "--baseline", str(folder)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bl"] and (folder / "README.md").is_file()
    # a link inside the baseline to a file elsewhere: refused by name, not published by the gate page
    secret = tmp_path / "secret.png"
    secret.write_bytes(b"not yours")
    index = json.loads((folder / "baseline.json").read_text())
    preview = folder / index["runs"][0]["preview"]
    preview.unlink()
    preview.symlink_to(secret)
    capsys.readouterr()
    assert main(["check", str(runs["darker"]), "--baseline", str(folder)]) == 2
    assert "outside the baseline folder" in capsys.readouterr().err
    # results.json naming an image outside its run's folder: save refuses to copy it
    hostile = tmp_path / "run" / "results.json"
    hostile.parent.mkdir()
    d = json.loads(runs["same"].read_text())
    d["scenes"][0]["runs"][0]["image"] = str(secret)
    for s in d["scenes"][0]["runs"][0].get("seed_runs", []):
        s["image"] = "../secret.png"
    hostile.write_text(json.dumps(d))
    assert main(["baseline", "save", str(tmp_path / "stolen"), "--results", str(hostile)]) == 2
    assert not (tmp_path / "stolen").exists()


@pytest.mark.parametrize("broken", [(0, 1), (0, 1, 2, 3)])
def test_a_candidate_with_broken_seeds_fails(runs, baseline, tmp_path, capsys, broken):
    """Seeds 0 and 7919 of 5 at 125x the baseline's relMSE (or 4 of 5): the paired test's spread grows with
    the change and missed it; the per-seed test sees each broken seed far outside the baseline's spread."""
    folder = tmp_path / "cand"
    shutil.copytree(runs["same"].parent, folder, symlinks=True)
    d = json.loads((folder / "results.json").read_text())
    run = next(r for r in d["scenes"][0]["runs"] if r["renderer"] == "mine")
    for k in broken:
        for p in run["seed_runs"][k]["points"]:
            p["metrics"]["relmse"] *= 125.0
    (folder / "results.json").write_text(json.dumps(d))
    status, report = check(folder / "results.json", baseline, capsys=capsys)
    assert status == 1
    seed = [g for g in report["gates"] if g["kind"] == "seed" and g["step"] == 8]
    assert seed and seed[0]["status"] == "regression" and seed[0]["p_holm"] <= 0.01
    assert "prediction-interval units above" in seed[0]["note"]
