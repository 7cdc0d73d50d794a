// crowdhealth verify — the fundamental diagrams: RiMEA 4 (speed against density in a corridor),
// its validation against Weidmann (1993) and the SFPE/IMO hydraulic table, and RiMEA 16 (the
// single-file fundamental diagram). docs/verification/fundamental.md says why each choice.
//
// RiMEA 4 asks for a corridor of 1000 m × 10 m or a periodic one. Here: a Toric world 8 m long
// (the period) with two walls 3 m apart along it, people walking east towards a goal far ahead
// (x = 10⁵ m: goals are not wrapped, so the direction stays east); <Navigation> cannot be used in
// a Toric world. Each density is one variant; the people are placed by the variant's `modify` on
// a staggered lattice (corridorLattice) with preferred speeds drawn from the run's seed. A 2 m ×
// 2 m measuring area in the middle records the density (people whose centre is inside / 4 m²)
// and the mean walking speed along the corridor of those inside, from 10 s to 40 s.
//
// rimea-4, val-weidmann and val-sfpe measure the same runs: the two validations read RiMEA 4's
// (TestDef::runsOf), so each (model, seed, density) is simulated once.
#include "verify_criteria_fundamental.h"
#include "verify_figures.h"
#include "verify_suite.h"

#include <crowdhealth/core/rng.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

namespace chverify {

namespace {

// ---- the set-up (docs/verification/fundamental.md) ----
constexpr const char* kCorridorFile = "rimea-04-fundamental.xml";
constexpr const char* kSingleFileFile = "rimea-16-single-file.xml";
const std::vector<double> kDensities = {0.5, 1, 2, 3, 4, 5, 6};      ///< P/m², RiMEA 4
const std::vector<double> kQuickDensities = {1, 3, 5};                 ///< those run with --quick
const std::vector<double> kLineDensities = {0.5, 1, 1.5, 2, 2.5};    ///< P/m along the single file
constexpr double kCorridorLength = 8, kCorridorWidth = 3;             ///< m (the file's period and walls)
constexpr double kLineLength = 20, kLineWidth = 0.8;                   ///< m (single file)
constexpr double kTransient = 10, kMeasured = 30;                     ///< s: measured from 10 s to 40 s
constexpr double kQuickTransient = 5, kQuickMeasured = 5;             ///< s, --quick
/// Preferred speeds: Weidmann's mean free speed 1.34 m/s with a spread of 0.2 m/s (the spread of
/// ISO 20414's demographic test), cut at ±2 standard deviations.
constexpr double kSpeedMean = 1.34, kSpeedSd = 0.2;

/// Replaces the agents of the loaded file by `count` copies of its first agent placed by
/// corridorLattice in a corridor `length` × `width` centred on y = 0, each with a preferred speed
/// drawn from the seed (the same draws for every model).
void fillCorridor(ch::ScenarioSpec& spec, const RunContext& ctx, double count, double length, double width) {
    if (spec.agents.empty()) throw std::runtime_error("the test file has no agent to copy");
    const ch::AgentSpec proto = spec.agents.front();
    const auto places = corridorLattice(static_cast<std::size_t>(std::lround(count)), length, width, proto.radius);
    ch::Rng rng(ctx.seed, 0x46445631);  // "FDV1": its own stream, apart from the simulation's
    spec.agents.clear();
    for (std::size_t k = 0; k < places.size(); ++k) {
        ch::AgentSpec a = proto;
        a.id = static_cast<ch::AgentId>(k);
        // A millimetre of jitter so no two runs start on an exact lattice.
        a.position = ch::Vec2(places[k].first + rng.uniform(-1e-3, 1e-3), places[k].second + rng.uniform(-1e-3, 1e-3));
        a.goal = ch::Vec2(proto.goal ? proto.goal->x() : 1e5, a.position.y());
        a.prefSpeed = kSpeedMean + kSpeedSd * std::clamp(rng.normal(), -2.0, 2.0);
        spec.agents.push_back(a);
    }
}

/// Watches a measuring area (x in [xmin, xmax], y in [ymin, ymax]) from `from` to `to` s: at each
/// record the people whose centre is inside at the start of the step, their walking speed along
/// x over the step (displacement / step, across the period), and the deepest overlap of two bodies
/// inside. `per` is the area (m²) or the length (m) the density is per.
class AreaObserver : public Observer {
public:
    AreaObserver(double nominal, double xmin, double xmax, double ymin, double ymax, double per, double from, double to)
        : nominal_(nominal), xmin_(xmin), xmax_(xmax), ymin_(ymin), ymax_(ymax), per_(per), from_(from), to_(to) {}
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        const double t = sim.time(), dt = sim.deltaTime();
        const bool measuring = t > from_ + 1e-9 && t <= to_ + 1e-9 && !prev_.empty();
        std::size_t inside = 0;
        double sumSpeed = 0;
        std::vector<std::pair<ch::Vec2, double>> bodies;
        for (std::size_t i = 0; i < A.size(); ++i) {
            const auto it = prev_.find(A.id[i]);
            if (measuring && it != prev_.end() && in(it->second)) {
                ++inside;
                sumSpeed += sim.world().offset(it->second, A.pos[i]).x() / dt;
                bodies.emplace_back(it->second, A.radius[i]);
            }
        }
        if (measuring) {
            ++records_;
            count_ += static_cast<double>(inside);
            if (inside > 0) speed_ += sumSpeed / static_cast<double>(inside), ++withSomeone_;
            for (std::size_t a = 0; a < bodies.size(); ++a)
                for (std::size_t b = a + 1; b < bodies.size(); ++b) {
                    const double gap = sim.world().offset(bodies[a].first, bodies[b].first).norm() - bodies[a].second - bodies[b].second;
                    overlap_ = std::max(overlap_, -gap);
                }
            for (std::size_t i = 0; i < A.size(); ++i)
                if (!std::isfinite(A.pos[i].x()) || !std::isfinite(A.pos[i].y())) blewUp_ = true;
        }
        prev_.clear();
        for (std::size_t i = 0; i < A.size(); ++i) prev_[A.id[i]] = A.pos[i];
    }
    Outcome finish(const ch::Simulation&) override {
        Outcome o;
        FdPoint p;
        p.nominal = nominal_;
        if (records_ > 0) p.density = count_ / static_cast<double>(records_) / per_;
        if (withSomeone_ > 0 && !blewUp_) p.speed = speed_ / static_cast<double>(withSomeone_), p.measured = true;
        o.values = {{"nominal", p.nominal}, {"density", p.density}, {"speed", p.speed},
                    {"flow", p.density * p.speed}, {"overlap", overlap_}, {"measured", p.measured ? 1.0 : 0.0}};
        o.check.pass = p.measured;
        o.check.value = p.measured ? p.speed : std::nan("");
        o.check.detail = blewUp_ ? "positions not finite: the run blew up" : pointText(o);
        return o;
    }

    /// "2 -> 2.14 P/m2: 0.83 m/s, overlap 1 cm"
    static std::string pointText(const Outcome& o, const char* unit = "P/m2") {
        const auto& v = o.values;
        if (v.at("measured") == 0) return fixedText(v.at("nominal"), 1) + ": nobody measured";
        std::string s = fixedText(v.at("nominal"), 1) + " -> " + fixedText(v.at("density"), 2) + " " + unit + ": " +
                        fixedText(v.at("speed"), 2) + " m/s";
        if (v.at("overlap") >= 0.005) s += ", overlap " + fixedText(100 * v.at("overlap"), 0) + " cm";
        return s;
    }

private:
    bool in(const ch::Vec2& p) const { return p.x() >= xmin_ && p.x() <= xmax_ && p.y() >= ymin_ && p.y() <= ymax_; }
    double nominal_, xmin_, xmax_, ymin_, ymax_, per_, from_, to_;
    std::map<ch::AgentId, ch::Vec2> prev_;
    std::size_t records_ = 0, withSomeone_ = 0;
    double count_ = 0, speed_ = 0, overlap_ = 0;
    bool blewUp_ = false;
};

std::unique_ptr<AreaObserver> corridorObserver(double nominal, bool quick) {
    const double from = quick ? kQuickTransient : kTransient, to = from + (quick ? kQuickMeasured : kMeasured);
    return std::make_unique<AreaObserver>(nominal, -1, 1, -1, 1, 4.0, from, to);
}

/// The corridor's variants (RiMEA 4; the validations read their runs): one per density.
std::vector<Variant> corridorVariants() {
    std::vector<Variant> out;
    for (const double rho : kDensities) {
        Variant v;
        v.label = fixedText(rho, 1) + " P/m2";
        v.file = kCorridorFile;
        v.inQuick = std::find(kQuickDensities.begin(), kQuickDensities.end(), rho) != kQuickDensities.end();
        v.modify = [rho](ch::ScenarioSpec& spec, const RunContext& ctx) {
            fillCorridor(spec, ctx, rho * kCorridorLength * kCorridorWidth, kCorridorLength, kCorridorWidth);
            spec.endTime = ctx.quick ? kQuickTransient + kQuickMeasured : kTransient + kMeasured;
        };
        out.push_back(std::move(v));
    }
    return out;
}

std::vector<FdPoint> pointsOf(const std::vector<const Outcome*>& outcomes) {
    std::vector<FdPoint> pts;
    for (const Outcome* o : outcomes) {
        if (!o || o->values.empty()) continue;
        FdPoint p;
        p.nominal = o->values.at("nominal");
        p.density = o->values.at("density");
        p.speed = o->values.at("speed");
        p.measured = o->values.at("measured") != 0;
        pts.push_back(p);
    }
    return pts;
}

/// "0.5 -> 0.52 P/m2: 1.30 m/s; 1 -> …": every density of one model and seed.
std::string allPoints(const std::vector<const Outcome*>& outcomes, const char* unit = "P/m2") {
    std::string s;
    for (const Outcome* o : outcomes) {
        if (!o || o->values.empty()) continue;
        if (!s.empty()) s += "; ";
        s += AreaObserver::pointText(*o, unit);
    }
    return s;
}

/// Per model, one point per variant: x the mean of `xKey` over the seeds, y the mean, smallest
/// and largest of `yKey` (only runs where someone was measured).
std::vector<ChartSeries> meanSeries(const FigureInput& in, const std::string& xKey, const std::string& yKey) {
    std::vector<ChartSeries> out;
    for (const std::string& m : in.models) {
        std::map<std::size_t, std::pair<std::vector<double>, std::vector<double>>> byVariant;
        for (const FigureRun& r : in.runs) {
            if (r.model != m || !r.outcome || r.outcome->values.empty() || r.outcome->values.at("measured") == 0) continue;
            byVariant[r.variant].first.push_back(r.outcome->values.at(xKey));
            byVariant[r.variant].second.push_back(r.outcome->values.at(yKey));
        }
        ChartSeries s;
        s.title = m;
        s.style = "errorbars";
        s.colour = modelColour(m);
        for (const auto& [v, xy] : byVariant) {
            const auto x = spreadOf(xy.first);
            const auto y = spreadOf(xy.second);
            if (x && y) s.points.push_back({x->mean, y->mean, y->min, y->max});
        }
        std::sort(s.points.begin(), s.points.end());
        if (!s.points.empty()) out.push_back(std::move(s));
    }
    return out;
}

ChartSeries curve(const std::string& title, const std::function<double(double)>& f, double to) {
    ChartSeries s;
    s.title = title;
    s.style = "lines";
    s.colour = "#000000";
    for (int k = 1; k <= 300; ++k) {
        const double x = to * k / 300.0;
        s.points.push_back({x, f(x)});
    }
    return s;
}

std::string drawDensityHeld(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "RiMEA 4: density measured in the 2 m x 2 m area against the density set (mean, min-max of seeds)";
    c.xlabel = "density set in the corridor (P/m^2)";
    c.ylabel = "density measured in the area (P/m^2)";
    c.keyPosition = "top left";
    c.series = meanSeries(in, "nominal", "density");
    for (ChartSeries& s : c.series) s.style = "errorbars";
    ChartSeries same;
    same.title = "measured = set";
    same.style = "lines";
    same.colour = "#000000";
    same.dashed = true;
    same.points = {{0, 0}, {7, 7}};
    c.series.push_back(same);
    c.xrange = {{0, 7}};
    c.yrange = {{0, 8}};
    return drawChart(c, png);
}

std::string drawWeidmann(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "Speed against density, periodic corridor 8 m x 3 m (mean of seeds, min-max bars)";
    c.xlabel = "density measured in the 2 m x 2 m area (P/m^2)";
    c.ylabel = "walking speed (m/s)";
    c.series = meanSeries(in, "density", "speed");
    c.series.push_back(curve("Weidmann 1993", weidmannSpeed, 7));
    c.xrange = {{0, 7}};
    c.yrange = {{0, 2.3}};  // room above the data for the key
    return drawChart(c, png);
}

std::string drawSfpe(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "Specific flow against density, periodic corridor 8 m x 3 m (mean of seeds, min-max bars)";
    c.xlabel = "density measured in the 2 m x 2 m area (P/m^2)";
    c.ylabel = "specific flow (P/(m s))";
    c.series = meanSeries(in, "density", "flow");
    c.series.push_back(curve("SFPE 1.40 (1 - 0.266 D) D", sfpeSpecificFlow, 7));
    ChartSeries imo;
    imo.title = "IMO MSC.1/Circ.1238 table";
    imo.style = "points";
    imo.colour = "#555555";
    for (const auto& [d, f] : imoTable()) imo.points.push_back({d, f});
    imo.points.push_back({7, imoTable().back().second});  // "≥ 3.5"
    c.series.push_back(imo);
    c.keyPosition = "top left";  // the models' lines rise to the top right
    c.xrange = {{0, 7}};
    c.yrange = {{0, 10}};
    return drawChart(c, png);
}

std::string drawSingleFile(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "RiMEA 16: single file, ring corridor 20 m x 0.8 m (mean of seeds, min-max bars; no data drawn)";
    c.xlabel = "density measured on the 2 m section (P/m)";
    c.ylabel = "walking speed (m/s)";
    c.series = meanSeries(in, "density", "speed");
    c.xrange = {{0, 3}};
    c.yrange = {{0, 2.3}};  // room above the data for the key
    return drawChart(c, png);
}

}  // namespace

void addFundamentalTests(std::vector<TestDef>& t) {
    TestDef d;

    d = {};
    d.id = "rimea-4";
    d.title = "RiMEA 4: fundamental diagram (periodic corridor)";
    d.kind = Kind::Documented;
    d.unit = "m/s";
    d.criterion = "documented: densities 0.5-6 P/m2 in a periodic corridor 8 m x 3 m, 2 m x 2 m measuring area, 10 s "
                  "transient, 30 s measured; value: the speed at 1 P/m2 set (Weidmann 1.06 m/s); detail: per density "
                  "set, the density measured in the area and the speed";
    d.failureMeans = "(no criterion) a density far from the one set means the model cannot hold it";
    d.source = "RiMEA 4.1.1 test 4";
    d.quickModel = "SocialForces";
    d.variants = corridorVariants();
    d.observer = [](const RunContext& ctx) -> std::unique_ptr<Observer> {
        return corridorObserver(kDensities.at(ctx.variant), ctx.quick);
    };
    d.combine = [](const std::vector<const Outcome*>& os, const RunContext&) {
        Check c{true, std::nan(""), allPoints(os)};
        for (const Outcome* o : os)
            if (o && !o->values.empty() && o->values.at("nominal") == 1 && o->values.at("measured") != 0)
                c.value = o->values.at("speed");
        return c;
    };
    d.figure = drawDensityHeld;
    t.push_back(d);

    d = {};
    d.id = "val-weidmann";
    d.title = "validation: speed vs density (Weidmann)";
    d.kind = Kind::Validation;
    d.unit = "m/s";
    d.criterion = "RMSE of the speeds measured in RiMEA 4's corridor against Weidmann's v(rho) at the measured density "
                  "(v0 1.34 m/s, gamma 1.913, rho_max 5.4; 0 beyond rho_max)";
    d.failureMeans = "a large error: the model's speed does not fall with density as people's do";
    d.source = "Weidmann 1993";
    d.runsOf = "rimea-4";
    d.combine = [](const std::vector<const Outcome*>& os, const RunContext&) { return weidmannError(pointsOf(os)); };
    d.figure = drawWeidmann;
    t.push_back(d);

    d = {};
    d.id = "val-sfpe";
    d.title = "validation: specific flow vs density (SFPE/IMO)";
    d.kind = Kind::Validation;
    d.unit = "P/(m s)";
    d.criterion = "RMSE of the specific flows rho*v of RiMEA 4's corridor against the IMO corridor table (linear "
                  "between its rows; 0.32 from 3.5 P/m2 on) at the measured density";
    d.failureMeans = "a large error: the model's flow does not rise to a capacity near 1.3 P/(m s) and fall beyond";
    d.source = "SFPE handbook; IMO MSC.1/Circ.1238";
    d.runsOf = "rimea-4";
    d.combine = [](const std::vector<const Outcome*>& os, const RunContext&) { return sfpeError(pointsOf(os)); };
    d.figure = drawSfpe;
    t.push_back(d);

    d = {};
    d.id = "rimea-16";
    d.title = "RiMEA 16: single-file fundamental diagram";
    d.kind = Kind::Documented;
    d.unit = "m/s";
    d.criterion = "documented: 0.5-2.5 P/m in a periodic corridor 20 m x 0.8 m, 2 m measuring section, 10 s transient, "
                  "30 s measured; value: the speed at 1 P/m set; detail: per density set, the density measured and the "
                  "speed (no published data is compared)";
    d.failureMeans = "(no criterion)";
    d.source = "RiMEA 4.1.1 test 16";
    d.quickModel = "SocialForces";
    for (const double rho : kLineDensities) {
        Variant v;
        v.label = fixedText(rho, 1) + " P/m";
        v.file = kSingleFileFile;
        v.inQuick = rho == 1 || rho == 2;
        v.modify = [rho](ch::ScenarioSpec& spec, const RunContext& ctx) {
            // One row: the lattice's width is a body, so every centre is on the corridor's axis.
            const double radius = spec.agents.empty() ? 0.2 : spec.agents.front().radius;
            fillCorridor(spec, ctx, rho * kLineLength, kLineLength, 2 * radius);
            spec.endTime = ctx.quick ? kQuickTransient + kQuickMeasured : kTransient + kMeasured;
        };
        d.variants.push_back(std::move(v));
    }
    d.observer = [](const RunContext& ctx) -> std::unique_ptr<Observer> {
        const double rho = kLineDensities.at(ctx.variant);
        const double from = ctx.quick ? kQuickTransient : kTransient, to = from + (ctx.quick ? kQuickMeasured : kMeasured);
        return std::make_unique<AreaObserver>(rho, -1, 1, -0.5 * kLineWidth, 0.5 * kLineWidth, 2.0, from, to);
    };
    d.combine = [](const std::vector<const Outcome*>& os, const RunContext&) {
        Check c{true, std::nan(""), allPoints(os, "P/m")};
        for (const Outcome* o : os)
            if (o && !o->values.empty() && o->values.at("nominal") == 1 && o->values.at("measured") != 0)
                c.value = o->values.at("speed");
        return c;
    };
    d.figure = drawSingleFile;
    t.push_back(d);
}

}  // namespace chverify
