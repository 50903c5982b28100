"""report.html / summary.md / junit.xml / summary.json from synthetic batches (library API)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from lxml import etree

from vinecli.report import build_report
from vinecli.report.plots import FIGURES

from .synth_runs import MISSIONS, clone_batch, write_ci_batch

XSD = Path(__file__).resolve().parents[1] / "data" / "junit-10.xsd"


def validate_junit(path: Path) -> etree._ElementTree:
    schema = etree.XMLSchema(etree.parse(str(XSD)))
    doc = etree.parse(str(path))
    schema.assertValid(doc)
    return doc


@pytest.fixture(scope="module")
def ci_report(ci_runs: Path, tmp_path_factory: pytest.TempPathFactory):
    return build_report(ci_runs, tmp_path_factory.mktemp("rep") / "report", workers=1)


def test_passing_batch(ci_report) -> None:
    assert ci_report.exit_code == 0
    assert (ci_report.n_runs, ci_report.n_passed, ci_report.n_failed, ci_report.n_errors) == (4, 4, 0, 0)
    assert sorted(p.name for p in ci_report.out_dir.iterdir()) == [
        "junit.xml", "manifest.json", "report.html", "summary.json", "summary.md"]


def test_html_is_self_contained_with_every_figure_and_check(ci_report, ci_runs: Path) -> None:
    html = ci_report.html.read_text(encoding="utf-8")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, re.I)
    assert "<script" not in html.lower() and "<link" not in html.lower() and "@import" not in html
    imgs = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    # every figure of every run; the three spray figures (deposition, coverage, budget) only for the run that sprayed
    assert len(imgs) == len(MISSIONS) * (len(FIGURES) - 3) + 3
    import base64

    assert all(base64.b64decode(b)[:8] == b"\x89PNG\r\n\x1a\n" for b in imgs)
    # overview columns and one section per run with every check
    for col in ("mission", "vehicle", "world", "seed", "status", "checks passed", "duration (sim)", "real-time factor"):
        assert f">{col}<" in html
    for m in MISSIONS:
        assert f'id="run-{m}"' in html
        summary = json.loads((ci_runs / m / "summary.json").read_text())
        for c in summary["checks"]:
            assert f"<b>{c['name']}</b>" in html
    assert "synthetic-vineyard" in html and "x500-sprayer" in html


def test_junit_validates_and_has_one_testcase_per_check(ci_report, ci_runs: Path) -> None:
    doc = validate_junit(ci_report.files["junit"])
    suites = doc.getroot().findall("testsuite")
    assert sorted(s.get("name") for s in suites) == sorted(MISSIONS)
    n_checks = sum(len(json.loads((ci_runs / m / "summary.json").read_text())["checks"]) for m in MISSIONS)
    assert len(doc.getroot().findall(".//testcase")) == n_checks
    assert doc.getroot().get("failures") == "0" and doc.getroot().get("errors") == "0"
    props = {p.get("name"): p.get("value") for p in doc.getroot().iter("property")}
    assert float(props["spray:deposit_balance_error"]) <= 1e-6 and "gust:deposit_emitted_l" not in props


def test_summary_json_and_markdown(ci_report) -> None:
    s = json.loads(ci_report.files["json"].read_text())
    assert s["passed"] is True and s["exit_code"] == 0 and s["totals"]["runs"] == 4
    gust = next(r for r in s["runs"] if r["case"] == "gust")
    assert gust["figures"] == {fid: "rendered" if fid not in ("fig23", "fig24", "fig25") else
                               "skipped: no deposition in this run (no sprayer used)" for fid in FIGURES}
    spray = next(r for r in s["runs"] if r["case"] == "spray")
    assert spray["figures"] == {fid: "rendered" for fid in FIGURES}
    assert spray["metrics"]["deposit_balance_error"] <= 1e-6 and spray["metrics"]["deposit_emitted_l"] > 0.5
    assert gust["metrics"]["max_tilt_deg"] > 3.0  # the gust tilts the vehicle ~5°
    md = ci_report.files["md"].read_text()
    assert md.startswith("## ✅") and "| gust | gust |" in md and "Failed checks" not in md
    dep = md.split("### Spray deposition", 1)[1]
    assert "| spray |" in dep and "| gust |" not in dep and "L/ha" in dep


def test_a_failing_check_appears_in_every_format(failing_runs: Path, tmp_path: Path) -> None:
    res = build_report(failing_runs, tmp_path / "rep", figures="none")
    assert res.exit_code == 1 and res.failed_checks == [("gust", "holds_position")]
    gust = json.loads((failing_runs / "gust" / "summary.json").read_text())
    chk = next(c for c in gust["checks"] if c["name"] == "holds_position")
    value = f"{chk['value']:.4g}"
    # JUnit: a <failure> with the value and the bound, still schema-valid
    doc = validate_junit(res.files["junit"])
    fails = doc.getroot().findall(".//testcase/failure")
    assert len(fails) == 1
    tc = fails[0].getparent()
    assert tc.get("name") == "holds_position" and tc.get("classname") == "gust.gust"
    assert fails[0].get("message") == f"holds_position: value {value}, expected <= 0.1"
    suite = next(s for s in doc.getroot().findall("testsuite") if s.get("name") == "gust")
    assert suite.get("failures") == "1"
    # Markdown, JSON, HTML
    md = res.files["md"].read_text()
    assert md.startswith("## ❌") and f"| gust | holds_position | {value} | <= 0.1 |" in md
    s = json.loads(res.files["json"].read_text())
    assert s["exit_code"] == 1 and s["totals"]["failed_checks"] == 1
    assert next(r for r in s["runs"] if r["case"] == "gust")["failed_checks"] == ["holds_position"]
    html = res.html.read_text()
    row = re.search(r'<tr class="fail"><td><b>holds_position</b>.*?</tr>', html, re.S)
    assert row and value in row.group(0) and "&lt;= 0.1" in row.group(0) and ">FAIL<" in row.group(0)


def test_an_errored_case_is_a_junit_error(ci_runs: Path, tmp_path: Path) -> None:
    runs = write_ci_batch(tmp_path / "runs", errored=["sweep-7"])
    res = build_report(runs, tmp_path / "rep", figures="none")
    assert res.exit_code == 1 and res.n_errors == 1 and res.n_failed == 0
    doc = validate_junit(res.files["junit"])
    errs = doc.getroot().findall(".//testcase/error")
    assert len(errs) == 1 and "worker crashed" in errs[0].get("message")
    assert "| sweep-7 | (run) |" in res.files["md"].read_text()
    assert "ERROR" in res.html.read_text()


def test_baseline_flags_an_injected_regression_in_every_format(ci_runs: Path, drifting_runs: Path,
                                                                tmp_path: Path) -> None:
    res = build_report(drifting_runs, tmp_path / "rep", baseline=ci_runs, figures="none")
    assert res.n_failed == 0  # every check still passes ...
    assert res.exit_code == 1  # ... but the position error regressed
    regs = [(g.case, g.kind, g.name) for g in res.regressions]
    assert ("gust", "metric", "hpos_error_max_m") in regs
    assert all(case == "gust" for case, _, _ in regs)
    g = next(g for g in res.regressions if g.name == "hpos_error_max_m")
    assert g.baseline == pytest.approx(0.25, abs=0.05) and g.current == pytest.approx(0.5, abs=0.05)
    doc = validate_junit(res.files["junit"])
    names = [tc.get("name") for tc in doc.getroot().iter("testcase") if tc.find("failure") is not None]
    assert "regression:hpos_error_max_m" in names
    assert "hpos_error_max_m" in res.files["md"].read_text()
    assert "Regressions vs baseline" in res.html.read_text()
    s = json.loads(res.files["json"].read_text())
    assert any(r["name"] == "hpos_error_max_m" for r in s["regressions"])


def test_newly_failing_check_is_a_regression(ci_runs: Path, failing_runs: Path, tmp_path: Path) -> None:
    res = build_report(failing_runs, tmp_path / "rep", baseline=ci_runs, figures="none", formats="json")
    assert [(g.case, g.kind, g.name) for g in res.regressions] == [("gust", "check", "holds_position")]


def test_same_valued_baseline_flags_nothing(ci_runs: Path, tmp_path: Path) -> None:
    same = tmp_path / "same"
    shutil.copytree(ci_runs, same)
    res = build_report(ci_runs, tmp_path / "rep", baseline=same, figures="none", formats="md,json")
    assert res.regressions == [] and res.exit_code == 0
    assert "No regressions (4 cases compared)" in res.files["md"].read_text()


def test_tolerance_override_silences_the_regression(ci_runs: Path, drifting_runs: Path, tmp_path: Path) -> None:
    from vinecli.report.baseline import parse_tolerances

    res = build_report(drifting_runs, tmp_path / "rep", baseline=ci_runs, figures="none", formats="json",
                       tolerances=parse_tolerances(["hpos_error_max_m=1.0", "max_tilt_deg=5:0.5"]))
    assert res.regressions == []


def test_large_batch_paginates_with_per_run_pages(ci_runs: Path, tmp_path: Path) -> None:
    big = clone_batch(ci_runs, tmp_path / "big", 130, fail_every=10)
    res = build_report(big, tmp_path / "rep", max_figure_runs=1, page_size=50, inline_limit=20, workers=1)
    assert res.n_runs == 130 and res.n_failed == 13 and res.figure_runs == 1
    out = res.out_dir
    assert sorted(p.name for p in (out / "pages").iterdir()) == ["overview-2.html", "overview-3.html"]
    assert len(list((out / "runs").glob("*.html"))) == 130
    html = res.html.read_text()
    assert "page 1 of 3" in html and 'href="pages/overview-2.html"' in html
    first = re.search(r'<tr class="(\w+)"><td><a href="runs/([^"]+)\.html">', html)
    assert first and first.group(1) == "fail"  # failing runs first
    assert "data:image/png" not in html  # figures only on per-run pages
    pages = sorted((out / "runs").glob("*.html"))
    with_figs = [p for p in pages if "data:image/png" in p.read_text()]
    assert len(with_figs) == 1
    assert "figures not rendered for this run" in next(p for p in pages if p not in with_figs).read_text()
    s = json.loads(res.files["json"].read_text())
    assert len(s["runs"]) == 130 and all((out / r["page"]).is_file() for r in s["runs"])
    validate_junit(res.files["junit"])


def test_figures_render_in_a_process_pool(ci_runs: Path, tmp_path: Path) -> None:
    from vinecli.report.assemble import render_all
    from vinecli.report.loader import load_runs
    from vinecli.report.plots import png_size

    runs = [r for r in load_runs(ci_runs) if r.case in ("overload", "takeoff")]
    calls: list[tuple[int, int]] = []
    figs = render_all(runs, workers=2, progress=lambda i, n: calls.append((i, n)))
    assert sorted(figs) == ["overload", "takeoff"] and calls[-1] == (2, 2)
    assert all(png_size(f["png"]) for run in figs.values() for fid, f in run.items() if fid not in ("fig23", "fig24", "fig25"))
