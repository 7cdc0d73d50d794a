// crowdhealth — shared by the renderer and the viewer (see render_scene.h).
#include "render_scene.h"

#include "crowdhealth/health/health.h"

#include <crowdhealth/io/diagnostics.h>
#include <crowdhealth/io/json.h>
#include <crowdhealth/io/xml.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>

namespace chrender {

Rgb densityColour(double rho) {
    if (!std::isfinite(rho)) rho = 0;
    const double pi = std::numbers::pi;
    const double d = std::min(5 * pi / 4, 5 * pi * rho / 32);
    Rgb c;
    c.r = std::max(0.0, -std::cos(d));
    c.g = std::max(0.0, std::sin(d));
    c.b = rho < 4 ? std::cos(d) : -std::sin(d);
    c.b = std::clamp(c.b, 0.0, 1.0);
    return c;
}

Rgb heatColour(double x) {
    if (!std::isfinite(x)) x = 0;
    x = std::clamp(x, 0.0, 1.0);
    const double pi = std::numbers::pi;
    Rgb c;
    c.r = std::sqrt(x);
    c.g = x * x * x;
    c.b = std::clamp(std::sin(2 * pi * x), 0.0, 1.0);
    return c;
}

std::optional<Colouring> parseColouring(const std::string& name) {
    if (name == "density") return Colouring::Density;
    if (name == "contact") return Colouring::Contact;
    if (name == "panic") return Colouring::Panic;
    if (name == "injury") return Colouring::Injury;
    if (name == "none") return Colouring::None;
    return std::nullopt;
}

std::string colouringName(Colouring c) {
    switch (c) {
        case Colouring::Density: return "density";
        case Colouring::Contact: return "contact";
        case Colouring::Panic: return "panic";
        case Colouring::Injury: return "injury";
        case Colouring::None: return "none";
    }
    return "none";
}

std::string colouringLabel(Colouring c) {
    switch (c) {
        case Colouring::Density: return "SPH density (1/m²)";
        case Colouring::Contact: return "contact acceleration (m/s²)";
        case Colouring::Panic: return "panic (0..1)";
        case Colouring::Injury: return "injury (0..1)";
        case Colouring::None: return "";
    }
    return "";
}

std::optional<ch::ScenarioSpec> loadForDisplay(const std::string& path, std::ostream& err) {
    ch::Diagnostics diags;
    std::optional<ch::ScenarioSpec> spec;
    try {
        spec = ch::loadScenario(path, diags);
    } catch (const std::exception& e) {
        diags.error(ch::SourceLoc{path, 0}, std::string("cannot load the scenario: ") + e.what());
    }
    diags.print(err);
    if (!spec || diags.hasErrors()) {
        if (!diags.hasErrors()) err << path << ": error: the scenario could not be loaded\n";
        return std::nullopt;
    }
    return spec;
}

Box sceneBounds(const ch::ScenarioSpec& spec) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    auto add = [&](const ch::Vec2& p) {
        if (!std::isfinite(p.x()) || !std::isfinite(p.y())) return;
        x0 = std::min(x0, p.x()); x1 = std::max(x1, p.x());
        y0 = std::min(y0, p.y()); y1 = std::max(y1, p.y());
    };
    for (const auto& o : spec.obstacles)
        for (const auto& p : o.points) add(p);
    for (const auto& a : spec.agents) {
        add(a.position);
        if (a.goal) add(*a.goal);
    }
    for (const ch::TargetSpec& t : spec.venue.targets) {  // targets and exits of a venue
        const auto b = t.shape.bounds();
        add(b.lo);
        add(b.hi);
    }
    if (spec.world.type == ch::WorldType::Planar) {
        add({spec.world.xmin, spec.world.ymin});
        add({spec.world.xmax, spec.world.ymax});
    } else if (spec.world.type == ch::WorldType::Toric) {
        add({-spec.world.width / 2, -spec.world.height / 2});
        add({spec.world.width / 2, spec.world.height / 2});
    }
    if (x0 > x1) { x0 = -10; x1 = 10; y0 = -10; y1 = 10; }
    return Box{x0 - 1, x1 + 1, y0 - 1, y1 + 1};
}

std::vector<GoalMark> goalMarks(const ch::ScenarioSpec& spec) {
    std::vector<GoalMark> marks;
    for (const auto& a : spec.agents) {
        if (!a.goal) continue;
        const double r = a.goalRadius >= 0 ? a.goalRadius : a.radius;
        auto it = std::find_if(marks.begin(), marks.end(),
                               [&](const GoalMark& m) { return (m.position - *a.goal).norm() < 1e-9; });
        if (it == marks.end()) marks.push_back({*a.goal, r});
        else it->radius = std::max(it->radius, r);
    }
    return marks;
}

std::optional<ch::ScenarioSpec> loadRunScenario(const std::filesystem::path& dir, std::string& error,
                                                std::ostream& diagnostics) {
    namespace fs = std::filesystem;
    const fs::path summary = dir / "summary.json";
    if (!fs::is_directory(dir) || !fs::exists(summary)) {
        error = dir.string() + " is not a run folder (no summary.json); give the -o folder of `crowdhealth -i … -o …`";
        return std::nullopt;
    }
    // Through the JSON library: a broken summary.json is reported with its path and what is wrong.
    ch::Json json;
    try {
        json = ch::readJsonFile(summary);
    } catch (const ch::JsonError& e) {
        error = e.what();
        return std::nullopt;
    }
    const auto scenarioIt = json.is_object() ? json.find("scenario") : json.end();
    if (scenarioIt == json.end() || !scenarioIt->is_string() || scenarioIt->get<std::string>().empty()) {
        error = summary.string() + " names no \"scenario\" (a string)";
        return std::nullopt;
    }
    const fs::path named(scenarioIt->get<std::string>());
    fs::path path = named;
    if (named.is_relative() && !fs::exists(named)) {
        // DIR itself, then the folder holding it (a run started beside its -o folder), also
        // when DIR is given as "." or with a trailing '/'.
        std::error_code ec;
        fs::path absolute = fs::weakly_canonical(fs::absolute(dir), ec);
        if (ec) absolute = fs::absolute(dir);
        for (const fs::path& base : {dir, absolute.parent_path()})
            if (fs::exists(base / named)) {
                path = base / named;
                break;
            }
    }
    if (!fs::exists(path)) {
        error = "the run's scenario " + named.string() +
                " (from summary.json) does not exist here; run from the folder the run was started in";
        return std::nullopt;
    }
    // The same seed, so generated agents get the radii they had in the run.
    ch::LoadOptions lo;
    if (const auto seed = json.find("seed"); seed != json.end() && !seed->is_null()) {
        if (!seed->is_number_unsigned()) {
            error = summary.string() + ": \"seed\" should be a whole number from 0 to 18446744073709551615, not " +
                    seed->dump();
            return std::nullopt;
        }
        lo.seed = seed->get<std::uint64_t>();
    }
    ch::Diagnostics diags;
    std::optional<ch::ScenarioSpec> spec;
    try {
        spec = ch::loadScenario(path.string(), diags, lo);
    } catch (const std::exception& e) {
        diags.error(ch::SourceLoc{path.string(), 0}, e.what());
    }
    diags.print(diagnostics);
    if (!spec || diags.hasErrors()) {
        error = "the run's scenario " + path.string() + " does not load";
        return std::nullopt;
    }
    return spec;
}

bool VenueMark::openAt(double t) const {
    bool open = true;
    for (const auto& [time, opens] : events)
        if (time <= t + 1e-9) open = opens;
    return open;
}

std::vector<VenueMark> venueMarks(const ch::ScenarioSpec& spec) {
    std::vector<VenueMark> marks;
    for (const ch::TargetSpec& t : spec.venue.targets) {
        VenueMark m;
        m.name = t.name;
        m.exit = t.exit;
        m.point = t.shape.kind == ch::TargetShape::Kind::Point;
        if (m.point) {
            m.centre = t.shape.point;
            m.radius = t.shape.radius;
        } else {
            m.outline = t.shape.polygon;
            m.centre = t.shape.centre();
        }
        for (const ch::ExitEventSpec& e : spec.venue.exitEvents)
            if (e.exit == t.name) m.events.emplace_back(e.time, e.open);
        // Events in time order; at equal times the file order stands (as Navigation applies them).
        std::stable_sort(m.events.begin(), m.events.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
        marks.push_back(std::move(m));
    }
    return marks;
}

std::vector<double> agentValues(ch::Simulation& sim, Colouring c) {
    const ch::AgentStore& a = sim.agents();
    std::vector<double> v(a.size(), 0.0);
    switch (c) {
        case Colouring::Density:
            sim.measureDensity(1.0);
            v = a.density;
            break;
        case Colouring::Contact:
            for (std::size_t i = 0; i < a.size(); ++i) v[i] = a.contactAccel[i].norm();
            break;
        case Colouring::Panic:  // level 0..1
            for (std::size_t i = 0; i < a.size(); ++i) v[i] = sim.health().recordOf(a, i).panic;
            break;
        case Colouring::Injury:  // 1 once injured
            for (std::size_t i = 0; i < a.size(); ++i) v[i] = sim.health().recordOf(a, i).injured() ? 1.0 : 0.0;
            break;
        case Colouring::None: break;
    }
    return v;
}

}  // namespace chrender
