"""Text from run directories is escaped in every report format (HTML, Markdown, JUnit XML with
control characters replaced), so a hostile or broken name neither injects markup nor crashes ``report``."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.report.text import md_text, printable

from .synth_runs import write_ci_batch

runner = CliRunner()

SCRIPT = "<script>alert(1)</script>"
SVG = "<svg onload=alert(2)>"
IMG = "<img src=x onerror=alert(3)>"


def hostile_batch(root: Path) -> Path:
    runs = write_ci_batch(root / "runs")
    p = runs / "gust" / "summary.json"
    s = json.loads(p.read_text())
    s["case"] = f"gust{SCRIPT}\x1b[31m"
    s["status_message"] = f"bad {IMG}\x07"
    c = s["checks"][0]
    c.update(name=f"{SVG}\x00 check $x^2$ | pipe", passed=False, message=f"{SCRIPT}\x0b message")
    s["passed"] = False
    p.write_text(json.dumps(s))
    b = json.loads((runs / "batch.json").read_text())
    b["pipeline"] = f"ci{SCRIPT}"
    for case in b["cases"]:
        if case["case"] == "gust":
            case.update(case=s["case"], passed=False)
    b["cases"].append({"case": f"err{SVG}\x1f", "run_id": "err", "status": "error", "passed": False,
                       "error": f"boom {IMG}\x02", "seed": 0})
    (runs / "batch.json").write_text(json.dumps(b))
    return runs


def test_helpers() -> None:
    assert printable("a\x1bb\x00c\td\ne") == "a\\x1bb\\x00c\td\ne"
    assert md_text("<b>&amp;|x\n<= 3 & 4") == "&lt;b>&amp;amp;\\|x <= 3 & 4"


def test_every_format_escapes_hostile_text(tmp_path: Path) -> None:
    runs = hostile_batch(tmp_path)
    out = tmp_path / "rep"
    r = runner.invoke(app, ["report", str(runs), "--out", str(out), "--figures", "none"])
    assert r.exit_code == 1, r.stderr  # a failed check and an errored case, but the report is written
    md = (out / "summary.md").read_text()
    html = (out / "report.html").read_text()
    junit = (out / "junit.xml").read_text()
    for text in (md, html):
        for raw in (SCRIPT, SVG, IMG, "<script", "<svg", "<img"):
            assert raw not in text
        assert "\x1b" not in text and "\x00" not in text and "\x07" not in text
    assert "&lt;script>" in md and "\\x1b" in md
    root = ET.fromstring(junit)  # well-formed XML (a control character made `report` exit 3 before)
    names = [tc.get("name") for tc in root.iter("testcase")]
    assert any(n and n.startswith(SVG + "\\x00") for n in names)
    assert any(tc.get("classname", "").endswith("\\x1b[31m") for tc in root.iter("testcase"))
    assert json.loads((out / "summary.json").read_text())["totals"]["errors"] == 1
