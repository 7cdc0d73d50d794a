// crowdhealth verify — ISO 20414 / NIST TN 1822: speed in a corridor, pre-evacuation time
// distributions (Kolmogorov–Smirnov), demographics N(1.2, 0.2) m/s and counter-flow
// (docs/verification/iso.md). Groups (iso-groups) wait for groups to exist: the row stays pending.
#include "verify_criteria_iso.h"
#include "verify_figures.h"
#include "verify_suite.h"

#include <crowdhealth/core/registry.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>

namespace chverify {

namespace {

/// iso-corridor: the one person's travel time over the 40 m of iso-corridor.xml.
class CorridorObserver : public Observer {
public:
    static constexpr double kDistance = 40.0;  ///< m from the start (x = 0.2) to the exit (x = 40.2)
    Outcome finish(const ch::Simulation& sim) override {
        std::optional<double> t;
        if (!sim.evacuations().empty()) t = sim.evacuations().front().time;
        return corridorSpeed(t, kDistance);
    }
};

/// iso-premovement-ks: when each person starts walking, then the KS test of the start times
/// against `ref`. Walking is RiMEA 5's (verify_tests_basic.cpp, PremovementObserver): half the
/// preferred speed kept for 1 s. The start is the last time the person was seen standing (under a
/// tenth of its preferred speed) before that: RiMEA 5 takes the beginning of the walking run, which
/// adds the time to reach half the speed (0.3-0.4 s with social forces' 0.5 s relaxation) to every
/// start; here that would shift the whole sample and enter D (0.011 for the normal's 0.027/s peak).
class PremovementKsObserver : public Observer {
public:
    static constexpr double kWalking = 0.5;
    static constexpr double kSustained = 1.0;
    static constexpr double kStanding = 0.1;  ///< share of the preferred speed under which one stands
    explicit PremovementKsObserver(Reference ref) : ref_(ref) {}
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (started_.count(A.id[i])) continue;
            const double v = A.vel[i].norm();
            if (v < kStanding * A.basePrefSpeed[i]) standing_[A.id[i]] = sim.time();
            if (v < kWalking * A.basePrefSpeed[i]) {
                since_.erase(A.id[i]);
                continue;
            }
            const double t = since_.try_emplace(A.id[i], sim.time() - sim.deltaTime()).first->second;
            if (sim.time() - t >= kSustained - 1e-9) {
                const auto still = standing_.find(A.id[i]);
                started_[A.id[i]] = still != standing_.end() ? std::min(t, still->second) : t;
            }
        }
    }
    Outcome finish(const ch::Simulation& sim) override {
        std::vector<StartRecord> people;
        std::vector<double> appeared;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            StartRecord r;
            r.id = a.id;
            r.due = a.startTime + a.premovement;
            if (auto it = started_.find(a.id); it != started_.end()) r.start = it->second;
            people.push_back(r);
            appeared.push_back(a.startTime);
        }
        // The draws themselves (the premovement times given): the seed's sample before any
        // simulation.
        std::vector<double> drawn;
        for (const ch::AgentSpec& a : sim.spec().agents) drawn.push_back(a.premovement);
        Outcome o = premovementDistribution(people, appeared, drawn, ref_);
        o.values["D drawn"] = ksStatistic(drawn, ref_);
        // The empirical CDF of the measured premovement times, for the figure.
        std::vector<double> measured;
        for (std::size_t i = 0; i < people.size(); ++i)
            if (people[i].start) measured.push_back(*people[i].start - appeared[i]);
        std::sort(measured.begin(), measured.end());
        for (std::size_t k = 0; k < measured.size(); ++k)
            o.rows.push_back({measured[k], static_cast<double>(k + 1) / static_cast<double>(measured.size())});
        o.values["D"] = o.check.value;
        return o;
    }

private:
    Reference ref_;
    std::map<ch::AgentId, double> since_;     ///< start of the current run of walking steps
    std::map<ch::AgentId, double> standing_;  ///< last time seen standing
    std::map<ch::AgentId, double> started_;
};

/// iso-demographics: each person's speed between x = 5 m and x = 25 m, then the KS test of the
/// speeds against `ref`.
class SpeedKsObserver : public Observer {
public:
    static constexpr double kFrom = 5, kTo = 25;  ///< m, the measuring lines
    explicit SpeedKsObserver(Reference ref) : ref_(ref) {}
    void step(const ch::Simulation& sim) override {
        const ch::AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            Track& k = tracks_[A.id[i]];
            if (k.seen) {
                if (!k.t5) k.t5 = crossingTime(k.t, k.x, sim.time(), A.pos[i].x(), kFrom);
                if (!k.t25) k.t25 = crossingTime(k.t, k.x, sim.time(), A.pos[i].x(), kTo);
            }
            k.seen = true;
            k.t = sim.time();
            k.x = A.pos[i].x();
        }
    }
    Outcome finish(const ch::Simulation& sim) override {
        std::vector<std::optional<double>> speeds;
        double off = 0;  // largest |measured − preferred| (m/s), shown in the detail
        std::vector<double> measured;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            std::optional<double> v;
            if (auto it = tracks_.find(a.id); it != tracks_.end() && it->second.t5 && it->second.t25)
                v = (kTo - kFrom) / (*it->second.t25 - *it->second.t5);
            if (v) {
                off = std::max(off, std::abs(*v - a.prefSpeed));
                measured.push_back(*v);
            }
            speeds.push_back(v);
        }
        Outcome o = speedDistribution(speeds, ref_);
        char buf[96];
        std::snprintf(buf, sizeof buf, "; largest |speed - preferred| %.3f m/s", off);
        o.check.detail += buf;
        o.values["off"] = off;
        std::sort(measured.begin(), measured.end());
        for (std::size_t k = 0; k < measured.size(); ++k)
            o.rows.push_back({measured[k], static_cast<double>(k + 1) / static_cast<double>(measured.size())});
        return o;
    }

private:
    struct Track {
        bool seen = false;
        double t = 0, x = 0;
        std::optional<double> t5, t25;
    };
    Reference ref_;
    std::map<ch::AgentId, Track> tracks_;
};

/// iso-counterflow: when each of the crowd measured (the agents of journey `to-east`) passes the
/// corridor's east end (x = 10 m, or leaves by the exit there); the crossing time is the last of
/// them.
class CounterflowObserver : public Observer {
public:
    static constexpr double kLine = 10;  ///< m, the corridor's east end
    void step(const ch::Simulation& sim) override {
        if (measured_.empty())
            for (const ch::AgentSpec& a : sim.spec().agents)
                if (a.journey == "to-east") measured_.insert(a.id);
        const ch::AgentStore& A = sim.agents();
        for (std::size_t i = 0; i < A.size(); ++i) {
            if (!measured_.count(A.id[i])) continue;
            Track& k = tracks_[A.id[i]];
            if (k.seen && !k.crossed) k.crossed = crossingTime(k.t, k.x, sim.time(), A.pos[i].x(), kLine);
            k.seen = true;
            k.t = sim.time();
            k.x = A.pos[i].x();
        }
    }
    Outcome finish(const ch::Simulation& sim) override {
        // A person leaves by the exit just beyond the corridor's end in the step its centre passes
        // x = 10 m, before the next observation: its exit time is its crossing time then.
        for (const auto& [id, e] : evacuationsById(sim))
            if (Track& k = tracks_[id]; measured_.count(id) && !k.crossed) k.crossed = e->time;
        std::size_t crossed = 0;
        double last = 0, sum = 0;
        for (const auto& [id, k] : tracks_)
            if (k.crossed) ++crossed, last = std::max(last, *k.crossed), sum += *k.crossed;
        const std::size_t n = measured_.size();
        Outcome o;
        o.check.pass = n > 0 && crossed == n;
        o.check.value = o.check.pass ? last : std::nan("");
        char buf[160];
        std::snprintf(buf, sizeof buf, "%zu/%zu crossed by %.0f s%s", crossed, n, sim.time(),
                      o.check.pass ? "" : " (gridlock)");
        o.check.detail = buf;
        o.values["crossed"] = static_cast<double>(crossed);
        if (o.check.pass) {
            o.values["last"] = last;
            o.values["mean"] = sum / static_cast<double>(n);
        }
        return o;
    }

private:
    struct Track {
        bool seen = false;
        double t = 0, x = 0;
        std::optional<double> crossed;
    };
    std::set<ch::AgentId> measured_;
    std::map<ch::AgentId, Track> tracks_;
};

/// The premovement distributions of iso-premovement-ks, one per variant (as the files draw them).
const std::vector<std::pair<std::string, Reference>>& premovementVariants() {
    static const std::vector<std::pair<std::string, Reference>> v = {
        {"iso-premovement-uniform.xml", {Reference::Kind::Uniform, 10, 100}},
        {"iso-premovement-normal.xml", {Reference::Kind::Normal, 55, 15, 10, 100}},
        {"iso-premovement-lognormal.xml", {Reference::Kind::Lognormal, 3.689, 0.4, 0, 150}},
    };
    return v;
}

/// The opposite counts of iso-counterflow, one per variant.
const std::vector<int> kOpposite = {0, 10, 50, 100};

/// Quick runs: the crowds of the lane files cut to their first `keep` sources (lanes).
void keepFirstAgents(ch::ScenarioSpec& spec, std::size_t keep) {
    if (spec.agents.size() > keep) spec.agents.resize(keep);
}

/// Keeps `n` agents of `journey`: those nearest `mouth`; removes the others of that journey.
void keepNearest(ch::ScenarioSpec& spec, const std::string& journey, std::size_t n, ch::Vec2 mouth) {
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t i = 0; i < spec.agents.size(); ++i)
        if (spec.agents[i].journey == journey) order.push_back({(spec.agents[i].position - mouth).norm(), i});
    std::stable_sort(order.begin(), order.end());
    std::vector<bool> drop(spec.agents.size(), false);
    for (std::size_t k = n; k < order.size(); ++k) drop[order[k].second] = true;
    std::vector<ch::AgentSpec> kept;
    for (std::size_t i = 0; i < spec.agents.size(); ++i)
        if (!drop[i]) kept.push_back(spec.agents[i]);
    spec.agents = std::move(kept);
}

/// The model's mean crossing time (min–max over the seeds) against the opposite count.
std::string drawCounterflow(const FigureInput& in, const std::filesystem::path& png) {
    Chart c;
    c.title = "ISO/NIST counter-flow: time for the 100 to cross (mean and range over the seeds)";
    c.xlabel = "opposite persons";
    c.ylabel = "crossing time of the last of the 100 (s)";
    c.keyPosition = "bottom right";  // the top holds the gridlock marks and the slowest crossings
    c.series = perModelSeries(in, "last", [](std::size_t v) { return static_cast<double>(kOpposite.at(v)); });
    // A gridlocked run has no crossing time: a black cross at the top of the chart marks it.
    ChartSeries jam;
    jam.title = "gridlock in a seed (not all across by the end, 180 s)";
    jam.style = "points";
    jam.colour = "#000000";
    double top = 0;
    for (const ChartSeries& s : c.series)
        for (const auto& p : s.points) top = std::max(top, p.size() > 3 ? p[3] : p[1]);
    for (const FigureRun& r : in.runs)
        if (r.outcome && !r.outcome->check.pass)
            jam.points.push_back({static_cast<double>(kOpposite.at(r.variant)), top + 10});
    if (!jam.points.empty()) c.series.push_back(std::move(jam));
    c.xrange = std::pair{-5.0, 105.0};
    return drawChart(c, png);
}

/// The empirical CDFs of the measured free walking speeds (seed 1 of each model) with N(1.2, 0.2).
std::string drawSpeeds(const FigureInput& in, const std::filesystem::path& png, const Reference& ref) {
    Chart c;
    c.title = "ISO/NIST demographics: measured free walking speeds (seed 1) against N(1.2, 0.2)";
    c.xlabel = "speed between x = 5 m and x = 25 m (m/s)";
    c.ylabel = "share of the 100 at or below";
    c.keyPosition = "bottom right";
    for (const std::string& m : in.models)
        for (const FigureRun& r : in.runs) {
            if (r.model != m || r.seed != 1 || !r.outcome || r.outcome->rows.empty()) continue;
            ChartSeries s;
            s.title = m;
            s.style = "steps";
            s.colour = modelColour(m);
            s.points = r.outcome->rows;
            c.series.push_back(std::move(s));
        }
    ChartSeries cdf;
    cdf.title = "N(1.2, 0.2)";
    cdf.style = "lines";
    cdf.colour = "#000000";
    cdf.dashed = true;
    for (int k = 0; k <= 100; ++k) {
        const double x = 0.5 + 1.4 * k / 100.0;
        cdf.points.push_back({x, ref.cdf(x)});
    }
    c.series.push_back(std::move(cdf));
    c.xrange = std::pair{0.5, 1.9};
    c.yrange = std::pair{0.0, 1.0};
    return drawChart(c, png);
}

/// ISO/NIST groups: the group's members (agents with a group) and when each left by an exit.
class GroupObserver : public Observer {
public:
    Outcome finish(const ch::Simulation& sim) override {
        const auto out = evacuationsById(sim);
        std::vector<std::optional<double>> arrivals;
        for (const ch::AgentSpec& a : sim.spec().agents) {
            if (a.groupIndex < 0) continue;
            const auto it = out.find(a.id);
            arrivals.push_back(it != out.end() ? std::optional<double>(it->second->time) : std::nullopt);
        }
        Outcome o = groupArrivesTogether(arrivals, kGroupSpread);
        o.values["spread"] = o.check.value;
        return o;
    }
    static constexpr double kGroupSpread = 10;  ///< s (docs/verification/iso.md, iso-groups)
};

/// Adds the SocialGroups force (every parameter at its default) to policy id 0 as a step of its
/// own, so that it works with any model: force-based, velocity-based (its acceleration is added to
/// the model's) or SPH's fine steps.
void addGroupForce(ch::ScenarioSpec& spec) {
    const ch::ComponentInfo* info = ch::Registry::instance().find("SocialGroups");
    if (info == nullptr) throw std::runtime_error("the SocialGroups force is not registered");
    ch::ComponentSpec c;
    c.name = info->name;
    c.params = ch::ParamSet(ch::Registry::fullTable(*info));
    ch::StepSpec step;
    step.timing = ch::StepTiming::Coarse;
    step.method = ch::OptimisationMethod::Gradient;
    step.stopAtGoal = true;
    step.components.push_back(std::move(c));
    for (ch::PolicySpec& p : spec.policies)
        if (p.id == 0) p.steps.push_back(step);
}

}  // namespace

void addIsoTests(std::vector<TestDef>& t) {
    const std::set<std::string> all = allModels();
    TestDef d;

    d = {};
    d.id = "iso-corridor";
    d.title = "ISO/NIST: speed in a corridor (40 m at 1.0 m/s +-0.05)";
    d.unit = "m/s";
    d.decimals = 3;
    d.criterion = "40 m / travel time (from standing) of one person at 1.0 m/s within 1.0 +- 0.05 m/s";
    d.failureMeans = "the model does not keep a lone person at its preferred speed";
    d.source = "ISO 20414 / NIST TN 1822";
    d.claimed = all;
    d.quickModel = "ORCA";
    d.variants = {Variant{"", "iso-corridor.xml", nullptr, true}};
    d.observer = [](const RunContext&) { return std::make_unique<CorridorObserver>(); };
    t.push_back(d);

    d = {};
    d.id = "iso-premovement-ks";
    d.title = "ISO/NIST: premovement distributions (Kolmogorov-Smirnov)";
    d.unit = "D";
    d.decimals = 3;
    d.criterion = "for uniform(10, 100), normal(55, 15) in [10, 100] and lognormal(ln 40, 0.4) up to 150 s: nobody "
                  "starts walking before its premovement (0.1 s tolerance), everyone starts, and the KS test of the "
                  "100 start times against the distribution does not reject at 5 % (D <= 0.134); value: the largest D";
    d.failureMeans = "start times do not follow the requested distribution (premovement not honoured, or people held up)";
    d.source = "ISO 20414 / NIST TN 1822";
    d.claimed = all;
    d.quickModel = "SocialForces";
    for (const auto& [file, ref] : premovementVariants()) {
        const std::string label = file.substr(16, file.size() - 20);  // "uniform", "normal", "lognormal"
        d.variants.push_back(Variant{label, file,
                                     [](ch::ScenarioSpec& s, const RunContext& ctx) {
                                         if (ctx.quick) keepFirstAgents(s, 40);
                                     },
                                     true});
    }
    d.observer = [](const RunContext& ctx) {
        return std::make_unique<PremovementKsObserver>(premovementVariants().at(ctx.variant).second);
    };
    d.combine = [](const std::vector<const Outcome*>& o, const RunContext&) {
        Check c{true, 0, ""};
        for (std::size_t v = 0; v < o.size(); ++v) {
            const std::string label = premovementVariants().at(v).first;
            c.pass = c.pass && o[v]->check.pass;
            if (!std::isnan(o[v]->check.value)) c.value = std::max(c.value, o[v]->check.value);
            c.detail += (v ? "; " : "") + label.substr(16, label.size() - 20) + ": " + o[v]->check.detail;
        }
        return c;
    };
    t.push_back(d);

    static const Reference speedRef{Reference::Kind::Normal, 1.2, 0.2, 0, 1e300};
    d = {};
    d.id = "iso-demographics";
    d.title = "ISO/NIST: demographics N(1.2, 0.2) m/s";
    d.unit = "D";
    d.decimals = 3;
    d.criterion = "100 free walking speeds (x 5-25 m, preferred speeds drawn from N(1.2, 0.2)): the KS test against "
                  "N(1.2, 0.2) does not reject at 5 % (D <= 0.134); value: D";
    d.failureMeans = "the model changes free walking speeds (or the draws do not follow the distribution)";
    d.source = "ISO 20414 / NIST TN 1822";
    // Karamouzas too since its model file adds the preferred velocity to its samples (before, its
    // speeds lay on UMANS' sampling grid: docs/verification/iso.md, models.md).
    d.claimed = all;
    d.quickModel = "PowerLaw";
    d.variants = {Variant{"", "iso-demographics.xml",
                          [](ch::ScenarioSpec& s, const RunContext& ctx) {
                              if (ctx.quick) keepFirstAgents(s, 40);
                          },
                          true}};
    d.observer = [](const RunContext&) { return std::make_unique<SpeedKsObserver>(speedRef); };
    d.figure = [](const FigureInput& in, const std::filesystem::path& png) { return drawSpeeds(in, png, speedRef); };
    t.push_back(d);

    d = {};
    d.id = "iso-counterflow";
    d.title = "ISO/NIST: counter-flow";
    d.unit = "s";
    d.decimals = 1;
    d.criterion = "10 m x 2 m corridor between two rooms: the time for all 100 to cross rises strictly from 0 to 10, "
                  "50 and 100 opposite persons; a gridlock fails; value: the smallest rise";
    d.failureMeans = "counter-flow does not slow the crowd (people pass through each other) or the model gridlocks";
    d.source = "ISO 20414 / NIST TN 1822";
    // Only SPH rises strictly on every seed; the others gridlock or cross faster against more
    // people in some seed (Karamouzas since its preferred-velocity sample: seed 1 116.3 s against
    // 100, 119.5 s against 50; docs/verification/iso.md).
    d.claimed = {"SPH"};
    d.quickModel = "SocialForces-venue";
    for (std::size_t v = 0; v < kOpposite.size(); ++v)
        d.variants.push_back(Variant{std::to_string(kOpposite[v]) + " opposite", "iso-counterflow.xml",
                                     [v](ch::ScenarioSpec& s, const RunContext& ctx) {
                                         std::size_t n = static_cast<std::size_t>(kOpposite[v]);
                                         if (ctx.quick) {
                                             keepNearest(s, "to-east", 30, ch::Vec2(0, 5));
                                             n = n * 3 / 10;
                                         }
                                         keepNearest(s, "to-west", n, ch::Vec2(10, 5));
                                     },
                                     true});
    d.observer = [](const RunContext&) { return std::make_unique<CounterflowObserver>(); };
    d.combine = [](const std::vector<const Outcome*>& o, const RunContext&) {
        std::vector<std::optional<double>> times;
        for (const Outcome* x : o) {
            const auto it = x->values.find("last");
            times.push_back(it != x->values.end() ? std::optional<double>(it->second) : std::nullopt);
        }
        return risingCrossingTimes(times, kOpposite);
    };
    d.figure = drawCounterflow;
    t.push_back(d);

    d = {};
    d.id = "iso-groups";
    d.title = "ISO/NIST: groups arrive together";
    d.unit = "s";
    d.decimals = 1;
    d.criterion = "one group of 15 (5 at 1.25 m/s, 10 at 0.5 m/s) walks 40 m with the SocialGroups force added to the "
                  "model: all arrive, the first and the last within 10 s (alone: about 48 s apart); value: the spread; "
                  "the detail also gives the spread without the force";
    d.failureMeans = "the group force does not hold the group together with this model (or someone is stuck)";
    d.source = "ISO 20414 / NIST TN 1822 (groups); Moussaid et al. 2010 (the group force)";
    // Claimed where every seed passes. The others keep the group within 11-13 s of arrivals
    // (45-50 s without the force) but not within 10 s: Moussaid's coherence acts only beyond
    // (N - 1)/2 = 7 m from the centre, so a group of 15 may stretch over 14 m; ORCA 25-27 s
    // (docs/verification/iso.md).
    d.claimed = {"Karamouzas", "SPH"};
    d.quickModel = "SPH";
    d.variants.push_back(Variant{"with SocialGroups", "iso-groups.xml",
                                 [](ch::ScenarioSpec& s, const RunContext&) { addGroupForce(s); }, true});
    d.variants.push_back(Variant{"without", "iso-groups.xml", nullptr, true});
    d.observer = [](const RunContext&) { return std::make_unique<GroupObserver>(); };
    d.combine = [](const std::vector<const Outcome*>& o, const RunContext&) {
        Check c = o.at(0)->check;
        if (o.size() > 1) c.detail += "; without the group force: spread " + fixedText(o[1]->check.value, 1) + " s";
        return c;
    };
    t.push_back(d);
}

}  // namespace chverify
