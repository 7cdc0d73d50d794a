// CrowdHealth — XML loader: the venue (docs/navigation.md). <Navigation>, <Target>, <Exit>,
// <ExitSet>, <Journey> in <World>; <Source> in <Agents>; <CloseExit>/<OpenExit> in <Schedule>;
// and the checks that need all of them (names, reachability), then the expansion of sources.
#include "crowdhealth/core/world.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/navigation/field.h"
#include "crowdhealth/navigation/navigation.h"

#include "xml_internal.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include <unistd.h>

namespace ch::xmlio {

namespace {

const ParamTable& navigationTable() {
    static const ParamTable t = [] {
        const NavigationSpec d;
        ParamTable table = {
            ParamSpec::real("cell_size", "m", d.grid.cellSize, 0.01, 10, "side of a cell of the navigation grid"),
            ParamSpec::real("clearance", "m", d.grid.clearance, 0, 10, "paths keep this far from walls where there is room"),
            ParamSpec::real("min_speed", "-", d.grid.minSpeed, 0, 1, "relative travel speed at a wall (path cost near walls)"),
            ParamSpec::real("margin", "m", d.margin, 0, 1000, "Infinite worlds: the grid spans everything plus this margin"),
        };
        table[2].minExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& targetTable(bool exit) {
    static const auto make = [](bool isExit) {
        ParamTable table = {
            ParamSpec::real("x", "m", 0, -1e300, 1e300, "point target: x"),
            ParamSpec::real("y", "m", 0, -1e300, 1e300, "point target: y"),
            ParamSpec::real("radius", "m", 0.5, 0, 1e300, "point target: reached within this distance"),
            ParamSpec::real("xmin", "m", 0, -1e300, 1e300, "rectangle: lower x"),
            ParamSpec::real("xmax", "m", 0, -1e300, 1e300, "rectangle: upper x"),
            ParamSpec::real("ymin", "m", 0, -1e300, 1e300, "rectangle: lower y"),
            ParamSpec::real("ymax", "m", 0, -1e300, 1e300, "rectangle: upper y"),
        };
        table[2].minExclusive = true;
        if (isExit) {
            ParamSpec w = ParamSpec::real("width", "m", 0, 0, 1e300, "clear width (quickest rule); absent: the longer side");
            w.minExclusive = true;
            table.push_back(w);
        }
        return table;
    };
    static const ParamTable target = make(false), exitTable = make(true);
    return exit ? exitTable : target;
}

const ParamTable& exitSetTable() {
    static const ParamTable t = [] {
        const ExitSetSpec d;
        ParamTable table = {
            ParamSpec::choice("choice", {"nearest", "quickest", "fixed", "weighted"}, 0, "rule that picks an exit"),
            ParamSpec::real("interval", "s", d.interval, 0, 1e300, "quickest: time between re-evaluations"),
            ParamSpec::real("hysteresis", "-", d.hysteresis, 0, 1, "quickest: switch only when this much quicker"),
            ParamSpec::real("flow_capacity", "P/(m*s)", d.flowCapacity, 0, 100, "quickest: specific flow through an exit"),
        };
        table[1].minExclusive = table[3].minExclusive = table[2].maxExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& waypointTable() {
    static const ParamTable t = {
        ParamSpec::real("dwell", "s", 0, 0, 1e300, "time spent inside the target before going on"),
        ParamSpec::integer("capacity", 0, 0, 1e9, "people inside at once (0 = unlimited)"),
    };
    return t;
}

const ParamTable& sourceTable() {
    static const ParamTable t = [] {
        const SourceSpec d;
        const AgentSpec a;
        ParamTable table = {
            ParamSpec::real("xmin", "m", 0, -1e300, 1e300, "area: lower x"),
            ParamSpec::real("xmax", "m", 0, -1e300, 1e300, "area: upper x"),
            ParamSpec::real("ymin", "m", 0, -1e300, 1e300, "area: lower y"),
            ParamSpec::real("ymax", "m", 0, -1e300, 1e300, "area: upper y"),
            ParamSpec::real("rate", "P/s", d.rate, 0, 1e6, "arrivals per second (without <Rate> children)"),
            ParamSpec::real("start", "s", 0, 0, 1e300, "first arrival"),
            ParamSpec::real("end", "s", 0, 0, 1e300, "no arrival after this time"),
            ParamSpec::integer("count", 0, 0, 1e7, "agents in all"),
            ParamSpec::real("rad", "m", a.radius, 0, 10, "body radius (unless drawn)"),
            ParamSpec::real("pref_speed", "m/s", a.prefSpeed, 0, 20, "preferred speed (unless drawn)"),
            ParamSpec::real("max_speed", "m/s", a.maxSpeed, 0, 20, "speed limit (unless drawn; at least pref_speed)"),
            ParamSpec::real("premovement", "s", 0, 0, 1e300, "time standing before walking (unless drawn)"),
            ParamSpec::real("max_acceleration", "m/s2", a.maxAcceleration, 0, 1e300, "acceleration limit"),
            ParamSpec::boolean("remove_at_goal", d.removeAtGoal, "a plain <goal>: remove the agent there"),
            // Groups of 2-20 as Agent@group and AgentGrid@group_size (xml.cpp's assignGroups).
            ParamSpec::integer("group_size_min", 2, 2, 20, "smallest group drawn (with group_size_max)"),
            ParamSpec::integer("group_size_max", 2, 2, 20, "largest group drawn (with group_size_min)"),
            ParamSpec::real("group_share", "-", d.groupShare, 0, 1, "fraction of the arrivals that come in groups"),
        };
        table[4].minExclusive = table[8].minExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& rateTable() {
    static const ParamTable t = {
        ParamSpec::real("time", "s", 0, 0, 1e300, "from this time on …"),
        ParamSpec::real("value", "P/s", 0, 0, 1e6, "… arrivals per second"),
    };
    return t;
}

const ParamTable& drawTable() {
    static const ParamTable t = {
        ParamSpec::choice("attribute", {"rad", "pref_speed", "max_speed", "premovement"}, 0, "the attribute drawn"),
        ParamSpec::choice("distribution", {"constant", "uniform", "normal", "lognormal"}, 0, "its distribution"),
        ParamSpec::real("value", "-", 0, -1e300, 1e300, "constant: the value (attribute's unit)"),
        ParamSpec::real("min", "-", 0, -1e300, 1e300, "uniform: lower bound; normal, lognormal: truncation"),
        ParamSpec::real("max", "-", 0, -1e300, 1e300, "uniform: upper bound; normal, lognormal: truncation"),
        ParamSpec::real("mean", "-", 0, -1e300, 1e300, "normal: mean"),
        ParamSpec::real("sd", "-", 0, 0, 1e300, "normal: standard deviation"),
        // e^20 ≈ 5e8 in the attribute's unit: far beyond any radius, speed or premovement.
        ParamSpec::real("mu", "-", 0, -20, 20, "lognormal: mean of the natural log of the value"),
        ParamSpec::real("sigma", "-", 0, 0, 5, "lognormal: standard deviation of the natural log"),
    };
    return t;
}

const ParamTable& exitEventTable() {
    static const ParamTable t = {ParamSpec::real("time", "s", 0, 0, 1e300, "when the exit closes or opens")};
    return t;
}

/// The element's `id` (required, non-empty) or nullopt (reported).
std::optional<std::string> readName(ElementReader& r, const char* what) {
    std::optional<std::string> id = r.text("id");
    if (!id || id->empty()) {
        r.error(r.loc(), std::string(what) + ": missing required attribute id (its name)");
        return std::nullopt;
    }
    // Names are listed in attributes separated by spaces or commas, and written into CSV files.
    if (id->find_first_of(" \t\r\n,\"") != std::string::npos) {
        r.error(r.loc("id"), std::string(what) + "@id: '" + *id + "' must not contain spaces, commas or quotes");
        return std::nullopt;
    }
    return id;
}

/// Space- or comma-separated words.
std::vector<std::string> words(const std::string& text) {
    std::string t = text;
    std::replace(t.begin(), t.end(), ',', ' ');
    std::istringstream in(t);
    std::vector<std::string> out;
    for (std::string w; in >> w;) out.push_back(w);
    return out;
}

/// A rectangle as a counter-clockwise polygon.
std::vector<Vec2> rectangle(double xmin, double xmax, double ymin, double ymax) {
    return {Vec2(xmin, ymin), Vec2(xmax, ymin), Vec2(xmax, ymax), Vec2(xmin, ymax)};
}

/// Reads the area of an element: xmin/xmax/ymin/ymax or ≥ 3 <Point> children (collected by the
/// caller in `points`). Returns the polygon (empty when reported broken or absent).
std::vector<Vec2> readArea(ElementReader& r, const std::vector<Vec2>& points, int pointElements, const char* what,
                           bool required) {
    const bool rect = r.has("xmin") || r.has("xmax") || r.has("ymin") || r.has("ymax");
    if (rect && pointElements > 0) {
        r.error(r.loc(), std::string(what) + ": give either xmin/xmax/ymin/ymax or <Point> children, not both");
        return {};
    }
    if (rect) {
        const auto xmin = r.required("xmin"), xmax = r.required("xmax"), ymin = r.required("ymin"), ymax = r.required("ymax");
        if (!xmin || !xmax || !ymin || !ymax) return {};
        if (*xmin >= *xmax) r.error(r.loc("xmax"), std::string(what) + ": xmin must be less than xmax");
        if (*ymin >= *ymax) r.error(r.loc("ymax"), std::string(what) + ": ymin must be less than ymax");
        if (*xmin >= *xmax || *ymin >= *ymax) return {};
        return rectangle(*xmin, *xmax, *ymin, *ymax);
    }
    if (pointElements > 0) {
        if (pointElements < 3) {
            r.error(r.loc(), std::string(what) + ": a polygon needs at least 3 <Point> elements, found " +
                                 std::to_string(pointElements));
            return {};
        }
        if (static_cast<int>(points.size()) != pointElements) return {};
        if (std::abs(polygonArea(points)) <= 0) {
            r.error(r.loc(), std::string(what) + ": the polygon has no area");
            return {};
        }
        return points;
    }
    if (required) r.error(r.loc(), std::string(what) + ": needs an area: xmin, xmax, ymin, ymax or <Point> children");
    return {};
}

void remember(LoadContext& ctx, const std::string& kind, const std::string& name, const SourceLoc& loc, ElementReader& r) {
    auto [it, inserted] = ctx.venueLocs.emplace(kind + ":" + name, loc);
    if (!inserted)
        r.error(loc, "duplicate " + kind + " name '" + name + "' (first defined at " + it->second.file + ":" +
                         std::to_string(it->second.line) + ")");
}

}  // namespace

void readNavigation(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Navigation", navigationTable());
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    if (ctx.spec.venue.navigation) {
        r.error(r.loc(), "more than one <Navigation> (the first is at line " +
                             std::to_string(ctx.spec.venue.navigation->loc.line) + ")");
        return;
    }
    NavigationSpec n;
    n.loc = r.loc();
    n.grid.cellSize = r.value("cell_size");
    n.grid.clearance = r.value("clearance");
    n.grid.minSpeed = r.value("min_speed");
    n.margin = r.value("margin");
    ctx.spec.venue.navigation = n;
}

void readTarget(LoadContext& ctx, const std::string& file, const XMLElement* el, bool exit) {
    const char* what = exit ? "Exit" : "Target";
    ElementReader r(ctx, file, el, what, targetTable(exit), {"id"});
    std::vector<Vec2> points;
    int pointElements = 0;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (!is(c, "Point")) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Point"});
            continue;
        }
        ++pointElements;
        if (std::optional<Vec2> p = readPoint(ctx, file, c, "Point")) points.push_back(*p);
    }
    TargetSpec t;
    t.loc = r.loc();
    t.exit = exit;
    const std::optional<std::string> name = readName(r, what);
    if (name) {
        t.name = *name;
        remember(ctx, "target", t.name, t.loc, r);
    }
    const bool point = r.has("x") || r.has("y");
    if (point) {
        if (pointElements > 0 || r.has("xmin") || r.has("xmax") || r.has("ymin") || r.has("ymax")) {
            r.error(r.loc(), std::string(what) + ": give one shape: x/y (a point), xmin/xmax/ymin/ymax (a rectangle) "
                                                 "or <Point> children (a polygon)");
            return;
        }
        const auto x = r.required("x"), y = r.required("y");
        if (!x || !y) return;
        t.shape.kind = TargetShape::Kind::Point;
        t.shape.point = Vec2(*x, *y);
        t.shape.radius = r.value("radius");
    } else {
        if (r.has("radius")) ctx.diags.warning(r.loc("radius"), std::string(what) + "@radius applies to a point (x, y) only; ignored");
        t.shape.kind = TargetShape::Kind::Polygon;
        t.shape.polygon = readArea(r, points, pointElements, what, true);
        if (t.shape.polygon.empty()) return;
    }
    if (exit) t.width = r.has("width") ? r.value("width") : 0.0;
    if (!r.failed() && name) ctx.spec.venue.targets.push_back(std::move(t));
}

void readExitSet(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "ExitSet", exitSetTable(), {"id", "exits", "weights", "fixed"});
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    ExitSetSpec s;
    s.loc = r.loc();
    const std::optional<std::string> name = readName(r, "ExitSet");
    if (name) {
        s.name = *name;
        remember(ctx, "exit set", s.name, s.loc, r);
    }
    s.choice = static_cast<ExitChoice>(static_cast<int>(r.value("choice")));
    s.interval = r.value("interval");
    s.hysteresis = r.value("hysteresis");
    s.flowCapacity = r.value("flow_capacity");
    s.exits = words(r.text("exits").value_or(""));
    if (s.exits.empty()) r.error(r.loc("exits"), "ExitSet: exits must name at least one <Exit> (exits=\"a b …\")");
    if (std::optional<std::string> w = r.text("weights")) {
        if (s.choice != ExitChoice::Weighted)
            ctx.diags.warning(r.loc("weights"), "ExitSet@weights applies to choice=\"weighted\" only; ignored");
        for (const std::string& word : words(*w)) {
            char* end = nullptr;
            const double v = std::strtod(word.c_str(), &end);
            if (end == word.c_str() || *end != '\0' || !std::isfinite(v) || v < 0) {
                r.error(r.loc("weights"), "ExitSet@weights: '" + word + "' is not a number ≥ 0");
                continue;
            }
            s.weights.push_back(v);
        }
        if (!r.failed() && s.weights.size() != s.exits.size())
            r.error(r.loc("weights"), "ExitSet@weights: " + std::to_string(s.weights.size()) + " weights for " +
                                          std::to_string(s.exits.size()) + " exits");
        double sum = 0;
        for (double v : s.weights) sum += v;
        if (!r.failed() && !(sum > 0)) r.error(r.loc("weights"), "ExitSet@weights: at least one weight must be positive");
    } else if (s.choice == ExitChoice::Weighted) {
        r.error(r.loc(), "ExitSet: choice=\"weighted\" needs weights=\"…\", one per exit");
    }
    s.fixed = r.text("fixed").value_or("");
    if (s.choice == ExitChoice::Fixed) {
        if (s.fixed.empty()) r.error(r.loc(), "ExitSet: choice=\"fixed\" needs fixed=\"EXIT\", one of its exits");
        else if (std::find(s.exits.begin(), s.exits.end(), s.fixed) == s.exits.end())
            r.error(r.loc("fixed"), "ExitSet@fixed: '" + s.fixed + "' is not one of its exits");
    } else if (!s.fixed.empty()) {
        ctx.diags.warning(r.loc("fixed"), "ExitSet@fixed applies to choice=\"fixed\" only; ignored");
    }
    if (!r.failed() && name) ctx.spec.venue.exitSets.push_back(std::move(s));
}

void readJourney(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    static const ParamTable none;
    ElementReader r(ctx, file, el, "Journey", none, {"id", "leave_by"});
    JourneySpec j;
    j.loc = r.loc();
    const std::optional<std::string> name = readName(r, "Journey");
    if (name) {
        j.name = *name;
        remember(ctx, "journey", j.name, j.loc, r);
    }
    j.leaveBy = r.text("leave_by").value_or("");
    bool broken = false;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (!is(c, "Waypoint")) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Waypoint"});
            continue;
        }
        ElementReader w(ctx, file, c, "Waypoint", waypointTable(), {"target"});
        for (const XMLElement* g = c->FirstChildElement(); g != nullptr; g = g->NextSiblingElement())
            reportUnexpectedElement(ctx, file, g, c->Name(), {});
        WaypointSpec wp;
        wp.loc = w.loc();
        wp.target = w.text("target").value_or("");
        if (wp.target.empty()) w.error(w.loc(), "Waypoint: missing required attribute target (a <Target> name)");
        wp.dwell = w.value("dwell");
        wp.capacity = static_cast<int>(w.value("capacity"));
        if (wp.capacity > 0 && wp.dwell <= 0)
            ctx.diags.warning(w.loc("capacity"), "Waypoint: a capacity without a dwell time lets people through one at "
                                                 "a time without stopping");
        broken = broken || w.failed();
        j.waypoints.push_back(std::move(wp));
    }
    if (j.waypoints.empty() && j.leaveBy.empty())
        r.error(r.loc(), "Journey: needs at least one <Waypoint> or leave_by=\"EXIT or EXITSET\"");
    if (!r.failed() && !broken && name) ctx.spec.venue.journeys.push_back(std::move(j));
}

void readSource(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Source", sourceTable(), {"id", "journey"});
    SourceSpec s;
    s.loc = r.loc();
    s.name = r.text("id").value_or("source " + std::to_string(ctx.spec.venue.sources.size() + 1));
    s.journey = r.text("journey").value_or("");
    if (!s.journey.empty()) ctx.journeyRefs.push_back({s.journey, r.loc("journey")});
    s.rate = r.value("rate");
    s.start = r.value("start");
    s.end = r.has("end") ? r.value("end") : kInf;
    s.count = r.has("count") ? static_cast<int>(r.value("count")) : -1;
    s.maxAcceleration = r.value("max_acceleration");
    s.removeAtGoal = r.value("remove_at_goal") != 0.0;
    s.radius.value = r.value("rad");
    s.prefSpeed.value = r.value("pref_speed");
    s.maxSpeed.value = r.value("max_speed");
    s.premovement.value = r.value("premovement");
    if (s.end < s.start) r.error(r.loc("end"), "Source: end must not be before start");
    // Groups: both sizes or neither; a share only with sizes.
    const bool groupMin = r.has("group_size_min"), groupMax = r.has("group_size_max");
    if (groupMin || groupMax) {
        const auto lo = r.required("group_size_min"), hi = r.required("group_size_max");
        if (lo && hi) {
            if (*lo > *hi)
                r.error(r.loc("group_size_max"), "Source: group_size_min (" + formatNumber(*lo) +
                                                     ") must not exceed group_size_max (" + formatNumber(*hi) +
                                                     "); give them equal for groups of one size");
            s.groupSizeMin = static_cast<int>(*lo);
            s.groupSizeMax = static_cast<int>(*hi);
        }
    }
    if (r.has("group_share")) {
        s.groupShare = r.value("group_share");
        if (!groupMin && !groupMax)
            r.error(r.loc("group_share"), "Source@group_share: nobody arrives in a group without group_size_min and "
                                          "group_size_max; give the group sizes too");
    }
    std::vector<Vec2> points;
    int pointElements = 0;
    bool hasPolicy = false, hasGoal = false;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "Point")) {
            ++pointElements;
            if (std::optional<Vec2> p = readPoint(ctx, file, c, "Point")) points.push_back(*p);
        } else if (is(c, "Policy") && !hasPolicy) {
            hasPolicy = true;
            if (std::optional<int> p = readPolicyRef(ctx, file, c)) s.policyId = *p;
        } else if (is(c, "goal") && !hasGoal) {
            hasGoal = true;
            s.goal = readPoint(ctx, file, c, "goal");
        } else if (is(c, "Rate")) {
            ElementReader rr(ctx, file, c, "Rate", rateTable());
            const auto time = rr.required("time"), value = rr.required("value");
            if (time && value) {
                if (!s.table.empty() && *time <= s.table.back().first)
                    rr.error(rr.loc("time"), "Rate: times must increase (the previous <Rate> is at " +
                                                 std::to_string(s.table.back().first) + " s)");
                s.table.push_back({*time, *value});
            }
        } else if (is(c, "Draw")) {
            ElementReader d(ctx, file, c, "Draw", drawTable());
            if (!d.has("attribute")) {
                d.error(d.loc(), "Draw: missing required attribute attribute (rad, pref_speed, max_speed or premovement)");
                continue;
            }
            DrawSpec* target[] = {&s.radius, &s.prefSpeed, &s.maxSpeed, &s.premovement};
            DrawSpec& spec = *target[static_cast<int>(d.value("attribute"))];
            spec.kind = static_cast<DrawSpec::Kind>(static_cast<int>(d.value("distribution")));
            switch (spec.kind) {
                case DrawSpec::Kind::Constant:
                    if (auto v = d.required("value")) spec.value = *v;
                    break;
                case DrawSpec::Kind::Uniform: {
                    const auto lo = d.required("min"), hi = d.required("max");
                    if (lo && hi) {
                        if (*lo > *hi) d.error(d.loc("max"), "Draw: min must not exceed max");
                        spec.min = *lo;
                        spec.max = *hi;
                    }
                    break;
                }
                case DrawSpec::Kind::Normal: {
                    const auto mean = d.required("mean"), sd = d.required("sd");
                    if (mean) spec.mean = *mean;
                    if (sd) spec.sd = *sd;
                    spec.min = d.has("min") ? d.value("min") : -1e300;
                    spec.max = d.has("max") ? d.value("max") : 1e300;
                    if (spec.min > spec.max) d.error(d.loc("max"), "Draw: min must not exceed max");
                    break;
                }
                case DrawSpec::Kind::Lognormal: {
                    const auto mu = d.required("mu"), sigma = d.required("sigma");
                    if (mu) spec.mu = *mu;
                    if (sigma) spec.sigma = *sigma;
                    spec.min = d.has("min") ? d.value("min") : 0;
                    spec.max = d.has("max") ? d.value("max") : 1e300;
                    if (spec.min > spec.max) d.error(d.loc("max"), "Draw: min must not exceed max");
                    else if (!(spec.max > 0))
                        d.error(d.loc("max"), "Draw: lognormal values are above 0: max must be too");
                    break;
                }
            }
            // The drawn values must be valid for the attribute: radius > 0, speeds and times ≥ 0.
            // A lognormal value is above 0 whatever its truncation.
            const double lowest = spec.kind == DrawSpec::Kind::Constant    ? spec.value
                                  : spec.kind == DrawSpec::Kind::Lognormal ? std::max(spec.min, 1e-300)
                                                                           : spec.min;
            const bool radius = &spec == &s.radius;
            if (radius ? !(lowest > 0) : lowest < 0)
                d.error(d.loc(), std::string("Draw: ") + (radius ? "rad must stay above 0" : "the attribute must stay ≥ 0") +
                                     ": give min (normal: a truncation bound) accordingly");
        } else if (is(c, "Policy") || is(c, "goal")) {
            ctx.diags.error(locOf(file, c), std::string("more than one <") + c->Name() + "> in <Source>");
        } else {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Point", "Policy", "goal", "Rate", "Draw"});
        }
    }
    if (!hasPolicy) r.error(r.loc(), "Source: missing required element <Policy id=\"…\"/>");
    s.area = readArea(r, points, pointElements, "Source", true);
    if (s.count < 0 && !std::isfinite(s.end))
        r.error(r.loc(), "Source: give count (agents in all) or end (the last arrival time), or both");
    if (!r.failed()) ctx.spec.venue.sources.push_back(std::move(s));
}

void readExitEvent(LoadContext& ctx, const std::string& file, const XMLElement* el, bool open) {
    const char* what = open ? "OpenExit" : "CloseExit";
    ElementReader r(ctx, file, el, what, exitEventTable(), {"exit"});
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    ExitEventSpec e;
    e.loc = r.loc();
    e.open = open;
    e.exit = r.text("exit").value_or("");
    if (e.exit.empty()) r.error(r.loc(), std::string(what) + ": missing required attribute exit (an <Exit> name)");
    const auto time = r.required("time");
    if (time) e.time = *time;
    if (!r.failed()) ctx.spec.venue.exitEvents.push_back(std::move(e));
}

void readMeasurement(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    static const ParamTable table = [] {
        ParamTable t = {ParamSpec::real("interval", "s", MeasurementSpec{}.interval, 0, 1e6,
                                        "time between rows of flows.csv and areas.csv")};
        t[0].minExclusive = true;
        return t;
    }();
    static const ParamTable lineTable = {
        ParamSpec::real("x1", "m", 0, -1e300, 1e300, "first end: x"),
        ParamSpec::real("y1", "m", 0, -1e300, 1e300, "first end: y"),
        ParamSpec::real("x2", "m", 0, -1e300, 1e300, "second end: x"),
        ParamSpec::real("y2", "m", 0, -1e300, 1e300, "second end: y"),
    };
    static const ParamTable areaTable = {
        ParamSpec::real("xmin", "m", 0, -1e300, 1e300, "rectangle: lower x"),
        ParamSpec::real("xmax", "m", 0, -1e300, 1e300, "rectangle: upper x"),
        ParamSpec::real("ymin", "m", 0, -1e300, 1e300, "rectangle: lower y"),
        ParamSpec::real("ymax", "m", 0, -1e300, 1e300, "rectangle: upper y"),
    };
    ElementReader r(ctx, file, el, "Measurement", table);
    MeasurementSpec& m = ctx.spec.measurement;
    if (m.loc.line > 0 && !m.loc.file.empty())
        ctx.diags.warning(r.loc(), "a second <Measurement> (the first is at line " + std::to_string(m.loc.line) +
                                       "): its lines and areas are added, its interval replaces the first's");
    m.loc = r.loc();
    m.interval = r.value("interval");
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "Line")) {
            ElementReader l(ctx, file, c, "Line", lineTable, {"id"});
            for (const XMLElement* g = c->FirstChildElement(); g != nullptr; g = g->NextSiblingElement())
                reportUnexpectedElement(ctx, file, g, c->Name(), {});
            MeasureLineSpec line;
            line.loc = l.loc();
            const std::optional<std::string> name = readName(l, "Line");
            if (name) {
                line.name = *name;
                remember(ctx, "measurement", line.name, line.loc, l);
            }
            const auto x1 = l.required("x1"), y1 = l.required("y1"), x2 = l.required("x2"), y2 = l.required("y2");
            if (!x1 || !y1 || !x2 || !y2) continue;
            line.a = Vec2(*x1, *y1);
            line.b = Vec2(*x2, *y2);
            if (!(line.length() > 0)) l.error(l.loc(), "Line: its two ends are the same point");
            if (!l.failed() && name) m.lines.push_back(std::move(line));
        } else if (is(c, "Area")) {
            ElementReader a(ctx, file, c, "Area", areaTable, {"id"});
            std::vector<Vec2> points;
            int pointElements = 0;
            for (const XMLElement* g = c->FirstChildElement(); g != nullptr; g = g->NextSiblingElement()) {
                if (!is(g, "Point")) {
                    reportUnexpectedElement(ctx, file, g, c->Name(), {"Point"});
                    continue;
                }
                ++pointElements;
                if (std::optional<Vec2> p = readPoint(ctx, file, g, "Point")) points.push_back(*p);
            }
            MeasureAreaSpec area;
            area.loc = a.loc();
            const std::optional<std::string> name = readName(a, "Area");
            if (name) {
                area.name = *name;
                remember(ctx, "measurement", area.name, area.loc, a);
            }
            area.polygon = readArea(a, points, pointElements, "Area", true);
            if (!a.failed() && name && !area.polygon.empty()) m.areas.push_back(std::move(area));
        } else {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Line", "Area"});
        }
    }
}

void checkVenue(LoadContext& ctx) {
    ScenarioSpec& spec = ctx.spec;
    VenueSpec& venue = spec.venue;
    Diagnostics& diags = ctx.diags;
    const int errorsBefore = diags.errorCount();
    std::vector<std::string> targetNames, exitNames, setNames, journeyNames;
    for (const TargetSpec& t : venue.targets) (t.exit ? exitNames : targetNames).push_back(t.name);
    for (const ExitSetSpec& s : venue.exitSets) setNames.push_back(s.name);
    for (const JourneySpec& j : venue.journeys) journeyNames.push_back(j.name);
    auto listed = [](const std::vector<std::string>& names) {
        std::string out;
        for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
        return out.empty() ? std::string("none") : out;
    };
    auto unknown = [&](const SourceLoc& loc, const std::string& what, const std::string& name,
                       const std::vector<std::string>& known) {
        const std::string near = closestMatch(name, known);
        diags.error(loc, what + " '" + name + "' does not exist" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                             "; defined: " + listed(known));
    };
    auto isExit = [&](const std::string& n) { return std::find(exitNames.begin(), exitNames.end(), n) != exitNames.end(); };
    std::vector<std::string> allTargets = targetNames;
    allTargets.insert(allTargets.end(), exitNames.begin(), exitNames.end());

    for (const ExitSetSpec& s : venue.exitSets)
        for (const std::string& e : s.exits)
            if (!isExit(e)) {
                if (venue.targetIndex(e) >= 0) diags.error(s.loc, "ExitSet '" + s.name + "': '" + e + "' is a <Target>, not an <Exit>");
                else unknown(s.loc, "ExitSet '" + s.name + "': exit", e, exitNames);
            }
    for (const JourneySpec& j : venue.journeys) {
        for (const WaypointSpec& w : j.waypoints)
            if (!w.target.empty() && venue.targetIndex(w.target) < 0) unknown(w.loc, "Waypoint: target", w.target, allTargets);
        if (!j.leaveBy.empty() && !isExit(j.leaveBy) && venue.exitSetIndex(j.leaveBy) < 0) {
            std::vector<std::string> both = exitNames;
            both.insert(both.end(), setNames.begin(), setNames.end());
            if (venue.targetIndex(j.leaveBy) >= 0)
                diags.error(j.loc, "Journey@leave_by: '" + j.leaveBy + "' is a <Target>; leave_by names an <Exit> or <ExitSet>");
            else
                unknown(j.loc, "Journey@leave_by: exit or exit set", j.leaveBy, both);
        }
    }
    for (const LoadContext::JourneyRef& ref : ctx.journeyRefs)
        if (venue.journeyIndex(ref.name) < 0) unknown(ref.loc, "journey", ref.name, journeyNames);
    for (const ExitEventSpec& e : venue.exitEvents)
        if (!isExit(e.exit)) unknown(e.loc, std::string(e.open ? "OpenExit" : "CloseExit") + "@exit: exit", e.exit, exitNames);
    if (venue.navigation && spec.world.type == WorldType::Toric)
        diags.error(venue.navigation->loc, "<Navigation> needs a Planar or Infinite world; this one is Toric");
    if (diags.errorCount() > errorsBefore) return;

    // Geometry: targets on walkable floor, agents able to reach their targets.
    if (venue.navigation) {
        const World world(spec.world, spec.obstacles);
        const auto [lo, hi] = navigationBounds(spec);  // the grid the simulation will build
        // Memory: the grid (9 bytes per cell) and one field per target and distinct goal (4 bytes
        // per cell, and 13 more per cell while one is being built) must fit.
        const double h = venue.navigation->grid.cellSize;
        const double cells = std::ceil((hi.x() - lo.x()) / h) * std::ceil((hi.y() - lo.y()) / h);
        std::set<std::pair<double, double>> goals;
        for (const AgentSpec& a : spec.agents)
            if (a.journey.empty() && a.goal) goals.insert({a.goal->x(), a.goal->y()});
        for (const SourceSpec& s : venue.sources)
            if (s.journey.empty() && s.goal) goals.insert({s.goal->x(), s.goal->y()});
        const double fields = static_cast<double>(venue.targets.size() + goals.size());
        const double need = cells * (9.0 + 13.0 + 4.0 * fields);
        const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGE_SIZE);
        const double have = pages > 0 && pageSize > 0 ? static_cast<double>(pages) * static_cast<double>(pageSize) : 0;
        const std::string numbers = "the navigation grid has " + formatNumber(cells, 3) + " cells of " + formatNumber(h) +
                                    " m and " + formatNumber(fields) + " path fields: about " +
                                    formatNumber(need / (1 << 20), 3) + " MiB";
        if (cells > 2e9 || (have > 0 && need > 0.8 * have)) {
            diags.error(venue.navigation->loc, numbers + (have > 0 ? " of this machine's " + formatNumber(have / (1 << 20), 3) + " MiB" : "") +
                                                   "; give a larger cell_size or a smaller world" +
                                                   (goals.size() > 100 ? " (each distinct agent goal is a field: give the agents shared targets)" : ""));
            return;
        }
        if (have > 0 && need > 0.4 * have) diags.warning(venue.navigation->loc, numbers + ": the run may exhaust memory");
        const WalkableGrid grid(world, venue.navigation->grid, lo, hi);
        const double search = 1.5 * grid.cellSize();
        // The target's floor: every walkable cell inside it or within 1.5 cells of it (as the field
        // seeds them), which may lie in several separate regions — an exit drawn across a door's
        // wall touches the floor on both sides, and people on either side reach it.
        std::vector<std::set<int>> component(venue.targets.size());
        for (std::size_t k = 0; k < venue.targets.size(); ++k) {
            const TargetSpec& t = venue.targets[k];
            const auto b = t.shape.bounds();
            int i0, j0, i1, j1;
            grid.cellOf(b.lo - Vec2(search, search), i0, j0);
            grid.cellOf(b.hi + Vec2(search, search), i1, j1);
            for (int iy = std::max(0, j0); iy <= std::min(grid.ny() - 1, j1); ++iy)
                for (int ix = std::max(0, i0); ix <= std::min(grid.nx() - 1, i1); ++ix)
                    if (grid.walkable(ix, iy) && t.shape.distance(grid.centre(ix, iy)) <= search)
                        component[k].insert(grid.component(ix, iy));
            if (component[k].empty())
                diags.error(t.loc, std::string(t.exit ? "Exit" : "Target") + " '" + t.name +
                                       "' touches no walkable floor: it lies inside a wall or obstacle, or outside the world");
        }
        if (diags.errorCount() > errorsBefore) return;
        // The components of a journey's targets (its exits: any one reachable will do).
        auto reachable = [&](int from, const JourneySpec& j, std::string& missing) {
            for (const WaypointSpec& w : j.waypoints)
                if (!component[static_cast<std::size_t>(venue.targetIndex(w.target))].count(from)) {
                    missing = "target '" + w.target + "'";
                    return false;
                }
            if (j.leaveBy.empty()) return true;
            std::vector<std::string> exits = {j.leaveBy};
            if (const int s = venue.exitSetIndex(j.leaveBy); s >= 0) exits = venue.exitSets[static_cast<std::size_t>(s)].exits;
            for (const std::string& e : exits)
                if (component[static_cast<std::size_t>(venue.targetIndex(e))].count(from)) return true;
            missing = "any exit of '" + j.leaveBy + "'";
            return false;
        };
        int reported = 0;
        // Nobody starts inside a solid obstacle (a generator's grid laid over a pillar): such an
        // agent could never walk out.
        for (const AgentSpec& a : spec.agents) {
            if (reported >= 5 || a.source >= 0 || !world.insideObstacle(a.position)) continue;
            diags.error(a.loc, "agent " + std::to_string(a.id) + " starts inside an obstacle at (" + formatNumber(a.position.x()) +
                                   ", " + formatNumber(a.position.y()) + "): move it or the generator's area");
            ++reported;
        }
        for (const AgentSpec& a : spec.agents) {
            if (a.journey.empty() || reported >= 5) continue;
            const int from = grid.componentNear(a.position, 2 * a.radius + grid.cellSize());
            const JourneySpec& j = venue.journeys[static_cast<std::size_t>(venue.journeyIndex(a.journey))];
            std::string missing;
            if (from < 0) {
                diags.error(a.loc, "an agent of journey '" + a.journey + "' starts inside a wall or off the floor");
                ++reported;
            } else if (!reachable(from, j, missing)) {
                diags.error(a.loc, "an agent of journey '" + a.journey + "' cannot reach " + missing +
                                       ": no walkable path leads there from its start");
                ++reported;
            }
        }
        // Plain goals navigate too: each must lie on floor its agent can reach.
        for (const AgentSpec& a : spec.agents) {
            if (!a.journey.empty() || !a.goal || reported >= 5) continue;
            const int from = grid.componentNear(a.position, 2 * a.radius + grid.cellSize());
            // The goal's floor: every region within 1.5 cells of it (a goal in a doorway touches both sides).
            std::set<int> to;
            {
                int i0, j0, i1, j1;
                grid.cellOf(*a.goal - Vec2(search, search), i0, j0);
                grid.cellOf(*a.goal + Vec2(search, search), i1, j1);
                for (int iy = std::max(0, j0); iy <= std::min(grid.ny() - 1, j1); ++iy)
                    for (int ix = std::max(0, i0); ix <= std::min(grid.nx() - 1, i1); ++ix)
                        if (grid.walkable(ix, iy) && (grid.centre(ix, iy) - *a.goal).norm() <= search)
                            to.insert(grid.component(ix, iy));
            }
            if (to.empty()) {
                diags.error(a.loc, "the agent's goal (" + std::to_string(a.goal->x()) + ", " + std::to_string(a.goal->y()) +
                                       ") lies inside a wall or obstacle, or off the navigation grid");
                ++reported;
            } else if (from >= 0 && !to.count(from)) {
                diags.error(a.loc, "the agent cannot reach its goal: no walkable path leads there from its start");
                ++reported;
            }
        }
        for (const SourceSpec& s : venue.sources) {
            if (s.journey.empty()) continue;
            Vec2 c(0, 0);
            for (const Vec2& p : s.area) c += p;
            c /= static_cast<double>(s.area.size());
            const int from = grid.componentNear(c, 2.0);
            const JourneySpec& j = venue.journeys[static_cast<std::size_t>(venue.journeyIndex(s.journey))];
            std::string missing;
            if (from < 0) diags.error(s.loc, "Source '" + s.name + "': its area has no walkable floor near its centre");
            else if (!reachable(from, j, missing))
                diags.error(s.loc, "Source '" + s.name + "': its agents cannot reach " + missing);
        }
        if (diags.errorCount() > errorsBefore) return;
    }

    // Sources become agents (positions chosen on arrival): at most kMaxArrivals in all.
    constexpr std::size_t kMaxArrivals = 10'000'000;
    std::size_t arrivals = 0;
    for (const SourceSpec& s : venue.sources) {
        arrivals += sourceArrivals(s, kMaxArrivals + 1).size();
        if (arrivals > kMaxArrivals) {
            diags.error(s.loc, "Source '" + s.name + "': the sources would create more than " +
                                   formatNumber(static_cast<double>(kMaxArrivals)) + " agents; check rate, count and end");
            return;
        }
    }
    // Groups drawn by sources are named after their source ("<id>/g<k>"): two sources drawing
    // groups need ids of their own, and no agent of the file may use such a name.
    std::map<std::string, const SourceSpec*> drawing;
    for (const SourceSpec& s : venue.sources) {
        if (s.groupSizeMin < 2) continue;
        auto [it, inserted] = drawing.emplace(s.name, &s);
        if (!inserted)
            diags.error(s.loc, "Source '" + s.name + "': another <Source> that draws groups has this id (at " +
                                   it->second->loc.file + ":" + std::to_string(it->second->loc.line) +
                                   "); their groups are named after it ('" + s.name + "/g1', ...): give each source an id of its own");
    }
    if (diags.errorCount() > errorsBefore) return;
    const std::size_t before = spec.agents.size();
    expandSources(spec);
    for (std::size_t k = before; k < spec.agents.size(); ++k) ctx.agentOrigins.push_back({false, spec.agents[k].loc});
    if (!drawing.empty()) {
        std::map<std::string, int> drawn;  // group name → its source
        for (std::size_t k = before; k < spec.agents.size(); ++k)
            if (!spec.agents[k].group.empty()) drawn.emplace(spec.agents[k].group, spec.agents[k].source);
        int reported = 0;
        for (std::size_t k = 0; k < before && reported < 5; ++k) {
            const auto it = drawn.find(spec.agents[k].group);
            if (it == drawn.end()) continue;
            diags.error(spec.agents[k].loc, "group '" + it->first + "' is also a group drawn by Source '" +
                                                venue.sources[static_cast<std::size_t>(it->second)].name +
                                                "': give the agent's group another name");
            ++reported;
        }
    }
}

}  // namespace ch::xmlio
