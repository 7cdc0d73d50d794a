#!/usr/bin/env bash
# Regenerates the section "Cost functions and forces" of docs/xml-reference.md from the program's
# registry: the lines between
#     <!-- BEGIN GENERATED: components -->
#     <!-- END GENERATED: components -->
# are replaced by the output of `crowdhealth --list-policies --format markdown`. Everything else
# in the file is left as it is. Run it after adding or changing a component (its parameter table)
# and commit the result; Tests/cli_docs_reference_test.cpp fails while the two differ.
#
# Usage: scripts/gen-xml-reference.sh [--check] [PATH/TO/crowdhealth]
#   PATH/TO/crowdhealth  the program to ask (default: $CROWDHEALTH, else build/bin/crowdhealth)
#   --check              change nothing; exit 1 if the section is out of date, 0 if current
# Needs bash and coreutils only.
set -euo pipefail
cd "$(dirname "$0")/.."

DOC="docs/xml-reference.md"
BEGIN="<!-- BEGIN GENERATED: components -->"
END="<!-- END GENERATED: components -->"

check=0
binary="${CROWDHEALTH:-build/bin/crowdhealth}"
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "gen-xml-reference: unknown option '$arg' (see --help)" >&2; exit 2 ;;
    *) binary="$arg" ;;
  esac
done

if [ ! -x "$binary" ]; then
  echo "gen-xml-reference: error: '$binary' is not an executable; build first" >&2
  echo "  (cmake -S . -B build && cmake --build build), or pass the program's path" >&2
  exit 2
fi
if [ ! -f "$DOC" ]; then
  echo "gen-xml-reference: error: $DOC not found" >&2
  exit 2
fi

# Each marker must stand alone on exactly one line, BEGIN before END.
begin_count=$(grep -cxF -- "$BEGIN" "$DOC" || true)
end_count=$(grep -cxF -- "$END" "$DOC" || true)
if [ "$begin_count" != 1 ] || [ "$end_count" != 1 ]; then
  echo "gen-xml-reference: error: $DOC must contain each marker exactly once on a line of its own:" >&2
  echo "  $BEGIN   (found $begin_count)" >&2
  echo "  $END     (found $end_count)" >&2
  exit 2
fi
begin_line=$(grep -nxF -- "$BEGIN" "$DOC" | cut -d: -f1)
end_line=$(grep -nxF -- "$END" "$DOC" | cut -d: -f1)
if [ "$begin_line" -ge "$end_line" ]; then
  echo "gen-xml-reference: error: in $DOC the END marker (line $end_line) comes before BEGIN (line $begin_line)" >&2
  exit 2
fi

tmp_dir=$(mktemp -d)
trap 'rm -rf "$tmp_dir"' EXIT

# Ask the program first: if it fails, the document is not touched.
if ! "$binary" --list-policies --format markdown >"$tmp_dir/generated.md"; then
  echo "gen-xml-reference: error: '$binary --list-policies --format markdown' failed" >&2
  exit 1
fi
# The END marker must stay on a line of its own.
if [ -s "$tmp_dir/generated.md" ] && [ -n "$(tail -c 1 "$tmp_dir/generated.md")" ]; then
  echo >>"$tmp_dir/generated.md"
fi

{
  head -n "$begin_line" "$DOC"
  cat "$tmp_dir/generated.md"
  tail -n "+$end_line" "$DOC"
} >"$tmp_dir/new.md"

if cmp -s "$tmp_dir/new.md" "$DOC"; then
  echo "gen-xml-reference: $DOC is up to date"
  exit 0
fi
if [ "$check" = 1 ]; then
  echo "gen-xml-reference: $DOC is out of date; run scripts/gen-xml-reference.sh" >&2
  diff -u "$DOC" "$tmp_dir/new.md" | head -n 40 >&2 || true
  exit 1
fi
# Same folder as the target, so the final rename is atomic.
cp "$tmp_dir/new.md" "$DOC.tmp"
mv "$DOC.tmp" "$DOC"
echo "gen-xml-reference: updated $DOC ($(grep -c '^### ' "$tmp_dir/generated.md") components)"
