#!/usr/bin/env python3
"""Holds each method page's parameter table to the method's declared parameters.

For every method that `dofkit methods --json` lists with parameters, docs/methods/<name>.md must
have a table row "| `param` | default | ..." for each parameter, whose default column starts with
the declared default (backticks ignored), and no parameter row for a key the method does not
declare. A parameter row is a table row whose first cell is a single `identifier` inside the
page's "Parameters" section (the first heading containing "Parameters" to the next heading).
"""
import argparse
import json
import os
import re
import subprocess
import sys


def first_token(text):
    text = text.replace("`", "").strip()
    return re.split(r"[\s,(/]", text, maxsplit=1)[0] if text else ""


def doc_rows(page_text):
    m = re.search(r"^#+ [^\n]*Parameters[^\n]*\n(.*?)(?=^#+ |\Z)", page_text, re.S | re.M)
    if not m:
        return None
    rows = {}
    for line in m.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 2 and re.fullmatch(r"`[a-z_][a-z0-9_]*`", cells[0]):
            rows[cells[0].strip("`")] = cells[1]
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dofkit", required=True)
    ap.add_argument("--docs", required=True, help="the docs/methods folder")
    args = ap.parse_args()
    listing = json.loads(subprocess.run([args.dofkit, "methods", "--json"], check=True,
                                        capture_output=True, text=True).stdout)
    failures = []
    checked = 0
    for m in listing:
        if not m["params"]:
            continue
        page = os.path.join(args.docs, m["name"] + ".md")
        if not os.path.exists(page):
            failures.append(f"{m['name']}: has parameters but no page {page}")
            continue
        with open(page, encoding="utf-8") as f:
            rows = doc_rows(f.read())
        if rows is None:
            failures.append(f"{page}: no 'Parameters' section")
            continue
        declared = {p["name"]: p["default"] for p in m["params"]}
        for name, default in declared.items():
            checked += 1
            if name not in rows:
                failures.append(f"{page}: parameter `{name}` (default {default}) has no row")
            elif first_token(rows[name]) != first_token(default):
                failures.append(f"{page}: `{name}` default documented as '{rows[name]}', declared '{default}'")
        for name in rows:
            if name not in declared:
                failures.append(f"{page}: row `{name}` is not a parameter of {m['name']}")
    for f in failures:
        print("FAIL:", f)
    print(f"{checked} parameters checked against docs/methods, {len(failures)} failures")
    return 1 if failures or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
