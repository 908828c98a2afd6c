#!/usr/bin/env python3
"""Issue 13's figures: dry runs of the demo tour over the worlds of the closed loop, seeds 1-5.

  scripts/closed_loop_figures.py [--build build] [--seeds 1 2 3 4 5] [--out /tmp/closed_loop]
                                 [--only calibration offsets rough pole faults]

Every run is a real `projtour run --dry-run`; every figure comes from its report.json (the
referee's projection_error_mm / projection_error_area_mm / light_off_target_fraction beside the
robot's own observed_error_mm). Prints one markdown table per world family and the honesty
count: visits reported projected whose referee error exceeds their tolerance.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEMO = os.path.join(ROOT, "missions", "demo_tour.yaml")
SHORT = os.path.join(ROOT, "tests", "integration", "data", "short_tour.yaml")
FAULT_DIR = os.path.join(ROOT, "tests", "integration", "data")
REVISIT = os.path.join(FAULT_DIR, "revisit_tour.yaml")
# Fault worlds written for a tour of their own, run with the seed in the world file.
OWN_TOUR = {"w_revisit": (REVISIT, 11), "w_pillar_nearer": (os.path.join(FAULT_DIR, "pillar_tour.yaml"), None),
            "w_slid_sign": (os.path.join(FAULT_DIR, "slid_sign_tour.yaml"), None)}


def world_text(seed, calibration=(1.0, 0.1), offset=(0.05, 3.0), noise_mm=None, faults=None):
    lines = [f"seed: {seed}", f"target_offset: {{max_m: {offset[0]}, max_deg: {offset[1]}}}",
             f"calibration_error: {{trans_mm: {calibration[0]}, rot_deg: {calibration[1]}}}"]
    if noise_mm is not None:
        lines.append(f"model_error: {{noise_mm: {noise_mm}}}")
    if faults:
        lines.append("faults:")
        lines += [f"  - {f}" for f in faults]
    return "\n".join(lines) + "\n"


def run(build, mission, world_file, seed, out_dir):
    cmd = [os.path.join(build, "projtour"), "run", mission, "--dry-run", "--world", world_file,
           "--out", out_dir] + (["--seed", str(seed)] if seed is not None else [])
    p = subprocess.run(cmd, capture_output=True, text=True)
    report = os.path.join(out_dir, "report.json")
    if not os.path.exists(report):
        sys.stderr.write(f"no report: {' '.join(cmd)}\n{p.stderr[-2000:]}\n")
        return None
    with open(report) as f:
        return json.load(f)


def visits(report):
    for t in report.get("targets", []):
        yield {
            "id": t["id"],
            "outcome": t["outcome"],
            "reason": t.get("reason", ""),
            "true_mm": t.get("projection_error_mm", {}).get("after_align"),
            "area_max_mm": t.get("projection_error_area_mm", {}).get("max"),
            "observed_mm": t.get("observed_error_mm"),
            "light_off": t.get("light_off_target_fraction"),
            "sequence_s": t.get("calibration", {}).get("sequence_s"),
            "calib_ms": t.get("calibration", {}).get("time_ms"),
        }


def fmt(v, d=1):
    return "-" if v is None else f"{v:.{d}f}"


def summarise(name, runs, tolerance_mm=3.0):
    vs = [v for r in runs if r for v in visits(r)]
    projected = [v for v in vs if v["outcome"] == "projected"]
    true = sorted(v["true_mm"] for v in projected if v["true_mm"] is not None)
    diffs = sorted(abs(v["observed_mm"] - v["true_mm"]) for v in projected
                   if v["observed_mm"] is not None and v["true_mm"] is not None)
    dishonest = [v for v in projected if v["true_mm"] is not None and v["true_mm"] > tolerance_mm]
    seq = [v["sequence_s"] for v in vs if v["sequence_s"] is not None]
    reasons = {}
    for v in vs:
        if v["outcome"] != "projected":
            key = v["reason"].split(":")[0]
            reasons[key] = reasons.get(key, 0) + 1
    return (f"| {name} | {len(projected)}/{len(vs)} | "
            f"{fmt(statistics.median(true) if true else None)} / {fmt(true[-1] if true else None)} | "
            f"{fmt(statistics.median(diffs) if diffs else None, 2)} / {fmt(diffs[-1] if diffs else None, 2)} | "
            f"{len(dishonest)} | {fmt(max(seq) if seq else None, 2)} | "
            f"{', '.join(f'{k} x{n}' for k, n in sorted(reasons.items())) or '-'} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--out", default="/tmp/closed_loop")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", nargs="+",
                    default=["calibration", "offsets", "rough", "pole", "faults"])
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    cases = []  # (family, name, mission, world text or file, seed)
    if "calibration" in a.only:
        for c in [(0.0, 0.0), (1.0, 0.1), (3.0, 0.3), (5.0, 0.5), (10.0, 1.0)]:
            for s in a.seeds:
                cases.append(("calibration", f"{c[0]:g} mm / {c[1]:g} deg", DEMO,
                              world_text(s, calibration=c), s))
    if "offsets" in a.only:
        for s in a.seeds:
            cases.append(("offsets", "0.20 m / 20 deg, 10 mm / 1 deg", DEMO,
                          world_text(s, calibration=(10.0, 1.0), offset=(0.20, 20.0)), s))
    if "rough" in a.only:
        for s in a.seeds:
            cases.append(("rough", "model noise_mm 4", DEMO, world_text(s, noise_mm=4.0), s))
    if "pole" in a.only:
        for s in a.seeds:
            cases.append(("pole", "pole 0.6 m before open-day-sign", DEMO,
                          world_text(s, faults=["{target: open-day-sign, type: pole, distance_m: 0.6}"]), s))
    if "faults" in a.only:
        for f in sorted(os.listdir(FAULT_DIR)):
            if f.startswith("w_") and f.endswith(".yaml"):
                mission, seed = SHORT, 11
                for prefix, (own, own_seed) in OWN_TOUR.items():
                    if f.startswith(prefix):
                        mission, seed = own, own_seed
                cases.append(("faults", f, mission, os.path.join(FAULT_DIR, f), seed))

    def go(i_case):
        i, (family, name, mission, world, seed) = i_case
        d = os.path.join(a.out, f"{family}-{i:03d}")
        world_file = world
        if not world.endswith(".yaml"):
            world_file = d + ".world.yaml"
            with open(world_file, "w") as f:
                f.write(world)
        return family, name, run(a.build, mission, world_file, seed, d)

    with ThreadPoolExecutor(a.jobs) as pool:
        results = list(pool.map(go, enumerate(cases)))
    print("| world | projected | true after-align error median / worst mm | "
          "observed - true median / worst mm | projected beyond tolerance | "
          "longest sequence s | not projected |")
    print("|---|---|---|---|---|---|---|")
    order = []
    for family, name, _ in results:
        if (family, name) not in order:
            order.append((family, name))
    total_dishonest = 0
    for family, name in order:
        runs = [r for f, n, r in results if f == family and n == name]
        print(summarise(name, runs))
        total_dishonest += sum(1 for r in runs if r for v in visits(r)
                               if v["outcome"] == "projected" and v["true_mm"] is not None
                               and v["true_mm"] > 3.0)
    print(f"\nvisits reported projected beyond their tolerance, all worlds: {total_dishonest}")


if __name__ == "__main__":
    main()
