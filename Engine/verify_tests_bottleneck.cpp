// crowdhealth verify — RiMEA 12 (effect of bottlenecks, a-d) and the validation of the flow through
// a bottleneck against Kretz et al. 2006 (docs/verification/bottleneck.md).
//
// Both tests use one scenario file each and build their sub-cases in memory: bottleneckGeometry()
// writes the walls and the exit of a room with a bottleneck in the middle of its east wall, of a
// given width and length, followed by the exit or by a second room with a second bottleneck of
// the same kind. The files are the geometry this function writes for their own case.
#include "verify_criteria_bottleneck.h"
#include "verify_figures.h"
#include "verify_suite.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>

namespace chverify {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double v, int decimals = 2) {
    if (!std::isfinite(v)) return "-";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}
std::optional<double> opt(double v) { return std::isfinite(v) ? std::optional<double>(v) : std::nullopt; }

/// A room (x from 0 to `depth`, y from 0 to `breadth`) with a bottleneck in the middle of its east
/// wall, and what lies beyond it.
struct Geometry {
    double depth = 10, breadth = 10;  ///< m, the room
    double width = 1, length = 0.2;   ///< m, the bottleneck
    enum class Beyond {
        Exit,        ///< the exit right behind the bottleneck
        SecondDoor,  ///< a second room 10 m deep with a second bottleneck like the first, then the exit
    } beyond = Beyond::Exit;
    static constexpr double kRoom2 = 10;  ///< m, depth of the second room
    /// x of the east side of the first bottleneck, and of the second room's east wall.
    double firstEnd() const { return depth + length; }
    double secondWall() const { return firstEnd() + kRoom2; }
};

/// Writes `g` into the scenario: its walls, the world's bounds and the exit named "door".
void bottleneckGeometry(ch::ScenarioSpec& s, const Geometry& g) {
    const double c = g.breadth / 2, y0 = c - g.width / 2, y1 = c + g.width / 2;
    const ch::SourceLoc loc = s.obstacles.empty() ? ch::SourceLoc{} : s.obstacles.front().loc;
    s.obstacles.clear();
    auto wall = [&](double ax, double ay, double bx, double by) {
        ch::ObstacleSpec o;
        o.points = {ch::Vec2(ax, ay), ch::Vec2(bx, by)};
        o.loc = loc;
        s.obstacles.push_back(std::move(o));
    };
    // A wall across x = at with a bottleneck (y0..y1) of `length`.
    auto doorWall = [&](double at) {
        wall(at, 0, at, y0);
        wall(at, y1, at, g.breadth);
        wall(at, y0, at + g.length, y0);
        wall(at, y1, at + g.length, y1);
    };
    wall(0, 0, g.depth, 0);
    wall(0, g.breadth, g.depth, g.breadth);
    wall(0, 0, 0, g.breadth);
    doorWall(g.depth);
    double exitFrom = g.firstEnd() + 0.3, exitY0 = y0, exitY1 = y1;
    if (g.beyond != Geometry::Beyond::Exit) {
        const double x = g.firstEnd(), e = g.secondWall();
        wall(x, 0, x, y0);
        wall(x, y1, x, g.breadth);
        wall(x, 0, e, 0);
        wall(x, g.breadth, e, g.breadth);
        doorWall(e);
        exitFrom = e + g.length + 0.3;
    }
    const double exitTo = exitFrom + 0.7;
    s.world.xmin = -1, s.world.xmax = exitTo + 1, s.world.ymin = -1, s.world.ymax = g.breadth + 1;
    const int k = s.venue.targetIndex("door");
    if (k < 0) throw std::runtime_error("the bottleneck test has no <Exit id=\"door\">");
    ch::TargetSpec& t = s.venue.targets[static_cast<std::size_t>(k)];
    t.shape.kind = ch::TargetShape::Kind::Polygon;
    t.shape.polygon = {ch::Vec2(exitFrom, exitY0), ch::Vec2(exitTo, exitY0), ch::Vec2(exitTo, exitY1), ch::Vec2(exitFrom, exitY1)};
    t.width = exitY1 - exitY0;
}

/// Keeps the first `n` agents (a smaller crowd for --quick).
void keepAgents(ch::ScenarioSpec& s, std::size_t n) {
    if (s.agents.size() > n) s.agents.resize(n);
}

/// An axis-aligned measuring area.
struct Area {
    double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
    double size() const { return (xmax - xmin) * (ymax - ymin); }
};

/// Both tests: the exit times, the flow from the `first`-th to the (N − `first`)-th person out,
/// and the density (P/m²) in up to two areas at every coarse step.
class BottleneckObserver : public Observer {
public:
    static constexpr std::size_t kFirst = 10;  ///< the flow is measured from the 10th to the (N−10)th out
    static constexpr double kWindow = 10;      ///< s, the density's moving mean (a jam lasts, a bunch passes)
    BottleneckObserver(std::size_t subcase, double width, std::vector<Area> areas)
        : subcase_(subcase), width_(width), areas_(std::move(areas)), samples_(areas_.size()) {}
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        if (start_.empty())  // the first call, before the first step: where everyone starts
            for (std::size_t i = 0; i < A.size(); ++i) start_[A.id[i]] = A.pos[i];
        for (std::size_t a = 0; a < areas_.size(); ++a) {
            const Area& r = areas_[a];
            std::size_t n = 0;
            for (std::size_t i = 0; i < A.size(); ++i)
                if (A.pos[i].x() >= r.xmin && A.pos[i].x() < r.xmax && A.pos[i].y() >= r.ymin && A.pos[i].y() < r.ymax) ++n;
            samples_[a].push_back(static_cast<double>(n) / r.size());
        }
        dt_ = sim.deltaTime();
    }
    Outcome finish(const ch::Simulation& sim) override {
        std::vector<double> times;
        for (const ch::Evacuation& e : sim.evacuations()) times.push_back(e.time);
        std::sort(times.begin(), times.end());
        const std::size_t total = sim.totalAgents();
        const std::optional<double> flow =
            total > 2 * kFirst ? passageFlow(times, kFirst, total - kFirst) : std::nullopt;
        Outcome o;
        o.check.pass = flow.has_value();
        o.check.value = flow.value_or(kNaN);
        o.check.detail = "b " + fmt(width_, 1) + " m: " + std::to_string(times.size()) + "/" + std::to_string(total) +
                         " out, flow " + (flow ? fmt(*flow) + " P/s" : std::string("not measured"));
        o.values["case"] = static_cast<double>(subcase_);
        o.values["b"] = width_;
        o.values["J"] = flow.value_or(kNaN);
        o.values["out"] = static_cast<double>(times.size());
        o.values["T"] = times.size() == total && !times.empty() ? times.back() : kNaN;
        const auto window = static_cast<std::size_t>(std::lround(kWindow / (dt_ > 0 ? dt_ : 0.1)));
        for (std::size_t a = 0; a < areas_.size(); ++a)
            o.values["rho" + std::to_string(a + 1)] = peakMovingMean(samples_[a], window).value_or(kNaN);
        for (std::size_t k = 0; k < times.size(); ++k) o.rows.push_back({times[k], static_cast<double>(k + 1)});
        // RiMEA 12a: exit time against the distance to the goal (the door's middle) at the start:
        // the mean exit time of the nearest and of the farthest third of those who left.
        const auto& targets = sim.spec().venue.targets;
        const int door = sim.spec().venue.targetIndex("door");
        if (door >= 0) {
            const ch::Vec2 goal = targets[static_cast<std::size_t>(door)].shape.centre();
            std::vector<std::pair<double, double>> byDistance;  // (distance, exit time)
            for (const ch::Evacuation& e : sim.evacuations())
                if (auto it = start_.find(e.id); it != start_.end()) byDistance.push_back({(it->second - goal).norm(), e.time});
            std::sort(byDistance.begin(), byDistance.end());
            const std::size_t third = byDistance.size() / 3;
            if (third > 0) {
                double near = 0, far = 0;
                for (std::size_t k = 0; k < third; ++k) near += byDistance[k].second, far += byDistance[byDistance.size() - 1 - k].second;
                o.values["tNear"] = near / static_cast<double>(third);
                o.values["tFar"] = far / static_cast<double>(third);
            }
        }
        return o;
    }

private:
    std::size_t subcase_;
    double width_;
    std::vector<Area> areas_;
    std::vector<std::vector<double>> samples_;
    double dt_ = 0.1;
    std::map<ch::AgentId, ch::Vec2> start_;
};

// ---- RiMEA 12 ----

/// The sub-cases of RiMEA 12, one variant each, in this order.
struct Subcase {
    const char* label;
    Geometry geometry;
};
const std::vector<Subcase>& rimea12Cases() {
    using B = Geometry::Beyond;
    static const std::vector<Subcase> cases = {
        {"base: b 1.0 m, L 0.2 m, exit behind", {10, 10, 1.0, 0.2, B::Exit}},
        {"12b: L 5 m", {10, 10, 1.0, 5.0, B::Exit}},
        {"12c: two doors in series", {10, 10, 1.0, 0.2, B::SecondDoor}},
        {"12d: b 0.8 m", {10, 10, 0.8, 0.2, B::Exit}},
        {"12d: b 1.2 m", {10, 10, 1.2, 0.2, B::Exit}},
    };
    return cases;
}
constexpr std::size_t kRimea12Quick = 50;  ///< persons in a quick run (150 in the full one)

/// The 2 m x 2 m in front of the middle of a wall at x = `wall`.
Area before(double wall, double breadth) { return {wall - 2, wall, breadth / 2 - 1, breadth / 2 + 1}; }


Check combineRimea12(const std::vector<const Outcome*>& outs, const RunContext&) {
    std::map<std::size_t, const Outcome*> by;
    for (const Outcome* o : outs) by[static_cast<std::size_t>(o->values.at("case"))] = o;
    auto val = [&](std::size_t k, const char* key) {
        const auto it = by.find(k);
        return it == by.end() ? kNaN : it->second->values.at(key);
    };
    std::vector<Check> parts;
    if (by.count(1) && by.count(0)) parts.push_back(longerIsSlower(opt(val(0, "J")), opt(val(1, "J"))));
    if (by.count(2)) parts.push_back(jamOnlyBeforeFirst(opt(val(2, "rho1")), opt(val(2, "rho2"))));
    if (by.count(0) && by.count(3) && by.count(4))
        parts.push_back(flowRisesWithWidth({{0.8, opt(val(3, "J"))}, {1.0, opt(val(0, "J"))}, {1.2, opt(val(4, "J"))}}));
    Check c = allSubcases(parts);
    // 12a is documented: in the base case, when people leave against how far from the door they
    // started, and when the last one is out.
    if (by.count(0)) {
        const auto& v = by[0]->values;
        auto get = [&](const char* key) { return v.count(key) ? v.at(key) : kNaN; };
        c.detail += "; 12a (documented): mean exit time of the nearest third " + fmt(get("tNear"), 1) +
                    " s, of the farthest third " + fmt(get("tFar"), 1) + " s, all out after " + fmt(get("T"), 1) + " s";
    }
    return c;
}

std::string drawRimea12(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "RiMEA 12: flow by sub-case (mean of the seeds, min-max bars)";
    c.xlabel = "1 base: b 1.0 m, L 0.2 m | 2 L 5 m (12b) | 3 two doors (12c) | 4 b 0.8 m | 5 b 1.2 m (12d)";
    c.ylabel = "flow, 10th to (N-10)th out (P/s)";
    // The sub-cases are categories, not a scale: each model's points sit side by side around the
    // sub-case's number, and a NaN row between them keeps gnuplot from joining them by lines.
    const std::size_t n = in.models.size();
    std::size_t k = 0;
    for (ChartSeries& s : perModelSeries(in, "J", [](std::size_t v) { return static_cast<double>(v + 1); })) {
        const double shift = n > 1 ? -0.25 + 0.5 * static_cast<double>(k++) / static_cast<double>(n - 1) : 0.0;
        std::vector<std::vector<double>> apart;
        for (std::vector<double>& p : s.points) {
            if (!apart.empty()) apart.push_back({p[0] - 0.5, kNaN, kNaN, kNaN});
            p[0] += shift;
            apart.push_back(p);
        }
        s.points = std::move(apart);
        c.series.push_back(std::move(s));
    }
    c.xrange = {{0.5, 5.5}};
    c.keyPosition = "outside right top";
    return drawChart(c, png);
}

// ---- Kretz et al. 2006 ----

const std::vector<double>& kretzWidths() {
    static const std::vector<double> w = {0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2};
    return w;
}
Geometry kretzGeometry(double width) { return {6, 8, width, 0.4, Geometry::Beyond::Exit}; }

Check combineKretz(const std::vector<const Outcome*>& outs, const RunContext&) {
    std::vector<WidthFlow> sim;
    std::string list, stuck;
    for (const Outcome* o : outs) {
        const double b = o->values.at("b"), j = o->values.at("J");
        sim.push_back({b, opt(j)});
        list += (list.empty() ? "" : ", ") + fmt(b, 1) + ": " + fmt(j);
        if (!std::isfinite(j)) stuck += (stuck.empty() ? "" : ", ") + fmt(b, 1) + " m (" + fmt(o->values.at("out"), 0) + " out)";
    }
    Check c;
    const std::optional<double> e = flowRmse(sim, kretz2006()), r = meanFlowRatio(sim, kretz2006());
    c.pass = e.has_value();
    c.value = e.value_or(kNaN);
    c.detail = "J (P/s) by b (m) " + list + "; RMSE " + fmt(c.value) + " P/s, J/J_Kretz " + fmt(r.value_or(kNaN));
    if (!stuck.empty()) c.detail += "; no flow (counted as 0) at " + stuck;
    return c;
}

std::string drawKretz(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "Bottleneck flow vs width: models (mean of the seeds, min-max bars) and Kretz et al. 2006";
    c.xlabel = "bottleneck width b (m)";
    c.ylabel = "flow J, 10th to 30th of 40 out (P/s)";
    const std::vector<double>& w = kretzWidths();
    c.series = perModelSeries(in, "J", [&](std::size_t v) { return v < w.size() ? w[v] : kNaN; });
    ChartSeries data;
    data.title = "Kretz et al. 2006 (every run)";
    data.style = "points";
    data.colour = "#000000";
    for (const MeasuredWidth& m : kretz2006())
        for (double j : m.flows) data.points.push_back({m.width, j});
    c.series.push_back(std::move(data));
    c.xrange = {{0.3, 1.3}};
    c.keyPosition = "top left";
    return drawChart(c, png);
}

}  // namespace

void addBottleneckTests(std::vector<TestDef>& t) {
    TestDef d;
    d.id = "rimea-12";
    d.title = "RiMEA 12: effect of bottlenecks";
    d.unit = "criteria";
    d.decimals = 0;
    d.criterion = "12b flow through a 5 m bottleneck < through 0.2 m; 12c before the 2nd of two doors in series the peak "
                  "10 s density (2 m x 2 m) stays <= 2.17 P/m2 while before the 1st it exceeds it; 12d flow rises with "
                  "the width 0.8 < 1.0 < 1.2 m (flows: 10th to 140th of 150 out); 12a documented (exit time by start "
                  "distance); value: sub-criteria failed";
    d.failureMeans = "the bottleneck's length or width does not limit the flow as it should, or people jam at a second "
                     "door that the first one already thins out";
    d.source = "RiMEA 4.1.1 test 12";
    d.claimed = {"RVO", "Karamouzas"};  // the models that pass on every seed (docs/verification/bottleneck.md)
    d.quickModel = "RVO";
    for (std::size_t k = 0; k < rimea12Cases().size(); ++k) {
        const Geometry g = rimea12Cases()[k].geometry;
        d.variants.push_back(Variant{rimea12Cases()[k].label, "rimea-12-bottleneck.xml",
                                     [g](ch::ScenarioSpec& s, const RunContext& ctx) {
                                         bottleneckGeometry(s, g);
                                         if (ctx.quick) keepAgents(s, kRimea12Quick);
                                     },
                                     true});
    }
    d.observer = [](const RunContext& ctx) {
        const Geometry& g = rimea12Cases().at(ctx.variant).geometry;
        std::vector<Area> areas = {before(g.depth, g.breadth)};
        if (g.beyond == Geometry::Beyond::SecondDoor) areas.push_back(before(g.secondWall(), g.breadth));
        return std::make_unique<BottleneckObserver>(ctx.variant, g.width, areas);
    };
    d.combine = combineRimea12;
    d.figure = drawRimea12;
    t.push_back(d);

    d = {};
    d.id = "val-kretz";
    d.title = "validation: bottleneck flow vs width (Kretz et al. 2006)";
    d.kind = Kind::Validation;
    d.unit = "P/s";
    d.criterion = "RMSE over the 8 widths 0.4-1.2 m of the flow J (10th to 30th of 40 out, P/s) against the mean of "
                  "Kretz's runs at each width; a width with no flow counts as J = 0";
    d.failureMeans = "a large error: the model's doors pass people faster (competitive crowd) or slower than normal egress";
    d.source = "Kretz, Grünebohm & Schreckenberg 2006 (J. Stat. Mech. P10014)";
    d.quickModel = "SocialForces-venue";
    for (double b : kretzWidths()) {
        const Geometry g = kretzGeometry(b);
        char label[32];
        std::snprintf(label, sizeof label, "b = %.1f m", b);
        // Quick: three widths (enough to see the slope).
        const bool quickToo = b == 0.6 || b == 0.9 || b == 1.2;
        d.variants.push_back(Variant{label, "val-kretz-bottleneck.xml",
                                     [g](ch::ScenarioSpec& s, const RunContext&) { bottleneckGeometry(s, g); }, quickToo});
    }
    d.observer = [](const RunContext& ctx) {
        const double b = kretzWidths().at(ctx.variant);
        return std::make_unique<BottleneckObserver>(ctx.variant, b, std::vector<Area>{});
    };
    d.combine = combineKretz;
    d.figure = drawKretz;
    t.push_back(d);
}

}  // namespace chverify
