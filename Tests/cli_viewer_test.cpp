// crowdhealth-viewer: starts under Xvfb, runs a few frames of the doorway base case, saves a
// screenshot that shows walls and coloured agents, and exits. Skipped (with the reason) when the
// viewer was not built or xvfb-run is not installed.
#define BOOST_TEST_MODULE cli_viewer
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <cstdlib>
#include <set>

using namespace clitest;
namespace utf = boost::unit_test;

namespace {

boost::test_tools::assertion_result viewerAvailable(utf::test_unit_id) {
#ifndef CH_VIEWER
    boost::test_tools::assertion_result r(false);
    r.message() << "crowdhealth-viewer was not built (CROWDHEALTH_BUILD_VIEWER=OFF, or GLFW/OpenGL/zlib missing): skipped";
    return r;
#else
    if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0) {
        boost::test_tools::assertion_result r(false);
        r.message() << "xvfb-run is not installed (Debian package xvfb): the viewer test is skipped";
        return r;
    }
    return true;
#endif
}

#ifdef CH_VIEWER
/// Runs the viewer under xvfb-run in `dir`. Under the sanitizers (scripts/test.sh --sanitize)
/// the viewer is checked for memory errors but not for leaks: Mesa's GL driver, which GLFW loads
/// and unloads, leaves 112 bytes that LeakSanitizer can only attribute to an "<unknown module>"
/// (so no suppression can name it). Outside the sanitizers ASAN_OPTIONS is ignored.
Result runViewer(const fs::path& dir, const std::vector<std::string>& args) {
    return runIn(dir, "ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" xvfb-run -a -s '-screen 0 1280x1024x24'",
                 CH_VIEWER, args);
}
#endif

std::string baseCase() { return (fs::path(CH_SOURCE_DIR) / "Examples" / "doorway" / "base-case.xml").string(); }

}  // namespace

BOOST_AUTO_TEST_CASE(screenshot_under_xvfb_is_not_blank, *utf::precondition(viewerAvailable)) {
#ifdef CH_VIEWER
    const fs::path dir = freshDir(caseName());
    Result r = runViewer(dir, {baseCase(), "--screenshot", "shot.ppm", "--frames", "3", "--size", "480x360"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, "viewer failed: " << r.err);
    BOOST_TEST(r.out.find("Saved shot.ppm") != std::string::npos, r.out);
    const std::string ppm = readFile(dir / "shot.ppm");
    std::istringstream in(ppm);
    std::string magic;
    int w = 0, h = 0, maxv = 0;
    in >> magic >> w >> h >> maxv;
    in.get();
    BOOST_REQUIRE(magic == "P6");
    BOOST_TEST(w == 480);
    BOOST_TEST(h == 360);
    BOOST_REQUIRE(maxv == 255);
    const std::size_t start = static_cast<std::size_t>(in.tellg());
    BOOST_REQUIRE_EQUAL(ppm.size() - start, std::size_t(w) * h * 3);
    std::size_t white = 0, grey = 0, coloured = 0;
    std::set<int> colours;
    for (std::size_t k = start; k + 2 < ppm.size(); k += 3) {
        const int r0 = std::uint8_t(ppm[k]), g = std::uint8_t(ppm[k + 1]), b = std::uint8_t(ppm[k + 2]);
        colours.insert(r0 << 16 | g << 8 | b);
        if (r0 > 245 && g > 245 && b > 245) ++white;
        else if (r0 == g && g == b && r0 > 120 && r0 < 160) ++grey;  // walls (0.55 grey)
        else if (std::max({r0, g, b}) - std::min({r0, g, b}) > 80) ++coloured;  // agents, colour bar
    }
    BOOST_TEST_MESSAGE(white << " white, " << grey << " wall, " << coloured << " coloured pixels, " << colours.size()
                             << " colours");
    BOOST_TEST(white > std::size_t(w) * h / 4);   // the floor
    BOOST_TEST(grey > std::size_t(w) * h / 50);   // the room's walls
    BOOST_TEST(coloured > std::size_t(w) * h / 50);  // 400 agents in density colours
    BOOST_TEST(colours.size() > 20u);

    // PNG screenshots too
    r = runViewer(dir, {baseCase(), "--screenshot", "shot.png", "--frames", "1", "--size", "320x240", "--color", "contact"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, "viewer failed: " << r.err);
    const std::string png = readFile(dir / "shot.png");
    BOOST_TEST(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
#endif
}

BOOST_AUTO_TEST_CASE(bad_arguments_exit_with_status_2, *utf::precondition(viewerAvailable)) {
#ifdef CH_VIEWER
    const fs::path dir = freshDir(caseName());
    // these fail before any window is opened
    Result r = runViewer(dir, {});
    BOOST_TEST(r.status == 2);
    r = runViewer(dir, {baseCase(), "--color", "rainbow"});
    BOOST_TEST(r.status == 2);
    r = runViewer(dir, {"no-such-file.xml"});
    BOOST_TEST(r.status == 2);
#endif
}
