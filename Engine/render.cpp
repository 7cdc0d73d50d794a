// crowdhealth render — see render.h and docs/rendering.md.
//
// Drawing is delegated to gnuplot (already a project dependency): this file gathers the frames
// (from a live simulation or from recorded trajectories), computes every agent's colour itself
// (so the picture uses exactly the paper's colour map), and writes a gnuplot script that draws
// obstacles, agents, goals, a colour bar, the time and a scale bar with a fixed world-to-pixel
// mapping (recorded in render.json, so tests and tools can find an agent's pixel).
#include "render.h"

#include "output_folder.h"

#include "plot_gnuplot.h"

#include "exit_codes.h"
#include "render_scene.h"
#include "trajectory_read.h"

#include <crowdhealth/io/json.h>
#include <crowdhealth/io/output.h>
#include <crowdhealth/core/simulation.h>
#include <crowdhealth/core/world.h>
#include <crowdhealth/io/xml.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace chcli {

namespace fs = std::filesystem;
namespace po = boost::program_options;
using chrender::Colouring;

namespace {

/// Simulated time (s) at which `--every` without `--time` stops a scenario that has no end.
constexpr double kRenderSafetyCap = 3600.0;
/// Agents drawn in one frame.
struct DrawAgent {
    long long id;
    double x, y, radius, value;
};
struct Frame {
    double time = 0;
    std::vector<DrawAgent> agents;
};

struct RenderOptions {
    std::string input, replay, output;
    std::optional<double> time, every;
    int width = 800, height = 800;
    Colouring colouring = Colouring::Density;
    double fps = 10;
    int threads = 0;
    bool quiet = false;
};

/// "800x600" → (800, 600).
bool parseSize(const std::string& s, int& w, int& h) {
    std::smatch m;
    static const std::regex re("^([0-9]{1,5})[xX]([0-9]{1,5})$");
    if (!std::regex_match(s, m, re)) return false;
    w = std::stoi(m[1].str());
    h = std::stoi(m[2].str());
    return true;
}

std::string num(double v, int digits = 6) { return ch::formatNumber(v, digits); }

std::string rgbHex(const chrender::Rgb& c) {
    auto byte = [](double v) { return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255)); };
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
    return buf;
}
long packedRgb(const chrender::Rgb& c) {
    auto byte = [](double v) { return static_cast<long>(std::lround(std::clamp(v, 0.0, 1.0) * 255)); };
    return (byte(c.r) << 16) | (byte(c.g) << 8) | byte(c.b);
}

/// A "nice" length (1, 2 or 5 × 10^k m) near a fifth of `span`.
double niceLength(double span) {
    const double target = std::max(span / 5, 1e-3);
    const double p = std::pow(10.0, std::floor(std::log10(target)));
    for (const double f : {5.0, 2.0, 1.0})
        if (f * p <= target) return f * p;
    return p;
}

// ---- gathering frames ------------------------------------------------------------------------

/// The times to draw: T alone, or 0, S, 2S, … up to T (or up to `until`).
std::vector<double> targetTimes(const RenderOptions& o, double until) {
    std::vector<double> t;
    if (!o.every) {
        t.push_back(*o.time);
        return t;
    }
    const double last = o.time ? *o.time : until;
    for (std::uint64_t k = 0;; ++k) {
        const double v = static_cast<double>(k) * *o.every;
        if (v > last + 1e-9) break;
        t.push_back(v);
        if (t.size() > 100000) break;
    }
    return t;
}

Frame captureLive(ch::Simulation& sim, Colouring c) {
    Frame f;
    f.time = sim.time();
    const std::vector<double> values = chrender::agentValues(sim, c);
    const ch::AgentStore& a = sim.agents();
    for (std::size_t i = 0; i < a.size(); ++i)
        f.agents.push_back({static_cast<long long>(a.id[i]), a.pos[i].x(), a.pos[i].y(), a.radius[i], values[i]});
    return f;
}

bool framesFromScenario(const RenderOptions& o, const ch::ScenarioSpec& spec, std::vector<Frame>& frames) {
    std::unique_ptr<ch::Simulation> sim;
    try {
        sim = std::make_unique<ch::Simulation>(spec);
    } catch (const std::exception& e) {
        std::cerr << o.input << ": error: " << e.what() << "\n";
        return false;
    }
    sim->setThreads(o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    const double until = sim->endTime() >= 0 ? sim->endTime() : kRenderSafetyCap;
    if (o.every && !o.time && sim->endTime() < 0 && !o.quiet)
        std::cerr << "crowdhealth render: note: the scenario has no end time; frames stop when every agent has left "
                     "(at most " << num(kRenderSafetyCap) << " s)\n";
    const double eps = 1e-9;
    for (const double t : targetTimes(o, until)) {
        while (sim->time() < t - eps && !sim->finished()) sim->stepCoarse();
        if (sim->time() < t - eps) {
            std::cerr << "crowdhealth render: note: the run ended at t = " << num(sim->time()) << " s, before "
                      << num(t) << " s; the last frame shows its end\n";
            frames.push_back(captureLive(*sim, o.colouring));
            break;
        }
        frames.push_back(captureLive(*sim, o.colouring));
        if (sim->finished() && o.every && !o.time) break;
    }
    return true;
}


std::optional<ch::ScenarioSpec> replaySpec(const RenderOptions& o) {
    std::string error;
    std::optional<ch::ScenarioSpec> spec = chrender::loadRunScenario(fs::path(o.replay), error, std::cerr);
    if (!spec) std::cerr << "crowdhealth render: error: " << error << "\n";
    return spec;
}

bool framesFromReplay(const RenderOptions& o, const ch::ScenarioSpec& spec, std::vector<Frame>& frames) {
    if (o.colouring == Colouring::Contact || o.colouring == Colouring::Panic || o.colouring == Colouring::Injury) {
        std::cerr << "crowdhealth render: error: --color " << chrender::colouringName(o.colouring)
                  << " cannot be replayed: a run's trajectories record positions only; render the scenario with -i "
                     "instead (it simulates up to the frame)\n";
        return false;
    }
    double dt = spec.deltaTime;
    std::map<std::int64_t, std::vector<Sample>> byFrame;
    std::string error;
    bool explicitFrames = false;
    if (!readTrajectories(fs::path(o.replay), dt, byFrame, explicitFrames, error)) {
        std::cerr << "crowdhealth render: error: " << error << "\n";
        return false;
    }
    std::map<long long, const ch::AgentSpec*> agentOf;
    for (const ch::AgentSpec& a : spec.agents) agentOf[a.id] = &a;
    const ch::World world(spec.world, spec.obstacles);
    const std::int64_t lastFrame = byFrame.empty() ? 0 : byFrame.rbegin()->first;
    const double lastTime = static_cast<double>(lastFrame) * dt;
    // Frames recorded every k coarse steps (a trajectory interval): a time between two frames
    // shows the earlier one, up to `stride` steps after it. trajectories.bin holds every recorded
    // frame, also empty ones, so the earlier frame is always right. The text formats have no
    // line for a frame without agents: there k is the most frequent gap between frames, and
    // when it is 1 (every step recorded) only the exact frame is used, as a gap then means that
    // nobody was in the world.
    std::int64_t stride = 1;
    if (explicitFrames) {
        stride = std::numeric_limits<std::int64_t>::max();
    } else if (byFrame.size() > 1) {
        std::map<std::int64_t, std::size_t> gaps;
        for (auto it = std::next(byFrame.begin()); it != byFrame.end(); ++it) ++gaps[it->first - std::prev(it)->first];
        const auto common = std::max_element(gaps.begin(), gaps.end(),
                                              [](const auto& a, const auto& b) { return a.second < b.second; });
        // +1: an interval that is not a whole number of steps gives gaps of k and k + 1.
        if (common->first > 1) stride = common->first + 1;
    }

    std::vector<double> times = targetTimes(o, lastTime);
    if (!o.every && *o.time > lastTime + dt / 2) {
        std::cerr << "crowdhealth render: error: the recording ends at t = " << num(lastTime) << " s, before --time "
                  << num(*o.time) << "\n";
        return false;
    }
    for (const double t : times) {
        std::int64_t f = std::llround(t / dt);
        if (f > lastFrame) break;
        auto it = byFrame.upper_bound(f);  // the recorded frame at or before f, within one stride
        if (it != byFrame.begin() && std::prev(it)->first > f - stride) {
            --it;
            f = it->first;
        } else {
            it = byFrame.end();
            if (f < stride) f = 0;  // before the first frame of UMANS files (no t = 0 row): the start
        }
        Frame fr;
        fr.time = static_cast<double>(f) * dt;
        std::vector<ch::Vec2> pos;
        std::vector<double> mass;
        if (it != byFrame.end()) {
            for (const Sample& s : it->second) {
                const auto a = agentOf.find(s.id);
                const double r = a != agentOf.end() ? a->second->radius : 0.24;
                mass.push_back(a != agentOf.end() ? a->second->mass : 1.0);
                pos.emplace_back(s.x, s.y);
                fr.agents.push_back({s.id, s.x, s.y, r, 0});
            }
        } else if (f == 0) {
            // UMANS files have no t = 0 row: the agents stand at their start positions.
            for (const ch::AgentSpec& a : spec.agents)
                if (a.startTime <= 0) {
                    pos.push_back(a.position);
                    mass.push_back(a.mass);
                    fr.agents.push_back({a.id, a.position.x(), a.position.y(), a.radius, 0});
                }
        }
        if (o.colouring == Colouring::Density) {
            const std::vector<double> rho = ch::measureDensity(pos, mass, world, 1.0);
            for (std::size_t i = 0; i < rho.size(); ++i) fr.agents[i].value = rho[i];
        }
        frames.push_back(std::move(fr));
    }
    return true;
}

// ---- drawing ---------------------------------------------------------------------------------

/// Pixel layout of a frame and the world rectangle shown.
struct Layout {
    int width, height;
    int left, right, top, bottom;  ///< margins in pixels
    chrender::Box view;            ///< world rectangle filling the plot area exactly (m)
};

Layout makeLayout(const RenderOptions& o, const chrender::Box& scene) {
    Layout l{o.width, o.height, 60, o.colouring == Colouring::None ? 20 : 130, 36, 50, {}};
    const double pw = l.width - l.left - l.right, ph = l.height - l.top - l.bottom;
    const double scale = std::min(pw / scene.width(), ph / scene.height());  // pixels per metre
    const double cx = (scene.xmin + scene.xmax) / 2, cy = (scene.ymin + scene.ymax) / 2;
    l.view = {cx - pw / scale / 2, cx + pw / scale / 2, cy - ph / scale / 2, cy + ph / scale / 2};
    return l;
}

chrender::Rgb colourOf(Colouring c, double value, double maxValue) {
    switch (c) {
        case Colouring::Density: return chrender::densityColour(value);
        case Colouring::Contact: return chrender::heatColour(maxValue > 0 ? value / maxValue : 0);
        case Colouring::Panic:
        case Colouring::Injury: return chrender::heatColour(value);
        case Colouring::None: break;
    }
    return {0.35, 0.55, 0.85};
}

/// The upper end of the colour bar.
double colourBarMax(Colouring c, const std::vector<Frame>& frames) {
    if (c == Colouring::Density) return 8;
    if (c != Colouring::Contact) return 1;
    double m = 0;
    for (const Frame& f : frames)
        for (const DrawAgent& a : f.agents) m = std::max(m, a.value);
    if (!(m > 0)) return 1;
    const double step = niceLength(m * 5) / 5;  // round up to a "nice" value
    return std::ceil(m / step) * step;
}

std::string dataFile(const RenderOptions& o, const std::vector<Frame>& frames, double barMax) {
    std::string s = "# crowdhealth render: the agents drawn, one block per frame (gnuplot `index`)\n";
    s += "# columns: frame time id x y radius value rgb   (m, s, m; value = " + chrender::colouringName(o.colouring) +
         "; rgb = 0xRRGGBB as an integer)\n";
    for (std::size_t k = 0; k < frames.size(); ++k) {
        if (k) s += "\n\n";
        s += "# frame " + std::to_string(k) + " t = " + num(frames[k].time) + " s\n";
        if (frames[k].agents.empty()) {  // an empty block would shift gnuplot's index
            s += std::to_string(k) + " " + num(frames[k].time) + " -1 nan nan 0 0 0\n";
            continue;
        }
        for (const DrawAgent& a : frames[k].agents) {
            s += std::to_string(k) + " " + num(frames[k].time) + " " + std::to_string(a.id) + " " + num(a.x, 8) + " " +
                 num(a.y, 8) + " " + num(a.radius) + " " + num(a.value, 17) + " " +  // exact: rgb follows from it
                 std::to_string(packedRgb(colourOf(o.colouring, a.value, barMax))) + "\n";
        }
    }
    return s;
}

std::string gnuplotScript(const RenderOptions& o, const ch::ScenarioSpec& spec, const Layout& l,
                          const std::vector<Frame>& frames, double barMax, const std::string& title) {
    std::ostringstream g;
    const double W = l.width, H = l.height;
    auto sx = [&](double px) { return num(px / W, 8); };
    auto sy = [&](double py) { return num(py / H, 8); };  // py from the bottom
    g << "# crowdhealth render: gnuplot script (edit and run `gnuplot render.gp` to restyle)\n";
    g << "set encoding utf8\nunset key\nset border lw 1 lc rgb '#404040'\n";
    g << "set lmargin at screen " << sx(l.left) << "\nset rmargin at screen " << sx(W - l.right) << "\n";
    g << "set bmargin at screen " << sy(l.bottom) << "\nset tmargin at screen " << sy(H - l.top) << "\n";
    g << "set xrange [" << num(l.view.xmin, 10) << ":" << num(l.view.xmax, 10) << "]\n";
    g << "set yrange [" << num(l.view.ymin, 10) << ":" << num(l.view.ymax, 10) << "]\n";
    g << "set xtics out nomirror scale 0.5\nset ytics out nomirror scale 0.5\n";
    g << "set xlabel 'x (m)' offset 0,0.5\nset ylabel 'y (m)' offset 1.5,0\n";
    g << "set style fill solid 1.0 border lc rgb '#202020'\n";

    int obj = 1;
    // obstacles: grey blocks
    for (const ch::ObstacleSpec& ob : spec.obstacles) {
        if (ob.points.size() < 2) continue;
        g << "set object " << obj++ << " polygon from ";
        for (std::size_t i = 0; i < ob.points.size(); ++i)
            g << (i ? " to " : "") << num(ob.points[i].x(), 10) << "," << num(ob.points[i].y(), 10);
        g << " to " << num(ob.points[0].x(), 10) << "," << num(ob.points[0].y(), 10)
          << " fillcolor rgb '#8c8c8c' fillstyle solid 1.0 border lc rgb '#5a5a5a' behind\n";
    }
    // goals: an orange ring with a label
    for (const chrender::GoalMark& m : chrender::goalMarks(spec)) {
        const double r = std::max(m.radius, 0.15);
        g << "set object " << obj++ << " circle at " << num(m.position.x(), 10) << "," << num(m.position.y(), 10)
          << " size " << num(r) << " fillstyle empty border lc rgb '#e07000' lw 2 front\n";
        g << "set label " << obj++ << " 'goal' at " << num(m.position.x(), 10) << "," << num(m.position.y() + r, 10)
          << " center offset 0,0.7 textcolor rgb '#b05000' front\n";
    }
    // targets and exits of a venue: outlines with their names (exits green, targets blue; an
    // exit drawn red and dashed, "closed", in the frames where the schedule has closed it)
    const std::vector<chrender::VenueMark> marks = chrender::venueMarks(spec);
    std::vector<int> markObject(marks.size(), 0);
    auto markCommands = [&](std::size_t k, bool open) {
        const chrender::VenueMark& m = marks[k];
        const std::string colour = !m.exit ? "#1f5fbf" : open ? "#1a9641" : "#d7191c";
        const std::string style = " fillstyle empty border lc rgb '" + colour + "' lw 2" + (open ? "" : " dt 2") + " front\n";
        std::ostringstream c;
        const int object = markObject[k];
        if (m.point) {
            c << "set object " << object << " circle at " << num(m.centre.x(), 10) << "," << num(m.centre.y(), 10)
              << " size " << num(std::max(m.radius, 0.15)) << style;
        } else {
            c << "set object " << object << " polygon from ";
            for (std::size_t i = 0; i <= m.outline.size(); ++i)
                c << (i ? " to " : "") << num(m.outline[i % m.outline.size()].x(), 10) << ","
                  << num(m.outline[i % m.outline.size()].y(), 10);
            c << style;
        }
        c << "set label " << object + 1 << " " << chplot::gpString(m.name + (open ? "" : " (closed)")) << " at "
          << num(m.centre.x(), 10) << "," << num(m.centre.y(), 10) << " center offset 0,1.1 noenhanced textcolor rgb '"
          << colour << "' front\n";
        return c.str();
    };
    for (std::size_t k = 0; k < marks.size(); ++k) {
        if (marks[k].outline.empty() && !marks[k].point) continue;
        markObject[k] = obj;
        obj += 2;
        g << markCommands(k, marks[k].openAt(frames.empty() ? 0.0 : frames.front().time));
    }
    // scale bar
    const double len = niceLength(l.view.width());
    const double bx = l.view.xmin + 0.04 * l.view.width(), by = l.view.ymin + 0.04 * l.view.height();
    g << "set arrow " << obj++ << " from " << num(bx, 10) << "," << num(by, 10) << " to " << num(bx + len, 10) << ","
      << num(by, 10) << " nohead lw 4 lc rgb 'black' front\n";
    g << "set label " << obj++ << " '" << num(len) << " m' at " << num(bx + len / 2, 10) << "," << num(by, 10)
      << " center offset 0,0.9 front\n";
    // colour bar: drawn as small rectangles in screen coordinates, with the same map as the agents
    if (o.colouring != Colouring::None) {
        const double x0 = W - l.right + 22, x1 = x0 + 18, y0 = l.bottom, y1 = H - l.top;
        const int n = 120;
        for (int i = 0; i < n; ++i) {
            const double v = barMax * (i + 0.5) / n;
            const double ya = y0 + (y1 - y0) * i / n, yb = y0 + (y1 - y0) * (i + 1) / n;
            g << "set object " << obj++ << " rectangle from screen " << sx(x0) << "," << sy(ya) << " to screen "
              << sx(x1) << "," << sy(yb + 0.6) << " fillcolor rgb '" << rgbHex(colourOf(o.colouring, v, barMax))
              << "' fillstyle solid 1.0 noborder front\n";
        }
        g << "set object " << obj++ << " rectangle from screen " << sx(x0) << "," << sy(y0) << " to screen " << sx(x1)
          << "," << sy(y1) << " fillstyle empty border lc rgb '#404040' front\n";
        const double tick = niceLength(barMax * 1.25);
        for (double v = 0; v <= barMax + 1e-9; v += tick) {
            const double y = y0 + (y1 - y0) * v / barMax;
            g << "set label " << obj++ << " '" << num(v) << (o.colouring == Colouring::Density && v >= 8 ? "+" : "")
              << "' at screen " << sx(x1 + 4) << "," << sy(y) << " left front\n";
        }
        g << "set label " << obj++ << " '" << chrender::colouringLabel(o.colouring) << "' at screen " << sx(x1 + 45)
          << "," << sy((y0 + y1) / 2) << " center rotate by 90 front\n";
    }

    auto plotFrames = [&](bool png) {
        for (std::size_t k = 0; k < frames.size(); ++k) {
            if (png) {
                char name[32];
                std::snprintf(name, sizeof name, "frame_%04zu.png", k);
                g << "set output '" << name << "'\n";
            }
            // Single-quoted (gpString): a scenario named with " or \ does not break the script.
            std::string heading = "t = ";
            heading += num(std::round(frames[k].time * 1000) / 1000);
            heading += " s    ";
            heading += title;
            heading += "    ";
            heading += std::to_string(frames[k].agents.size());
            heading += " agents";
            g << "set title " << chplot::gpString(heading) << "\n";
            // Exits that close or reopen: their state at this frame's time.
            for (std::size_t m = 0; m < marks.size(); ++m)
                if (markObject[m] > 0 && marks[m].exit && !marks[m].events.empty())
                    g << markCommands(m, marks[m].openAt(frames[k].time));
            g << "plot 'render-data.txt' index " << k
              << " using 4:5:6:8 with circles lc rgb variable lw 0.5\n";
        }
    };
    g << "set terminal pngcairo size " << l.width << "," << l.height << " font 'sans,10' background rgb 'white'\n";
    plotFrames(true);
    if (frames.size() > 1) {
        const int delay = std::max(1, static_cast<int>(std::lround(100.0 / o.fps)));
        g << "set terminal gif animate delay " << delay << " loop 0 optimize size " << l.width << "," << l.height
          << " background rgb 'white'\n";
        g << "set output 'animation.gif'\n";
        plotFrames(false);
    }
    g << "set output\n";
    return g.str();
}

std::string renderJson(const RenderOptions& o, const std::string& scenario, const Layout& l,
                       const std::vector<Frame>& frames, double barMax, bool gif, bool mp4) {
    ch::Json j;
    j["scenario"] = scenario;
    j["source"] = o.replay.empty() ? "simulation" : "replay";
    j["color"] = chrender::colouringName(o.colouring);
    j["color_max"] = ch::jsonNumber(barMax);
    j["width"] = l.width;
    j["height"] = l.height;
    j["view"] = ch::Json{{"xmin", ch::jsonNumber(l.view.xmin)}, {"xmax", ch::jsonNumber(l.view.xmax)},
                         {"ymin", ch::jsonNumber(l.view.ymin)}, {"ymax", ch::jsonNumber(l.view.ymax)}};
    j["plot_pixels"] = ch::Json{{"left", l.left}, {"right", l.width - l.right},
                                {"top", l.top}, {"bottom", l.height - l.bottom}};
    j["animation"] = gif ? ch::Json("animation.gif") : ch::Json(nullptr);
    j["video"] = mp4 ? ch::Json("animation.mp4") : ch::Json(nullptr);
    ch::Json list = ch::Json::array();
    for (std::size_t k = 0; k < frames.size(); ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%04zu.png", k);
        list.push_back(ch::Json{{"file", name}, {"time", ch::jsonNumber(frames[k].time)},
                                {"agents", frames[k].agents.size()}});
    }
    j["frames"] = std::move(list);
    return ch::jsonText(j);
}

void printRenderHelp(std::ostream& out, const po::options_description& desc) {
    out << "Usage: crowdhealth render -i SCENARIO -o OUTDIR --time T [options]\n"
           "       crowdhealth render --replay RUNDIR -o OUTDIR [--time T] [options]\n\n"
           "Draws PNG frames of a scenario (simulated up to each frame) or of a finished run (from its\n"
           "trajectories), and an animation (GIF; MP4 too when ffmpeg is installed). Needs gnuplot.\n\n"
        << desc
        << "\nOutputs in OUTDIR: frame_0000.png …, animation.gif/.mp4 (several frames), render-data.txt,\n"
           "render.gp, render.json. See docs/rendering.md.\n";
}

}  // namespace

int renderCommand(int argc, char* argv[]) {
    RenderOptions o;
    std::string size = "800x800", colour = "density";
    po::options_description desc("Options");
    desc.add_options()
        ("help,h", "this help")
        ("input,i", po::value(&o.input), "scenario XML to simulate and draw")
        ("replay", po::value(&o.replay), "draw a finished run from its folder (summary.json + trajectories)")
        ("output,o", po::value(&o.output), "folder for the frames (created if needed)")
        ("time", po::value<double>(), "time of the frame (s); with --every, the last frame's time")
        ("every", po::value<double>(), "draw a frame every S seconds from t = 0 (to --time, else to the end)")
        ("size", po::value(&size), "image size in pixels, WxH (default 800x800)")
        ("color", po::value(&colour), "agent colouring: density (default), contact, panic, injury, none")
        ("fps", po::value(&o.fps), "animation frames per second (default 10)")
        ("threads,t", po::value(&o.threads), "OpenMP threads of the simulation (default: all)")
        ("quiet,q", "print nothing but errors");
    po::variables_map vm;
    try {
        po::store(po::command_line_parser(argc, argv).options(desc).run(), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "crowdhealth render: error: " << e.what() << "\n(see crowdhealth render --help)\n";
        return kExitInput;
    }
    if (vm.count("help")) {
        printRenderHelp(std::cout, desc);
        return kExitOk;
    }
    o.quiet = vm.count("quiet") > 0;
    if (vm.count("time")) o.time = vm["time"].as<double>();
    if (vm.count("every")) o.every = vm["every"].as<double>();

    auto usage = [](const std::string& msg) {
        std::cerr << "crowdhealth render: error: " << msg << "\n(see crowdhealth render --help)\n";
        return kExitInput;
    };
    if (o.input.empty() == o.replay.empty()) return usage("give exactly one of -i SCENARIO and --replay RUNDIR");
    if (o.output.empty()) return usage("give the output folder with -o OUTDIR");
    if (!o.time && !o.every) return usage("give --time T (one frame) or --every S (a series)");
    if (o.time && !(std::isfinite(*o.time) && *o.time >= 0)) return usage("--time must be a time ≥ 0 (s)");
    if (o.every && !(std::isfinite(*o.every) && *o.every > 0)) return usage("--every must be > 0 (s)");
    if (!parseSize(size, o.width, o.height) || o.width < 320 || o.height < 240 || o.width > 8000 || o.height > 8000)
        return usage("--size must be WxH with 320 ≤ W ≤ 8000 and 240 ≤ H ≤ 8000 pixels, e.g. 800x800");
    const auto c = chrender::parseColouring(colour);
    if (!c) return usage("--color must be density, contact, panic, injury or none (got \"" + colour + "\")");
    o.colouring = *c;
    if (!(o.fps > 0 && o.fps <= 100)) return usage("--fps must be in (0, 100]");

    const std::optional<std::string> found = chplot::findGnuplot();
    if (!found) {
        std::cerr << "crowdhealth render: error: " << chplot::missingGnuplotMessage("render") << " — nothing was drawn\n";
        return kExitRuntime;
    }
    const std::string gnuplot = *found;

    // the scene and its frames
    std::optional<ch::ScenarioSpec> spec;
    std::string scenarioPath;
    if (!o.replay.empty()) {
        spec = replaySpec(o);
        if (!spec) return kExitInput;
        scenarioPath = spec->sourceFile;
    } else {
        spec = chrender::loadForDisplay(o.input, std::cerr);
        if (!spec) {
            std::cerr << "crowdhealth render: nothing was drawn\n";
            return kExitInput;
        }
        scenarioPath = o.input;
    }
    std::vector<Frame> frames;
    const bool ok = o.replay.empty() ? framesFromScenario(o, *spec, frames) : framesFromReplay(o, *spec, frames);
    if (!ok) return kExitInput;
    if (frames.empty()) {
        std::cerr << "crowdhealth render: error: no frame to draw\n";
        return kExitInput;
    }

    // files
    const fs::path out(o.output);
    std::error_code ec;
    fs::create_directories(out, ec);
    if (!fs::is_directory(out)) {
        std::cerr << "crowdhealth render: error: cannot create the folder " << out.string() << "\n";
        return kExitRuntime;
    }
    const Layout layout = makeLayout(o, chrender::sceneBounds(*spec));
    const double barMax = colourBarMax(o.colouring, frames);
    const std::string title = fs::path(scenarioPath).filename().string();
    try {
        ch::writeFileAtomic(out / "render-data.txt", dataFile(o, frames, barMax));
        ch::writeFileAtomic(out / "render.gp", gnuplotScript(o, *spec, layout, frames, barMax, title));
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth render: error: " << e.what() << "\n";
        return kExitRuntime;
    }
    fs::remove(out / "animation.gif", ec);
    fs::remove(out / "animation.mp4", ec);

    const std::string cmd = "cd " + chplot::shellQuote(out.string()) + " && " + chplot::shellQuote(gnuplot) +
                            " render.gp >render-gnuplot.log 2>&1 </dev/null";
    if (std::system(cmd.c_str()) != 0) {
        std::cerr << "crowdhealth render: error: gnuplot failed; its messages are in "
                  << (out / "render-gnuplot.log").string() << ":\n";
        std::ifstream log(out / "render-gnuplot.log");
        std::cerr << log.rdbuf();
        return kExitRuntime;
    }
    fs::remove(out / "render-gnuplot.log", ec);

    bool mp4 = false;
    const bool gif = frames.size() > 1;
    if (gif) {
        if (const std::optional<std::string> found = chplot::findProgram("CROWDHEALTH_FFMPEG", "ffmpeg")) {
            const std::string& ffmpeg = *found;
            const std::string fcmd = "cd " + chplot::shellQuote(out.string()) + " && " + chplot::shellQuote(ffmpeg) +
                                     " -y -loglevel error -framerate " + num(o.fps) +
                                     " -i frame_%04d.png -vf 'scale=trunc(iw/2)*2:trunc(ih/2)*2' -pix_fmt yuv420p "
                                     "-c:v libx264 animation.mp4 </dev/null >render-ffmpeg.log 2>&1";
            mp4 = std::system(fcmd.c_str()) == 0;
            if (!mp4)
                std::cerr << "crowdhealth render: warning: ffmpeg could not make animation.mp4 (see "
                          << (out / "render-ffmpeg.log").string() << "); the GIF is there\n";
            else
                fs::remove(out / "render-ffmpeg.log", ec);
        } else if (!o.quiet) {
            std::cerr << "crowdhealth render: note: ffmpeg not found, so no animation.mp4 (install the Debian package "
                         "ffmpeg for one); animation.gif is there\n";
        }
    }
    try {
        ch::writeFileAtomic(out / "render.json", renderJson(o, scenarioPath, layout, frames, barMax, gif, mp4));
    } catch (const std::exception& e) {
        std::cerr << "crowdhealth render: error: " << e.what() << "\n";
        return kExitRuntime;
    }
    // Drawn into a run folder (one with a manifest): the files join it, so the next run into the
    // folder replaces them rather than refusing them or leaving them stale.
    {
        std::vector<std::string> names = {"render-data.txt", "render.gp", "render.json"};
        for (std::size_t k = 0; k < frames.size(); ++k) {
            char name[32];
            std::snprintf(name, sizeof name, "frame_%04zu.png", k);
            names.push_back(name);
        }
        if (gif) names.push_back("animation.gif");
        if (mp4) names.push_back("animation.mp4");
        addToManifest(out, names);
    }
    if (!o.quiet) {
        std::cout << "Drew " << frames.size() << (frames.size() == 1 ? " frame" : " frames") << " ("
                  << layout.width << "x" << layout.height << ", coloured by " << chrender::colouringName(o.colouring)
                  << ") into " << out.string() << (gif ? ", with animation.gif" : "") << (mp4 ? " and animation.mp4" : "")
                  << "\n";
    }
    return kExitOk;
}

}  // namespace chcli
