// paths.png of `crowdhealth plot` / `--plot` (Engine/plot_paths*.{h,cpp}, docs/navigation.md
// "Plots"): drawn for a venue run that wrote trajectories, with the paths in the colours of the
// exits the agents left by and grey only for agents that did not leave by one; not drawn (and
// named in a note) for a run without trajectories. The data functions (evacuations.csv's exit
// column, paths grouped by exit) are checked on inputs written here.
#define BOOST_TEST_MODULE cli_paths_plot
#include <boost/test/unit_test.hpp>

#include "cli_support.h"
#include "png_support.h"

#include "plot_paths_data.h"

#include <map>

using namespace clitest;

namespace {

void write(const fs::path& file, const std::string& text) { writeText(file, text); }

// The colours of plot.cpp's palette (seriesColour) for the first two exits, and of "no exit".
constexpr std::uint32_t kFirstExit = 0x1f77b4, kSecondExit = 0xff7f0e, kNoExit = 0xa0a0a0;

/// A 10 m × 6 m room with an exit in the west and one in the east wall (nearest rule): three
/// people start near each. `stayer`: one more person with a plain goal inside the room, who
/// never leaves by an exit.
std::string venue(bool stayer) {
    std::string agents;
    for (int k = 0; k < 3; ++k) {
        const std::string y = std::to_string(1.5 + 1.5 * k);
        agents += "<Agent rad=\"0.25\" pref_speed=\"1.3\" journey=\"out\"><pos x=\"2\" y=\"" + y +
                  "\"/><Policy id=\"0\"/></Agent>\n";
        agents += "<Agent rad=\"0.25\" pref_speed=\"1.3\" journey=\"out\"><pos x=\"8\" y=\"" + y +
                  "\"/><Policy id=\"0\"/></Agent>\n";
    }
    if (stayer)
        agents += "<Agent rad=\"0.25\" pref_speed=\"1.3\"><pos x=\"5\" y=\"1\"/><goal x=\"5\" y=\"5\"/>"
                  "<Policy id=\"0\"/></Agent>\n";
    return R"(<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="25" seed="3">
  <World type="Planar" xmin="-1" xmax="11" ymin="-1" ymax="7">
    <Navigation/>
    <Obstacle><Point x="0" y="0"/><Point x="10" y="0"/></Obstacle>
    <Obstacle><Point x="0" y="6"/><Point x="10" y="6"/></Obstacle>
    <Obstacle><Point x="0" y="0"/><Point x="0" y="2.4"/></Obstacle>
    <Obstacle><Point x="0" y="3.6"/><Point x="0" y="6"/></Obstacle>
    <Obstacle><Point x="10" y="0"/><Point x="10" y="2.4"/></Obstacle>
    <Obstacle><Point x="10" y="3.6"/><Point x="10" y="6"/></Obstacle>
    <Exit id="west" xmin="-0.8" xmax="-0.3" ymin="2.4" ymax="3.6"/>
    <Exit id="east" xmin="10.3" xmax="10.8" ymin="2.4" ymax="3.6"/>
    <ExitSet id="both" exits="west east" choice="nearest"/>
    <Journey id="out" leave_by="both"/>
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5" ContactForceScale="62.5">
      <costfunction name="SocialForcesAvoidance" range="5" R="0.1"/>
      <costfunction name="GoalReachingForce"/>
    </Policy>
  </Policies>
  <Output trajectories="bin"/>
  <Agents>
)" + agents + R"(  </Agents>
</Simulation>
)";
}

}  // namespace

// ---- the program ------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(paths_png_is_drawn_for_a_venue_run_in_the_exits_colours) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(false));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "--plot"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(r.out.find("paths.png") != std::string::npos, r.out);
    const std::string evacuations = readFile(dir / "out" / "evacuations.csv");
    BOOST_TEST(evacuations.find("west") != std::string::npos, evacuations);
    BOOST_TEST(evacuations.find("east") != std::string::npos, evacuations);
    const fs::path png = dir / "out" / "paths.png";
    BOOST_REQUIRE(fs::exists(png));
    const Image img = decodePng(png);
    BOOST_TEST(img.width >= 900u);
    BOOST_TEST(img.height >= 500u);
    // Both exits' colours (paths and outlines), and no grey path: everyone left by an exit (a few
    // pixels of that grey come from antialiasing the black walls and text; a grey path of 4 m
    // gives some 400, see the next case).
    BOOST_TEST(img.count(kFirstExit) > 200u);
    BOOST_TEST(img.count(kSecondExit) > 200u);
    BOOST_TEST(img.count(kNoExit) < 80u);
    // It joins the run's manifest (a later run into the folder replaces it).
    const std::vector<std::string> manifest = manifestOf(dir / "out");
    BOOST_TEST((std::find(manifest.begin(), manifest.end(), "paths.png") != manifest.end()));
}

BOOST_AUTO_TEST_CASE(an_agent_that_leaves_by_no_exit_is_drawn_grey) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(true));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    // `crowdhealth plot DIR` from another folder: the scenario is found relative to DIR's parent.
    const Result p = run(dir / "out", {"plot", "."});
    BOOST_REQUIRE_MESSAGE(p.status == 0, p.err);
    BOOST_TEST(p.out.find("without walls") == std::string::npos, p.out);
    const Image img = decodePng(dir / "out" / "paths.png");
    BOOST_TEST(img.count(kNoExit) > 200u);
    BOOST_TEST(img.count(kFirstExit) > 200u);
    BOOST_TEST(img.count(kSecondExit) > 200u);
}

BOOST_AUTO_TEST_CASE(no_paths_png_without_trajectories) {
    const fs::path dir = freshDir(caseName());
    write(dir / "venue.xml", venue(false));
    const Result r = run(dir, {"-i", "venue.xml", "-o", "out", "--plot", "--trajectories", "none"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(fs::exists(dir / "out" / "fig3.png"));
    BOOST_TEST(!fs::exists(dir / "out" / "paths.png"));
    BOOST_TEST(r.out.find("no paths.png") != std::string::npos, r.out);
    // A stale paths.png in a folder without trajectories is removed, not left describing another run.
    write(dir / "out" / "paths.png", "stale");
    const Result p = run(dir, {"plot", "out"});
    BOOST_REQUIRE_MESSAGE(p.status == 0, p.err);
    BOOST_TEST(!fs::exists(dir / "out" / "paths.png"));
}

BOOST_AUTO_TEST_CASE(plot_help_names_paths_png) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"plot", "--help"});
    BOOST_TEST(r.status == 0);
    BOOST_TEST(r.out.find("paths.png") != std::string::npos, r.out);
}

// ---- the data -------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(paths_are_grouped_by_exit_in_name_order_then_the_rest) {
    // Three frames; agent 5 leaves by "west", agent 2 by "east", agent 9 by none and appears late.
    std::map<std::int64_t, std::vector<chcli::Sample>> byFrame;
    byFrame[0] = {{2, 0.0, 0.0}, {5, 10.0, 0.0}};
    byFrame[1] = {{2, 1.0, 0.5}, {5, 9.0, 0.0}, {9, 4.0, 4.0}};
    byFrame[3] = {{2, 2.0, 1.0}, {9, 4.5, 4.0}};
    const std::map<long long, std::string> exitOf = {{5, "west"}, {2, "east"}, {7, "west"}};
    const std::vector<chplot::PathGroup> groups = chplot::pathsByExit(byFrame, exitOf);
    BOOST_REQUIRE_EQUAL(groups.size(), 3u);
    BOOST_TEST(groups[0].exit == "east");
    BOOST_TEST(groups[1].exit == "west");
    BOOST_TEST(groups[2].exit == "");
    BOOST_TEST((groups[0].ids == std::vector<long long>{2}));
    BOOST_TEST((groups[1].ids == std::vector<long long>{5}));  // 7 has no trajectory: no path
    BOOST_TEST((groups[2].ids == std::vector<long long>{9}));
    const chplot::Polyline east = {{0.0, 0.0}, {1.0, 0.5}, {2.0, 1.0}};
    BOOST_TEST((groups[0].paths.at(0) == east));
    const chplot::Polyline west = {{10.0, 0.0}, {9.0, 0.0}};
    BOOST_TEST((groups[1].paths.at(0) == west));
    const chplot::Polyline rest = {{4.0, 4.0}, {4.5, 4.0}};
    BOOST_TEST((groups[2].paths.at(0) == rest));
    // Nobody without an exit: no "" group; no exits at all: one "" group.
    byFrame[1].pop_back();
    byFrame[3].pop_back();
    BOOST_TEST(chplot::pathsByExit(byFrame, exitOf).size() == 2u);
    const auto all = chplot::pathsByExit(byFrame, {});
    BOOST_REQUIRE_EQUAL(all.size(), 1u);
    BOOST_TEST(all[0].exit == "");
    BOOST_TEST((all[0].ids == std::vector<long long>{2, 5}));
}

BOOST_AUTO_TEST_CASE(evacuation_exits_are_read_from_the_exit_column) {
    const fs::path dir = freshDir(caseName());
    std::map<long long, std::string> exitOf;
    write(dir / "with.csv", "id,time,exit\n3,12.5,north\n1,13,\n7,14.1,south\n");
    BOOST_TEST(chplot::readEvacuationExits(dir / "with.csv", exitOf) == "");
    const std::map<long long, std::string> want = {{3, "north"}, {7, "south"}};
    BOOST_TEST((exitOf == want));
    // A run without exits writes no exit column: nobody left by one.
    write(dir / "without.csv", "id,time\n3,12.5\n");
    BOOST_TEST(chplot::readEvacuationExits(dir / "without.csv", exitOf) == "");
    BOOST_TEST(exitOf.empty());
    // A broken id names the file and line.
    write(dir / "broken.csv", "id,time,exit\n3,12.5,north\nx,13,south\n");
    const std::string err = chplot::readEvacuationExits(dir / "broken.csv", exitOf);
    BOOST_TEST(err.find("broken.csv:3") != std::string::npos, err);
    BOOST_TEST(chplot::readEvacuationExits(dir / "missing.csv", exitOf) != "");
}
