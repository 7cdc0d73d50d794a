// los.png, flows.png and areas.png of `crowdhealth plot` / `--plot` (Engine/plot_measure*.{h,cpp},
// Engine/plot_venue.{h,cpp}, docs/measurement.md "Plots"), and the venue drawn over heatmap.png:
// drawn for a venue run with measurement lines and areas, in Fruin's colours and with the
// measurement drawn over the maps (los.png, heatmap.png, paths.png); flows.png and areas.png not drawn without flows.csv and
// areas.csv, los.png not drawn for a heatmap.csv without worst_los (an older run). The data
// functions (worst_los as a grid, Fruin's colours and ranges, flows.csv and areas.csv per line
// and area, the windowed specific flow) are checked on inputs written here.
#define BOOST_TEST_MODULE cli_los_plot
#include <boost/test/unit_test.hpp>

#include "cli_support.h"
#include "png_support.h"

#include "plot_measure_data.h"

#include <crowdhealth/health/safety.h>
#include <crowdhealth/measure/recorder.h>

#include <set>

using namespace clitest;

namespace {

void write(const fs::path& file, const std::string& text) { writeText(file, text); }

// Fruin's colours of levels A and F (plot_measure_data.cpp) and the measurement's magenta
// (plot_venue.h), the walls' dark grey.
constexpr std::uint32_t kLosA = 0x2166ac, kMeasure = 0xc0008c, kWall = 0x303030;

/// A 10 m × 6 m room with a 1.2 m exit in the west and one in the east wall; nine people in a
/// 1.5 m × 1.5 m block near the west door and three near the east. `measurement`: a line across
/// each door (forward = out) and an area in front of each.
std::string venue(bool measurement, bool exits = true) {
    std::string agents;
    for (int k = 0; k < 9; ++k)
        agents += "<Agent rad=\"0.2\" pref_speed=\"1.3\"" + std::string(exits ? " journey=\"out\"" : "") +
                  "><pos x=\"" + std::to_string(1.2 + 0.5 * (k % 3)) + "\" y=\"" + std::to_string(2.5 + 0.5 * (k / 3)) +
                  "\"/>" + (exits ? "" : "<goal x=\"9\" y=\"3\"/>") + "<Policy id=\"0\"/></Agent>\n";
    for (int k = 0; k < 3; ++k)
        agents += "<Agent rad=\"0.2\" pref_speed=\"1.3\"" + std::string(exits ? " journey=\"out\"" : "") +
                  "><pos x=\"8\" y=\"" + std::to_string(2 + k) + "\"/>" + (exits ? "" : "<goal x=\"1\" y=\"3\"/>") +
                  "<Policy id=\"0\"/></Agent>\n";
    const std::string exitsXml = exits ? R"(
    <Exit id="west" xmin="-0.8" xmax="-0.3" ymin="2.4" ymax="3.6"/>
    <Exit id="east" xmin="10.3" xmax="10.8" ymin="2.4" ymax="3.6"/>
    <ExitSet id="both" exits="west east" choice="nearest"/>
    <Journey id="out" leave_by="both"/>)"
                                       : "";
    const std::string measure = measurement ? R"(
  <Measurement interval="1">
    <Line id="door_w" x1="0" y1="3.6" x2="0" y2="2.4"/>
    <Line id="door_e" x1="10" y1="2.4" x2="10" y2="3.6"/>
    <Area id="front_w" xmin="0" xmax="2" ymin="1.5" ymax="4.5"/>
    <Area id="front_e"><Point x="8" y="1.5"/><Point x="10" y="1.5"/><Point x="10" y="4.5"/><Point x="8" y="4.5"/></Area>
  </Measurement>)"
                                            : "";
    return R"(<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="20" seed="3">
  <World type="Planar" xmin="-1" xmax="11" ymin="-1" ymax="7">
    <Navigation/>
    <Obstacle><Point x="0" y="0"/><Point x="10" y="0"/></Obstacle>
    <Obstacle><Point x="0" y="6"/><Point x="10" y="6"/></Obstacle>
    <Obstacle><Point x="0" y="0"/><Point x="0" y="2.4"/></Obstacle>
    <Obstacle><Point x="0" y="3.6"/><Point x="0" y="6"/></Obstacle>
    <Obstacle><Point x="10" y="0"/><Point x="10" y="2.4"/></Obstacle>
    <Obstacle><Point x="10" y="3.6"/><Point x="10" y="6"/></Obstacle>)" +
           exitsXml + R"(
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
      <costfunction name="SocialForcesAvoidance" range="5" R="0.1"/>
      <costfunction name="GoalReachingForce"/>
    </Policy>
  </Policies>)" + measure + R"(
  <Agents>
)" + agents + R"(  </Agents>
</Simulation>
)";
}

bool listed(const fs::path& dir, const std::string& name) {
    const std::vector<std::string> m = manifestOf(dir);
    return std::find(m.begin(), m.end(), name) != m.end();
}

}  // namespace

// ---- the program ------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(a_run_with_measurement_draws_los_flows_and_areas_over_the_venue) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(true));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "--plot", "--trajectories", "bin"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    for (const char* png : {"los.png", "flows.png", "areas.png", "heatmap.png", "paths.png"}) {
        BOOST_TEST(fs::exists(dir / "out" / png), png);
        BOOST_TEST(r.out.find(png) != std::string::npos, r.out);
        BOOST_TEST(listed(dir / "out", png), png);  // joins the manifest: the next run replaces it
    }
    // The LoS map: cells in Fruin's colours (A at least: most of the room sees a few people), the
    // walls and the measurement lines and areas over them.
    const Image los = decodePng(dir / "out" / "los.png");
    BOOST_TEST(los.width >= 1000u);
    BOOST_TEST(los.count(kLosA) > 2000u);
    BOOST_TEST(los.count(kMeasure) > 300u);
    BOOST_TEST(los.count(kWall) > 300u);
    // At least one more level than A: nine people in 2.25 m² are at D or worse for a while.
    std::size_t worse = 0;
    for (const char level : {'B', 'C', 'D', 'E', 'F'}) worse += los.count(chplot::losColour(level)) > 400u;
    BOOST_TEST(worse >= 2u);
    // The heat map draws the venue and the measurement too (both panels).
    const Image heat = decodePng(dir / "out" / "heatmap.png");
    BOOST_TEST(heat.count(kMeasure) > 600u);
    BOOST_TEST(heat.count(kWall) > 600u);
    // paths.png draws the same venue (through the same VenueOverlay).
    const Image paths = decodePng(dir / "out" / "paths.png");
    BOOST_TEST(paths.count(kMeasure) > 300u);
    BOOST_TEST(paths.count(kWall) > 300u);
    // flows.png and areas.png: one colour per line/exit and per area (the qualitative palette).
    const Image flows = decodePng(dir / "out" / "flows.png");
    BOOST_TEST(flows.count(0x1f77b4) > 300u);  // door_w
    BOOST_TEST(flows.count(0xd62728) > 300u);  // the fourth series: exit east
    const Image areas = decodePng(dir / "out" / "areas.png");
    BOOST_TEST(areas.count(0x1f77b4) > 300u);
    BOOST_TEST(areas.count(0xff7f0e) > 300u);
}

BOOST_AUTO_TEST_CASE(no_flows_or_areas_png_without_their_csv) {
    const fs::path dir = freshDir(caseName());
    // No exit and no measurement: neither flows.csv nor areas.csv.
    write(dir / "venue.xml", venue(false, false));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "--plot", "--trajectories", "none"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(!fs::exists(dir / "out" / "flows.csv"));
    BOOST_TEST(!fs::exists(dir / "out" / "flows.png"));
    BOOST_TEST(!fs::exists(dir / "out" / "areas.png"));
    BOOST_TEST(r.out.find("no flows.png") != std::string::npos, r.out);
    BOOST_TEST(r.out.find("no areas.png") != std::string::npos, r.out);
    BOOST_TEST(fs::exists(dir / "out" / "los.png"));  // every run's heatmap.csv has worst_los
    // Exits but no measurement: flows.png (the exits' flows), no areas.png.
    write(dir / "exits.xml", venue(false, true));
    const Result e = run(dir, {"-i", "exits.xml", "-o", "exits", "--plot", "--trajectories", "none"});
    BOOST_REQUIRE_MESSAGE(e.status == 0, e.err);
    BOOST_TEST(fs::exists(dir / "exits" / "flows.png"));
    BOOST_TEST(!fs::exists(dir / "exits" / "areas.png"));
    // Stale figures in a folder without the CSVs are removed, not left describing another run.
    write(dir / "out" / "flows.png", "stale");
    write(dir / "out" / "areas.png", "stale");
    const Result p = run(dir, {"plot", "out"});
    BOOST_REQUIRE_MESSAGE(p.status == 0, p.err);
    BOOST_TEST(!fs::exists(dir / "out" / "flows.png"));
    BOOST_TEST(!fs::exists(dir / "out" / "areas.png"));
}

BOOST_AUTO_TEST_CASE(no_los_png_for_a_heatmap_without_worst_los) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(true));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "-q", "--trajectories", "none"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    // An older run: heatmap.csv without its last column.
    std::istringstream in(readFile(dir / "out" / "heatmap.csv"));
    std::string line, old;
    while (std::getline(in, line)) old += line.substr(0, line.rfind(',')) + "\n";
    BOOST_REQUIRE(old.find("worst_los") == std::string::npos);
    write(dir / "out" / "heatmap.csv", old);
    write(dir / "out" / "los.png", "stale");
    const Result p = run(dir, {"plot", "out"});
    BOOST_REQUIRE_MESSAGE(p.status == 0, p.err);
    BOOST_TEST(!fs::exists(dir / "out" / "los.png"));
    BOOST_TEST(p.out.find("no worst_los column") != std::string::npos, p.out);
    BOOST_TEST(fs::exists(dir / "out" / "heatmap.png"));
}

BOOST_AUTO_TEST_CASE(cells_nobody_came_near_stay_white) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(true));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "--plot", "--trajectories", "none"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::size_t before = decodePng(dir / "out" / "los.png").count(kLosA);
    // The same heat map with every cell reached (max_density > 0): the cells nobody came near —
    // the middle of the room between the two groups, the corners — turn from white to A.
    std::istringstream in(readFile(dir / "out" / "heatmap.csv"));
    std::string line, all;
    std::getline(in, line);
    all = line + "\n";
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::string cell;
        std::istringstream row(line);
        while (std::getline(row, cell, ',')) cells.push_back(cell);
        BOOST_REQUIRE_EQUAL(cells.size(), 7u);
        if (cells[2] == "0") cells[2] = "0.001";
        for (std::size_t k = 0; k < cells.size(); ++k) all += (k ? "," : "") + cells[k];
        all += "\n";
    }
    write(dir / "out" / "heatmap.csv", all);
    const Result p = run(dir, {"plot", "out", "-q"});
    BOOST_REQUIRE_MESSAGE(p.status == 0, p.err);
    const std::size_t after = decodePng(dir / "out" / "los.png").count(kLosA);
    BOOST_TEST(after > before + before / 4, before << " A pixels, " << after << " with every cell reached");
}

BOOST_AUTO_TEST_CASE(plot_help_names_the_new_figures) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"plot", "--help"});
    BOOST_TEST(r.status == 0);
    for (const char* png : {"los.png", "flows.png", "areas.png"}) BOOST_TEST(r.out.find(png) != std::string::npos, r.out);
}

// ---- the data -------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(worst_los_is_read_into_a_grid) {
    const fs::path dir = freshDir(caseName());
    const std::string header =
        "x,y,max_density,max_contact_accel,seconds_above_density_threshold,seconds_above_crush_threshold";
    write(dir / "new.csv", header + ",worst_los\n0.5,0.5,0,0,0,0,A\n1.5,0.5,2.5,0,0,0,F\n0.5,1.5,0.2,0,0,0,A\n");
    std::vector<chplot::LosCell> cells;
    bool hasLos = false;
    BOOST_TEST(chplot::readLosGrid(dir / "new.csv", cells, hasLos) == "");
    BOOST_TEST(hasLos);
    BOOST_REQUIRE_EQUAL(cells.size(), 3u);
    BOOST_TEST(cells[1].x == 1.5);
    BOOST_TEST(cells[1].y == 0.5);
    BOOST_TEST(cells[1].level == 'F');
    BOOST_TEST(!cells[0].reached);  // nobody within reach: left white
    BOOST_TEST(cells[1].reached);
    BOOST_TEST(cells[2].reached);
    // An older heatmap.csv: no column, no cells, no error.
    write(dir / "old.csv", header + "\n0.5,0.5,0,0,0,0\n");
    BOOST_TEST(chplot::readLosGrid(dir / "old.csv", cells, hasLos) == "");
    BOOST_TEST(!hasLos);
    BOOST_TEST(cells.empty());
    // A level outside A–F names the file and line.
    write(dir / "bad.csv", header + ",worst_los\n0.5,0.5,0,0,0,0,A\n1.5,0.5,1,0,0,0,G\n");
    const std::string err = chplot::readLosGrid(dir / "bad.csv", cells, hasLos);
    BOOST_TEST(err.find("bad.csv:3") != std::string::npos, err);
    // Runs combined: the worst level of any run, reached when any run reached the cell.
    const std::vector<chplot::LosCell> a = {{0.5, 0.5, 'C', true}, {1.5, 0.5, 'A', false}};
    const std::vector<chplot::LosCell> b = {{0.5, 0.5, 'B', true}, {1.5, 0.5, 'E', true}, {0.5, 1.5, 'A', false}};
    const std::vector<chplot::LosCell> all = chplot::combineLos({a, b});
    BOOST_REQUIRE_EQUAL(all.size(), 3u);
    BOOST_TEST(all[0].level == 'C');  // (0.5, 0.5)
    BOOST_TEST(all[1].level == 'E');  // (1.5, 0.5)
    BOOST_TEST(all[1].reached);
    BOOST_TEST(all[2].y == 1.5);
    BOOST_TEST(!all[2].reached);
}

BOOST_AUTO_TEST_CASE(levels_have_fruins_colours_and_ranges) {
    // Blue, light blue, green, yellow, orange, red: six different colours, none white.
    std::set<unsigned> colours;
    for (const char level : {'A', 'B', 'C', 'D', 'E', 'F'}) colours.insert(chplot::losColour(level));
    BOOST_TEST(colours.size() == 6u);
    BOOST_TEST(colours.count(0xffffffu) == 0u);
    BOOST_TEST(chplot::losColour('A') == 0x2166acu);
    BOOST_TEST(chplot::losColour('F') == 0xd7191cu);
    BOOST_TEST(chplot::losColourHex('F') == "#d7191c");
    BOOST_TEST(chplot::losColour('G') == 0xffffffu);
    // The legend's ranges in persons/m² and m²/person, as fruinLevel draws the boundaries.
    BOOST_TEST(chplot::losLegend('A') == "A: ρ ≤ 0.31 P/m² (≥ 3.25 m²/P)");
    BOOST_TEST(chplot::losLegend('C') == "C: 0.43 < ρ ≤ 0.72 P/m² (1.39 to 2.32 m²/P)");
    BOOST_TEST(chplot::losLegend('F') == "F: ρ > 2.15 P/m² (< 0.46 m²/P)");
    // Each legend's range holds its level: just above the lower density and at 99.99 % of the upper.
    for (const char level : {'B', 'C', 'D', 'E', 'F'}) {
        // Exactly at the boundary: the level before (each level includes its upper density), as
        // docs/measurement.md says.
        BOOST_TEST(ch::fruinLevel(ch::fruinLowerDensity(level)) == level - 1);
        BOOST_TEST(ch::fruinLevel(ch::fruinLowerDensity(level) * 1.0001) == level);
        BOOST_TEST(ch::fruinLevel(ch::fruinLowerDensity(level) * 0.9999) == level - 1);
    }
}

BOOST_AUTO_TEST_CASE(the_arrow_points_to_the_side_the_recorder_counts_as_forward) {
    // For lines in every direction, a short move from the middle along the arrow is a forward
    // crossing for MeasurementRecorder (ch::crossing), and the reverse move a backward one.
    for (int k = 0; k < 12; ++k) {
        const double angle = k * 0.5236 + 0.1;
        const ch::Vec2 a(1, 2), b = a + 3.0 * ch::Vec2(std::cos(angle), std::sin(angle));
        const ch::Vec2 f = chplot::forwardDirection(a, b), mid = 0.5 * (a + b);
        BOOST_TEST(std::abs(f.norm() - 1) < 1e-12);
        BOOST_TEST(ch::crossing(a, b, mid - 0.1 * f, mid + 0.1 * f) == +1, "angle " << angle);
        BOOST_TEST(ch::crossing(a, b, mid + 0.1 * f, mid - 0.1 * f) == -1, "angle " << angle);
    }
    // Examples/venues/four-exits.xml's south door, drawn west to east: forward is south (out).
    const ch::Vec2 f = chplot::forwardDirection(ch::Vec2(9.5, 0), ch::Vec2(10.5, 0));
    BOOST_TEST(f.x() == 0.0);
    BOOST_TEST(f.y() == -1.0);
    BOOST_TEST(chplot::forwardDirection(ch::Vec2(1, 1), ch::Vec2(1, 1)).norm() == 0.0);
}

BOOST_AUTO_TEST_CASE(flows_csv_is_read_per_line_and_exit) {
    const fs::path dir = freshDir(caseName());
    // A 2 m line and a 1 m exit, 1 s rows.
    write(dir / "flows.csv",
          "time,line,kind,forward,backward,flow,specific_flow\n"
          "1,door,line,2,0,2,1\n1,out,exit,1,0,1,1\n"
          "2,door,line,3,1,4,2\n2,out,exit,2,0,2,2\n"
          "3,door,line,2,0,2,1\n3,out,exit,0,0,0,0\n");
    std::vector<chplot::FlowSeries> s;
    BOOST_TEST(chplot::readFlows(dir / "flows.csv", s) == "");
    BOOST_REQUIRE_EQUAL(s.size(), 2u);
    BOOST_TEST(s[0].name == "door");
    BOOST_TEST(!s[0].exit);
    BOOST_TEST(s[1].name == "out");
    BOOST_TEST(s[1].exit);
    BOOST_TEST(s[0].width == 2.0);  // flow / specific_flow
    BOOST_TEST(s[1].width == 1.0);
    BOOST_TEST(s[0].totalForward == 7);
    BOOST_TEST(s[0].totalBackward == 1);
    BOOST_REQUIRE_EQUAL(s[0].specificFlow.size(), 3u);
    BOOST_TEST(s[0].specificFlow[1].second == 2.0);
    BOOST_TEST(s[0].forward[2].second == 2.0);
    BOOST_TEST(s[0].backward[1].second == 1.0);
    // Over a 2 s window: crossings in (t − 2, t] / 2 s / width.
    const chplot::Curve w = chplot::windowedSpecificFlow(s[0], 2.0);
    BOOST_REQUIRE_EQUAL(w.size(), 3u);
    BOOST_TEST(w[0].second == 2.0 / 2 / 2);
    BOOST_TEST(w[1].second == (2.0 + 4) / 2 / 2);  // rows 1 and 2
    BOOST_TEST(w[2].second == (4.0 + 2) / 2 / 2);  // rows 2 and 3 (row 1, at t − 2, is out)
    // A measurement line may have an exit's name: two series.
    write(dir / "same.csv", "time,line,kind,forward,backward,flow,specific_flow\n1,out,line,2,0,2,1\n1,out,exit,1,0,1,1\n");
    BOOST_TEST(chplot::readFlows(dir / "same.csv", s) == "");
    BOOST_REQUIRE_EQUAL(s.size(), 2u);
    BOOST_TEST(!s[0].exit);
    BOOST_TEST(s[1].exit);
    BOOST_TEST(s[1].totalForward == 1);
    // A line never crossed has no width: no windowed curve.
    write(dir / "none.csv", "time,line,kind,forward,backward,flow,specific_flow\n1,l,line,0,0,0,0\n");
    BOOST_TEST(chplot::readFlows(dir / "none.csv", s) == "");
    BOOST_TEST(chplot::windowedSpecificFlow(s.at(0), 10).empty());
    // Errors name the file and line.
    write(dir / "bad.csv", "time,line,kind,forward,backward,flow,specific_flow\n1,l,line,x,0,0,0\n");
    const std::string err = chplot::readFlows(dir / "bad.csv", s);
    BOOST_TEST(err.find("bad.csv:2") != std::string::npos, err);
    write(dir / "short.csv", "time,line,forward\n");
    BOOST_TEST(chplot::readFlows(dir / "short.csv", s).find("kind") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(areas_csv_is_read_per_area) {
    const fs::path dir = freshDir(caseName());
    write(dir / "areas.csv",
          "time,area,density,speed,specific_flow,los,people\n"
          "1,a,0.5,1.2,0.6,C,3\n1,b,0,0,0,A,0\n2,a,2.5,0.3,0.75,F,15\n2,b,0.2,1,0.2,A,1\n");
    std::vector<chplot::AreaSeries> s;
    BOOST_TEST(chplot::readAreas(dir / "areas.csv", s) == "");
    BOOST_REQUIRE_EQUAL(s.size(), 2u);
    BOOST_TEST(s[0].name == "a");
    BOOST_TEST(s[1].name == "b");
    BOOST_REQUIRE_EQUAL(s[0].density.size(), 2u);
    BOOST_TEST(s[0].density[1].second == 2.5);
    BOOST_TEST(s[0].speed[0].second == 1.2);
    BOOST_TEST(s[0].people[1].second == 15.0);
    BOOST_TEST((s[0].los == std::vector<char>{'C', 'F'}));
    write(dir / "bad.csv", "time,area,density,speed,specific_flow,los,people\n1,a,0.5,1,0.5,Z,3\n");
    const std::string err = chplot::readAreas(dir / "bad.csv", s);
    BOOST_TEST(err.find("bad.csv:2") != std::string::npos, err);
}
