#!/usr/bin/env python3
"""Counts the test cases in the JUnit XML files under a folder (gtest, rostest, catkin).

Prints every failed or skipped case, then the last line "N passed, N failed". Exit status 1
when a case failed or no result was found at all.
"""
import pathlib
import sys
import xml.etree.ElementTree as ET


def main(folder):
    passed, failed, skipped = [], [], []
    files = sorted(pathlib.Path(folder).rglob("*.xml"))
    for path in files:
        # rostest writes a summary file plus the test node's own file; count the node's cases
        # once, from the summary (rostest-*.xml), which also records a node that never ran.
        if path.name.startswith("rosunit-"):
            continue
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as e:
            failed.append(f"{path.name}: unreadable result file ({e})")
            continue
        for case in root.iter("testcase"):
            name = f"{case.get('classname', '')}.{case.get('name', '')}".strip(".")
            if case.find("failure") is not None or case.find("error") is not None:
                failed.append(f"{path.name}: {name}")
            elif case.find("skipped") is not None or case.get("result") == "skipped":
                skipped.append(f"{path.name}: {name}")
            else:
                passed.append(name)
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
