#!/usr/bin/env python3
"""Turns the ThreadSanitizer reports of a run (FOLDER/report.PID) into JUnit failures.

ROS, boost and the other Debian libraries are not built with ThreadSanitizer: it cannot see
their atomics, so it reports races inside them (a message freed by roscpp's thread, say) that
are not races. A report counts when one of its accesses (or lock acquisitions) is made by
flexcloud's own code: walking the access's stack from the top, through the runtime's own frames
and inlined std and boost code, the first other frame is in flexcloud's sources. Every counted
report becomes one failed case of FOLDER/tsan-reports.xml; the others are counted in its
system-out.

    tsan_reports.py FOLDER
"""
import pathlib
import re
import sys
import xml.sax.saxutils as xml

OURS = re.compile(r"/(src/(ros|core|io|sim|tools)|test/(ros|common))/[\w/]+\.(cpp|h):\d+")
FRAME = re.compile(r"^\s+#\d+ (\S+) (.*)$")
INLINED = ("/include/c++/", "/include/boost/")


def access_paragraphs(report):
    """The paragraphs of a report that describe an access or a lock acquisition."""
    for paragraph in report.split("\n\n"):
        lines = [l for l in paragraph.strip().splitlines() if not l.startswith("WARNING:")]
        head = lines[0].strip() if lines else ""
        if head.startswith(("Location", "Thread", "SUMMARY")) or "created at" in head:
            continue
        if re.search(r"(Read|Write|read|write|acquired here)", head):
            yield paragraph


def made_by_us(paragraph):
    """True when the access's first frame outside the runtime and inlined code is ours."""
    for line in paragraph.splitlines():
        m = FRAME.match(line)
        if not m:
            continue
        where = m.group(2)
        if where.startswith("<null>"):  # no source: the runtime's interceptor or a library
            if re.search(r"\(lib[^+)]*\+0x", where):
                return False
            continue
        if OURS.search(where):
            return True
        if not any(part in where for part in INLINED):
            return False  # another library's header code (a ROS header): not our access
    return False


def ours(report):
    return any(made_by_us(p) for p in access_paragraphs(report))


def reports(folder):
    for path in sorted(pathlib.Path(folder).glob("report.*")):
        for text in path.read_text(errors="replace").split("==================\n"):
            if "WARNING: ThreadSanitizer" in text:
                yield path.name, text


def main(folder):
    counted, ignored = [], 0
    for name, text in reports(folder):
        if ours(text):
            counted.append((name, text))
        else:
            ignored += 1
    cases = []
    for i, (name, text) in enumerate(counted):
        first = next((l for l in text.splitlines() if l.startswith("WARNING:")), "report")
        cases.append(f'<testcase classname="tsan" name="{name}-{i}">'
                     f'<failure message={xml.quoteattr(first)}>{xml.escape(text[:20000])}'
                     f'</failure></testcase>')
    if not cases:
        cases.append('<testcase classname="tsan" name="no_report_on_flexcloud_code"/>')
    note = f"{ignored} reports inside uninstrumented libraries ignored"
    pathlib.Path(folder, "tsan-reports.xml").write_text(
        f'<testsuite name="tsan" tests="{len(cases)}">{"".join(cases)}'
        f'<system-out>{xml.escape(note)}</system-out></testsuite>\n')
    print(f"ThreadSanitizer: {len(counted)} reports on flexcloud's code, {note}", file=sys.stderr)
    return 1 if counted else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
