"""JUnit XML for CI: one testsuite, one testcase per record and method.

Testcases (``classname`` = the record name):

* ``name = "event N / method"`` for each fit of the current run (``time``: the method's
  and its validation's wall time, when the run measured it): passes, or one
  ``<failure>`` per regression of that fit (type = the finding's kind, the message names
  record, method, parameter, baseline, current and change); ``not_applicable`` and
  ``failed`` fits that are not regressions are ``<skipped>`` with their reason;
* ``name = "recommended model (...)"``: passes when the record's recommended model has
  the verdict ok, else ``<skipped>`` with its verdict and flags (never green);
* ``name = "record"`` for a record that failed to load or analyse (``<error>``, its one-line
  reason; a ``<failure>`` too when it was ok in the baseline) and for record-level
  regressions (a record missing from the run);
* a fit that was in the baseline but is missing now gets its own testcase with a failure
  when it counts as a regression.

The document is valid against the JUnit schema of the Jenkins xUnit plugin
(``junit-10.xsd``, jenkinsci/xunit-plugin, ``src/main/resources/org/jenkinsci/plugins/
xunit/types/model/xsd/junit-10.xsd``): ``<testsuites>`` takes ``name``, ``time``,
``tests``, ``failures`` and ``errors`` only (its ``skipped`` count is on the
``<testsuite>``, with ``time``, ``timestamp`` and ``hostname``), times are plain decimals.
User text (record names, reasons, messages) is written with its control characters as
visible escapes (:func:`pipeline.quoting.printable`): XML 1.0 forbids most of them, and a
file holding one is not well-formed.

Built with :mod:`xml.etree.ElementTree`; :func:`write_junit` is the only file access.
"""

from __future__ import annotations

import math
import os
import socket
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from ..errors import UserError
from ..files import write_atomic
from ..gate import Comparison, Finding
from ..quoting import printable
from ..schema import FitDoc, RecordDoc, ResultsDoc

SUITE = "pipeline"


def junit_xml(current: ResultsDoc, comparison: Comparison | None = None, *,
              time: float | None = None, hostname: str | None = None,
              times: Mapping[tuple[str, int, str], float] | None = None) -> str:
    """The JUnit XML document of a results document and its comparison (or none).

    ``time``: the run's wall time in seconds (the testcases' sum, 0, when not given);
    ``hostname``: where it ran (this machine's name when not given); ``times``: each
    fit's wall time, by ``(record, event, label)`` (its testcase's ``time``; 0 for a fit
    not in it, e.g. read from a results.json, which keeps no times).
    """
    times = times or {}
    comparison = comparison or Comparison()
    suite = ET.Element("testsuite", {"name": _suite_name(current)})
    if current.created:
        suite.set("timestamp", current.created)
    suite.set("hostname", socket.gethostname() if hostname is None else hostname)
    _properties(suite, current, comparison)
    seen: set[tuple[str, int | None, str | None]] = set()
    for rec in current.records:
        name = rec.name
        if rec.status != "ok":
            suite.append(_failed_record_case(rec, comparison.for_fit(name, None, None)))
            seen.add((name, None, None))
            continue
        for fit in rec.fits:
            key = (name, fit.event, fit.label)
            seen.add(key)
            suite.append(_fit_case(name, fit, comparison.for_fit(*key), times.get(key)))
        if rec.recommended is not None:
            suite.append(_recommended_case(rec))
    for key in _unseen_keys(comparison, seen):
        suite.append(_orphan_case(key, comparison.for_fit(*key)))
    _count(suite)
    seconds = _seconds(0.0 if time is None else time)
    suite.set("time", seconds)
    root = ET.Element("testsuites", {"name": SUITE, "time": seconds})
    root.append(suite)
    for attr in ("tests", "failures", "errors"):  # the schema has no skipped here
        root.set(attr, suite.get(attr, "0"))
    _printable(root)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


#: The start of every JUnit file this tool writes (its root element, ``name`` first).
OUR_ROOT = f'<testsuites name="{SUITE}'.encode()


def refuse_foreign_junit(path: Path) -> None:
    """An existing file at ``path`` that is not a JUnit file this tool wrote is one
    :class:`UserError` line (issue 31: ``--junit`` replaced whatever it named, a config
    or a log included); a missing file, or one of ours from an earlier run, is fine."""
    if not path.exists():
        return
    if not path.is_file():  # a FIFO nobody writes would block the read forever
        raise UserError(f"{path}: exists and is not a regular file; expected a JUnit file "
                        "path (give another --junit path)")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise UserError(f"{path}: cannot read the JUnit file ({exc.strerror or exc})") from None
    if OUR_ROOT not in head:
        raise UserError(f"{path}: exists and is not a JUnit file pipeline wrote; remove it "
                        "or give another --junit path")


def write_junit(path: str | os.PathLike, current: ResultsDoc,
                comparison: Comparison | None = None, *, time: float | None = None,
                times: Mapping[tuple[str, int, str], float] | None = None) -> Path:
    """Write :func:`junit_xml` to ``path`` atomically (temporary file, then rename)."""
    p = Path(path)
    write_atomic(p, junit_xml(current, comparison, time=time, times=times).encode("utf-8"),
                 "JUnit file", through=True)
    return p


def _seconds(t: float) -> str:
    """A time as the schema's SUREFIRE_TIME takes it: digits and a decimal point."""
    return f"{t:.6f}" if math.isfinite(t) and t > 0 else "0"  # a reading takes < 1 ms


def _printable(root: ET.Element) -> None:
    """Every attribute and text of the tree with control characters made visible (the
    one place: a testcase, a message or a property added later is covered too)."""
    for el in root.iter():
        if el.text:
            el.text = printable(el.text, lines=True)
        for key, value in el.attrib.items():
            el.set(key, printable(value, lines=True))


# -- testcases ---------------------------------------------------------------------------

def _suite_name(current: ResultsDoc) -> str:
    return f"{SUITE}: {current.config}" if current.config else SUITE


def _properties(suite: ET.Element, current: ResultsDoc, comparison: Comparison) -> None:
    props = ET.SubElement(suite, "properties")
    items = {"pipeline_version": current.pipeline_version,
             "schema_version": current.schema_version,
             "config": current.config or None,
             "baseline_summary": comparison.summary() if comparison.settings else None}
    items.update({f"tolerance.{k}": v for k, v in comparison.settings.items()})
    for key, value in items.items():
        if value is not None:
            ET.SubElement(props, "property", {"name": key, "value": str(value)})


def _case(record: str, name: str, seconds: float | None = None) -> ET.Element:
    return ET.Element("testcase", {"classname": record, "name": name,
                                   "time": _seconds(seconds or 0.0)})


def _fit_case(record: str, fit: FitDoc, findings: list[Finding],
              seconds: float | None = None) -> ET.Element:
    case = _case(record, f"event {fit.event} / {fit.label}", seconds)
    for f in findings:
        _add_failure(case, f)
    status = fit.status
    if not findings and status != "ok":
        reason = fit.reason or "no reason given"
        text = reason if status == "not_applicable" else f"method failed: {reason}"
        ET.SubElement(case, "skipped", {"message": text, "type": status})
    return case


def _recommended_case(rec: RecordDoc) -> ET.Element:
    """The record's recommended model: passes when its verdict is ok, else ``<skipped>``
    with the verdict and its flags (never green for a model to use with care)."""
    r = rec.recommended
    case = _case(rec.name, f"recommended model ({r.label}, event {r.event})")
    if r.verdict not in (None, "ok"):
        codes = ", ".join(f.code for f in r.flags) or "no flags"
        ET.SubElement(case, "skipped", {"message": f"verdict {r.verdict}: {codes}",
                                        "type": r.verdict}).text = "\n".join(
            f"{f.code}: {f.message}" for f in r.flags)
    return case


def _failed_record_case(rec: RecordDoc, findings: list[Finding]) -> ET.Element:
    case = _case(rec.name, "record")
    error = rec.error or "; ".join(rec.errors) or "record failed"
    err = ET.SubElement(case, "error", {"message": error, "type": "failed"})
    err.text = f"record: {rec.name}\nsource: {rec.source}\nerror: {error}"
    for f in findings:
        _add_failure(case, f)
    return case


def _orphan_case(key: tuple[str, int | None, str | None], findings: list[Finding]
                 ) -> ET.Element:
    record, event, method = key
    case = _case(record, "record" if method is None else f"event {event} / {method}")
    for f in findings:
        _add_failure(case, f)
    return case


def _unseen_keys(comparison: Comparison, seen: set) -> list[tuple[str, int | None, str | None]]:
    keys: list[tuple[str, int | None, str | None]] = []
    for f in comparison.regressions:
        key = (f.record, f.event, f.method)
        if key not in seen and key not in keys:
            keys.append(key)
    return keys


def _add_failure(case: ET.Element, f: Finding) -> None:
    el = ET.SubElement(case, "failure", {"message": f.message, "type": f.kind})
    lines = [f"record: {f.record}", f"event: {'-' if f.event is None else f.event}",
             f"method: {f.method or '-'}", f"kind: {f.kind}"]
    row = f.as_row()
    if f.parameter:
        lines.append(f"parameter: {f.parameter}")
    lines += [f"baseline: {_value(f.baseline_value)}", f"current: {_value(f.current_value)}"]
    if f.change is not None:
        lines.append(f"change: {row['change']}")
    if f.tolerance is not None:
        lines.append(f"tolerance: {f.tolerance * 100:.1f} %")
    el.text = "\n".join(lines)


def _value(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return "-" if v is None else str(v)


def _count(suite: ET.Element) -> None:
    cases = suite.findall("testcase")
    suite.set("tests", str(len(cases)))
    suite.set("failures", str(sum(1 for c in cases if c.find("failure") is not None
                                  and c.find("error") is None)))
    suite.set("errors", str(sum(1 for c in cases if c.find("error") is not None)))
    suite.set("skipped", str(sum(1 for c in cases if c.find("skipped") is not None)))
