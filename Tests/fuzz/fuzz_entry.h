// CrowdHealth fuzzing — what each libFuzzer target does with its input, shared by the targets
// (fuzz_*.cpp, built with clang by scripts/fuzz.sh) and by fuzz_regressions_test (every input
// that once crashed, replayed in the normal suite). docs/development.md explains both.
//
// An input is one or more files separated by a line "--FILE--":
//   loader:  main.xml, then inc1.xml, inc2.xml, inc3.xml (the main file names them with file="…";
//            each is also written as incK.dxf and incK.wkt for the venue geometry readers)
//   readers: trajectories.bin, trajectories.txt, output_7.csv (UMANS), then a run folder's
//            metrics.csv, summary.json, health.csv, heatmap.csv
// The files are written to a scratch folder and read through the program's own readers; any
// outcome but a crash, a sanitizer report, a hang or an unbounded allocation is fine.
#pragma once

#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/xml.h"

#include "plot_data.h"
#include "trajectory_read.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace ch::fuzz {

namespace fs = std::filesystem;

inline constexpr std::string_view kSeparator = "\n--FILE--\n";

/// Splits the input into at most `parts` files (the last takes the rest).
inline std::vector<std::string> splitFiles(const std::uint8_t* data, std::size_t size, std::size_t parts) {
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    std::vector<std::string> out;
    std::size_t from = 0;
    while (out.size() + 1 < parts) {
        const std::size_t at = all.find(kSeparator, from);
        if (at == std::string_view::npos) break;
        out.emplace_back(all.substr(from, at - from));
        from = at + kSeparator.size();
    }
    out.emplace_back(all.substr(from));
    return out;
}

/// A scratch folder of this process, emptied before each input.
inline fs::path scratch(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("ch-fuzz-" + std::to_string(::getpid())) / name;
    std::error_code ec;
    fs::remove_all(dir, ec);
    fs::create_directories(dir);
    return dir;
}

inline void writeFile(const fs::path& file, const std::string& bytes) {
    std::ofstream out(file, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// The scenario loader and the --check path (load, then build the simulation) on fuzzed files.
inline void loaderInput(const std::uint8_t* data, std::size_t size) {
    const fs::path dir = scratch("loader");
    const std::vector<std::string> files = splitFiles(data, size, 4);
    writeFile(dir / "main.xml", files[0]);
    // Each named file under three names, so file="incK.dxf" and "incK.wkt" reach the venue
    // geometry readers (docs/geometry.md) as "incK.xml" reaches the XML one.
    for (std::size_t k = 1; k < files.size(); ++k)
        for (const char* ext : {".xml", ".dxf", ".wkt"}) writeFile(dir / ("inc" + std::to_string(k) + ext), files[k]);
    Diagnostics diags;
    const std::optional<ScenarioSpec> spec = loadScenario((dir / "main.xml").string(), diags);
    std::ostringstream sink;
    diags.print(sink);
    // --check builds the simulation too. Large crowds are valid but slow the fuzzer down.
    if (spec && spec->agents.size() <= 2000) {
        Simulation sim(*spec);
        (void)sim.deltaTime();
    }
}

/// The readers of files users hand back to the program: render --replay's trajectories (binary,
/// PedPy text, UMANS csv) and the run folder that plot and compare read.
inline void readersInput(const std::uint8_t* data, std::size_t size) {
    const std::vector<std::string> files = splitFiles(data, size, 7);
    const auto part = [&](std::size_t k) { return k < files.size() ? files[k] : std::string(); };
    const char* names[3] = {"trajectories.bin", "trajectories.txt", "output_7.csv"};
    for (std::size_t k = 0; k < 3; ++k) {
        const fs::path dir = scratch(std::string("traj") + std::to_string(k));
        writeFile(dir / names[k], part(k));
        double dt = 0.1;
        bool explicitFrames = false;
        std::string error;
        std::map<std::int64_t, std::vector<chcli::Sample>> byFrame;
        (void)chcli::readTrajectories(dir, dt, byFrame, explicitFrames, error);
    }
    const fs::path run = scratch("run");
    const char* runFiles[4] = {"metrics.csv", "summary.json", "health.csv", "heatmap.csv"};
    for (std::size_t k = 0; k < 4; ++k) writeFile(run / runFiles[k], part(3 + k));
    chplot::Experiment e;
    (void)chplot::loadExperiment(run, e);
}

}  // namespace ch::fuzz
