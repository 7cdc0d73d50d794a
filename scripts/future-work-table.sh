#!/usr/bin/env bash
# Runs every scenario of Examples/future-work/ (each *.xml there, whoever added it) with
# replications and plots, then prints one Markdown table row per scenario: evacuation time
# (mean ± sd over the runs, or "not all out" with counts), injured (mean), fallen and helped
# (mean, when summary.json has them, else "-"), peak local density (mean ± sd) and the verdicts.
# Usage (from anywhere; paths are relative to the repository):
#   scripts/future-work-table.sh                     runs and tabulates, 10 replications each
#   REPLICATIONS=5 THREADS=1 scripts/future-work-table.sh
#   NO_RUN=1 scripts/future-work-table.sh            tabulates the runs already in OUT
#   OUT=out/fw scripts/future-work-table.sh          (default OUT: out/future-work)
#   CROWDHEALTH=/path/to/crowdhealth ...             (default: build/bin/crowdhealth)
# Each scenario NAME.xml runs into OUT/NAME/ (run_000 … and the figures); its log is OUT/NAME.log.
# The table goes to stdout and to OUT/table.md; the CPU time of each scenario's runs to stderr.
# Needs python3 (standard library only) to read the results.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
cd "$repo"
ch="${CROWDHEALTH:-build/bin/crowdhealth}"
out="${OUT:-out/future-work}"
reps="${REPLICATIONS:-10}"
threads=()
[ -n "${THREADS:-}" ] && threads=(-t "$THREADS")
shopt -s nullglob
scenarios=(Examples/future-work/*.xml)
if [ ${#scenarios[@]} -eq 0 ]; then
  echo "future-work-table: no scenario in Examples/future-work/" >&2
  exit 2
fi
mkdir -p "$out"
if [ -z "${NO_RUN:-}" ]; then
  if [ ! -x "$ch" ]; then
    echo "future-work-table: $ch not found; build it (cmake --build build --target crowdhealth_cli) or set CROWDHEALTH" >&2
    exit 2
  fi
  for x in "${scenarios[@]}"; do
    name="$(basename "$x" .xml)"
    # Run through python so that the CPU time of the runs (user + system, all replications) can be
    # reported without /usr/bin/time.
    if ! python3 - "$ch" "$x" "$out/$name" "$reps" "$out/$name.log" "${threads[@]}" <<'EOF'
import os, resource, subprocess, sys
ch, scenario, outdir, reps, log = sys.argv[1:6]
extra = sys.argv[6:]
with open(log, "w") as f:
    r = subprocess.run([ch, "-i", scenario, "-o", outdir, "--replications", reps, "--plot", *extra],
                       stdout=f, stderr=subprocess.STDOUT)
u = resource.getrusage(resource.RUSAGE_CHILDREN)
print(f"future-work-table: {scenario}: {reps} replications, {u.ru_utime + u.ru_stime:.1f} s CPU, "
      f"exit {r.returncode} (log {log})", file=sys.stderr)
sys.exit(r.returncode)
EOF
    then
      echo "future-work-table: $x failed; see $out/$name.log" >&2
    fi
  done
fi
python3 - "$out" "${scenarios[@]}" <<'EOF' | tee "$out/table.md"
import csv, glob, json, math, os, statistics, sys

out, scenarios = sys.argv[1], sys.argv[2:]
LEVELS = ["critical", "dangerous", "caution", "safe"]


def fmt(x, digits=1):
    return f"{x:.{digits}f}"


def mean_sd(values, digits=1):
    if not values:
        return "-"
    if len(values) == 1:
        return fmt(values[0], digits)
    return f"{fmt(statistics.mean(values), digits)} ± {fmt(statistics.stdev(values), digits)}"


def as_count(value):
    """A number, or the length of a list (e.g. one entry per fallen person); else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, list):
        return float(len(value))
    return None


def find_count(summary, key):
    """A count named `key` in summary.json: at the top level, in the verdict, or one level down."""
    places = [summary, summary.get("verdict") or {}] + [v for v in summary.values() if isinstance(v, dict)]
    for where in places:
        if isinstance(where, dict) and key in where and as_count(where[key]) is not None:
            return as_count(where[key])
    return None


def injured(run_dir, summary):
    n = find_count(summary, "injured")
    if n is not None:
        return n
    path = os.path.join(run_dir, "health.csv")
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        return float(sum(1 for row in csv.DictReader(f) if (row.get("injured_at") or "").strip()))


print("| scenario | runs | evacuation time (s) | injured | fallen | helped | peak local density (1/m²) | verdict |")
print("|---|---|---|---|---|---|---|---|")
for scenario in scenarios:
    name = os.path.splitext(os.path.basename(scenario))[0]
    runs = sorted(d for d in glob.glob(os.path.join(out, name, "run_*")) if os.path.exists(os.path.join(d, "summary.json")))
    if not runs:
        print(f"| {name} | 0 | no runs in {os.path.join(out, name)} | - | - | - | - | - |")
        continue
    summaries = [json.load(open(os.path.join(d, "summary.json"))) for d in runs]
    n = len(summaries)
    evac = [s["evacuation_time"] for s in summaries if s.get("evacuation_time") is not None]
    if len(evac) == n:
        evac_cell = mean_sd(evac)
    else:
        total = summaries[0].get("agents_total", 0)
        remaining = [s.get("remaining", 0) for s in summaries]
        evac_cell = (f"not all out: {n - len(evac)} of {n} runs, "
                     f"{fmt(statistics.mean(remaining))} of {total} inside (mean)")
        if evac:
            evac_cell += f"; the others {mean_sd(evac)}"

    def mean_of(values):
        values = [v for v in values if v is not None]
        return fmt(statistics.mean(values)) if len(values) == n else "-"

    inj = mean_of([injured(d, s) for d, s in zip(runs, summaries)])
    fallen = mean_of([find_count(s, "fallen") for s in summaries])
    helped = mean_of([find_count(s, "helped") for s in summaries])
    dens = mean_sd([s["peaks"]["max_density"] for s in summaries if (s.get("peaks") or {}).get("max_density") is not None], 2)
    levels = [(s.get("verdict") or {}).get("level", "?") for s in summaries]
    order = LEVELS + sorted(set(levels) - set(LEVELS))
    verdict = ", ".join(f"{lvl} ×{levels.count(lvl)}" for lvl in order if levels.count(lvl))
    print(f"| {name} | {n} | {evac_cell} | {inj} | {fallen} | {helped} | {dens} | {verdict} |")
EOF
