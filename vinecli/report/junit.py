"""JUnit XML for CI (junitparser): one testsuite per mission, one testcase per check.

Testcase ``classname`` is ``<mission>.<case>``, ``name`` the check name; a failed check is a
``<failure>`` whose message states the measured value and the bound; a case that could not run
is one ``<error>`` testcase; baseline regressions are extra failing testcases named
``regression:<name>``. Control characters in any text are written as ``\\xNN`` escapes. The output validates against the Jenkins/Surefire JUnit schema
(``tests/data/junit-10.xsd``): ``<testsuites>`` carries name/tests/failures/errors/time only.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vinecli.report.baseline import Comparison
from vinecli.report.loader import Run
from vinecli.report.text import format_value, printable


def check_message(c: dict[str, Any], failsafe: str = "") -> str:
    """One line: ``name: value V, expected OP BOUND`` (``; failsafe: ...`` when the run had one; control
    characters escaped)."""
    msg = f"{c['name']}: value {format_value(c.get('value'))}, expected {c.get('op')} {format_value(c.get('bound'))}"
    return printable(f"{msg}; failsafe: {failsafe}" if failsafe else msg)


def write_junit(path: Path, runs: Sequence[Run], comparison: Comparison | None = None, name: str = "vinecli") -> None:
    """Write ``junit.xml`` for ``runs`` (and regressions from ``comparison``)."""
    from junitparser import Error, Failure, JUnitXml, TestCase, TestSuite

    x = printable
    xml = JUnitXml(x(name))
    suites: dict[str, Any] = {}
    cases: dict[str, list[Any]] = {}  # added once per suite: add_testcase recounts the suite each time (O(n²))
    for run in runs:
        suite = suites.get(run.mission)
        if suite is None:
            suite = suites[run.mission] = TestSuite(x(run.mission))
            suite.add_property("mission", x(run.mission))
            cases[run.mission] = []
        add = cases[run.mission].append
        from vinecli.report.deposition_tables import deposition_properties

        for k, v in deposition_properties(run):  # spray deposition metrics of the run
            suite.add_property(x(k), x(v))
        classname = x(f"{run.mission}.{run.case}")
        wall = float(run.timing.get("wall_time_s") or 0.0)
        if run.errored:
            tc = TestCase("run", classname, 0.0)
            err = Error(x(f"the case could not run: {run.error}"), "error")
            err.text = x(run.error or "")
            tc.result = [err]
            add(tc)
        checks = run.checks
        for c in checks:
            tc = TestCase(x(c["name"]), classname, round(wall / max(1, len(checks)), 4))
            if not c.get("passed"):
                f = Failure(check_message(c, run.failsafe_text), "check")
                f.text = x(f"{c.get('message') or ''}\nquantity: {c.get('quantity')}, reduce: {c.get('reduce')}, "
                           f"window: {format_value(c.get('window'))} s\nrun: {run.run_id} ({run.status}: "
                           f"{run.summary.get('status_message') or ''})")
                tc.result = [f]
            add(tc)
        for r in comparison.for_case(run.case) if comparison else []:
            tc = TestCase(x(f"regression:{r.name}"), classname, 0.0)
            tc.result = [Failure(x(r.message), f"regression-{r.kind}")]
            add(tc)
    tests = failures = errors = 0
    time = 0.0
    for mission, suite in suites.items():
        suite.add_testcases(cases[mission])
        suite.time = round(float(suite.time or 0.0), 4)
        tests += int(suite.tests)
        failures += int(suite.failures)
        errors += int(suite.errors)
        time += float(suite.time or 0.0)
        xml.add_testsuite(suite)
    # root statistics set by hand: the Jenkins schema has no "skipped" on <testsuites>
    xml.tests, xml.failures, xml.errors, xml.time = tests, failures, errors, round(time, 4)
    xml.write(str(path), pretty=True)
