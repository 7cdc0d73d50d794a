// crowdhealth plot — paths.png (see plot_paths.h).
#include "plot_paths.h"

#include "plot.h"
#include "plot_gnuplot.h"
#include "plot_paths_data.h"
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

constexpr const char* kNoExitColour = "#a0a0a0";
constexpr const char* kWallColour = "#303030";
constexpr const char* kTargetColour = "#000000";

bool hasTrajectories(const fs::path& dir) {
    std::error_code ec;
    if (fs::exists(dir / "trajectories.bin", ec) || fs::exists(dir / "trajectories.txt", ec)) return true;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("output_", 0) == 0 && entry.path().extension() == ".csv") return true;
    }
    return false;
}

/// "30 s" with at most 3 significant decimals.
std::string seconds(double t) { return ch::formatNumber(t, 4) + " s"; }

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

    // The scenario: walls, targets and exits. Its diagnostics (warnings) are not repeated here.
    std::ostringstream diagnostics;
    std::string scenarioError;
    const std::optional<ch::ScenarioSpec> spec = chrender::loadRunScenario(run->dir, scenarioError, diagnostics);
    if (!spec) notes.push_back("paths.png without walls and exits: " + scenarioError);
    const std::vector<chrender::VenueMark> marks = spec ? chrender::venueMarks(*spec) : std::vector<chrender::VenueMark>{};

    // An exit's colour: its place among the scenario's exits (else among the groups), so that an
    // exit keeps its colour from run to run.
    std::vector<std::string> exitNames;
    for (const chrender::VenueMark& m : marks)
        if (m.exit) exitNames.push_back(m.name);
    for (const PathGroup& g : groups)
        if (!g.exit.empty() && std::find(exitNames.begin(), exitNames.end(), g.exit) == exitNames.end())
            exitNames.push_back(g.exit);
    auto colourOf = [&](const std::string& exit) -> std::string {
        const auto it = std::find(exitNames.begin(), exitNames.end(), exit);
        return it == exitNames.end() ? kNoExitColour : seriesColour(static_cast<std::size_t>(it - exitNames.begin()));
    };

    // Extent: the scene (walls, starts, goals, a planar world) and every path point.
    double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
    auto grow = [&](double x, double y) {
        if (!std::isfinite(x) || !std::isfinite(y)) return;
        x0 = std::min(x0, x);
        x1 = std::max(x1, x);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
    };
    if (spec) {
        for (const ch::ObstacleSpec& o : spec->obstacles)
            for (const ch::Vec2& p : o.points) grow(p.x(), p.y());
        for (const chrender::VenueMark& m : marks) {
            for (const ch::Vec2& p : m.outline) grow(p.x(), p.y());
            if (m.point) {
                grow(m.centre.x() - m.radius, m.centre.y() - m.radius);
                grow(m.centre.x() + m.radius, m.centre.y() + m.radius);
            }
        }
    }
    for (const PathGroup& g : groups)
        for (const Polyline& p : g.paths)
            for (const auto& [x, y] : p) grow(x, y);
    if (!std::isfinite(x0)) x0 = y0 = -1, x1 = y1 = 1;
    const double pad = 0.04 * std::max({x1 - x0, y1 - y0, 1.0});
    x0 -= pad, x1 += pad, y0 -= pad, y1 += pad;

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

    int object = 1;
    if (spec) {
        // Walls: obstacles of three or more points filled grey (pillars, boxes), every one outlined.
        for (const ch::ObstacleSpec& o : spec->obstacles) {
            if (o.points.size() < 3) continue;
            std::string cmd = "set object " + std::to_string(object++) + " polygon from ";
            for (std::size_t i = 0; i <= o.points.size(); ++i) {
                const ch::Vec2& p = o.points[i % o.points.size()];
                cmd += (i ? " to " : "") + num(p.x()) + "," + num(p.y());
            }
            cmd += " fillcolor rgb '#b4b4b4' fillstyle solid 1.0 noborder behind";
            job.cmd(cmd);
        }
        // Targets and exits: labels (an exit that closes says when) and point targets' circles.
        for (const chrender::VenueMark& m : marks) {
            std::string label = m.name;
            for (const auto& [t, opens] : m.events) label += std::string(opens ? ", opens " : ", closes ") + seconds(t);
            const std::string colour = m.exit ? colourOf(m.name) : kTargetColour;
            job.cmd("set label " + std::to_string(object++) + " " + gpString(label) + " at " + num(m.centre.x()) + "," +
                    num(m.centre.y()) + " center front boxed noenhanced font ',11' textcolor rgb '" + colour + "'");
            if (m.point)
                job.cmd("set object " + std::to_string(object++) + " circle at " + num(m.centre.x()) + "," +
                        num(m.centre.y()) + " size " + num(std::max(m.radius, 0.15)) +
                        " fillstyle empty border lc rgb '" + colour + "' lw 2 front");
        }
    }

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
        const std::string name = g.exit.empty() ? (exitOf.empty() && exitNames.empty() ? "paths (" + who + ")"
                                                                                       : "did not leave by an exit (" + who + ")")
                                                : "left by " + g.exit + " (" + who + ")";
        const std::string colour = g.exit.empty() ? kNoExitColour : colourOf(g.exit);
        elements.push_back("'-' using 1:2 with lines lw 0.7 lc rgb '" + colour + "' title " + gpString(name));
        blocks.push_back(std::move(rows));
    }
    if (spec) {
        Rows walls;
        for (const ch::ObstacleSpec& o : spec->obstacles) {
            if (o.points.empty()) continue;
            for (std::size_t i = 0; i <= o.points.size(); ++i) {
                if (i == o.points.size() && o.points.size() < 3) break;  // a wall segment: no closing edge
                const ch::Vec2& p = o.points[i % o.points.size()];
                walls.push_back({p.x(), p.y()});
            }
            walls.push_back({std::nan(""), std::nan("")});
        }
        if (!walls.empty()) {
            elements.push_back(std::string("'-' using 1:2 with lines lw 2.5 lc rgb '") + kWallColour + "' title 'walls'");
            blocks.push_back(std::move(walls));
        }
        Rows targets;
        for (const chrender::VenueMark& m : marks) {
            if (m.point || m.outline.empty()) continue;
            Rows outline;
            for (std::size_t i = 0; i <= m.outline.size(); ++i)
                outline.push_back({m.outline[i % m.outline.size()].x(), m.outline[i % m.outline.size()].y()});
            if (m.exit) {
                // Each exit in its colour; dashed when it closes at some time.
                elements.push_back("'-' using 1:2 with lines lw 2.5 " + std::string(m.events.empty() ? "" : "dt 2 ") +
                                   "lc rgb '" + colourOf(m.name) + "' notitle");
                blocks.push_back(std::move(outline));
            } else {
                targets.insert(targets.end(), outline.begin(), outline.end());
                targets.push_back({std::nan(""), std::nan("")});
            }
        }
        if (!targets.empty()) {
            elements.push_back(std::string("'-' using 1:2 with lines lw 1.5 dt 3 lc rgb '") + kTargetColour +
                               "' title 'targets'");
            blocks.push_back(std::move(targets));
        }
        bool anyExit = false, anyCloses = false;
        for (const chrender::VenueMark& m : marks) {
            anyExit = anyExit || m.exit;
            anyCloses = anyCloses || (m.exit && !m.events.empty());
        }
        if (anyExit)
            elements.push_back(std::string("keyentry with lines lw 2.5 lc rgb '#606060' title '") +
                               (anyCloses ? "exits (dashed: closes at some time)" : "exits") + "'");
    }
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
