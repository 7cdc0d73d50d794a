// Venue geometry from files (docs/geometry.md): DXF drawings written here by hand (a minimal R12
// ENTITIES section, as dxflib reads it) and WKT polygons load to the expected walls (counts,
// lengths, positions, scale), arcs and circles become chords within 1 cm, layers map to exits,
// targets, measurement lines and areas, a WKT outer ring gives wall segments and its holes solid
// polygons, malformed files get errors naming the file and the entity or the token's line and
// column, and a WKT room with an exit is left by everyone in it.
#define BOOST_TEST_MODULE xml_geometry
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/core/world.h"
#include "crowdhealth/io/xml.h"
#include "scenario_files.h"

#include <algorithm>
#include <clocale>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <locale>
#include <sstream>
#include <string>
#include <vector>

using namespace ch;
namespace fs = std::filesystem;
using test::Loaded;
using test::load;
using test::scratch;

namespace {

void writeFile(const std::string& name, const std::string& text) { std::ofstream(scratch() / name, std::ios::binary) << text; }

/// A DXF file written group by group.
class Dxf {
public:
    Dxf& header(int insunits) {
        g(0, "SECTION"), g(2, "HEADER"), g(9, "$INSUNITS"), g(70, std::to_string(insunits)), g(0, "ENDSEC");
        return *this;
    }
    Dxf& entities() {
        g(0, "SECTION"), g(2, "ENTITIES");
        return *this;
    }
    Dxf& line(const std::string& layer, double x1, double y1, double x2, double y2, const std::string& handle = "") {
        g(0, "LINE");
        if (!handle.empty()) g(5, handle);
        g(8, layer), n(10, x1), n(20, y1), n(30, 0), n(11, x2), n(21, y2), n(31, 0);
        return *this;
    }
    Dxf& lwpolyline(const std::string& layer, const std::vector<std::pair<double, double>>& pts, bool closed,
                    const std::string& handle = "", const std::vector<double>& bulges = {}) {
        g(0, "LWPOLYLINE");
        if (!handle.empty()) g(5, handle);
        g(8, layer), g(90, std::to_string(pts.size())), g(70, closed ? "1" : "0");
        for (std::size_t k = 0; k < pts.size(); ++k) {
            n(10, pts[k].first), n(20, pts[k].second);
            if (k < bulges.size() && bulges[k] != 0) n(42, bulges[k]);
        }
        return *this;
    }
    Dxf& polyline(const std::string& layer, const std::vector<std::pair<double, double>>& pts, bool closed) {
        g(0, "POLYLINE"), g(8, layer), g(66, "1"), n(10, 0), n(20, 0), n(30, 0), g(70, closed ? "1" : "0");
        for (const auto& [x, y] : pts) g(0, "VERTEX"), g(8, layer), n(10, x), n(20, y), n(30, 0);
        g(0, "SEQEND"), g(8, layer);
        return *this;
    }
    Dxf& arc(const std::string& layer, double cx, double cy, double r, double a0, double a1) {
        g(0, "ARC"), g(8, layer), n(10, cx), n(20, cy), n(30, 0), n(40, r), n(50, a0), n(51, a1);
        return *this;
    }
    Dxf& circle(const std::string& layer, double cx, double cy, double r, const std::string& handle = "") {
        g(0, "CIRCLE");
        if (!handle.empty()) g(5, handle);
        g(8, layer), n(10, cx), n(20, cy), n(30, 0), n(40, r);
        return *this;
    }
    Dxf& text(const std::string& layer, const std::string& words) {
        g(0, "TEXT"), g(8, layer), n(10, 0), n(20, 0), n(30, 0), n(40, 1), g(1, words);
        return *this;
    }
    /// A raw group (for broken files).
    Dxf& g(int code, const std::string& value) {
        o_ << code << "\n" << value << "\n";
        return *this;
    }
    std::string end() {
        g(0, "ENDSEC"), g(0, "EOF");
        return o_.str();
    }
    std::string unfinished() const { return o_.str(); }
    /// The line the next group will start at (1-based).
    int nextLine() const {
        const std::string s = o_.str();
        return 1 + static_cast<int>(std::count(s.begin(), s.end(), '\n'));
    }

private:
    Dxf& n(int code, double v) {
        std::ostringstream s;
        s.precision(17);
        s << v;
        return g(code, s.str());
    }
    std::ostringstream o_;
};

const char* kPolicy = R"(
  <Policies>
    <Policy id="0" OptimizationMethod="gradient" RelaxationTime="0.5">
      <costfunction name="SocialForcesAvoidance" range="5"/>
      <costfunction name="GoalReachingForce"/>
    </Policy>
  </Policies>)";

/// A scenario whose world holds `obstacles` (and `more` after it).
std::string scenario(const std::string& obstacles, const std::string& more = "", const std::string& agents = "") {
    return "<Simulation delta_time=\"0.1\" end_time=\"60\">\n<World type=\"Infinite\">\n" + obstacles + "\n" + more +
           "</World>\n" + kPolicy + "\n<Agents>\n" + agents + "</Agents>\n</Simulation>\n";
}


bool has(const std::string& text, const std::string& needle) { return text.find(needle) != std::string::npos; }

/// Loads and requires success.
ScenarioSpec loadOk(const std::string& name, const std::string& xml) {
    const Loaded l = load(name, xml);
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    BOOST_TEST(!has(l.messages, "error"), l.messages);
    return *l.spec;
}

/// Loads, requires failure, and requires `where` (as "file:line: error: ") and `words` in one message.
void expectError(const std::string& name, const std::string& xml, const std::string& where, const std::string& words) {
    const Loaded l = load(name, xml);
    BOOST_TEST(!l.spec.has_value());
    bool found = false;
    std::istringstream lines(l.messages);
    for (std::string line; std::getline(lines, line);)
        found = found || (has(line, where) && has(line, words));
    BOOST_TEST(found, "messages:\n" << l.messages << "expected one line with: '" << where << "' and '" << words << "'");
}

std::string at(const std::string& file, int line) { return (scratch() / file).string() + ":" + std::to_string(line) + ": "; }

std::size_t twoPoint(const ScenarioSpec& s) {
    return static_cast<std::size_t>(std::count_if(s.obstacles.begin(), s.obstacles.end(),
                                                  [](const ObstacleSpec& o) { return o.points.size() == 2; }));
}

bool near(const Vec2& a, const Vec2& b, double tol = 1e-9) { return (a - b).norm() <= tol; }

/// True when some two-point obstacle joins a and b (either way).
bool hasSegment(const ScenarioSpec& s, const Vec2& a, const Vec2& b) {
    for (const ObstacleSpec& o : s.obstacles)
        if (o.points.size() == 2 &&
            ((near(o.points[0], a) && near(o.points[1], b)) || (near(o.points[0], b) && near(o.points[1], a))))
            return true;
    return false;
}

}  // namespace

// ---- DXF: walls ---------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(dxf_lines_and_polylines_become_walls_in_metres) {
    // Drawn in millimetres: a 10 m wall, an open L of two segments, a closed square pillar, and an
    // old-style POLYLINE with VERTEX entities (open, two segments).
    writeFile("walls.dxf", Dxf()
                               .entities()
                               .line("0", 0, 0, 10000, 0)
                               .lwpolyline("WALLS", {{0, 5000}, {4000, 5000}, {4000, 9000}}, false)
                               .lwpolyline("WALLS", {{6000, 6000}, {7000, 6000}, {7000, 7000}, {6000, 7000}}, true)
                               .polyline("WALLS", {{0, 12000}, {3000, 12000}, {3000, 15000}}, false)
                               .end());
    const ScenarioSpec s = loadOk("walls.xml", scenario("<Obstacles file=\"walls.dxf\" scale=\"0.001\"/>"));
    BOOST_TEST(s.obstacles.size() == 6u);
    // The drawing is listed among the files the scenario read (sweep and calibrate hash them).
    BOOST_TEST_REQUIRE(s.includedFiles.size() == 1u);
    BOOST_TEST(fs::path(s.includedFiles[0]).filename() == "walls.dxf");
    BOOST_TEST(twoPoint(s) == 5u);
    BOOST_TEST(hasSegment(s, Vec2(0, 0), Vec2(10, 0)));
    BOOST_TEST(hasSegment(s, Vec2(0, 5), Vec2(4, 5)));
    BOOST_TEST(hasSegment(s, Vec2(4, 5), Vec2(4, 9)));
    BOOST_TEST(hasSegment(s, Vec2(0, 12), Vec2(3, 12)));
    BOOST_TEST(hasSegment(s, Vec2(3, 12), Vec2(3, 15)));
    // Open polylines are never closed: no wall joins their ends.
    BOOST_TEST(!hasSegment(s, Vec2(0, 5), Vec2(4, 9)));
    BOOST_TEST(!hasSegment(s, Vec2(0, 12), Vec2(3, 15)));
    // The closed square is one solid polygon obstacle of 1 m × 1 m.
    const auto pillar = std::find_if(s.obstacles.begin(), s.obstacles.end(), [](const ObstacleSpec& o) { return o.points.size() == 4; });
    BOOST_TEST_REQUIRE((pillar != s.obstacles.end()));
    BOOST_TEST(std::abs(polygonArea(pillar->points)) == 1.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(near(pillar->points[0], Vec2(6, 6)));
    // Every obstacle remembers its entity's line in the drawing.
    for (const ObstacleSpec& o : s.obstacles) BOOST_TEST(has(o.loc.file, "walls.dxf"));
    BOOST_TEST(s.obstacles[0].loc.line == 5);  // "0 / LINE" after "0 SECTION 2 ENTITIES"
}

BOOST_AUTO_TEST_CASE(reading_a_dxf_drawing_leaves_the_locale_as_it_was) {
    // dxflib sets the process's locale to "C" while it reads; a program that embeds the library
    // (Python, C) must find its own afterwards (Python then still reads its text files as UTF-8).
    writeFile("locale.dxf", Dxf().entities().line("0", 0, 0, 1000, 0).end());
    const char* set = std::setlocale(LC_CTYPE, "C.UTF-8");
    BOOST_TEST_REQUIRE(set != nullptr, "this system has no C.UTF-8 locale");
    const std::string before = std::setlocale(LC_ALL, nullptr);
    BOOST_TEST(before != "C");
    const ScenarioSpec s = loadOk("locale.xml", scenario("<Obstacles file=\"locale.dxf\" scale=\"0.001\"/>"));
    BOOST_TEST(s.obstacles.size() == 1u);
    BOOST_TEST(std::string(std::setlocale(LC_ALL, nullptr)) == before);
    BOOST_TEST(std::locale().name() == "C");  // the C++ global locale, as every program starts
    // A program that set the C++ global locale too finds both again.
    std::locale::global(std::locale("C.UTF-8"));
    (void)loadOk("locale.xml", scenario("<Obstacles file=\"locale.dxf\" scale=\"0.001\"/>"));
    BOOST_TEST(std::locale().name() == "C.UTF-8");
    BOOST_TEST(std::string(std::setlocale(LC_CTYPE, nullptr)) == "C.UTF-8");
    std::locale::global(std::locale::classic());
    std::setlocale(LC_ALL, "C");
}

BOOST_AUTO_TEST_CASE(dxf_without_scale_is_in_metres_and_scale_multiplies) {
    writeFile("metres.dxf", Dxf().entities().line("0", 1, 2, 4, 6).end());
    const ScenarioSpec m = loadOk("metres.xml", scenario("<Obstacles file=\"metres.dxf\"/>"));
    BOOST_TEST_REQUIRE(m.obstacles.size() == 1u);
    BOOST_TEST((m.obstacles[0].points[1] - m.obstacles[0].points[0]).norm() == 5.0, boost::test_tools::tolerance(1e-12));
    const ScenarioSpec c = loadOk("cm.xml", scenario("<Obstacles file=\"metres.dxf\" scale=\"0.01\"/>"));
    BOOST_TEST(near(c.obstacles[0].points[0], Vec2(0.01, 0.02)));
    BOOST_TEST(near(c.obstacles[0].points[1], Vec2(0.04, 0.06)));
}

BOOST_AUTO_TEST_CASE(arcs_circles_and_bulges_become_chords_within_a_centimetre) {
    writeFile("round.dxf", Dxf()
                               .entities()
                               .arc("0", 10, 0, 5, 0, 90)      // a quarter of a 5 m circle round (10, 0)
                               .circle("0", 20, 20, 0.5)       // a round pillar
                               .lwpolyline("0", {{0, 10}, {4, 10}}, false, "", {1.0})  // a half circle from (0,10) to (4,10)
                               .lwpolyline("0", {{0, 20}, {4, 20}}, false, "", {std::tan(M_PI / 8)})  // a quarter circle
                               .end());
    const ScenarioSpec s = loadOk("round.xml", scenario("<Obstacles file=\"round.dxf\"/>"));
    std::vector<ObstacleSpec> arcSegs, bulgeSegs, quarterSegs, circles;
    for (const ObstacleSpec& o : s.obstacles) {
        if (o.points.size() > 2) circles.push_back(o);
        else if (o.points[0].x() <= 4 + 1e-9 && o.points[0].y() >= 17) quarterSegs.push_back(o);
        else if (o.points[0].x() <= 4 + 1e-9 && o.points[0].y() >= 7.9) bulgeSegs.push_back(o);
        else arcSegs.push_back(o);
    }
    // The arc: open, from (15, 0) to (10, 5), every vertex on the circle, every chord's middle
    // within 1 cm of it, and no more chords than needed (a chord of 1 cm sagitta spans 2·acos(1 − 0.01/5)).
    BOOST_TEST_REQUIRE(!arcSegs.empty());
    const double need = std::ceil((M_PI / 2) / (2 * std::acos(1 - 0.01 / 5)));
    BOOST_TEST(arcSegs.size() == static_cast<std::size_t>(need));
    BOOST_TEST(near(arcSegs.front().points[0], Vec2(15, 0), 1e-9));
    BOOST_TEST(near(arcSegs.back().points[1], Vec2(10, 5), 1e-9));
    for (const ObstacleSpec& o : arcSegs) {
        for (const Vec2& p : o.points) BOOST_TEST((p - Vec2(10, 0)).norm() == 5.0, boost::test_tools::tolerance(1e-9));
        const double sag = 5.0 - (0.5 * (o.points[0] + o.points[1]) - Vec2(10, 0)).norm();
        BOOST_TEST(sag <= 0.01 + 1e-12);
    }
    BOOST_TEST(!hasSegment(s, Vec2(15, 0), Vec2(10, 5)));  // never closed
    // The circle: one solid polygon, vertices on the circle, area near π r².
    BOOST_TEST_REQUIRE(circles.size() == 1u);
    const auto& c = circles[0].points;
    BOOST_TEST(c.size() >= 8u);
    for (const Vec2& p : c) BOOST_TEST((p - Vec2(20, 20)).norm() == 0.5, boost::test_tools::tolerance(1e-9));
    for (std::size_t k = 0; k < c.size(); ++k)
        BOOST_TEST(0.5 - (0.5 * (c[k] + c[(k + 1) % c.size()]) - Vec2(20, 20)).norm() <= 0.01 + 1e-12);
    BOOST_TEST(std::abs(polygonArea(c)) > 0.95 * M_PI * 0.25);
    // The bulge of 1 between (0, 10) and (4, 10): a half circle of radius 2 round (2, 10), on the
    // right of the direction of travel (counter-clockwise: below the chord).
    BOOST_TEST_REQUIRE(bulgeSegs.size() >= 4u);
    for (const ObstacleSpec& o : bulgeSegs)
        for (const Vec2& p : o.points) {
            BOOST_TEST((p - Vec2(2, 10)).norm() == 2.0, boost::test_tools::tolerance(1e-9));
            BOOST_TEST(p.y() <= 10 + 1e-9);
        }
    // A bulge of tan(22.5°) between (0, 20) and (4, 20): a quarter circle whose centre lies left of
    // the direction of travel, at (2, 22), radius 2·√2, the arc below the chord.
    BOOST_TEST_REQUIRE(quarterSegs.size() >= 4u);
    BOOST_TEST(near(quarterSegs.front().points[0], Vec2(0, 20)));
    BOOST_TEST(near(quarterSegs.back().points[1], Vec2(4, 20)));
    for (const ObstacleSpec& o : quarterSegs)
        for (const Vec2& p : o.points) {
            BOOST_TEST((p - Vec2(2, 22)).norm() == 2 * std::sqrt(2.0), boost::test_tools::tolerance(1e-9));
            BOOST_TEST(p.y() <= 20 + 1e-9);
        }
}

BOOST_AUTO_TEST_CASE(only_the_model_space_entities_are_read_and_mirrored_arcs_are_mirrored) {
    // A block definition holding a line, an entity in paper space (group 67 = 1), and a circle whose
    // extrusion is (0, 0, -1): its OCS centre (5, 0) is the world's (-5, 0).
    Dxf d;
    d.g(0, "SECTION").g(2, "BLOCKS").g(0, "BLOCK").g(8, "0").g(2, "CHAIR").g(70, "0").g(10, "0").g(20, "0").g(30, "0");
    d.g(0, "LINE").g(8, "0").g(10, "100").g(20, "100").g(30, "0").g(11, "200").g(21, "100").g(31, "0");
    d.g(0, "ENDBLK").g(8, "0").g(0, "ENDSEC");
    d.entities().line("0", 0, 0, 1, 0);
    d.g(0, "LINE").g(67, "1").g(8, "0").g(10, "50").g(20, "50").g(30, "0").g(11, "60").g(21, "50").g(31, "0");
    d.g(0, "CIRCLE").g(8, "0").g(10, "5").g(20, "0").g(30, "0").g(40, "1").g(210, "0").g(220, "0").g(230, "-1");
    writeFile("spaces.dxf", d.end());
    const ScenarioSpec s = loadOk("spaces.xml", scenario("<Obstacles file=\"spaces.dxf\"/>"));
    BOOST_TEST_REQUIRE(s.obstacles.size() == 2u);
    BOOST_TEST(hasSegment(s, Vec2(0, 0), Vec2(1, 0)));
    BOOST_TEST_REQUIRE(s.obstacles[1].points.size() > 2u);
    for (const Vec2& p : s.obstacles[1].points) BOOST_TEST((p - Vec2(-5, 0)).norm() == 1.0, boost::test_tools::tolerance(1e-9));
}

// ---- DXF: layers --------------------------------------------------------------------------------

namespace {
std::string concourseDxf() {
    return Dxf()
        .entities()
        .lwpolyline("BOUNDARY", {{0, 0}, {30, 0}, {30, 20}, {0, 20}}, true)
        .lwpolyline("0", {{10, 10}, {11, 10}, {11, 11}, {10, 11}}, true)      // a solid pillar
        .lwpolyline("EXITS", {{29, 2}, {30, 2}, {30, 4}, {29, 4}}, true, "2A")
        .polyline("EXITS", {{29, 12}, {30, 12}, {30, 14}, {29, 14}}, true)
        .lwpolyline("GATES", {{14, 5}, {16, 5}, {16, 7}, {14, 7}}, true)
        .line("COUNT", 28, 2, 28, 4)
        .lwpolyline("COUNT", {{28, 12}, {28, 13}, {28, 14}}, false)
        .lwpolyline("ZONES", {{25, 1}, {28, 1}, {28, 5}, {25, 5}}, true)
        .circle("ZONES", 26, 13, 1)
        .line("NOTES", 0, 0, 100, 100)
        .text("NOTES", "hello")
        .end();
}
const char* kLayers = R"(<Obstacles file="concourse.dxf">
      <Layer name="BOUNDARY" as="boundary"/>
      <Layer name="EXITS" as="exit"/>
      <Layer name="gates" as="target" prefix="GATE"/>
      <Layer name="COUNT" as="line"/>
      <Layer name="ZONES" as="area"/>
      <Layer name="NOTES" as="ignore"/>
    </Obstacles>)";
}  // namespace

BOOST_AUTO_TEST_CASE(layers_map_entities_to_exits_targets_lines_areas_and_walls) {
    writeFile("concourse.dxf", concourseDxf());
    const Loaded l = load("layers.xml", scenario(kLayers));
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    const ScenarioSpec& s = *l.spec;
    // Walls: the boundary's four edges as segments (its inside stays walkable), the pillar solid.
    BOOST_TEST(s.obstacles.size() == 5u);
    BOOST_TEST(twoPoint(s) == 4u);
    BOOST_TEST(hasSegment(s, Vec2(0, 20), Vec2(0, 0)));  // the closing edge of a closed boundary
    // Exits and the target, named LAYER-N (or PREFIX-N) in drawing order.
    BOOST_TEST_REQUIRE(s.venue.targets.size() == 3u);
    BOOST_TEST(s.venue.targets[0].name == "EXITS-1");
    BOOST_TEST(s.venue.targets[0].exit);
    BOOST_TEST((s.venue.targets[0].shape.kind == TargetShape::Kind::Polygon));
    BOOST_TEST(s.venue.targets[0].shape.polygon.size() == 4u);
    BOOST_TEST(s.venue.targets[0].shape.contains(Vec2(29.5, 3)));
    BOOST_TEST(s.venue.targets[1].name == "EXITS-2");
    BOOST_TEST(s.venue.targets[1].shape.contains(Vec2(29.5, 13)));
    BOOST_TEST(s.venue.targets[2].name == "GATE-1");
    BOOST_TEST(!s.venue.targets[2].exit);
    // Lines: the LINE, and one per segment of the three-vertex polyline.
    const auto& lines = s.measurement.lines;
    BOOST_TEST_REQUIRE(lines.size() == 3u);
    BOOST_TEST(lines[0].name == "COUNT-1");
    BOOST_TEST(near(lines[0].a, Vec2(28, 2)));
    BOOST_TEST(near(lines[0].b, Vec2(28, 4)));
    BOOST_TEST(lines[1].name == "COUNT-2");
    BOOST_TEST(lines[1].length() == 1.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(near(lines[2].b, Vec2(28, 14)));
    // Areas: the rectangle and the circle.
    const auto& areas = s.measurement.areas;
    BOOST_TEST_REQUIRE(areas.size() == 2u);
    BOOST_TEST(areas[0].name == "ZONES-1");
    BOOST_TEST(std::abs(polygonArea(areas[0].polygon)) == 12.0, boost::test_tools::tolerance(1e-12));
    BOOST_TEST(areas[1].name == "ZONES-2");
    BOOST_TEST(std::abs(polygonArea(areas[1].polygon)) > 0.95 * M_PI);
    // The ignored layer gives nothing, and its TEXT is not worth a warning.
    BOOST_TEST(!has(l.messages, "TEXT"), l.messages);
}

BOOST_AUTO_TEST_CASE(entities_not_read_are_a_warning_unless_their_layer_is_ignored) {
    Dxf d;
    d.entities().line("0", 0, 0, 1, 0);
    const int first = d.nextLine();
    d.text("0", "a").text("PLAN", "b").text("NOTES", "c");
    writeFile("text.dxf", d.end());
    const Loaded l = load("text.xml", scenario(R"(<Obstacles file="text.dxf"><Layer name="NOTES" as="ignore"/></Obstacles>)"));
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    BOOST_TEST(has(l.messages, (scratch() / "text.dxf").string() + ":" + std::to_string(first) +
                                   ": warning: 2 TEXT entities ignored (CrowdHealth reads LINE"), l.messages);
}

BOOST_AUTO_TEST_CASE(layer_names_match_in_any_case_and_a_missing_layer_is_a_warning_with_a_suggestion) {
    writeFile("concourse.dxf", concourseDxf());
    const Loaded l = load("missing-layer.xml", scenario(R"(<Obstacles file="concourse.dxf">
      <Layer name="exits" as="exit"/>
      <Layer name="ZONE" as="area"/>
    </Obstacles>)"));
    BOOST_TEST_REQUIRE(l.spec.has_value(), l.messages);
    BOOST_TEST(l.spec->venue.targets.size() == 2u);
    BOOST_TEST(has(l.messages, at("missing-layer.xml", 5) + "warning: Layer 'ZONE': no entity of"), l.messages);
    BOOST_TEST(has(l.messages, "(did you mean 'ZONES'?)"), l.messages);
    // ZONES is unmapped: its closed shapes are solid walls.
    BOOST_TEST(l.spec->measurement.areas.empty());
}

BOOST_AUTO_TEST_CASE(insunits_that_disagree_with_scale_are_a_warning) {
    writeFile("mm.dxf", Dxf().header(4).entities().line("0", 0, 0, 1000, 0).end());
    const Loaded bad = load("insunits-bad.xml", scenario("<Obstacles file=\"mm.dxf\"/>"));
    BOOST_TEST_REQUIRE(bad.spec.has_value(), bad.messages);
    BOOST_TEST(has(bad.messages, "warning: the drawing's $INSUNITS (4) says millimetres"), bad.messages);
    const Loaded good = load("insunits-good.xml", scenario("<Obstacles file=\"mm.dxf\" scale=\"0.001\"/>"));
    BOOST_TEST_REQUIRE(good.spec.has_value(), good.messages);
    BOOST_TEST(!has(good.messages, "INSUNITS"), good.messages);
    BOOST_TEST((good.spec->obstacles[0].points[1] - good.spec->obstacles[0].points[0]).norm() == 1.0,
               boost::test_tools::tolerance(1e-12));
}

// ---- DXF: errors ----------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(an_open_polyline_on_an_exit_or_area_layer_is_an_error_naming_the_entity) {
    Dxf d;
    d.entities().line("0", 0, 0, 1, 0);
    const int entityLine = d.nextLine();
    d.lwpolyline("EXITS", {{0, 0}, {1, 0}, {1, 1}}, false, "2F");
    writeFile("open-exit.dxf", d.end());
    const std::string file = (scratch() / "open-exit.dxf").string();
    expectError("open-exit.xml", scenario(R"(<Obstacles file="open-exit.dxf"><Layer name="EXITS" as="exit"/></Obstacles>)"),
                file + ":" + std::to_string(entityLine) + ": error: entity LWPOLYLINE handle 2F on layer 'EXITS'",
                "an exit must be a closed polyline");
    expectError("open-area.xml", scenario(R"(<Obstacles file="open-exit.dxf"><Layer name="EXITS" as="area"/></Obstacles>)"),
                file + ":" + std::to_string(entityLine) + ": error:", "a measurement area must be a closed polyline");
    // A LINE on an exit layer has no area either; a closed shape on a line layer is not a line.
    expectError("line-exit.xml", scenario(R"(<Obstacles file="open-exit.dxf"><Layer name="0" as="exit"/></Obstacles>)"),
                file + ":5: error: entity LINE on layer '0'", "an exit must be a closed polyline");
    writeFile("closed-line.dxf", Dxf().entities().circle("COUNT", 0, 0, 1, "A1").end());
    expectError("closed-line.xml", scenario(R"(<Obstacles file="closed-line.dxf"><Layer name="COUNT" as="line"/></Obstacles>)"),
                "closed-line.dxf:5: error: entity CIRCLE handle A1", "a measurement line must be a LINE or an open polyline");
}

BOOST_AUTO_TEST_CASE(an_unknown_as_word_or_a_bad_layer_element_is_an_error_at_its_xml_line) {
    writeFile("concourse.dxf", concourseDxf());
    expectError("as.xml", scenario(R"(<Obstacles file="concourse.dxf">
      <Layer name="EXITS" as="door"/></Obstacles>)"),
                at("as.xml", 4) + "error: Layer@as", "door");
    expectError("noname.xml", scenario(R"(<Obstacles file="concourse.dxf"><Layer as="exit"/></Obstacles>)"),
                at("noname.xml", 3) + "error: ", "Layer: missing required attribute name");
    expectError("twice.xml", scenario(R"(<Obstacles file="concourse.dxf"><Layer name="EXITS" as="exit"/>
      <Layer name="exits" as="area"/></Obstacles>)"),
                at("twice.xml", 4) + "error: ", "mapped twice");
    expectError("xmlscale.xml", scenario(R"(<Obstacles scale="0.001"><Box x="0" y="0" width="1" height="1"/></Obstacles>)"),
                at("xmlscale.xml", 3) + "error: ", "Obstacles@scale applies to a DXF or WKT file");
    expectError("badscale.xml", scenario(R"(<Obstacles file="concourse.dxf" scale="0"/>)"),
                at("badscale.xml", 3) + "error: Obstacles@scale", "");
    writeFile("room.wkt", "POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0))");
    expectError("wktlayer.xml", scenario(R"(<Obstacles file="room.wkt"><Layer name="A" as="exit"/></Obstacles>)"),
                at("wktlayer.xml", 3) + "error: ", "<Layer>");
    expectError("xmllayer.xml", scenario(R"(<Obstacles><Layer name="A" as="exit"/></Obstacles>)"),
                at("xmllayer.xml", 3) + "error: ", "<Layer>");
}

BOOST_AUTO_TEST_CASE(malformed_dxf_files_are_errors_naming_the_file_and_line) {
    const std::string xml = scenario("<Obstacles file=\"bad.dxf\"/>");
    const std::string bad = (scratch() / "bad.dxf").string();
    // Truncated: the end of the file is missing (no ENDSEC, no EOF).
    Dxf t;
    t.entities().line("0", 0, 0, 1, 0).line("0", 1, 0, 1, 1);
    writeFile("bad.dxf", t.unfinished());
    expectError("truncated.xml", xml, bad + ":", "truncated");
    // Cut in the middle of a group.
    writeFile("bad.dxf", t.unfinished() + "0\n");
    expectError("cut.xml", xml, bad + ":", "truncated");
    // A coordinate that is not a number, at its own line.
    Dxf n;
    n.entities().g(0, "LINE").g(8, "0").g(10, "0").g(20, "zero").g(11, "1").g(21, "0");
    writeFile("bad.dxf", n.end());
    expectError("nan.xml", xml, bad + ":12: error: LINE (at line 5): group 20", "must be a number, found 'zero'");
    // Not a DXF file at all.
    writeFile("bad.dxf", "this is a text file\nnot a drawing\n");
    expectError("notdxf.xml", xml, bad + ":1: error: ", "not a DXF drawing");
    writeFile("bad.dxf", "<?xml version=\"1.0\"?><Obstacles/>");
    expectError("xmldxf.xml", xml, bad + ":1: error: ", "not a DXF drawing");
    writeFile("bad.dxf", "");
    expectError("empty.xml", xml, bad + ":1: error: ", "the file is empty");
    writeFile("bad.dxf", std::string("AutoCAD Binary DXF\r\n\x1a\0", 22));
    expectError("binary.xml", xml, bad + ":1: error: ", "binary DXF is not supported");
    // An LWPOLYLINE whose vertex count lies, and one that asks dxflib for a billion vertices.
    Dxf c;
    c.entities().g(0, "LWPOLYLINE").g(8, "0").g(90, "3").g(70, "0").g(10, "0").g(20, "0").g(10, "1").g(20, "0");
    writeFile("bad.dxf", c.end());
    expectError("count.xml", xml, bad + ":5: error: ", "LWPOLYLINE declares 3 vertices (group 90) but holds 2");
    Dxf h;
    h.entities().g(0, "LWPOLYLINE").g(8, "0").g(90, "1000000000").g(70, "0").g(10, "0").g(20, "0");
    writeFile("bad.dxf", h.end());
    expectError("huge.xml", xml, bad + ":10: error: ", "out of range");
    // No usable entity: only text.
    writeFile("bad.dxf", Dxf().entities().text("0", "a note").end());
    expectError("nothing.xml", xml, at("nothing.xml", 3) + "error: ", "holds no usable entity");
    // Everything on an ignored layer.
    writeFile("ignored.dxf", Dxf().entities().line("NOTES", 0, 0, 1, 1).end());
    expectError("ignored.xml", scenario(R"(<Obstacles file="ignored.dxf"><Layer name="NOTES" as="ignore"/></Obstacles>)"),
                at("ignored.xml", 3) + "error: ", "holds no usable entity");
    // Missing file: at the XML line that names it.
    expectError("missing.xml", scenario("<Obstacles file=\"nowhere.dxf\"/>"), at("missing.xml", 3) + "error: ",
                "cannot find file 'nowhere.dxf'");
    // No ENTITIES section.
    writeFile("bad.dxf", Dxf().header(6).unfinished() + "0\nEOF\n");
    expectError("noentities.xml", xml, bad + ":1: error: ", "no ENTITIES section");
}

// ---- WKT ----------------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(wkt_outer_ring_gives_wall_segments_and_holes_give_solid_polygons) {
    // A 20 m × 10 m room with two square pillars, written over several lines, in centimetres.
    writeFile("pillars.wkt", "POLYGON (\n  (0 0, 2000 0, 2000 1000, 0 1000, 0 0),\n"
                             "  (500 400, 700 400, 700 600, 500 600, 500 400),\n"
                             "  (1300 400, 1500 400, 1500 600, 1300 600, 1300 400)\n)\n");
    const ScenarioSpec s = loadOk("pillars.xml", scenario("<Obstacles file=\"pillars.wkt\" scale=\"0.01\"/>"));
    BOOST_TEST(s.obstacles.size() == 6u);
    BOOST_TEST_REQUIRE(s.includedFiles.size() == 1u);
    BOOST_TEST(fs::path(s.includedFiles[0]).filename() == "pillars.wkt");
    BOOST_TEST(twoPoint(s) == 4u);
    BOOST_TEST(hasSegment(s, Vec2(0, 0), Vec2(20, 0)));
    BOOST_TEST(hasSegment(s, Vec2(20, 0), Vec2(20, 10)));
    BOOST_TEST(hasSegment(s, Vec2(20, 10), Vec2(0, 10)));
    BOOST_TEST(hasSegment(s, Vec2(0, 10), Vec2(0, 0)));
    std::vector<ObstacleSpec> holes;
    for (const ObstacleSpec& o : s.obstacles)
        if (o.points.size() > 2) holes.push_back(o);
    BOOST_TEST_REQUIRE(holes.size() == 2u);
    BOOST_TEST(holes[0].points.size() == 4u);  // the repeated closing point is dropped
    BOOST_TEST(std::abs(polygonArea(holes[0].points)) == 4.0, boost::test_tools::tolerance(1e-9));
    BOOST_TEST(near(holes[1].points[0], Vec2(13, 4)));
    BOOST_TEST(holes[0].loc.line == 3);
    // Inside the room is walkable, inside a pillar is not.
    const World world(s.world, s.obstacles);
    BOOST_TEST(!world.insideObstacle(Vec2(10, 5)));
    BOOST_TEST(world.insideObstacle(Vec2(6, 5)));
}

BOOST_AUTO_TEST_CASE(wkt_multipolygon_gives_each_polygon_its_walls) {
    writeFile("multi.wkt", "multipolygon (((0 0, 4 0, 4 4, 0 4, 0 0), (1 1, 2 1, 2 2, 1 1)), ((10 0, 13 0, 13 3, 10 0)))");
    const ScenarioSpec s = loadOk("multi.xml", scenario("<Obstacles file=\"multi.wkt\"/>"));
    BOOST_TEST(s.obstacles.size() == 4u + 1u + 3u);
    BOOST_TEST(twoPoint(s) == 7u);
    BOOST_TEST(hasSegment(s, Vec2(13, 3), Vec2(10, 0)));
}

BOOST_AUTO_TEST_CASE(malformed_wkt_is_an_error_at_the_line_and_column_of_the_token) {
    const std::string xml = scenario("<Obstacles file=\"bad.wkt\"/>");
    const std::string bad = (scratch() / "bad.wkt").string();
    const auto check = [&](const std::string& name, const std::string& text, int line, int column, const std::string& words) {
        writeFile("bad.wkt", text);
        expectError(name, xml, bad + ":" + std::to_string(line) + ": error: column " + std::to_string(column) + ": ", words);
    };
    check("token.xml", "POLYGON ((0 0, 4 0,\n 4 x4, 0 4, 0 0))", 2, 4, "expected a number (y), found 'x4'");
    check("keyword.xml", "LINESTRING (0 0, 1 1)", 1, 1, "expected POLYGON or MULTIPOLYGON, found 'LINESTRING'");
    check("open.xml", "POLYGON ((0 0, 4 0, 4 4, 0 4))", 1, 10, "outer ring is not closed");
    check("paren.xml", "POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0)", 1, 35, "expected ',' or ')' after a ring, found the end of the file");
    check("trailing.xml", "POLYGON ((0 0, 4 0, 4 4, 0 0)) extra", 1, 32, "unexpected 'extra' after the geometry");
    check("empty.xml", "POLYGON EMPTY", 1, 9, "EMPTY geometry");
    check("z.xml", "POLYGON Z ((0 0 0, 4 0 0, 4 4 0, 0 0 0))", 1, 9, "only 2-D coordinates");
    check("third.xml", "POLYGON ((0 0 1, 4 0, 4 4, 0 0))", 1, 15, "a third coordinate");
    check("hole.xml", "POLYGON ((0 0, 4 0, 4 4, 0 4, 0 0),\n(3 3, 5 3, 5 5, 3 3))", 2, 1, "hole 1 has a corner (5, 3) outside its outer ring");
    check("flat.xml", "POLYGON ((0 0, 4 0, 8 0, 0 0))", 1, 10, "outer ring has no area");
    check("nothing.xml", "", 1, 1, "expected POLYGON or MULTIPOLYGON, found the end of the file");
    check("short.xml", "POLYGON ((0 0, 1 0, 0 0))", 1, 10, "outer ring has 3 points: a ring needs at least 4");
    check("bom.xml", "\xEF\xBB\xBFPOLYGON ((0 0, 1 0, 1 1, 0 0), (q))", 1, 36, "expected a number (x), found 'q'");
}

// ---- a run ----------------------------------------------------------------------------------------

BOOST_AUTO_TEST_CASE(agents_leave_a_wkt_room_with_a_pillar_through_its_exit) {
    // A 10 m × 6 m room, open on its east side between y = 2.2 and 3.8 into a 1 m deep alcove (the
    // outer ring runs out through the door and back), a pillar in the middle, an exit in the alcove
    // (clear of its walls: checkVenue takes the first walkable cell within 1.5 cells of a target as
    // its floor, which for an exit flush with a wall can be the cell behind that wall).
    writeFile("room.wkt", "POLYGON ((0 0, 10 0, 10 2.2, 11 2.2, 11 3.8, 10 3.8, 10 6, 0 6, 0 0),"
                          " (4.5 2.5, 5.5 2.5, 5.5 3.5, 4.5 3.5, 4.5 2.5))");
    std::ostringstream agents;
    for (int k = 0; k < 12; ++k)
        agents << "<Agent rad=\"0.25\" pref_speed=\"1.3\" max_speed=\"1.6\" journey=\"out\"><pos x=\"" << 1 + (k % 3)
               << "\" y=\"" << 1 + 0.9 * (k / 3) << "\"/><Policy id=\"0\"/></Agent>\n";
    const ScenarioSpec spec = loadOk("run.xml", scenario("<Obstacles file=\"room.wkt\"/>\n<Navigation/>",
                                                         "<Exit id=\"door\" xmin=\"10.2\" xmax=\"10.8\" ymin=\"2.4\" ymax=\"3.6\"/>\n"
                                                         "<Journey id=\"out\" leave_by=\"door\"/>\n",
                                                         agents.str()));
    Simulation sim(spec);
    sim.setThreads(1);
    while (!sim.finished()) sim.stepCoarse();
    BOOST_TEST(sim.evacuations().size() == 12u);
    BOOST_TEST(sim.agents().size() == 0u);
    BOOST_TEST(sim.time() < 60.0);
}
