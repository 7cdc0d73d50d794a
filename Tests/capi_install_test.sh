#!/usr/bin/env bash
# The C API from an installed tree (docs/c-api.md): `cmake --install` into a temporary prefix,
# Examples/c-api/example.c compiled with gcc -std=c99 against it through pkg-config and through
# find_package(CrowdHealth), run on a small scenario; checks its output (agents move, time
# advances, a parameter changes, a misspelt parameter and a bad file give their errors). Then the
# example plugin (Examples/plugin) built on its own against the installed tree, loaded by the
# installed program (--plugin, <Plugin>) and by a C program (ch_load_plugin): a model added
# without rebuilding CrowdHealth (docs/adding-a-policy.md).
#
#   capi_install_test.sh BUILD_DIR SOURCE_DIR [EXTRA_CFLAGS]
# EXTRA_CFLAGS: -fsanitize=… under the sanitizer build (the library is instrumented, so the
# program must be too).
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
extra=${3:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "capi_install_test: FAIL: $*" >&2; exit 1; }

prefix="$tmp/prefix"
cmake --install "$build" --prefix "$prefix" >"$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install"; }

# What an installed tree holds.
pc=$(find "$prefix" -name crowdhealth.pc)
[ -n "$pc" ] || fail "no crowdhealth.pc installed"
libdir=$(dirname "$(dirname "$pc")")
for f in "$prefix/include/crowdhealth/crowdhealth_c.h" "$prefix/include/crowdhealth/version.h" \
         "$prefix/include/crowdhealth/core/simulation.h" "$libdir/libcrowdhealth.so" \
         "$libdir/cmake/CrowdHealth/CrowdHealthConfig.cmake" "$prefix/bin/crowdhealth"; do
  [ -e "$f" ] || fail "not installed: ${f#"$prefix"/}"
done
version=$(PKG_CONFIG_PATH="$(dirname "$pc")" pkg-config --modversion crowdhealth)
soname=$(readelf -d "$libdir/libcrowdhealth.so" | sed -n 's/.*Library soname: \[\(.*\)\]/\1/p')
[ "$soname" = "libcrowdhealth.so.${version%.*}" ] || fail "SONAME '$soname' for version $version"
"$prefix/bin/crowdhealth" --version | grep -q "$version" || fail "the installed program's --version is not $version"

# A scenario with three errors (lines 5 and 8, and the missing policies at line 2).
cat >"$tmp/bad.xml" <<'XML'
<?xml version="1.0" encoding="utf-8"?>
<Simulation delta_time="0.1" end_time="10" seed="1">
	<World type="Infinite" />
	<Agents>
		<Agent id="0" rad="0.25" pref_speed="1.3" max_spead="1.6">
			<pos x="0" y="0" />
			<goal x="5" y="0" />
			<Policy id="3" />
		</Agent>
	</Agents>
</Simulation>
XML
scenario="$src/Examples/corridor/bidirectional-socialforces.xml"

# 1. pkg-config, as docs/c-api.md shows.
export PKG_CONFIG_PATH="$(dirname "$pc")"
# shellcheck disable=SC2046,SC2086
gcc -std=c99 -Wall -Wextra -pedantic -Werror $extra "$src/Examples/c-api/example.c" \
    $(pkg-config --cflags --libs crowdhealth) -lm -o "$tmp/example"
LD_LIBRARY_PATH="$libdir" "$tmp/example" "$scenario" "$tmp/bad.xml" >"$tmp/out.txt" 2>"$tmp/err.txt" ||
  { cat "$tmp/out.txt" "$tmp/err.txt"; fail "the example failed"; }
cat "$tmp/out.txt"

out="$tmp/out.txt"
grep -qx "CrowdHealth $version" "$out" || fail "ch_version is not $version"
grep -qx "t = 0.00 s: 80 agents (dt 0.10 s, end time 60.0 s)" "$out" || fail "the start"
grep -q "^too small: ch_simulation_positions: the buffer holds 0 agents, but there are 80$" "$out" ||
  fail "asking for the count"
grep -qx "SocialForcesAvoidance.V0: 2.1 -> 4.2" "$out" || fail "set_parameter/get_parameter"
grep -q "^set_parameter failed: .*SocialForcesAvoidance has no parameter 'V_0' (did you mean 'V0'?)" "$out" ||
  fail "set_parameter on an unknown name"
# After 10 s at about 1.3 m/s the walkers have gone several metres, and still walk.
line=$(grep "^t = 10.00 s: " "$out") || fail "time did not reach 10 s"
disp=$(sed -n 's/.*mean displacement \([0-9.]*\) m.*/\1/p' <<<"$line")
speed=$(sed -n 's/.*mean speed \([0-9.]*\) m\/s.*/\1/p' <<<"$line")
awk -v d="$disp" -v s="$speed" 'BEGIN { exit !(d > 5 && d < 14 && s > 0.5 && s < 1.7) }' ||
  fail "mean displacement $disp m, mean speed $speed m/s after 10 s"
grep -q "^load failed:$" "$out" || fail "the bad file loaded"
for l in 5 8 2; do grep -q "^$tmp/bad.xml:$l: error: " "$out" || fail "no error at bad.xml:$l"; done
grep -q "bad.xml:5: error: unknown attribute 'max_spead' on <Agent> (did you mean 'max_speed'?)" "$out" ||
  fail "the message of bad.xml:5"

# 2. find_package(CrowdHealth) from a C-only CMake project: the same program, the same output.
mkdir "$tmp/consumer"
cat >"$tmp/consumer/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.20)
project(consumer LANGUAGES C)
find_package(CrowdHealth $version REQUIRED)
add_executable(example "$src/Examples/c-api/example.c")
set_target_properties(example PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
target_link_libraries(example PRIVATE CrowdHealth::crowdhealth m)
CMAKE
unset PKG_CONFIG_PATH
cmake -S "$tmp/consumer" -B "$tmp/consumer/build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_C_FLAGS="$extra" >"$tmp/consumer.log" 2>&1 || { cat "$tmp/consumer.log"; fail "find_package(CrowdHealth)"; }
cmake --build "$tmp/consumer/build" >>"$tmp/consumer.log" 2>&1 || { cat "$tmp/consumer.log"; fail "building with CMake"; }
# The imported target carries the library's path (RPATH in the build tree): no LD_LIBRARY_PATH.
"$tmp/consumer/build/example" "$scenario" "$tmp/bad.xml" >"$tmp/out2.txt" 2>&1 || { cat "$tmp/out2.txt"; fail "the CMake-built example"; }
cmp -s "$out" "$tmp/out2.txt" || { diff "$out" "$tmp/out2.txt"; fail "the CMake-built example printed something else"; }
# 3. docs/c-api.md quotes lines of the example: each must still be in it, as it is (one source).
doc="$src/docs/c-api.md"
if [ -f "$doc" ]; then
  quoted=$(awk '/^```c$/ {on = 1; next} /^```$/ {on = 0} on && NF' "$doc")
  [ -n "$quoted" ] || fail "docs/c-api.md quotes no C"
  while IFS= read -r l; do
    grep -Fxq -- "$l" "$src/Examples/c-api/example.c" || fail "docs/c-api.md quotes a line that is not in Examples/c-api/example.c: $l"
  done <<<"$quoted"
fi

# 4. A plugin built against the installed tree alone (CrowdHealth::plugin), run by the installed
# program and through the C API: its force changes the walk.
cmake -S "$src/Examples/plugin" -B "$tmp/plugin" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_FLAGS="$extra" >"$tmp/plugin.log" 2>&1 || { cat "$tmp/plugin.log"; fail "configuring Examples/plugin against the installed tree"; }
cmake --build "$tmp/plugin" >>"$tmp/plugin.log" 2>&1 || { cat "$tmp/plugin.log"; fail "building Examples/plugin against the installed tree"; }
plugin="$tmp/plugin/plugins/libdistancing.so"
[ -f "$plugin" ] || fail "no $plugin"
# It links nothing of CrowdHealth's: the program that loads it provides the library.
! readelf -d "$plugin" | grep -q "libcrowdhealth" || fail "the plugin links libcrowdhealth"
"$prefix/bin/crowdhealth" --plugin "$plugin" --list-policies >"$tmp/list.txt" || fail "--plugin --list-policies"
grep -q "^DistancingForce  \[force\]" "$tmp/list.txt" || fail "the installed program does not list the plugin's force"
walkers() {  # $1: extra cost function line
  cat <<XML
<Simulation delta_time="0.1" end_time="10">
	<Plugin file="$plugin" />
	<World type="Infinite" />
	<Policies><Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">
		<costfunction name="GoalReachingForce" />$1
	</Policy></Policies>
	<Agents>
		<Agent id="0" rad="0.25" pref_speed="1.2"><pos x="0" y="0.5"/><goal x="100" y="0.5"/><Policy id="0"/></Agent>
		<Agent id="1" rad="0.25" pref_speed="1.2"><pos x="0" y="-0.5"/><goal x="100" y="-0.5"/><Policy id="0"/></Agent>
	</Agents>
</Simulation>
XML
}
walkers '<costfunction name="DistancingForce" distance="1.5" />' >"$tmp/distancing.xml"
"$prefix/bin/crowdhealth" -i "$tmp/distancing.xml" -o "$tmp/distancing-out" -q || fail "the installed program with <Plugin>"
cat >"$tmp/plugin.c" <<'C'
#include <crowdhealth/crowdhealth_c.h>
#include <math.h>
#include <stdio.h>
int main(int argc, char** argv) {
    if (ch_load_plugin(argv[1]) != CH_OK) { printf("load_plugin failed: %s\n", ch_last_error()); return 1; }
    if (ch_load_plugin("/nonexistent/libnothing.so") == CH_OK) return 1;
    printf("refused: %s\n", ch_last_error());
    ch_simulation* sim = ch_simulation_load(argv[2], NULL);
    if (!sim) { printf("load failed: %s\n", ch_last_error()); return 1; }
    while (ch_simulation_time(sim) < 9.95) if (ch_simulation_step(sim) != CH_OK) return 1;
    double xy[4];
    size_t n = 0;
    if (ch_simulation_positions(sim, xy, 2, &n) != CH_OK || n != 2) return 1;
    printf("separation %.3f\n", hypot(xy[0] - xy[2], xy[1] - xy[3]));
    ch_simulation_free(sim);
    return 0;
}
C
# The scenario without <Plugin>: the C program loads the plugin itself.
walkers '<costfunction name="DistancingForce" distance="1.5" />' | grep -v "<Plugin" >"$tmp/noplugin.xml"
# shellcheck disable=SC2046,SC2086
gcc -std=c99 -Wall -Werror $extra "$tmp/plugin.c" $(PKG_CONFIG_PATH="$(dirname "$pc")" pkg-config --cflags --libs crowdhealth) -lm -o "$tmp/plugin-c"
LD_LIBRARY_PATH="$libdir" "$tmp/plugin-c" "$plugin" "$tmp/noplugin.xml" >"$tmp/plugin-c.txt" 2>&1 || { cat "$tmp/plugin-c.txt"; fail "ch_load_plugin"; }
cat "$tmp/plugin-c.txt"
grep -q "^refused: /nonexistent/libnothing.so: no such file" "$tmp/plugin-c.txt" || fail "ch_load_plugin's error"
sep=$(sed -n 's/^separation //p' "$tmp/plugin-c.txt")
awk -v s="$sep" 'BEGIN { exit !(s > 1.49 && s < 1.6) }' || fail "separation $sep m with DistancingForce (1 m without, 1.5 m expected)"
echo "capi_install_test: OK"
