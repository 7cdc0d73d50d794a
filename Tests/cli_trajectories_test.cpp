// Trajectory outputs that keep up with large runs (issue 6): the compact trajectories.bin, its
// layout byte by byte (docs/user-guide.md, "trajectories.bin"), the trajectory interval
// (<Output trajectory_interval>, --trajectory-interval), its errors, and Ctrl-C leaving whole
// frames only.
#define BOOST_TEST_MODULE cli_trajectories
#include <boost/test/unit_test.hpp>

#include "cli_support.h"

#include <crowdhealth/io/output.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>

using namespace clitest;

namespace {

constexpr double kDt = 0.1;  // delta_time of evacuation.xml and the UMANS examples (s)

/// A little-endian number at `at`, decoded here without the library's reader.
template <class T>
T le(const std::string& bytes, std::size_t at) {
    BOOST_REQUIRE_MESSAGE(at + sizeof(T) <= bytes.size(), "read past the end of the file at byte " << at);
    std::uint64_t bits = 0;
    for (std::size_t k = 0; k < sizeof(T); ++k)
        bits |= static_cast<std::uint64_t>(static_cast<unsigned char>(bytes[at + k])) << (8 * k);
    if constexpr (sizeof(T) == 4) return std::bit_cast<T>(static_cast<std::uint32_t>(bits));
    else if constexpr (sizeof(T) == 2) return std::bit_cast<T>(static_cast<std::uint16_t>(bits));
    else return std::bit_cast<T>(bits);
}

struct BinRecord { std::uint32_t id; float x, y, vx, vy; };
struct BinFrame { double time; std::uint32_t step; std::vector<BinRecord> records; };
struct BinFile {
    std::uint16_t version = 0;
    std::uint32_t flags = 0, recordSize = 0;
    double deltaTime = 0, interval = 0;
    std::vector<BinFrame> frames;
};

/// Decodes trajectories.bin by its documented layout, requiring it to end exactly after a frame.
BinFile decodeBin(const fs::path& file) {
    const std::string b = readFile(file);
    BOOST_REQUIRE_MESSAGE(b.size() >= 32, file << " is shorter than its header");
    BOOST_REQUIRE(b.compare(0, 6, "CHTRJ1") == 0);
    BinFile f;
    f.version = le<std::uint16_t>(b, 6);
    f.flags = le<std::uint32_t>(b, 8);
    f.recordSize = le<std::uint32_t>(b, 12);
    f.deltaTime = le<double>(b, 16);
    f.interval = le<double>(b, 24);
    BOOST_REQUIRE(f.recordSize == ((f.flags & 1) ? 20u : 12u));
    std::size_t at = 32;
    while (at < b.size()) {
        BinFrame fr;
        fr.time = le<double>(b, at);
        fr.step = le<std::uint32_t>(b, at + 8);
        const std::uint32_t n = le<std::uint32_t>(b, at + 12);
        at += 16;
        BOOST_REQUIRE_MESSAGE(b.size() - at >= std::size_t{n} * f.recordSize,
                              file << ": the frame of step " << fr.step << " is cut short");
        for (std::uint32_t k = 0; k < n; ++k, at += f.recordSize) {
            BinRecord r{le<std::uint32_t>(b, at), le<float>(b, at + 4), le<float>(b, at + 8), 0, 0};
            if (f.flags & 1) {
                r.vx = le<float>(b, at + 12);
                r.vy = le<float>(b, at + 16);
            }
            fr.records.push_back(r);
        }
        f.frames.push_back(std::move(fr));
    }
    BOOST_TEST(at == b.size());  // whole frames, nothing after the last
    return f;
}

/// trajectories.txt as frame → id → (x, y).
std::map<long, std::map<long, std::pair<double, double>>> readPedPy(const fs::path& file) {
    std::map<long, std::map<long, std::pair<double, double>>> byFrame;
    for (const std::string& l : lines(readFile(file))) {
        if (l.empty() || l[0] == '#') continue;
        std::istringstream in(l);
        long id = -1, frame = -1;
        double x, y, z;
        BOOST_REQUIRE_MESSAGE(static_cast<bool>(in >> id >> frame >> x >> y >> z), "row: " << l);
        byFrame[frame][id] = {x, y};
    }
    return byFrame;
}

/// A copy of Tests/data/cli/evacuation.xml in `dir` whose <Output> element is `output`.
std::string evacuationWithOutput(const fs::path& dir, const std::string& output) {
    std::string xml = readFile(testData("evacuation.xml"));
    const std::string old = "<Output metrics_interval=\"0.5\" />";
    const auto at = xml.find(old);
    BOOST_REQUIRE_MESSAGE(at != std::string::npos, "evacuation.xml no longer has " << old);
    xml.replace(at, old.size(), output);
    const fs::path file = dir / "scenario.xml";
    std::ofstream(file) << xml;
    return file.string();
}

/// The line of `text` in `file` (1-based; 0 if absent).
int lineOf(const std::string& file, const std::string& text) {
    const auto all = lines(readFile(file));
    for (std::size_t i = 0; i < all.size(); ++i)
        if (all[i].find(text) != std::string::npos) return static_cast<int>(i) + 1;
    return 0;
}

}  // namespace

BOOST_AUTO_TEST_CASE(bin_holds_the_txt_positions_in_float32_and_reads_back_with_the_library) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--trajectories", "txt,bin", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(tmpFiles(dir).empty());
    BOOST_TEST(!fs::exists(dir / "out" / "output_0.csv"));  // txt,bin only

    const BinFile bin = decodeBin(dir / "out" / "trajectories.bin");
    BOOST_TEST(bin.version == 1u);
    BOOST_TEST(bin.flags == 0u);
    BOOST_TEST(bin.deltaTime == kDt);
    BOOST_TEST(bin.interval == kDt);  // no interval given: every coarse step

    const auto txt = readPedPy(dir / "out" / "trajectories.txt");
    const std::string summary = readFile(dir / "out" / "summary.json");
    const auto steps = static_cast<std::uint32_t>(jsonValue(summary, "coarse_steps"));
    BOOST_REQUIRE(bin.frames.size() == steps + 1u);  // frame 0 … the last step
    std::size_t compared = 0;
    for (std::size_t k = 0; k < bin.frames.size(); ++k) {
        const BinFrame& f = bin.frames[k];
        BOOST_TEST(f.step == k);
        BOOST_TEST(std::abs(f.time - k * kDt) < 1e-9, "frame " << k);
        // The same agents as the text file's frame (which has no line for an empty frame).
        const auto it = txt.find(static_cast<long>(f.step));
        BOOST_TEST(f.records.size() == (it == txt.end() ? 0u : it->second.size()), "frame " << k);
        std::uint32_t previousId = 0;
        for (std::size_t i = 0; i < f.records.size(); ++i) {
            const BinRecord& rec = f.records[i];
            if (i > 0) BOOST_TEST(rec.id > previousId);  // by increasing id
            previousId = rec.id;
            BOOST_REQUIRE(it != txt.end());
            const auto p = it->second.find(rec.id);
            BOOST_REQUIRE_MESSAGE(p != it->second.end(), "agent " << rec.id << " frame " << k << " not in the txt");
            // txt: 4 decimals (±5e-5 m); float32: a relative 6e-8 of positions of at most 10 m.
            BOOST_TEST(std::abs(rec.x - p->second.first) < 6e-5, "agent " << rec.id << " frame " << k);
            BOOST_TEST(std::abs(rec.y - p->second.second) < 6e-5, "agent " << rec.id << " frame " << k);
            ++compared;
        }
    }
    BOOST_TEST(compared > 200u);
    // The last frame is empty: everyone has been evacuated (an empty frame is still a frame).
    BOOST_TEST(bin.frames.back().records.empty());

    // The library's reader sees the same file.
    const ch::BinaryTrajectories lib = ch::readBinaryTrajectories(dir / "out" / "trajectories.bin");
    BOOST_REQUIRE(lib.frames.size() == bin.frames.size());
    for (std::size_t k = 0; k < bin.frames.size(); ++k) {
        BOOST_REQUIRE(lib.frames[k].id.size() == bin.frames[k].records.size());
        for (std::size_t i = 0; i < lib.frames[k].id.size(); ++i) {
            BOOST_TEST(lib.frames[k].id[i] == bin.frames[k].records[i].id);
            BOOST_TEST(lib.frames[k].x[i] == bin.frames[k].records[i].x);
            BOOST_TEST(lib.frames[k].y[i] == bin.frames[k].records[i].y);
        }
    }
}

BOOST_AUTO_TEST_CASE(bin_with_velocities_carries_vx_vy) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario =
        evacuationWithOutput(dir, R"(<Output trajectories="bin" trajectory_velocities="true"/>)");
    const Result r = run(dir, {"-i", scenario, "-o", "out", "--end-time", "1", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(!fs::exists(dir / "out" / "trajectories.txt"));
    const BinFile bin = decodeBin(dir / "out" / "trajectories.bin");
    BOOST_TEST(bin.flags == 1u);
    BOOST_TEST(bin.recordSize == 20u);
    BOOST_REQUIRE(bin.frames.size() == 11u);
    // Agent 0 walks towards +x at up to max_speed = 1.6 m/s: its velocity says so, and agrees with
    // its displacement over one step.
    const auto agent0 = [](const BinFrame& f) {
        for (const BinRecord& r : f.records)
            if (r.id == 0) return r;
        BOOST_FAIL("agent 0 missing");
        return BinRecord{};
    };
    const BinRecord a = agent0(bin.frames[9]), b = agent0(bin.frames[10]);
    BOOST_TEST(b.vx > 0.3f);
    BOOST_TEST(std::hypot(b.vx, b.vy) < 1.6f + 1e-3f);
    BOOST_TEST(std::abs((b.x - a.x) / kDt - b.vx) < 1e-3);  // positions integrate velocities
}

BOOST_AUTO_TEST_CASE(trajectory_interval_half_a_second_records_every_fifth_step_in_every_format) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario =
        evacuationWithOutput(dir, R"(<Output trajectories="umans,txt,bin" trajectory_interval="0.5"/>)");
    const Result r = run(dir, {"-i", scenario, "-o", "out", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    BOOST_TEST(r.err.find("Output@trajectory_interval") == std::string::npos, r.err);  // 0.5 = 5 × 0.1: no warning
    const std::string summary = readFile(dir / "out" / "summary.json");
    const auto last = static_cast<std::uint32_t>(jsonValue(summary, "coarse_steps"));
    BOOST_REQUIRE(last % 5 != 0);  // so the final frame is an extra one

    // Frames 0, 5, 10, … and the final state.
    std::vector<std::uint32_t> expected;
    for (std::uint32_t s = 0; s <= last; s += 5) expected.push_back(s);
    expected.push_back(last);

    const BinFile bin = decodeBin(dir / "out" / "trajectories.bin");
    BOOST_TEST(bin.interval == 0.5);
    std::vector<std::uint32_t> binSteps;
    for (const BinFrame& f : bin.frames) {
        binSteps.push_back(f.step);
        BOOST_TEST(std::abs(f.time - f.step * kDt) < 1e-9);
    }
    BOOST_TEST(binSteps == expected, boost::test_tools::per_element());

    std::set<std::uint32_t> txtSteps;
    for (const auto& [frame, agents] : readPedPy(dir / "out" / "trajectories.txt")) txtSteps.insert(frame);
    // The text has no line for the final, empty frame (all evacuated).
    std::set<std::uint32_t> nonEmpty;
    for (const BinFrame& f : bin.frames)
        if (!f.records.empty()) nonEmpty.insert(f.step);
    BOOST_TEST(txtSteps == nonEmpty, boost::test_tools::per_element());
    BOOST_TEST(readFile(dir / "out" / "trajectories.txt").rfind("# framerate: 10\n", 0) == 0u);  // frame = step

    // UMANS: agent 0's rows every 0.5 s (no t = 0 row), ending with its last frame in the world.
    const auto rows = lines(readFile(dir / "out" / "output_0.csv"));
    BOOST_REQUIRE(rows.size() >= 3u);
    for (std::size_t k = 0; k < rows.size(); ++k) {
        const double t = std::stod(split(rows[k], ',')[0]);
        BOOST_TEST(std::abs(t - 0.5 * static_cast<double>(k + 1)) < 1e-6, "row " << k);
    }

    // --trajectory-interval overrides the scenario's.
    const Result o = run(dir, {"-i", scenario, "-o", "cli", "--trajectory-interval", "1", "--end-time", "2", "-q"});
    BOOST_REQUIRE_MESSAGE(o.status == 0, o.err);
    std::vector<std::uint32_t> cliSteps;
    for (const BinFrame& f : decodeBin(dir / "cli" / "trajectories.bin").frames) cliSteps.push_back(f.step);
    BOOST_TEST(cliSteps == (std::vector<std::uint32_t>{0, 10, 20}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(interval_off_the_coarse_steps_is_a_warning_and_takes_the_next_step) {
    const fs::path dir = freshDir(caseName());
    const std::string scenario =
        evacuationWithOutput(dir, R"(<Output trajectories="bin" trajectory_interval="0.25"/>)");
    const Result r = run(dir, {"-i", scenario, "-o", "out", "--end-time", "1", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::string warning = scenario + ":" + std::to_string(lineOf(scenario, "<Output")) +
                                ": warning: Output@trajectory_interval (0.25 s) is not a whole multiple of delta_time";
    BOOST_TEST(r.err.find(warning) != std::string::npos, r.err);
    std::vector<std::uint32_t> steps;
    for (const BinFrame& f : decodeBin(dir / "out" / "trajectories.bin").frames) steps.push_back(f.step);
    // 0, then the first step at or after 0.25, 0.5, 0.75 and 1 s.
    BOOST_TEST(steps == (std::vector<std::uint32_t>{0, 3, 5, 8, 10}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(bad_trajectory_interval_is_a_located_error_and_nothing_is_written) {
    const fs::path dir = freshDir(caseName());
    for (const std::string value : {"0", "-0.5", "abc", "inf"}) {
        const std::string scenario = evacuationWithOutput(
            dir, "<Output trajectories=\"bin\"\n        trajectory_interval=\"" + value + "\"/>");
        const Result r = run(dir, {"-i", scenario, "-o", "out"});
        BOOST_TEST(r.status == 2, value << ": " << r.err);
        // The attribute's own line (the second line of the element).
        const std::string where = scenario + ":" + std::to_string(lineOf(scenario, "trajectory_interval=")) +
                                  ": error: Output@trajectory_interval: ";
        BOOST_TEST(r.err.find(where) != std::string::npos, value << ": " << r.err);
        BOOST_TEST(r.err.find("nothing was simulated or written") != std::string::npos, r.err);
        BOOST_TEST(!fs::exists(dir / "out"), value);
    }
    // An unknown format in the list.
    const std::string scenario = evacuationWithOutput(dir, R"(<Output trajectories="txt,binary"/>)");
    const Result r = run(dir, {"-i", scenario, "-o", "out"});
    BOOST_TEST(r.status == 2, r.err);
    const std::string message = scenario + ":" + std::to_string(lineOf(scenario, "<Output")) +
                                ": error: Output@trajectories: 'txt,binary' is not one of";
    BOOST_TEST(r.err.find(message) != std::string::npos, r.err);
    BOOST_TEST(!fs::exists(dir / "out"));

    // The command line: usage errors, exit 2, nothing written either.
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"--trajectory-interval", "0"}, {"--trajectory-interval", "x"},
          {"--trajectory-interval", "nan"}, {"--trajectories", "none,bin"}, {"--trajectories", "bin,"}}) {
        std::vector<std::string> all = {"-i", testData("evacuation.xml"), "-o", "out"};
        all.insert(all.end(), args.begin(), args.end());
        const Result c = run(dir, all);
        BOOST_TEST(c.status == 2, args[0] << " " << args[1] << ": " << c.err);
        std::string message = "crowdhealth: error: ";  // built with += (GCC 12 -Wrestrict on "literal" + string)
        message += args[0];
        message += " must be";
        BOOST_TEST(c.err.find(message) != std::string::npos, c.err);
        BOOST_TEST(!fs::exists(dir / "out"));
    }
}

BOOST_AUTO_TEST_CASE(interrupted_run_leaves_a_bin_file_of_whole_frames) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", umansExample("Circle50-SocialForces.xml"), "-o", "out", "--trajectories", "bin",
                               "--trajectory-interval", "1", "--debug-interrupt-after", "35", "-t", "2"});
    BOOST_TEST(r.status == 130, r.err);
    BOOST_TEST(tmpFiles(dir).empty());
    const BinFile bin = decodeBin(dir / "out" / "trajectories.bin");  // requires whole frames to the end
    std::vector<std::uint32_t> steps;
    for (const BinFrame& f : bin.frames) {
        steps.push_back(f.step);
        BOOST_TEST(f.records.size() == 50u);  // nobody leaves Circle50 in 3.5 s
    }
    // Every second, then the interrupted step (3.5 s).
    BOOST_TEST(steps == (std::vector<std::uint32_t>{0, 10, 20, 30, 35}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(library_reader_rejects_a_cut_file_and_a_foreign_one) {
    const fs::path dir = freshDir(caseName());
    const Result r = run(dir, {"-i", testData("evacuation.xml"), "-o", "out", "--trajectories", "bin",
                               "--end-time", "1", "-q"});
    BOOST_REQUIRE_MESSAGE(r.status == 0, r.err);
    const std::string whole = readFile(dir / "out" / "trajectories.bin");
    std::ofstream(dir / "cut.bin", std::ios::binary) << whole.substr(0, whole.size() - 5);
    BOOST_CHECK_EXCEPTION(ch::readBinaryTrajectories(dir / "cut.bin"), ch::OutputError, [](const ch::OutputError& e) {
        return std::string(e.what()).find("ends inside the frame of step 10") != std::string::npos;
    });
    std::ofstream(dir / "foreign.bin", std::ios::binary) << "# framerate: 10\n# x/m\n# y/m\n# z/m\n0 0 1 2 0\n";
    BOOST_CHECK_THROW(ch::readBinaryTrajectories(dir / "foreign.bin"), ch::OutputError);
}
