// crowdhealth plot — paths.png (see plot_paths.h).
#include "plot_paths.h"

#include "plot.h"
#include "plot_gnuplot.h"
#include "plot_paths_data.h"
#include "plot_venue.h"
#include "render_scene.h"
#include "trajectory_read.h"

#include <crowdhealth/io/output.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace chplot {

namespace {

std::string num(double v) { return ch::formatNumber(v, 10); }

bool hasTrajectories(const fs::path& dir) {
    std::error_code ec;
    if (fs::exists(dir / "trajectories.bin", ec) || fs::exists(dir / "trajectories.txt", ec)) return true;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("output_", 0) == 0 && entry.path().extension() == ".csv") return true;
    }
    return false;
}

}  // namespace

void drawPaths(const Experiment& e, std::vector<fs::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes) {
    const fs::path png = e.dir / "paths.png";
    const RunData* run = nullptr;
    for (const RunData& r : e.runs)
        if (hasTrajectories(r.dir)) {
            run = &r;
            break;
        }
    std::error_code ec;
    if (!run) {
        fs::remove(png, ec);  // a stale one would describe another run
        notes.push_back("no trajectories in " + e.dir.string() + (e.replications ? "/run_*" : "") +
                        ": no paths.png (write them with <Output trajectories=\"bin\"/> or --trajectories bin)");
        return;
    }

    double dt = 0.1;
    std::map<std::int64_t, std::vector<chcli::Sample>> byFrame;
    bool explicitFrames = false;
    std::string error;
    if (!chcli::readTrajectories(run->dir, dt, byFrame, explicitFrames, error)) {
        errors.push_back("paths.png: " + error);
        return;
    }
    std::map<long long, std::string> exitOf;
    if (fs::exists(run->dir / "evacuations.csv", ec)) {
        if (const std::string err = readEvacuationExits(run->dir / "evacuations.csv", exitOf); !err.empty()) {
            errors.push_back("paths.png: " + err);
            return;
        }
    }
    const std::vector<PathGroup> groups = pathsByExit(byFrame, exitOf);

    // The scenario: walls, targets, exits and measurement lines and areas.
    std::string scenarioNote;
    VenueOverlay venue = VenueOverlay::load(*run, scenarioNote);
    if (!venue.has()) notes.push_back("paths.png without walls and exits: " + scenarioNote);
    const std::optional<ch::ScenarioSpec>& spec = venue.spec();
    // An exit's colour: its place among the scenario's exits (else among the groups), so that an
    // exit keeps its colour from run to run.
    for (const PathGroup& g : groups) venue.addExitName(g.exit);
    bool anyExitName = false;
    for (const chrender::VenueMark& m : venue.marks()) anyExitName = anyExitName || m.exit;
    for (const PathGroup& g : groups) anyExitName = anyExitName || !g.exit.empty();
    auto colourOf = [&](const std::string& exit) { return venue.exitColour(exit); };

    // Extent: the scene (walls, targets, exits, measurement) and every path point.
    Extent extent;
    venue.grow(extent);
    for (const PathGroup& g : groups)
        for (const Polyline& p : g.paths)
            for (const auto& [x, y] : p) extent.grow(x, y);
    extent.pad(0.04);
    const double x0 = extent.x0, x1 = extent.x1, y0 = extent.y0, y1 = extent.y1;

    std::size_t agents = 0;
    for (const PathGroup& g : groups) agents += g.paths.size();
    std::string title = "Paths: " + e.name;
    if (spec) title += " (" + fs::path(spec->sourceFile).filename().string() + ")";
    if (e.runs.size() > 1) title += ", " + run->name;
    title += ", " + std::to_string(agents) + " agents";

    GnuplotJob job;
    job.cmd("set title " + gpString(title) + " noenhanced font ',15'");
    job.cmd("set size ratio -1");
    job.cmd("set xrange [" + num(x0) + ":" + num(x1) + "]");
    job.cmd("set yrange [" + num(y0) + ":" + num(y1) + "]");
    job.cmd("set xlabel 'x (m)'");
    job.cmd("set ylabel 'y (m)'");
    job.cmd("set tics out nomirror");
    job.cmd("set grid lc rgb '#e4e4e4'");
    job.cmd("set key outside right top box opaque samplen 2 spacing 1.2 font ',11' noenhanced");
    job.cmd("set style textbox opaque noborder margins 1,1");

    const VenueStyle style;  // exits in their colours, walls behind the paths
    venue.setObjects(job, 1, style, 0.035 * std::max(x1 - x0, y1 - y0));

    std::vector<std::string> elements;
    std::vector<Rows> blocks;
    // Paths first (thin), so that the walls and outlines are drawn over them.
    for (const PathGroup& g : groups) {
        Rows rows;
        for (const Polyline& p : g.paths) {
            for (const auto& [x, y] : p) rows.push_back({x, y});
            rows.push_back({std::nan(""), std::nan("")});  // a gap between agents
        }
        const std::string who = std::to_string(g.paths.size()) + (g.paths.size() == 1 ? " person" : " people");
        const std::string name = g.exit.empty() ? (exitOf.empty() && !anyExitName ? "paths (" + who + ")"
                                                                                       : "did not leave by an exit (" + who + ")")
                                                : "left by " + g.exit + " (" + who + ")";
        const std::string colour = g.exit.empty() ? kNoExitColour : colourOf(g.exit);
        elements.push_back("'-' using 1:2 with lines lw 0.7 lc rgb '" + colour + "' title " + gpString(name));
        blocks.push_back(std::move(rows));
    }
    venue.addElements(elements, blocks, style);
    if (blocks.empty()) {
        job.cmd("set label 9 'no agent recorded' at graph 0.5, graph 0.5 center");
        job.cmd("plot -1e30 notitle");
    } else {
        std::string plot = "plot ";
        for (std::size_t i = 0; i < elements.size(); ++i) plot += (i ? ", " : "") + elements[i];
        job.cmd(plot);
        for (Rows& r : blocks) job.data(std::move(r));
    }
    // Size: the venue's aspect ratio, within 900–2000 px wide, plus room for the key.
    const double aspect = (y1 - y0) / std::max(1e-9, x1 - x0);
    const int plotWidth = 1200;
    const int height = std::clamp(static_cast<int>(std::lround(plotWidth * aspect)) + 160, 600, 1800);
    const std::string err = drawPng(job, pngTerminal(plotWidth + 420, height), png);
    if (err.empty()) written.push_back(png);
    else errors.push_back(err);
}

}  // namespace chplot
