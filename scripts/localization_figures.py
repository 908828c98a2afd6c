#!/usr/bin/env python3
"""Issue 14's localization figures, on recorded drives from mrpt-common.

  scripts/localization_figures.py [--build build] [--seeds 1 2 3] [--out /tmp/loc_figures]

1. MRPT's simulated drive graphslam-engine-demos/action_observations_map/simul.rawlog (ground
   truth beside it) on maps/graphslam_basic_thick.yaml (walls ~3 m thick) and
   maps/graphslam_basic_thin.yaml (the same walls one cell thick): ATE of `projtour localize`
   with the boundary likelihood field and with MRPT's all-cells field.
2. MRPT's real drive "2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog" on its
   malaga-cs-fac-building simplemap (no ground truth): the share of scan endpoints within 0.1 m
   of a wall face from scan --from-scan on, for `projtour localize` and for MRPT's stock
   `pf-localization` (mrpt-apps) run on the same data with its own localization_demo.ini, only
   the files, the initial area and the 3-D window changed. pf-localization's per-step estimates
   are matched to the rawlog's scan timestamps and scored by the same code (`projtour localize
   --score`).
"""
import argparse
import math
import os
import re
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = "/usr/share/mrpt/datasets"
DRIVE = os.path.join(DATA, "graphslam-engine-demos", "action_observations_map", "simul.rawlog")
MALAGA = os.path.join(DATA, "2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog")
MALAGA_MAP = os.path.join(DATA, "malaga-cs-fac-building.simplemap.gz")
STOCK_INI = "/usr/share/mrpt/config_files/pf-localization/localization_demo.ini"
FROM_SCAN = 10  # both filters start near the map's first keyframe; scored once settled


def localize(build, args):
    done = subprocess.run([os.path.join(build, "projtour"), "localize"] + args,
                          capture_output=True, text=True, check=True)
    text = done.stderr
    figures = {}
    m = re.search(r"ATE over (\d+) scans: rms ([\d.]+) m, median ([\d.]+) m, max ([\d.]+) m", text)
    if m:
        figures["ate"] = tuple(float(v) for v in m.groups()[1:])
    m = re.search(r"endpoints within [\d.]+ m of a wall face from scan \d+: ([\d.]+)% of (\d+)",
                  text)
    if m:
        figures["on_map_pct"] = float(m.group(1))
    m = re.search(r"([\d.]+) ms per update", text)
    if m:
        figures["ms_per_update"] = float(m.group(1))
    return figures


def pf_localization(out, seed):
    """Stock pf-localization on the Malaga drive; returns its estimates as a TUM file."""
    log_dir = os.path.join(out, f"pf_{seed}")
    with open(STOCK_INI) as f:
        ini = f.read()
    replace = {"map_file": MALAGA_MAP, "rawlog_file": MALAGA, "logOutput_dir": log_dir,
               "init_PDF_min_x": "-1", "init_PDF_max_x": "1", "init_PDF_min_y": "-1",
               "init_PDF_max_y": "1", "SHOW_PROGRESS_3D_REAL_TIME": "false",
               "3DSceneFrequency": "-1"}
    for key, value in replace.items():
        ini, n = re.subn(rf"^{re.escape(key)}\s*=.*$", f"{key}={value}", ini, flags=re.M)
        assert n == 1, key
    ini_file = os.path.join(out, f"pf_{seed}.ini")
    with open(ini_file, "w") as f:
        f.write(ini)
    # pf-localization draws from MRPT's generator as it was left: runs are repeats, not seeds.
    done = subprocess.run(["pf-localization", ini_file], capture_output=True, text=True,
                          check=True, cwd=out)
    steps = [tuple(float(v) for v in m.groups()) for m in
             re.finditer(r"PDF estimation: \(([-\d.]+),([-\d.]+),([-\d.]+)deg\)", done.stdout +
                         done.stderr)]
    subprocess.run(["rawlog-edit", "--list-timestamps", "-i", MALAGA], capture_output=True,
                   check=True, cwd=out)  # writes out.txt
    stamps = []
    with open(os.path.join(out, "out.txt")) as f:
        for line in f:
            if "CObservation2DRangeScan" in line:
                stamps.append(float(line.split()[0]))
    assert len(stamps) == len(steps), (len(stamps), len(steps))
    tum = os.path.join(out, f"pf_{seed}.tum")
    with open(tum, "w") as f:
        for t, (x, y, yaw_deg) in zip(stamps, steps):
            half = math.radians(yaw_deg) / 2
            f.write(f"{t:.6f} {x} {y} 0 0 0 {math.sin(half)} {math.cos(half)}\n")
    return tum


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--out", default=tempfile.mkdtemp(prefix="loc_figures_"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    print(f"1. {DRIVE} (1733 scans), ATE rms / median / max in m, per seed")
    for variant in ("thick", "thin"):
        for field in ("boundary", "occupied"):
            rows = []
            for seed in args.seeds:
                f = localize(args.build, [
                    "--map", os.path.join(ROOT, "maps", f"graphslam_basic_{variant}.yaml"),
                    "--rawlog", DRIVE, "--init", "0,0,0", "--field", field, "--seed", str(seed),
                    "--truth", DRIVE + ".GT.txt",
                    "--out", os.path.join(args.out, f"drive_{variant}_{field}_{seed}.tum")])
                rows.append("%.3f/%.3f/%.3f" % f["ate"])
            print(f"   {variant:5s} walls, {field:8s} field: " + "  ".join(rows))

    print(f"2. {os.path.basename(MALAGA)} on {os.path.basename(MALAGA_MAP)}: endpoints within "
          f"0.1 m of a wall face from scan {FROM_SCAN}, per seed")
    for field in ("boundary", "occupied"):
        rows = []
        for seed in args.seeds:
            f = localize(args.build, [
                "--map", MALAGA_MAP, "--rawlog", MALAGA, "--init", "0,0,0", "--field", field,
                "--seed", str(seed), "--from-scan", str(FROM_SCAN),
                "--out", os.path.join(args.out, f"malaga_{field}_{seed}.tum")])
            rows.append("%.1f%%" % f["on_map_pct"])
        print(f"   projtour localize, {field:8s} field: " + "  ".join(rows))
    rows = []
    for seed in args.seeds:
        tum = pf_localization(args.out, seed)
        f = localize(args.build, ["--map", MALAGA_MAP, "--rawlog", MALAGA, "--score", tum,
                                  "--from-scan", str(FROM_SCAN)])
        rows.append("%.1f%%" % f["on_map_pct"])
    print("   MRPT pf-localization (stock ini), repeats:  " + "  ".join(rows))


if __name__ == "__main__":
    main()
