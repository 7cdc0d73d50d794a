#!/usr/bin/env bash
# Van Toll et al. 2021, Table 1: runs every navigation profile of the doorway comparison with
# replications and writes the table — evacuated, mean density at t = 15 s and flow from the 1st to
# the 350th evacuee — beside the published values, as Markdown and CSV.
#
# Usage: Examples/doorway/vantoll/compare.sh [REPLICATIONS] [OUTDIR]
#   REPLICATIONS  runs per profile, seeds 1 … N (default 3)
#   OUTDIR        where each profile's runs go, OUTDIR/<profile>/{run_000,…,summary.csv}, and the
#                 tables OUTDIR/table1.md and OUTDIR/table1.csv (default vantoll-table1)
# Environment:
#   CROWDHEALTH   the program (default: build/bin/crowdhealth beside this repository's top level)
#   THREADS       runs at a time (crowdhealth -t; default 2)
#   PROFILES      space-separated subset of profile names, e.g. "sf-k1000 rvo-sph-rho3"
#                 (default: all; names are the XML files here without .xml)
#   ROOM_ORDER    counterclockwise (default: ../room.xml as it is) or clockwise: the same walls
#                 written as <Obstacle> polygons listed clockwise (OUTDIR/profiles/), to see what
#                 UMANS' wall rule (SocialForcesAvoidance walls="umans") does with such a file
#                 (docs/policies.md, "What UMANS' SocialForcesAvoidance computes")
# A profile whose OUTDIR/<profile>/summary.csv already holds REPLICATIONS runs is not run again
# (delete the folder to redo it). Needs bash, coreutils and awk; no python.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
top="$(cd "$here/../../.." && pwd)"
reps="${1:-3}"
outdir="${2:-vantoll-table1}"
bin="${CROWDHEALTH:-$top/build/bin/crowdhealth}"
threads="${THREADS:-2}"

case "$reps" in ''|*[!0-9]*|0) echo "compare.sh: REPLICATIONS must be a whole number >= 1, not '$reps'" >&2; exit 2 ;; esac
if [ ! -x "$bin" ]; then
  echo "compare.sh: error: '$bin' is not an executable; build first (cmake --build build --target crowdhealth_cli)" >&2
  echo "  or set CROWDHEALTH=path/to/crowdhealth" >&2
  exit 2
fi
if ! "$bin" --help 2>/dev/null | grep -q -- '--replications'; then
  echo "compare.sh: error: '$bin' has no --replications option; rebuild it" >&2
  exit 2
fi

# profile | label | setting | published density @15 s | published flow (P/s); "" = not published.
# (DESIGN §7; "≈" values of the paper are taken as written.)
table='sph-rho3|SPH|rho0_max = 3|3.27|3.08
sph-rho4|SPH|rho0_max = 4|4.21|4.17
sph-rho5|SPH|rho0_max = 5|5.09|4.89
sph-rho6|SPH|rho0_max = 6|5.89|5.80
sph-rho7|SPH|rho0_max = 7|6.61|6.45
sph-rho8|SPH|rho0_max = 8|7.23|7.20
sf-k50|SF|K_ag = 50|4.39|2.70
sf-k1000|SF|K_ag = 1000|4.21|1.29
rvo|RVO|K_ag = 1000|3.23|0.97
sf-sph-rho3|SF+SPH|rho0_max = 3|3.03|2.34
sf-sph-rho4|SF+SPH|rho0_max = 4||
sf-sph-rho5|SF+SPH|rho0_max = 5||
sf-sph-rho6|SF+SPH|rho0_max = 6||
sf-sph-rho7|SF+SPH|rho0_max = 7||
sf-sph-rho8|SF+SPH|rho0_max = 8|4.2|2.79
rvo-sph-rho3|RVO+SPH|rho0_max = 3|2.61|1.43
rvo-sph-rho4|RVO+SPH|rho0_max = 4||1.43
rvo-sph-rho5|RVO+SPH|rho0_max = 5||1.43
rvo-sph-rho6|RVO+SPH|rho0_max = 6||1.43
rvo-sph-rho7|RVO+SPH|rho0_max = 7||1.43
rvo-sph-rho8|RVO+SPH|rho0_max = 8|3.06|1.43
sf-to-sph-rho4|SF→SPH|rho0_max = 4|4.07|3.72
sf-to-sph-rho5|SF→SPH|rho0_max = 5|4.79|4.43
sf-to-sph-rho6|SF→SPH|rho0_max = 6|5.32|4.85
rvo-to-sph-rho4|RVO→SPH|rho0_max = 4||
rvo-to-sph-rho5|RVO→SPH|rho0_max = 5||
rvo-to-sph-rho6|RVO→SPH|rho0_max = 6||'

wanted() {
  [ -z "${PROFILES:-}" ] && return 0
  local p
  for p in $PROFILES; do [ "$p" = "$1" ] && return 0; done
  return 1
}

if [ -n "${PROFILES:-}" ]; then
  for p in $PROFILES; do
    if ! printf '%s\n' "$table" | cut -d'|' -f1 | grep -qx -- "$p"; then
      echo "compare.sh: unknown profile '$p'; known: $(printf '%s\n' "$table" | cut -d'|' -f1 | tr '\n' ' ')" >&2
      exit 2
    fi
  done
fi

mkdir -p "$outdir"

# ROOM_ORDER=clockwise: the profiles run from OUTDIR/profiles/, beside a copy of room.xml whose
# <Box x y width height> walls become <Obstacle> polygons (x,y) (x,y+h) (x+w,y+h) (x+w,y).
profiles="$here"
case "${ROOM_ORDER:-counterclockwise}" in
  counterclockwise) ;;
  clockwise)
    profiles="$outdir/profiles"
    mkdir -p "$profiles"
    awk '
      BEGIN { print "<?xml version=\"1.0\" encoding=\"utf-8\"?>"
              print "<!-- ../room.xml, every wall listed clockwise (written by compare.sh). -->"
              print "<Obstacles>" }
      /<Box / { delete v
                for (i = 1; i <= NF; i++) if (match($i, /^(x|y|width|height)="/)) {
                  k = substr($i, 1, RLENGTH - 2); val = substr($i, RLENGTH + 1); sub(/".*/, "", val); v[k] = val }
                if (!("x" in v) || !("y" in v) || !("width" in v) || !("height" in v)) { bad = 1; exit }
                x = v["x"]; y = v["y"]; X = x + v["width"]; Y = y + v["height"]
                printf "\t<Obstacle><Point x=\"%s\" y=\"%s\"/><Point x=\"%s\" y=\"%s\"/>", x, y, x, Y
                printf "<Point x=\"%s\" y=\"%s\"/><Point x=\"%s\" y=\"%s\"/></Obstacle>\n", X, Y, X, y }
      END { if (bad) exit 1; print "</Obstacles>" }
    ' "$here/../room.xml" > "$profiles/room-clockwise.xml" ||
      { echo "compare.sh: error: cannot read the <Box> walls of $here/../room.xml" >&2; exit 2; }
    for f in "$here"/*.xml; do  # the profiles and agents.xml
      sed -e 's|file="\.\./room\.xml"|file="room-clockwise.xml"|' "$f" > "$profiles/$(basename "$f")"
    done
    ;;
  *) echo "compare.sh: ROOM_ORDER must be counterclockwise or clockwise, not '$ROOM_ORDER'" >&2; exit 2 ;;
esac
# How many finished runs a summary.csv holds (rows before 'mean').
runs_in() { awk -F, 'NR > 1 && $1 == "mean" { exit } NR > 1 { n++ } END { print n + 0 }' "$1"; }

while IFS='|' read -r name label setting pdens pflow; do
  wanted "$name" || continue
  dir="$outdir/$name"
  if [ -f "$dir/summary.csv" ] && [ "$(runs_in "$dir/summary.csv")" -eq "$reps" ]; then
    echo "compare.sh: $name: reusing $dir/summary.csv" >&2
    continue
  fi
  rm -rf -- "$dir"
  echo "compare.sh: $name ($label, $setting): $reps runs" >&2
  start=$SECONDS
  "$bin" -i "$profiles/$name.xml" -o "$dir" --replications "$reps" --seed 1 -t "$threads" -q ||
    echo "compare.sh: warning: $name: crowdhealth exited with status $? (see $dir)" >&2
  echo "compare.sh: $name done in $((SECONDS - start)) s" >&2
done <<< "$table"

# One line per profile: the mean row of its summary.csv (evacuated, flow, density @15 s, with sd)
# beside the published values; deviations in % where both exist.
csv="$outdir/table1.csv"
md="$outdir/table1.md"
printf '%s\n' "$table" | while IFS='|' read -r name label setting pdens pflow; do
  wanted "$name" || continue
  f="$outdir/$name/summary.csv"
  [ -f "$f" ] || { echo "$name|$label|$setting|$pdens|$pflow|||||||0"; continue; }
  awk -F, -v name="$name" -v label="$label" -v setting="$setting" -v pd="$pdens" -v pf="$pflow" '
    NR == 1 { for (c = 1; c <= NF; c++) col[$c] = c; next }
    $1 == "mean" { ev = $col["evacuated"]; fl = $col["flow"]; de = $col["mean_density_at_15s"] }
    $1 == "sd"   { sfl = $col["flow"]; sde = $col["mean_density_at_15s"] }
    $1 == "n"    { n = $col["evacuated"] }
    END { printf "%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s\n", name, label, setting, pd, pf, ev, de, sde, fl, sfl, n }
  ' "$f"
done > "$outdir/.rows"

awk -F'|' -v csv="$csv" -v md="$md" '
  function num(x) { return x != "" }
  function f2(x) { return num(x) ? sprintf("%.2f", x) : "–" }
  function dev(m, p) { return (num(m) && num(p) && p != 0) ? sprintf("%+.0f %%", 100 * (m - p) / p) : "" }
  function devcsv(m, p) { return (num(m) && num(p) && p != 0) ? sprintf("%.1f", 100 * (m - p) / p) : "" }
  function pm(m, s) { return num(m) ? f2(m) (num(s) ? " ± " sprintf("%.2f", s) : "") : "–" }
  BEGIN {
    print "profile,setting,file,runs,evacuated,density15,density15_sd,density15_paper,density15_dev_pct,flow,flow_sd,flow_paper,flow_dev_pct" > csv
    print "| profile | setting | runs | evacuated | density @15 s (1/m²) | paper | Δ | flow (P/s) | paper | Δ |" > md
    print "|---|---|---|---|---|---|---|---|---|---|" > md
  }
  {
    name = $1; label = $2; setting = $3; pd = $4; pf = $5; ev = $6; de = $7; sde = $8; fl = $9; sfl = $10; n = $11
    printf "%s,%s,%s.xml,%s,%s,%s,%s,%s,%s,%s,%s,%s,%s\n", label, setting, name, n, ev, de, sde, pd, devcsv(de, pd), fl, sfl, pf, devcsv(fl, pf) > csv
    printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", label, setting, n, num(ev) ? sprintf("%.1f", ev) : "–", pm(de, sde), num(pd) ? pd : "–", dev(de, pd), pm(fl, sfl), num(pf) ? pf : "–", dev(fl, pf) > md
  }
' "$outdir/.rows"
rm -f "$outdir/.rows"

cat "$md"
echo
echo "compare.sh: wrote $md and $csv (mean ± sample sd over the runs; Δ = (measured − paper)/paper)" >&2
