#!/usr/bin/env python3
"""Two sets of reference runs (scripts/reference_runs.sh), bit for bit apart from the wall clock.

  scripts/compare_runs.py BEFORE AFTER [--ignore KEY ...]

Compares each run's report.json, checkpoint.json and events.jsonl (key order included) without
timing.wall_s and the align and calibration time_ms, sim_projector_log.jsonl byte for byte, and
the validate messages and exit codes. --ignore drops a key wherever it stands (a figure the
change adds on purpose). Exit 0 when nothing differs."""
import argparse
import difflib
import json
import os
import sys


def strip(j, ignore, key=""):
    if isinstance(j, list):
        return [strip(x, ignore) for x in j]
    if isinstance(j, dict):
        return {k: strip(v, ignore, k) for k, v in j.items()
                if k not in ignore and not ((key == "timing" and k == "wall_s") or
                                            (key in ("align", "calibration") and k == "time_ms"))}
    return j


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--ignore", nargs="*", default=[])
    args = parser.parse_args()
    ignore = set(args.ignore)
    compared = differ = 0
    runs = sorted(d for d in os.listdir(args.before) if os.path.isdir(os.path.join(args.before, d)))
    for run in runs:
        a, b = os.path.join(args.before, run), os.path.join(args.after, run)
        for name in ("report.json", "checkpoint.json"):
            ja = strip(json.load(open(os.path.join(a, name))), ignore)
            jb = strip(json.load(open(os.path.join(b, name))), ignore)
            compared += 1
            if json.dumps(ja) != json.dumps(jb):
                differ += 1
                print(f"{run}/{name} differs")
        ea = [json.dumps(strip(json.loads(line), ignore)) for line in open(os.path.join(a, "events.jsonl"))]
        eb = [json.dumps(strip(json.loads(line), ignore)) for line in open(os.path.join(b, "events.jsonl"))]
        compared += 1
        if ea != eb:
            differ += 1
            print(f"{run}/events.jsonl differs")
        log = "sim_projector_log.jsonl"
        compared += 1
        if open(os.path.join(a, log), "rb").read() != open(os.path.join(b, log), "rb").read():
            differ += 1
            print(f"{run}/{log} differs")
    va = open(os.path.join(args.before, "validate.txt")).read()
    vb = open(os.path.join(args.after, "validate.txt")).read()
    compared += 1
    if va != vb:
        differ += 1
        print("validate.txt differs:")
        print("\n".join(list(difflib.unified_diff(va.splitlines(), vb.splitlines(), lineterm=""))[:40]))
    print(f"{len(runs)} runs, {compared} files compared, {differ} differ; "
          f"validate over {va.count('== ')} files")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
