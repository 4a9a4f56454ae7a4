"""JUnit XML of a gated run: one test case per gate, for CI systems that show test results.

The de-facto format that Jenkins, GitLab and GitHub Actions' test reporters read:
``<testsuites><testsuite><testcase classname name time>`` with a ``<failure>`` for a
failing gate, ``<skipped>`` for an inconclusive or skipped one, and the gate's numbers in
``<system-out>``. A changed image that does not fail the gate passes with its note.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

from compare.util.files import write_text_atomic
from compare.util.text import xml_text
from compare.report.gate import GateReport

__all__ = ["junit_xml", "write_junit"]


def junit_xml(report: GateReport) -> str:
    """The report as JUnit XML text."""
    gates = report.gates
    failures = sum(g.failed(report.settings) for g in gates)
    skipped = sum(g.status in ("inconclusive", "skipped") for g in gates)
    root = ET.Element("testsuites", name="compare check --baseline", tests=str(len(gates)),
                      failures=str(failures), errors="0", skipped=str(skipped))
    suite = ET.SubElement(root, "testsuite", name="regression gate", tests=str(len(gates)), failures=str(failures),
                          errors="0", skipped=str(skipped), time="0")
    props = ET.SubElement(suite, "properties")
    for k, v in (("baseline", report.baseline), ("candidate", report.candidate),
                 ("alpha", f"{report.settings.alpha:g}"), ("machine", report.machine or "same")):
        ET.SubElement(props, "property", name=k, value=xml_text(v))
    for g, row in zip(gates, report.rows()):
        at = f"{g.unit or 'step'} {g.step}: " if g.step is not None else ""
        case = ET.SubElement(suite, "testcase", classname=xml_text(f"compare.gate.{g.scene} {g.size}.{g.renderer}"),
                             name=xml_text(f"{at}{g.kind} {g.metric}"), time="0")
        text = xml_text(f"{g.status}: baseline {row[2] or '-'}, candidate {row[3] or '-'} ({row[4] or '-'}); "
                        f"p (Holm) {row[5] or '-'}; {g.note}")
        if g.failed(report.settings):
            ET.SubElement(case, "failure", message=xml_text(f"{g.status}: {g.name}"), type=g.status).text = text
        elif g.status in ("inconclusive", "skipped"):
            ET.SubElement(case, "skipped", message=xml_text(f"{g.status}: {g.note}"))
        ET.SubElement(case, "system-out").text = text
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_junit(report: GateReport, path: str | os.PathLike) -> Path:
    """Write :func:`junit_xml` to ``path`` atomically."""
    write_text_atomic(path, junit_xml(report))
    return Path(path)
