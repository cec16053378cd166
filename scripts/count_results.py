#!/usr/bin/env python3
"""Counts the test cases in the JUnit XML files under a folder (gtest, rostest, catkin).

Prints every failed or skipped case (a failed one with the first lines of its message, so a CI
log says why), then the last line "N passed, N failed". Exit status 1 when a case failed or no
result was found at all.
"""
import pathlib
import sys
import xml.etree.ElementTree as ET


def why(case):
    """The first lines of a failed case's message (gtest puts the failed assertion there, and
    after it the test's own words, which say why)."""
    node = case.find("failure")
    if node is None:
        node = case.find("error")
    text = (node.get("message") or node.text or "").strip()
    lines = [line.strip() for line in text.splitlines() if line.strip()][:12]
    return "".join(f"\n          {line[:300]}" for line in lines)


def cases(path):
    """(name, outcome) of every test case in a JUnit file; outcome: passed/failed/skipped."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        return [(f"unreadable result file ({e})", "failed")]
    out = []
    for case in root.iter("testcase"):
        name = f"{case.get('classname', '')}.{case.get('name', '')}".strip(".")
        if case.find("failure") is not None or case.find("error") is not None:
            out.append((name + why(case), "failed"))
        elif case.find("skipped") is not None or case.get("result") == "skipped":
            out.append((name, "skipped"))
        else:
            out.append((name, "passed"))
    return out


def main(folder):
    passed, failed, skipped = [], [], []
    buckets = {"passed": passed, "failed": failed, "skipped": skipped}
    files = sorted(pathlib.Path(folder).rglob("*.xml"))
    for path in files:
        if path.name.startswith("rosunit-"):
            continue  # counted through their rostest summary below
        results = cases(path)
        if path.name.startswith("rostest-"):
            # A rostest summary has one case per test node ("test<name>"); the node's own cases
            # are in rosunit-<name>.xml. Count those, and the summary only if the node failed
            # without them (it crashed, hung or never started).
            expanded = []
            for name, outcome in results:
                node = name.rsplit(".", 1)[-1]
                node = node[4:] if node.startswith("test") else node
                unit = path.parent / f"rosunit-{node}.xml"
                inner = cases(unit) if unit.exists() else []
                expanded += [(f"{node}/{n}", o) for n, o in inner]
                if outcome != "passed" and not any(o == "failed" for _, o in inner):
                    expanded.append((name, outcome))
            results = expanded
        for name, outcome in results:
            buckets[outcome].append(f"{path.name}: {name}" if outcome != "passed" else name)
    for s in skipped:
        print(f"SKIPPED {s}")
    for f in failed:
        print(f"FAILED  {f}")
    if not files:
        print("no test results found under", folder)
        failed.append("no results")
    if skipped:
        print(f"{len(skipped)} skipped")
    print(f"{len(passed)} passed, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
