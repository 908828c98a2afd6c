#!/usr/bin/env python3
"""Issue 14's demo figures: the demo tour in the busy building against the empty one, seeds 1-5.

  scripts/busy_figures.py [--build build] [--seeds 1 2 3 4 5] [--out /tmp/busy] [--jobs 2]

Every run is a real `projtour run --dry-run` of missions/demo_tour.yaml in
missions/demo_world_busy.yaml and in missions/demo_world.yaml; every figure comes from its
report.json: targets projected, the referee's clearance and light-on-person figures (the
`building` section), localization error on arrival, the referee's after-align projection error
and the mission time.
"""
import argparse
import json
import os
import statistics
import subprocess
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEMO = os.path.join(ROOT, "missions", "demo_tour.yaml")
WORLDS = {"busy": os.path.join(ROOT, "missions", "demo_world_busy.yaml"),
          "empty": os.path.join(ROOT, "missions", "demo_world.yaml")}


def run(build, out, world, seed):
    run_dir = os.path.join(out, f"{world}_{seed}")
    subprocess.run([os.path.join(build, "projtour"), "run", DEMO, "--dry-run", "--world",
                    WORLDS[world], "--seed", str(seed), "--out", run_dir],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    with open(os.path.join(run_dir, "report.json")) as f:
        return world, seed, json.load(f)


def median(values):
    return statistics.median(values) if values else float("nan")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--out", default="/tmp/busy")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    jobs = [(w, s) for w in WORLDS for s in args.seeds]
    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(lambda j: run(args.build, args.out, *j), jobs))
    print("| world | seed | projected | skipped (reason) | clearance violations | min clearance m "
          "(to) | lit on head / person ticks | loc err on arrival median m (vs the building) | "
          "after-align median "
          "mm | mission s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    totals = {}
    for world, seed, r in sorted(results, key=lambda x: (x[0], x[1])):
        t = r["targets"]
        projected = [x for x in t if x["outcome"] == "projected"]
        skipped = [f'{x["id"]} ({x.get("reason", "").split(":")[0]})' for x in t
                   if x["outcome"] != "projected"]
        b = r.get("building", {})
        loc = [x["localization_error"]["trans_m"] for x in t if "localization_error" in x]
        # Against the building (the map's own error added), where the map is off it.
        loc_b = [x["localization_error"].get("building_trans_m", x["localization_error"]["trans_m"])
                 for x in t if "localization_error" in x]
        after = [x["projection_error_mm"]["after_align"] for x in projected
                 if x.get("projection_error_mm", {}).get("after_align") is not None]
        clearance = b.get("min_clearance_m")
        print(f'| {world} | {seed} | {len(projected)}/{len(t)} | {", ".join(skipped) or "-"} | '
              f'{b.get("clearance_violations", "-")} | '
              f'{"-" if clearance is None else f"{clearance:.2f}"} ({b.get("min_clearance_to", "-")}) | '
              f'{b.get("lit_on_head_ticks", "-")} / {b.get("lit_on_person_ticks", "-")} | '
              f'{median(loc):.3f} ({median(loc_b):.3f}) | {median(after):.2f} | '
              f'{r["timing"]["mission_s"]:.1f} |')
        tot = totals.setdefault(world, {"projected": 0, "visits": 0, "violations": 0, "lit": 0,
                                        "loc": [], "loc_b": [], "after": [],
                                        "mission": []})
        tot["projected"] += len(projected)
        tot["visits"] += len(t)
        tot["violations"] += b.get("clearance_violations", 0)
        tot["lit"] += b.get("lit_on_person_ticks", 0)
        tot["loc"] += loc
        tot["loc_b"] += loc_b
        tot["after"] += after
        tot["mission"].append(r["timing"]["mission_s"])
    print()
    for world, tot in totals.items():
        print(f'{world}: {tot["projected"]}/{tot["visits"]} projected, {tot["violations"]} clearance '
              f'violations, {tot["lit"]} lit-on-person ticks, localization error on arrival median '
              f'{median(tot["loc"]):.3f} m on the map ({median(tot["loc_b"]):.3f} m against the '
              f'building), after-align median {median(tot["after"]):.2f} mm, '
              f'mission time mean {statistics.mean(tot["mission"]):.1f} s')


if __name__ == "__main__":
    main()
