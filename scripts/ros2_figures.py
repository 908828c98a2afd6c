#!/usr/bin/env python3
"""Issue 17's tour figures: the demo tour over ROS 2 (DDS) against the direct sim drivers.

  scripts/ros2_figures.py [--build build] [--seeds 1 2 3 4 5] [--out /tmp/ros2_figures]
                          [--lock FILE]

For each seed, two real dry runs of missions/demo_tour.yaml in missions/demo_world.yaml:
  dds     projtour-sim-ros2 (--idle-exit-s 5, same mission, world and seed) started first, then
          `projtour run ... --dry-run --ros2-bridge`: base and laser are ros2_base/ros2_laser
          over loopback DDS on a domain of this script's own;
  direct  `projtour run ... --dry-run`, the sim drivers in process.
The runs go one after the other (never two at once), so their wall and CPU times do not compete.
Every tour figure comes from the run's report.json: outcome, mission time, targets projected,
the median and worst per-target projection error after align (the referee's,
projection_error_mm.after_align), the worst localization error on arrival. wall is the projtour
process from start to exit; cpu its user + system time (and the bridge's, for dds) from wait4.
Everything runs with ROS_LOCALHOST_ONLY=1: nothing leaves the machine.
"""
import argparse
import fcntl
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEMO = os.path.join(ROOT, "missions", "demo_tour.yaml")
WORLD = os.path.join(ROOT, "missions", "demo_world.yaml")


def claim_dds_domain():
    """A domain no test or benchmark of this machine holds: the same lock files as
    tests/plugins/drivers/ros2/ros2_test_domain.hpp and tests/bench/bench_ros2.cpp, held while the script runs."""
    start = (os.getpid() + 31) % 200
    for i in range(200):
        d = 1 + (start + i) % 200
        fd = os.open(f"/tmp/projtour-test-dds-domain-{d}.lock", os.O_CREAT | os.O_RDWR, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return d, fd
        except OSError:
            os.close(fd)
    sys.exit("ros2_figures: no free DDS domain (all 200 lock files held)")


def spawn(argv, env, log):
    with open(log, "w") as f:
        return subprocess.Popen(argv, env=env, stdout=f, stderr=subprocess.STDOUT)


def reap(proc, timeout_s=None):
    """Exit status, wall seconds since `proc.started`, CPU seconds (user + system); past
    `timeout_s` the process is sent SIGTERM first."""
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    while True:
        pid, status, usage = os.wait4(proc.pid, 0 if deadline is None else os.WNOHANG)
        if pid != 0:
            break
        if time.monotonic() > deadline:
            proc.terminate()
            deadline = None
        time.sleep(0.05)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, time.monotonic() - proc.started, usage.ru_utime + usage.ru_stime


def run(build, out, mode, seed, env):
    run_dir = os.path.join(out, f"{mode}_{seed}")
    args = [os.path.join(build, "projtour"), "run", DEMO, "--dry-run", "--world", WORLD,
            "--seed", str(seed), "--out", run_dir]
    bridge = None
    if mode == "dds":
        args.insert(4, "--ros2-bridge")
        bridge = spawn([os.path.join(build, "projtour-sim-ros2"), DEMO, "--world", WORLD,
                        "--seed", str(seed), "--idle-exit-s", "5"], env,
                       os.path.join(out, f"bridge_{seed}.log"))
        bridge.started = time.monotonic()
    tour = spawn(args, env, os.path.join(out, f"{mode}_{seed}.log"))
    tour.started = time.monotonic()
    rc, wall_s, cpu_s = reap(tour)
    bridge_cpu_s = None
    if bridge is not None:
        # It leaves by itself 5 s (--idle-exit-s) after the tour's last /clock.
        bridge_rc, _, bridge_cpu_s = reap(bridge, timeout_s=30)
        if bridge_rc != 0:
            print(f"ros2_figures: the bridge of seed {seed} exited {bridge_rc}, see "
                  f"{out}/bridge_{seed}.log", file=sys.stderr)
    report_file = os.path.join(run_dir, "report.json")
    if rc != 0 or not os.path.exists(report_file):
        sys.exit(f"ros2_figures: {mode} seed {seed} exited {rc}; see {out}/{mode}_{seed}.log")
    with open(report_file) as f:
        report = json.load(f)
    return {"report": report, "wall_s": wall_s, "cpu_s": cpu_s, "bridge_cpu_s": bridge_cpu_s}


def row(mode, seed, r):
    rep = r["report"]
    targets = rep["targets"]
    after = [t["projection_error_mm"]["after_align"] for t in targets
             if t["outcome"] == "projected" and "projection_error_mm" in t]
    loc = [t["localization_error"]["trans_m"] for t in targets if "localization_error" in t]
    projected = sum(1 for t in targets if t["outcome"] == "projected")
    cpu = f"{r['cpu_s']:.1f}"
    if r["bridge_cpu_s"] is not None:
        cpu += f" + {r['bridge_cpu_s']:.1f}"
    return (f"| {seed} | {mode} | {rep['outcome']} | {rep['timing']['mission_s']:.2f} | "
            f"{projected}/{len(targets)} | {statistics.median(after):.2f} | {max(after):.2f} | "
            f"{max(loc):.3f} | {r['wall_s']:.1f} | {cpu} |")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--out", default="/tmp/ros2_figures")
    parser.add_argument("--lock", help="held shared (flock) during each run, so that a build "
                        "taking it exclusively never relinks the programs under a run")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    domain, _lock = claim_dds_domain()
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_LOCALHOST_ONLY="1")
    print(f"DDS domain {domain} (loopback only); runs in {args.out}", file=sys.stderr)
    results = {}
    for seed in args.seeds:
        for mode in ("dds", "direct"):
            lock = os.open(args.lock, os.O_CREAT | os.O_RDONLY) if args.lock else None
            if lock is not None:
                fcntl.flock(lock, fcntl.LOCK_SH)
            results[mode, seed] = run(args.build, args.out, mode, seed, env)
            if lock is not None:
                os.close(lock)
            print(f"seed {seed} {mode}: done", file=sys.stderr)

    print("| seed | drivers | outcome | mission s | projected | after-align median mm | "
          "after-align worst mm | worst loc err m | wall s | cpu s (tour + bridge) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for seed in args.seeds:
        for mode in ("dds", "direct"):
            print(row(mode, seed, results[mode, seed]))
    for mode in ("dds", "direct"):
        walls = [results[mode, s]["wall_s"] for s in args.seeds]
        missions = [results[mode, s]["report"]["timing"]["mission_s"] for s in args.seeds]
        print(f"\n{mode}: mission time median {statistics.median(missions):.2f} s, "
              f"wall median {statistics.median(walls):.1f} s", end="")
    print()


if __name__ == "__main__":
    main()
