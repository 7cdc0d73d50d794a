// `crowdhealth render`: PNG frames of the doorway base case show the grey walls and the agents in
// the paper's density colours at their positions; replays of a run's trajectories; clear errors.
// The PNG is decoded here with zlib (Tests/CMakeLists.txt links it when found).
#define BOOST_TEST_MODULE cli_render
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#ifdef CH_HAVE_ZLIB
#include <zlib.h>
#endif

#include <cstdint>
#include <cstdlib>
#include <map>
#include <set>

using namespace clitest;

namespace {

struct Image {
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgb;  ///< 3 bytes per pixel, rows top to bottom
    std::array<int, 3> at(int x, int y) const {
        const std::size_t k = (static_cast<std::size_t>(y) * width + x) * 3;
        return {rgb[k], rgb[k + 1], rgb[k + 2]};
    }
};

std::uint32_t be32(const std::string& s, std::size_t at) {
    return (std::uint32_t(std::uint8_t(s[at])) << 24) | (std::uint32_t(std::uint8_t(s[at + 1])) << 16) |
           (std::uint32_t(std::uint8_t(s[at + 2])) << 8) | std::uint32_t(std::uint8_t(s[at + 3]));
}

/// The PNG's size from its IHDR chunk (0×0 if it is not a PNG).
std::pair<int, int> pngSize(const std::string& png) {
    if (png.size() < 24 || png.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || png.compare(12, 4, "IHDR") != 0) return {0, 0};
    return {static_cast<int>(be32(png, 16)), static_cast<int>(be32(png, 20))};
}

#ifdef CH_HAVE_ZLIB
/// Decodes an 8-bit RGB or RGBA, non-interlaced PNG (what pngcairo writes) into RGB.
Image decodePng(const std::string& png) {
    Image img;
    auto [w, h] = pngSize(png);
    BOOST_REQUIRE_MESSAGE(w > 0 && h > 0, "not a PNG");
    const int depth = std::uint8_t(png[24]), type = std::uint8_t(png[25]), interlace = std::uint8_t(png[28]);
    BOOST_REQUIRE_MESSAGE(depth == 8 && (type == 2 || type == 6) && interlace == 0,
                          "unsupported PNG (depth " << depth << ", colour type " << type << ")");
    const int channels = type == 6 ? 4 : 3;
    std::string idat;
    for (std::size_t at = 8; at + 8 <= png.size();) {
        const std::uint32_t len = be32(png, at);
        const std::string kind = png.substr(at + 4, 4);
        if (kind == "IDAT") idat += png.substr(at + 8, len);
        at += 12 + len;
    }
    const std::size_t stride = static_cast<std::size_t>(w) * channels;
    std::vector<std::uint8_t> raw((stride + 1) * h);
    uLongf size = raw.size();
    BOOST_REQUIRE(uncompress(raw.data(), &size, reinterpret_cast<const Bytef*>(idat.data()), idat.size()) == Z_OK);
    BOOST_REQUIRE_EQUAL(size, raw.size());
    std::vector<std::uint8_t> cur(stride), prev(stride, 0);
    img.width = w;
    img.height = h;
    img.rgb.resize(static_cast<std::size_t>(w) * h * 3);
    for (int y = 0; y < h; ++y) {
        const std::uint8_t filter = raw[y * (stride + 1)];
        const std::uint8_t* line = &raw[y * (stride + 1) + 1];
        for (std::size_t i = 0; i < stride; ++i) {
            const int a = i >= std::size_t(channels) ? cur[i - channels] : 0, b = prev[i],
                      c = i >= std::size_t(channels) ? prev[i - channels] : 0;
            int p = 0;
            switch (filter) {
                case 0: p = 0; break;
                case 1: p = a; break;
                case 2: p = b; break;
                case 3: p = (a + b) / 2; break;
                case 4: {
                    const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
                    p = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
                    break;
                }
                default: BOOST_FAIL("bad PNG filter " << int(filter));
            }
            cur[i] = static_cast<std::uint8_t>(line[i] + p);
        }
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < 3; ++k) img.rgb[(std::size_t(y) * w + x) * 3 + k] = cur[std::size_t(x) * channels + k];
        std::swap(cur, prev);
    }
    return img;
}
#endif

/// The paper's colour map (the test's own copy): ρ → RGB 0..255.
std::array<int, 3> paperColour(double rho) {
    const double pi = 3.14159265358979323846;
    const double d = std::min(5 * pi / 4, 5 * pi * rho / 32);
    const double r = std::max(0.0, -std::cos(d)), g = std::max(0.0, std::sin(d));
    const double b = std::clamp(rho < 4 ? std::cos(d) : -std::sin(d), 0.0, 1.0);
    return {int(std::lround(r * 255)), int(std::lround(g * 255)), int(std::lround(b * 255))};
}

bool near(const std::array<int, 3>& a, const std::array<int, 3>& b, int tol) {
    for (int k = 0; k < 3; ++k)
        if (std::abs(a[k] - b[k]) > tol) return false;
    return true;
}

struct DrawnAgent {
    int frame;
    double time, x, y, radius, value;
    long rgb;
};

std::vector<DrawnAgent> readRenderData(const fs::path& file) {
    std::vector<DrawnAgent> v;
    for (const std::string& l : lines(readFile(file))) {
        if (l.empty() || l[0] == '#') continue;
        std::istringstream s(l);
        DrawnAgent a;
        long long id;
        s >> a.frame >> a.time >> id >> a.x >> a.y >> a.radius >> a.value >> a.rgb;
        if (s && id >= 0) v.push_back(a);
    }
    return v;
}

/// World → pixel with the mapping render.json records.
struct Mapping {
    double xmin, xmax, ymin, ymax, left, right, top, bottom;
    explicit Mapping(const std::string& json) {
        xmin = jsonValue(json, "xmin"); xmax = jsonValue(json, "xmax");
        ymin = jsonValue(json, "ymin"); ymax = jsonValue(json, "ymax");
        left = jsonValue(json, "left"); right = jsonValue(json, "right");
        top = jsonValue(json, "top"); bottom = jsonValue(json, "bottom");
    }
    int px(double x) const { return int(std::lround(left + (x - xmin) / (xmax - xmin) * (right - left))); }
    int py(double y) const { return int(std::lround(bottom - (y - ymin) / (ymax - ymin) * (bottom - top))); }
};

std::string baseCase() { return (fs::path(CH_SOURCE_DIR) / "Examples" / "doorway" / "base-case.xml").string(); }

/// A small doorway scenario (25 agents in the base case's room) that ends at 4 s.
std::string smallDoorway(const fs::path& dir) {
    const std::string room = (fs::path(CH_SOURCE_DIR) / "Examples" / "doorway" / "room-particles.xml").string();
    std::ofstream(dir / "small.xml") << R"(<?xml version="1.0"?>
<Simulation delta_time="0.1" delta_time_fine="0.02" end_time="4" seed="3">
  <World type="Infinite"/>
  <Obstacles file=")" << room << R"("/>
  <Policies>
    <Policy id="0" ContactForceScale="0">
      <Step DeltaTime="fine" OptimizationMethod="gradient" RelaxationTime="0.5">
        <CostFunction name="GoalReachingForce" range="0" strength="1"/>
        <CostFunction name="SPH" range="1" viscosity="3" walls="particles"/>
        <CostFunction name="ContactForces" range="1"/>
      </Step>
    </Policy>
  </Policies>
  <Agents>
    <AgentGrid x="15.5" y="7.5" columns="5" rows="5" spacing="0.7" rad_min="0.215" rad_max="0.265"
               remove_at_goal="true" goal_radius="0.5"><Policy id="0"/><goal x="22" y="10"/></AgentGrid>
  </Agents>
</Simulation>
)";
    return (dir / "small.xml").string();
}

}  // namespace

BOOST_AUTO_TEST_CASE(base_case_frame_shows_walls_and_density_colours) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"render", "-i", baseCase(), "-o", "frames", "--time", "30", "--size", "640x560", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const fs::path frame = dir / "frames" / "frame_0000.png";
    BOOST_REQUIRE(fs::exists(frame));
    const std::string png = readFile(frame);
    BOOST_TEST(pngSize(png).first == 640);
    BOOST_TEST(pngSize(png).second == 560);
    BOOST_TEST(!fs::exists(dir / "frames" / "animation.gif"));  // one frame: no animation

    const std::string json = readFile(dir / "frames" / "render.json");
    BOOST_TEST(jsonValue(json, "width") == 640);
    BOOST_TEST(jsonValue(json, "time") == 30);
    const std::vector<DrawnAgent> agents = readRenderData(dir / "frames" / "render-data.txt");
    BOOST_TEST_MESSAGE(agents.size() << " agents at t = 30 s");
    BOOST_REQUIRE(agents.size() > 100);  // the room is far from empty at 30 s
    double maxRho = 0;
    for (const DrawnAgent& a : agents) {
        BOOST_TEST(a.time == 30.0);
        maxRho = std::max(maxRho, a.value);
        // the colour written is the paper's map of the density
        const std::array<int, 3> c = paperColour(a.value);
        BOOST_TEST(a.rgb == (long(c[0]) << 16 | long(c[1]) << 8 | c[2]));
    }
    BOOST_TEST(maxRho > 4.0);  // a dense crowd at the door

#ifdef CH_HAVE_ZLIB
    const Image img = decodePng(png);
    const Mapping m(json);
    // walls: grey blocks (the left wall x ∈ [−1, 0], the bottom wall y ∈ [−1, 0])
    for (const auto& [x, y] : std::vector<std::pair<double, double>>{{-0.5, 10}, {10, -0.5}, {20.5, 15}}) {
        const auto c = img.at(m.px(x), m.py(y));
        BOOST_TEST_INFO("wall pixel at (" << x << ", " << y << ")");
        BOOST_TEST((c[0] == c[1] && c[1] == c[2] && c[0] > 100 && c[0] < 180));
    }
    // empty floor: white
    BOOST_TEST(near(img.at(m.px(3), m.py(10)), {255, 255, 255}, 2));
    // every agent's centre pixel has its density colour (a few may be hidden by a neighbour)
    std::size_t match = 0;
    for (const DrawnAgent& a : agents)
        if (near(img.at(m.px(a.x), m.py(a.y)), paperColour(a.value), 12)) ++match;
    BOOST_TEST_MESSAGE(match << " of " << agents.size() << " agent centres have their colour");
    BOOST_TEST(match >= agents.size() * 9 / 10);
#else
    BOOST_TEST_MESSAGE("zlib not found at build time: the PNG's pixels are not checked");
#endif
}

BOOST_AUTO_TEST_CASE(replay_draws_a_series_and_recomputes_density) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario = smallDoorway(dir);
    Result r = run(dir, {"-i", scenario, "-o", "run", "--trajectories", "txt", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    r = run(dir, {"render", "--replay", "run", "-o", "replay", "--every", "1", "--size", "400x300", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    for (const char* f : {"frame_0000.png", "frame_0001.png", "frame_0002.png", "frame_0003.png", "frame_0004.png"})
        BOOST_TEST(pngSize(readFile(dir / "replay" / f)).first == 400);
    BOOST_TEST(!fs::exists(dir / "replay" / "frame_0005.png"));
    BOOST_TEST(readFile(dir / "replay" / "animation.gif").substr(0, 6) == "GIF89a");

    // the same instant simulated live: same agents, same density (positions are rounded in the file)
    r = run(dir, {"render", "-i", scenario, "-o", "live", "--time", "2", "--size", "400x300", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    std::map<std::pair<double, double>, double> live;
    std::vector<DrawnAgent> replayed;
    for (const DrawnAgent& a : readRenderData(dir / "live" / "render-data.txt")) live[{a.x, a.y}] = a.value;
    for (const DrawnAgent& a : readRenderData(dir / "replay" / "render-data.txt"))
        if (a.frame == 2) replayed.push_back(a);
    BOOST_REQUIRE_EQUAL(replayed.size(), live.size());
    for (const DrawnAgent& a : replayed) {
        double best = 1e9, value = 0;
        for (const auto& [p, v] : live) {
            const double d = std::hypot(p.first - a.x, p.second - a.y);
            if (d < best) { best = d; value = v; }
        }
        BOOST_TEST(best < 1e-3);
        BOOST_TEST(std::abs(value - a.value) < 1e-2 * std::max(1.0, value));
    }

    // contact acceleration is not in trajectories: a clear refusal
    r = run(dir, {"render", "--replay", "run", "-o", "contact", "--time", "1", "--color", "contact"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("trajectories record positions only") != std::string::npos, r.err);
}

BOOST_AUTO_TEST_CASE(replay_of_trajectories_bin_with_an_interval_matches_the_text_replay) {
    // One run writes trajectories.bin and .txt every 0.5 s; a copy of the folder without the .bin
    // replays from the text. Times between two frames show the earlier frame (1.3 s → 1 s).
    const fs::path dir = freshDir(caseName());
    const std::string scenario = smallDoorway(dir);
    Result r =
        run(dir, {"-i", scenario, "-o", "run", "--trajectories", "txt,bin", "--trajectory-interval", "0.5", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    fs::create_directories(dir / "text");
    for (const char* f : {"summary.json", "trajectories.txt"}) fs::copy_file(dir / "run" / f, dir / "text" / f);
    for (const char* folder : {"run", "text"}) {
        r = run(dir, {"render", "--replay", folder, "-o", std::string(folder) + "-frames", "--every", "1.3", "--size",
                      "400x300", "-q"});
        BOOST_REQUIRE_MESSAGE(r.status == 0, folder << ": " << r.err);
    }
    const std::vector<DrawnAgent> fromBin = readRenderData(dir / "run-frames" / "render-data.txt");
    const std::vector<DrawnAgent> fromText = readRenderData(dir / "text-frames" / "render-data.txt");
    BOOST_REQUIRE(!fromBin.empty());
    BOOST_REQUIRE_EQUAL(fromBin.size(), fromText.size());
    std::set<double> times;
    for (std::size_t k = 0; k < fromBin.size(); ++k) {
        BOOST_TEST(fromBin[k].frame == fromText[k].frame);
        BOOST_TEST(fromBin[k].time == fromText[k].time);
        BOOST_TEST(std::abs(fromBin[k].x - fromText[k].x) < 1e-4);  // float32 against 4 decimals
        BOOST_TEST(std::abs(fromBin[k].y - fromText[k].y) < 1e-4);
        BOOST_TEST(std::abs(fromBin[k].value - fromText[k].value) < 1e-2 * std::max(1.0, fromText[k].value));
        times.insert(fromBin[k].time);
    }
    // --every 1.3 up to the 4 s recording: 0, 1.3, 2.6 and 3.9 s show the frames of 0, 1, 2.5, 3.5 s.
    BOOST_TEST(times == (std::set<double>{0, 1, 2.5, 3.5}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(replay_of_a_recorded_folder_uses_the_poly6_density) {
    // A run folder written by hand: two agents of mass 1 half a metre apart, far from the walls.
    // Replayed density = W(0) + W(0.5 m) with the 2D Poly6 kernel, h = 1 m: 4/π (1 + 0.75³).
    const fs::path dir = freshDir(caseName());
    const std::string room = (fs::path(CH_SOURCE_DIR) / "Examples" / "doorway" / "room-particles.xml").string();
    std::ofstream(dir / "pair.xml") << R"(<?xml version="1.0"?>
<Simulation delta_time="0.1" end_time="2">
  <World type="Infinite"/>
  <Obstacles file=")" << room << R"("/>
  <Policies><Policy id="0" OptimizationMethod="gradient"><CostFunction name="GoalReachingForce" range="0"/></Policy></Policies>
  <Agents>
    <Agent id="7" rad="0.24" mass="1"><pos x="10" y="10"/><goal x="22" y="10"/><Policy id="0"/></Agent>
    <Agent id="9" rad="0.3" mass="1"><pos x="10.5" y="10"/><goal x="22" y="10"/><Policy id="0"/></Agent>
  </Agents>
</Simulation>
)";
    fs::create_directories(dir / "run");
    std::ofstream(dir / "run" / "summary.json") << "{\n  \"scenario\": \"" << (dir / "pair.xml").string()
                                                << "\",\n  \"seed\": 1\n}\n";
    std::ofstream(dir / "run" / "trajectories.txt") << "# framerate: 10\n# x/m\n# y/m\n# z/m\n"
                                                       "7 0 10 10 0\n9 0 10.5 10 0\n"
                                                       "7 10 5 5 0\n9 10 5.5 5 0\n";
    const Result r = run(dir, {"render", "--replay", "run", "-o", "frames", "--time", "1", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::vector<DrawnAgent> agents = readRenderData(dir / "frames" / "render-data.txt");
    BOOST_REQUIRE_EQUAL(agents.size(), 2u);
    const double expected = 4 / 3.14159265358979323846 * (1 + 0.75 * 0.75 * 0.75);
    for (const DrawnAgent& a : agents) {
        BOOST_TEST(a.time == 1.0);
        BOOST_TEST(a.value == expected, boost::test_tools::tolerance(1e-5));
        BOOST_TEST(a.y == 5.0);
    }
    BOOST_TEST(agents[0].radius == 0.24);  // radii come from the scenario, by id
    BOOST_TEST(agents[1].radius == 0.3);
    // beyond the recording: a clear error
    const Result late = run(dir, {"render", "--replay", "run", "-o", "late", "--time", "5", "-q"});
    BOOST_TEST(late.status == 2);
    BOOST_TEST(late.err.find("recording ends") != std::string::npos, late.err);
}

BOOST_AUTO_TEST_CASE(health_colourings_come_from_the_crowdhealth_layer) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario = smallDoorway(dir);
    for (const char* c : {"panic", "injury", "contact"}) {
        const Result r = run(dir, {"render", "-i", scenario, "-o", c, "--time", "0.5", "--color", c, "-q"});
        BOOST_TEST(r.status == 0, c << ": " << r.err);
        BOOST_TEST(fs::exists(dir / c / "frame_0000.png"), c);
        BOOST_TEST(readFile(dir / c / "render.json").find(std::string("\"color\": \"") + c + "\"") != std::string::npos, c);
    }
}

BOOST_AUTO_TEST_CASE(usage_errors_and_missing_gnuplot) {
    const fs::path dir = freshDir(caseName());
    Result r = run(dir, {"render", "-i", baseCase(), "-o", "x"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("--time") != std::string::npos, r.err);
    r = run(dir, {"render", "-i", baseCase(), "-o", "x", "--time", "1", "--size", "12"});
    BOOST_TEST(r.status == 2);
    r = run(dir, {"render", "-i", baseCase(), "-o", "x", "--time", "1", "--color", "rainbow"});
    BOOST_TEST(r.status == 2);
    r = run(dir, {"render", "--replay", "nowhere", "-o", "x", "--time", "1"});
    BOOST_TEST(r.status == 2);
    BOOST_TEST(r.err.find("summary.json") != std::string::npos, r.err);

    ::setenv("CROWDHEALTH_GNUPLOT", "crowdhealth-test-no-such-gnuplot", 1);
    r = run(dir, {"render", "-i", baseCase(), "-o", "x", "--time", "1"});
    ::unsetenv("CROWDHEALTH_GNUPLOT");
    BOOST_TEST(r.status == 1);
    BOOST_TEST(r.err.find("gnuplot-nox") != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "x" / "frame_0000.png"));
}
