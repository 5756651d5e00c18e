#!/usr/bin/env python3
"""Runs every command of the README's Quick start, in order, in a fresh temporary folder.

The Quick start is the first ```sh block after the "## Quick start" heading. Lines ending in a
backslash continue on the next line; comment lines are skipped; `build/dofkit` is replaced by
the dofkit under test. Every command must exit 0 and the files it names must appear; the
`compare` of the reference render against the scene's ground truth must reach 33 dB PSNR
(the scene's own camera: a mismatched camera scores ~25 dB, which is what this guards).
"""
import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile


def quickstart_commands(readme_text):
    m = re.search(r"^## Quick start\n(.*?)^```sh\n(.*?)^```", readme_text, re.S | re.M)
    if not m:
        raise SystemExit("README.md: no ```sh block under '## Quick start'")
    commands, pending = [], ""
    for line in m.group(2).splitlines():
        stripped = line.strip()
        if not pending and (not stripped or stripped.startswith("#")):
            continue
        if stripped.endswith("\\"):
            pending += stripped[:-1] + " "
            continue
        commands.append(pending + stripped)
        pending = ""
    if pending:
        raise SystemExit("README.md: the Quick start ends inside a continued line")
    return commands


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--readme", required=True)
    ap.add_argument("--dofkit", required=True)
    args = ap.parse_args()
    with open(args.readme, encoding="utf-8") as f:
        commands = quickstart_commands(f.read())
    if len(commands) < 5:
        raise SystemExit(f"README.md: only {len(commands)} Quick start commands found")
    failures = 0
    compare_psnr = None
    with tempfile.TemporaryDirectory(prefix="dofkit-quickstart-") as work:
        for cmd in commands:
            argv = shlex.split(cmd, comments=True)
            if argv[0] != "build/dofkit":
                print(f"FAIL: a Quick start command does not start with build/dofkit: {cmd}")
                failures += 1
                continue
            argv[0] = args.dofkit
            print("$", cmd, flush=True)
            r = subprocess.run(argv, cwd=work, capture_output=True, text=True, timeout=600)
            sys.stdout.write(r.stdout[-2000:])
            if r.returncode != 0:
                print(f"FAIL: exit {r.returncode}: {cmd}\n{r.stderr[-2000:]}")
                failures += 1
                continue
            # Every output the command names must exist.
            for flag in ("--output", "--debug-output", "--out"):
                if flag in argv:
                    path = os.path.join(work, argv[argv.index(flag) + 1])
                    if not os.path.exists(path):
                        print(f"FAIL: {cmd}: {flag} {path} was not written")
                        failures += 1
            if argv[1] == "compare":
                m = re.search(r"PSNR[^0-9\n]*([0-9]+\.[0-9]+)", r.stdout)
                if not m:
                    print(f"FAIL: no PSNR in the output of: {cmd}")
                    failures += 1
                else:
                    compare_psnr = float(m.group(1))
    if compare_psnr is None:
        print("FAIL: the Quick start has no compare command")
        failures += 1
    elif compare_psnr < 33.0:
        print(f"FAIL: the Quick start's compare scores {compare_psnr} dB (< 33): camera settings do not match the scene")
        failures += 1
    print(f"{len(commands)} Quick start commands, {failures} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
