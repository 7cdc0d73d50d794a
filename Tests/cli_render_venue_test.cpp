// `crowdhealth render` of a venue (Engine/render.cpp, render_scene.cpp; docs/rendering.md): the
// frames outline the targets and exits with their names, and an exit closed by the schedule is
// drawn red and dashed, named "(closed)", from the frame at which it closes.
#define BOOST_TEST_MODULE cli_render_venue
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

using namespace clitest;

namespace {

const char* kVenue = R"(<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="10">
  <World type="Planar" xmin="-1" xmax="11" ymin="-1" ymax="7">
    <Navigation/>
    <Obstacle><Point x="0" y="0"/><Point x="10" y="0"/></Obstacle>
    <Obstacle><Point x="0" y="6"/><Point x="10" y="6"/></Obstacle>
    <Exit id="west" xmin="-0.8" xmax="-0.3" ymin="2.4" ymax="3.6"/>
    <Exit id="east" xmin="10.3" xmax="10.8" ymin="2.4" ymax="3.6"/>
    <Target id="desk" x="5" y="3" radius="0.4"/>
    <ExitSet id="both" exits="west east"/>
    <Journey id="out" leave_by="both"><Waypoint target="desk"/></Journey>
  </World>
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">
      <costfunction name="SocialForcesAvoidance" range="5"/>
      <costfunction name="GoalReachingForce"/>
    </Policy>
  </Policies>
  <Agents>
    <Agent rad="0.25" journey="out"><pos x="2" y="3"/><Policy id="0"/></Agent>
  </Agents>
  <Schedule><CloseExit exit="east" time="1"/></Schedule>
</Simulation>
)";

}  // namespace

BOOST_AUTO_TEST_CASE(frames_outline_targets_and_exits_and_show_a_closed_exit) {
    const fs::path dir = freshDir(caseName());
    std::ofstream(dir / "venue.xml") << kVenue;
    const Result r = run(dir, {"render", "-i", "venue.xml", "-o", "frames", "--time", "2", "--every", "1", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(fs::exists(dir / "frames" / "frame_0002.png"));
    const std::string gp = readFile(dir / "frames" / "render.gp");
    // Every target and exit is named; the point target is a circle.
    BOOST_TEST(gp.find("'west'") != std::string::npos);
    BOOST_TEST(gp.find("'desk'") != std::string::npos);
    BOOST_TEST(gp.find("circle at 5,3") != std::string::npos, gp.substr(0, 3000));
    // east is open in the frames at 0 s (before the closure) and closed in those at 1 s and 2 s:
    // the script sets its state before each frame's plot, the closed one red and dashed.
    std::vector<std::size_t> plots;
    for (std::size_t at = gp.find("set output 'frame_"); at != std::string::npos; at = gp.find("set output 'frame_", at + 1))
        plots.push_back(at);
    BOOST_REQUIRE_EQUAL(plots.size(), 3u);
    auto frame = [&](std::size_t k) {
        return gp.substr(plots[k], (k + 1 < plots.size() ? plots[k + 1] : gp.find("set output\n", plots[k])) - plots[k]);
    };
    BOOST_TEST(frame(0).find("'east'") != std::string::npos, frame(0));
    BOOST_TEST(frame(0).find("(closed)") == std::string::npos, frame(0));
    for (std::size_t k : {1u, 2u}) {
        BOOST_TEST(frame(k).find("'east (closed)'") != std::string::npos, frame(k));
        BOOST_TEST(frame(k).find("dt 2") != std::string::npos, frame(k));
    }
    // west never closes: its outline is set once, before the frames, and stays open.
    BOOST_TEST(gp.find("'west (closed)'") == std::string::npos);
}
