#!/usr/bin/env python3
"""Run UMANS' example scenarios in UMANS and in CrowdHealth and compare what the agents do.

For every example XML (default: ../shared/umans-examples/*.xml) both programs run with one
thread and a wall-clock bound; from the per-agent trajectories (UMANS' output_<id>.csv, rows
`time,x,y[,...]`) this computes, for each program and in the same way:

* arrived fraction: an agent has *arrived* at the first trajectory sample whose centre lies within
  the agent's radius of its goal (plus 1 mm, for UMANS' single precision) — UMANS'
  Agent::hasReachedGoal, applied to the written samples;
* mean arrival time (s) over the agents that arrived;
* closest approach (m): the smallest gap |x_i − x_j| − r_i − r_j between two agents at the same
  sample time (negative = bodies overlap).

An example *behaves alike* when every agent arrives in both programs and the mean arrival times
differ by at most 35 % of UMANS'. Writes OUT/compare.csv and OUT/compare.md and prints the
summary. Python 3 standard library only.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import os
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

TOL = 0.35
GOAL_SLACK = 1e-3


def lower_tag(el):
    return el.tag.lower() if isinstance(el.tag, str) else ""


def parse_lenient(path):
    """The root of an XML file, read as leniently as UMANS' tinyxml2: files with several top-level
    elements (some of UMANS' agent files carry a stray <Simulation/> before <Agents>) are read as
    if wrapped in one element."""
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    # Comments go first: UMANS' files hold some that XML forbids (<!-------->), which tinyxml2 accepts.
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    try:
        return ET.fromstring(text)
    except ET.ParseError:
        text = re.sub(r"^\s*<\?xml[^>]*\?>", "", text)
        return ET.fromstring("<wrapped>" + text + "</wrapped>")


def read_agents(xml_path):
    """(end_time, [ (id, radius, goal_x, goal_y) ]) in file order, ids as both programs assign them."""
    root = parse_lenient(xml_path)
    end_time = float(root.get("end_time", "nan"))
    agents = []
    next_id = 0
    used = set()

    def take(container_path):
        nonlocal next_id
        croot = parse_lenient(container_path) if isinstance(container_path, str) else container_path
        for a in croot.iter():
            if lower_tag(a) != "agent":
                continue
            rad = float(a.get("rad", "0.24"))
            goal = None
            for c in a:
                if lower_tag(c) == "goal":
                    goal = (float(c.get("x")), float(c.get("y")))
            if a.get("id") is not None:
                aid = int(a.get("id"))
            else:
                while next_id in used:
                    next_id += 1
                aid = next_id
            used.add(aid)
            agents.append((aid, rad, goal))

    base = os.path.dirname(xml_path)
    for el in root:
        if lower_tag(el) == "agents":
            if el.get("file"):
                take(os.path.join(base, el.get("file")))
            else:
                take(el)
    return end_time, agents


def read_traj(path):
    rows = []
    with open(path) as f:
        for line in f:
            p = line.strip().split(",")
            if len(p) >= 3:
                try:
                    rows.append((float(p[0]), float(p[1]), float(p[2])))
                except ValueError:
                    pass
    return rows


def analyse(outdir, agents):
    """Arrived fraction, mean arrival time, closest approach, from OUTDIR/output_<id>.csv."""
    if not agents:
        return None
    arrivals = []
    by_time = {}
    radius = {}
    missing = 0
    for aid, rad, goal in agents:
        radius[aid] = rad
        path = os.path.join(outdir, "output_%d.csv" % aid)
        if not os.path.exists(path):
            missing += 1
            continue
        arrived = None
        for t, x, y in read_traj(path):
            key = round(t, 4)
            by_time.setdefault(key, []).append((x, y, aid))
            if arrived is None and goal is not None and math.hypot(goal[0] - x, goal[1] - y) <= rad + GOAL_SLACK:
                arrived = t
        if arrived is not None:
            arrivals.append(arrived)
    if missing == len(agents):
        return None
    closest = math.inf
    rmax = max(radius.values())
    for pts in by_time.values():
        pts.sort()
        n = len(pts)
        for i in range(n):
            xi, yi, ai = pts[i]
            for j in range(i + 1, n):
                xj, yj, aj = pts[j]
                if xj - xi - 2 * rmax > closest:
                    break
                gap = math.hypot(xj - xi, yj - yi) - radius[ai] - radius[aj]
                if gap < closest:
                    closest = gap
    return {
        "arrived": len(arrivals) / len(agents),
        "mean_arrival": sum(arrivals) / len(arrivals) if arrivals else math.nan,
        "closest": closest if len(agents) > 1 else math.nan,
    }


def run(cmd, outdir, timeout, env=None):
    os.makedirs(outdir, exist_ok=True)
    for f in os.listdir(outdir):
        if f.startswith("output_"):
            os.remove(os.path.join(outdir, f))
    t0 = time.monotonic()
    try:
        # The log goes beside the output folder, not into it: crowdhealth refuses an output folder
        # that holds files it did not write (docs/user-guide.md, "The output folder").
        with open(outdir.rstrip("/") + ".log", "w") as log:
            r = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, timeout=timeout, env=env)
        status = "ok" if r.returncode == 0 else "exit %d" % r.returncode
    except subprocess.TimeoutExpired:
        status = "timeout"
    return status, time.monotonic() - t0


def one_example(xml, args):
    name = os.path.splitext(os.path.basename(xml))[0]
    end_time, agents = read_agents(xml)
    res = {"example": name, "agents": len(agents)}
    env = dict(os.environ, OMP_NUM_THREADS="1")
    udir = os.path.join(args.out, "runs", name, "umans")
    cdir = os.path.join(args.out, "runs", name, "crowdhealth")
    if not agents:
        res["note"] = "no agents"
        return res
    if math.isnan(end_time):
        res["note"] = "no end_time"
        return res
    if args.reuse and os.path.exists(udir + ".log"):
        ustat = "reused"
    else:
        ustat, _ = run([args.umans, "-i", os.path.abspath(xml), "-o", os.path.abspath(udir) + "/", "-t", "1"],
                       udir, args.timeout, env)
    cmd = [args.crowdhealth, "-i", os.path.abspath(xml), "-o", os.path.abspath(cdir),
           "--trajectories", "umans", "-t", "1"] + args.ch_args
    cstat, csec = run(cmd, cdir, args.timeout, env)
    res["umans_status"], res["ch_status"] = ustat, cstat
    res["ch_seconds"] = csec
    res["umans"] = analyse(udir, agents)
    res["ch"] = analyse(cdir, agents)
    return res


def fmt(v, nd=2):
    if v is None or (isinstance(v, float) and (math.isnan(v) or math.isinf(v))):
        return "–"
    return ("%%.%df" % nd) % v


def verdict(r):
    u, c = r.get("umans"), r.get("ch")
    if not u or not c:
        return "not run", False
    if u["arrived"] < 1:
        return "UMANS: not all arrive", False
    if c["arrived"] < 1:
        return "**differs** (not all arrive)", True
    d = (c["mean_arrival"] - u["mean_arrival"]) / u["mean_arrival"]
    if abs(d) > TOL:
        return "**differs** (%+.0f %%)" % (100 * d), True
    return "alike (%+.0f %%)" % (100 * d), True


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(here)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--examples", default=os.path.join(repo, "..", "shared", "umans-examples"))
    p.add_argument("--umans", default="/tmp/umans-ref/build/UMANS-ConsoleApplication-Linux")
    p.add_argument("--crowdhealth", default=os.path.join(repo, "build", "bin", "crowdhealth"))
    p.add_argument("--out", default="compare-umans")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--timeout", type=float, default=600, help="wall-clock bound of one run (s)")
    p.add_argument("--only", default="", help="regular expression on the example name")
    p.add_argument("--reuse", action="store_true", help="reuse UMANS' runs already in OUT/runs")
    p.add_argument("--ch-arg", dest="ch_args", action="append", default=[],
                   help="extra argument for crowdhealth (repeatable)")
    args = p.parse_args()

    xmls = sorted(os.path.join(args.examples, f) for f in os.listdir(args.examples)
                  if f.endswith(".xml") and re.search(args.only, f[:-4]))
    os.makedirs(args.out, exist_ok=True)
    results = []
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as ex:
        futs = {ex.submit(one_example, x, args): x for x in xmls}
        for f in cf.as_completed(futs):
            try:
                r = f.result()
            except Exception as e:  # one broken example must not hide the others
                r = {"example": os.path.splitext(os.path.basename(futs[f]))[0], "agents": 0,
                     "note": "error: %s" % e}
            results.append(r)
            print("%-40s %s" % (r["example"], verdict(r)[0]), file=sys.stderr, flush=True)
    results.sort(key=lambda r: r["example"])

    with open(os.path.join(args.out, "compare.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["example", "agents", "umans_arrived", "umans_mean_arrival_s", "umans_closest_m",
                    "ch_arrived", "ch_mean_arrival_s", "ch_closest_m", "verdict"])
        for r in results:
            u, c = r.get("umans") or {}, r.get("ch") or {}
            w.writerow([r["example"], r["agents"], u.get("arrived", ""), u.get("mean_arrival", ""),
                        u.get("closest", ""), c.get("arrived", ""), c.get("mean_arrival", ""),
                        c.get("closest", ""), verdict(r)[0].replace("*", "")])

    counted = alike = 0
    lines = ["| example | agents | UMANS arrived | UMANS mean arrival (s) | UMANS closest (m) | "
             "CrowdHealth arrived | CrowdHealth mean arrival (s) | CrowdHealth closest (m) | verdict |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        u, c = r.get("umans"), r.get("ch")
        v, counts = verdict(r)
        if counts:
            counted += 1
            alike += v.startswith("alike")
        if not u or not c:
            lines.append("| %s | %d | – | – | – | – | – | – | %s |" % (r["example"], r["agents"], r.get("note", v)))
            continue
        lines.append("| %s | %d | %.0f %% | %s | %s | %.0f %% | %s | %s | %s |" % (
            r["example"], r["agents"], 100 * u["arrived"], fmt(u["mean_arrival"], 1), fmt(u["closest"]),
            100 * c["arrived"], fmt(c["mean_arrival"], 1), fmt(c["closest"]), v))
    summary = ("%d of %d examples where UMANS' agents all arrive behave alike (every agent arrives, "
               "mean arrival time within %d %% of UMANS')" % (alike, counted, round(100 * TOL)))
    with open(os.path.join(args.out, "compare.md"), "w") as f:
        f.write("\n".join(lines) + "\n\n" + summary + "\n")
    print("\n".join(lines))
    print()
    print(summary)


if __name__ == "__main__":
    main()
