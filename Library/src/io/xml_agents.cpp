// CrowdHealth — XML loader: <Agent>, and the generators <AgentGrid> (CrowdHealth, the paper's
// room filler) and <SpawnRectangle> (SPH-era UMANS).
#include "crowdhealth/core/rng.h"

#include "xml_internal.h"

#include <cmath>
#include <limits>

namespace ch::xmlio {

namespace {

/// Van Toll et al.'s body-mass factor: mass scales with the body's area, 1 at radius 0.24 m.
double autoMass(double radius) { return (radius / 0.24) * (radius / 0.24); }

/// Upper bound on generated agents, so a typo such as rows="1e9" fails cleanly instead of
/// exhausting memory.
constexpr double kMaxGeneratedAgents = 1e7;
/// Members of one social group at most (families and friends walking together: 2-5 in
/// Moussaïd et al. 2010; ISO 20414's group test has 15; larger parties are allowed up to this).
constexpr int kMaxGroupSize = 20;

// Agent attribute ranges. Speeds up to 20 m/s catch unit mistakes (km/h) without rejecting
// anything a pedestrian model needs; max_acceleration is unbounded because van Toll's profiles
// switch the clamp off with values like 1e6.
ParamSpec radiusParam(const char* name, double def) {
    ParamSpec p = ParamSpec::real(name, "m", def, 0, 10, "body radius");
    p.minExclusive = true;
    return p;
}
ParamSpec prefSpeedParam(const char* name) {
    return ParamSpec::real(name, "m/s", AgentSpec{}.prefSpeed, 0, 20, "preferred walking speed");
}
ParamSpec maxSpeedParam(const char* name) {
    return ParamSpec::real(name, "m/s", AgentSpec{}.maxSpeed, 0, 20, "speed limit");
}
ParamSpec maxAccelerationParam(const char* name) {
    return ParamSpec::real(name, "m/s2", AgentSpec{}.maxAcceleration, 0, 1e300, "acceleration limit");
}
ParamSpec removeAtGoalParam(const char* name) {
    return ParamSpec::boolean(name, AgentSpec{}.removeAtGoal, "remove the agent when it reaches its goal");
}
ParamSpec goalRadiusParam() {
    return ParamSpec::real("goal_radius", "m", -1, 0, 1e300, "distance at which the goal counts as reached; "
                                                             "absent: the agent's radius");
}
ParamSpec premovementParam() {
    return ParamSpec::real("premovement", "s", 0, 0, 1e300, "time the agent stands after appearing before it walks");
}
ParamSpec startTimeParam(const char* name) {
    return ParamSpec::real(name, "s", 0, 0, 1e300, "time at which the agent appears");
}

const ParamTable& agentTable() {
    static const ParamTable t = [] {
        const AgentSpec d;
        ParamTable table = {
            ParamSpec::integer("id", -1, 0, 9007199254740992.0, "agent id; absent: the next free id"),
            radiusParam("rad", d.radius),
            prefSpeedParam("pref_speed"),
            maxSpeedParam("max_speed"),
            maxAccelerationParam("max_acceleration"),
            ParamSpec::real("mass", "-", d.mass, 0, 1e300, "body-mass factor, or \"auto\" = (rad/0.24)^2"),
            removeAtGoalParam("remove_at_goal"),
            startTimeParam("start_time"),
            goalRadiusParam(),
            premovementParam(),
        };
        table[5].minExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& colorTable() {
    static const ParamTable t = {
        ParamSpec::integer("r", 0, 0, 255, "red"),
        ParamSpec::integer("g", 0, 0, 255, "green"),
        ParamSpec::integer("b", 0, 0, 255, "blue"),
    };
    return t;
}

const ParamTable& agentGridTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("x", "m", 0, -1e300, 1e300, "x of the first agent"),
            ParamSpec::real("y", "m", 0, -1e300, 1e300, "y of the first agent"),
            ParamSpec::integer("columns", 1, 1, 1e300, "agents along x"),
            ParamSpec::integer("rows", 1, 1, 1e300, "agents along y"),
            ParamSpec::real("spacing", "m", 1, 0, 1e300, "distance between neighbouring agents"),
            radiusParam("rad_min", 0.215),
            radiusParam("rad_max", 0.265),
            prefSpeedParam("pref_speed"),
            maxSpeedParam("max_speed"),
            maxAccelerationParam("max_acceleration"),
            removeAtGoalParam("remove_at_goal"),
            goalRadiusParam(),
            startTimeParam("start_time"),
            premovementParam(),
            ParamSpec::integer("group_size", 0, 0, kMaxGroupSize,
                               "consecutive agents (row by row) walking as one social group; 0: everyone alone"),
        };
        table[4].minExclusive = true;
        return table;
    }();
    return t;
}

const ParamTable& spawnRectangleTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("xmin", "m", 0, -1e300, 1e300, "rectangle lower x"),
            ParamSpec::real("xmax", "m", 0, -1e300, 1e300, "rectangle upper x"),
            ParamSpec::real("ymin", "m", 0, -1e300, 1e300, "rectangle lower y"),
            ParamSpec::real("ymax", "m", 0, -1e300, 1e300, "rectangle upper y"),
            ParamSpec::integer("NrAgentsHorizontal", 1, 1, 1e300, "agents per row"),
            ParamSpec::integer("NrAgentsVertical", 1, 1, 1e300, "agents per column"),
            ParamSpec::real("StartTime", "s", 0, 0, 1e300, "time of the first wave"),
            ParamSpec::real("EndTime", "s", 0, 0, 1e300, "no wave after this time"),
            ParamSpec::real("Interval", "s", 0, 0, 1e300, "time between waves; 0 = one wave"),
            removeAtGoalParam("RemoveAtGoal"),
            ParamSpec::real("PositionNoise", "m", 0, 0, 1e300, "uniform jitter of each position, ±"),
            radiusParam("AgentRadius", AgentSpec{}.radius),
            ParamSpec::real("AgentRadiusNoise", "m", 0, 0, 10, "uniform jitter of each radius, ±"),
            // CrowdHealth additions, so generated crowds can use van Toll's agent settings.
            prefSpeedParam("pref_speed"),
            maxSpeedParam("max_speed"),
            maxAccelerationParam("max_acceleration"),
            goalRadiusParam(),
        };
        return table;
    }();
    return t;
}

/// The <Policy id>, <goal> children shared by the generators; anything else is reported.
struct GeneratorChildren {
    std::optional<int> policy;
    std::optional<Vec2> goal;
    bool hasPolicy = false, hasGoal = false;
};

GeneratorChildren readGeneratorChildren(LoadContext& ctx, const std::string& file, const XMLElement* el,
                                        bool journey = false) {
    GeneratorChildren out;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "Policy") && !out.hasPolicy) {
            out.hasPolicy = true;
            out.policy = readPolicyRef(ctx, file, c);
        } else if (is(c, "goal") && !out.hasGoal) {
            out.hasGoal = true;
            out.goal = readPoint(ctx, file, c, "goal");
        } else if (is(c, "Policy") || is(c, "goal")) {
            ctx.diags.error(locOf(file, c), std::string("more than one <") + c->Name() + "> in <" + el->Name() + ">");
        } else {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"Policy", "goal"});
        }
    }
    if (!out.hasPolicy)
        ctx.diags.error(locOf(file, el), std::string(el->Name()) + ": missing required element <Policy id=\"…\"/>");
    if (!out.hasGoal && !journey)
        ctx.diags.warning(locOf(file, el), std::string(el->Name()) +
                                               " has no <goal>: its agents will stay where they are");
    return out;
}

}  // namespace

void readAgent(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Agent", agentTable(), {"journey", "group"});
    AgentSpec a;
    a.loc = r.loc();
    const std::optional<double> id = r.optional("id");
    if (id) a.id = static_cast<AgentId>(*id);
    a.radius = r.value("rad");
    a.prefSpeed = r.value("pref_speed");
    a.maxSpeed = r.value("max_speed");
    a.maxAcceleration = r.value("max_acceleration");
    if (std::optional<std::string> m = r.text("mass"); m && equalsIgnoreCase(*m, "auto"))
        a.mass = autoMass(a.radius);
    else
        a.mass = r.value("mass");
    a.removeAtGoal = r.value("remove_at_goal") != 0.0;
    a.startTime = r.value("start_time");
    if (std::optional<double> g = r.optional("goal_radius")) a.goalRadius = *g;
    a.premovement = r.value("premovement");
    a.journey = r.text("journey").value_or("");
    if (!a.journey.empty()) ctx.journeyRefs.push_back({a.journey, r.loc("journey")});
    if (std::optional<std::string> g = r.text("group")) {
        if (g->empty()) r.error(r.loc("group"), "Agent@group: empty group name (leave the attribute out for an agent walking alone)");
        a.group = *g;
    }

    const XMLElement *pos = nullptr, *goal = nullptr, *policy = nullptr, *color = nullptr;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        const XMLElement** slot = is(c, "pos") ? &pos : is(c, "goal") ? &goal : is(c, "Policy") ? &policy
                                  : is(c, "color") ? &color : nullptr;
        if (slot == nullptr) {
            reportUnexpectedElement(ctx, file, c, el->Name(), {"pos", "goal", "Policy", "color"});
            continue;
        }
        if (*slot != nullptr) {
            ctx.diags.error(locOf(file, c), std::string("more than one <") + c->Name() + "> in <Agent> (the first is at line " +
                                                std::to_string((*slot)->GetLineNum()) + ")");
            continue;
        }
        *slot = c;
    }
    if (pos == nullptr) {
        r.error(r.loc(), "Agent: missing required element <pos x=\"…\" y=\"…\"/>");
    } else if (std::optional<Vec2> p = readPoint(ctx, file, pos, "pos")) {
        a.position = *p;
    }
    if (goal == nullptr && a.journey.empty()) {
        // UMANS only warns: such an agent simply stays where it is.
        ctx.diags.warning(r.loc(), "Agent has no <goal>: it will stay where it is");
    } else if (goal != nullptr) {
        a.goal = readPoint(ctx, file, goal, "goal");
    }
    if (policy == nullptr) {
        r.error(r.loc(), "Agent: missing required element <Policy id=\"…\"/>");
    } else if (std::optional<int> p = readPolicyRef(ctx, file, policy)) {
        a.policyId = *p;
    }
    if (color != nullptr) {
        ElementReader cr(ctx, file, color, "color", colorTable());
        for (const XMLElement* c = color->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
            reportUnexpectedElement(ctx, file, c, color->Name(), {});
        const auto red = cr.required("r"), green = cr.required("g"), blue = cr.required("b");
        if (red && green && blue)
            a.color = std::array<std::uint8_t, 3>{static_cast<std::uint8_t>(*red), static_cast<std::uint8_t>(*green),
                                                  static_cast<std::uint8_t>(*blue)};
    }
    // Broken agents are still added (the load fails anyway): keeps ids and counts meaningful and
    // avoids a follow-up "no agents" warning.
    addAgent(ctx, std::move(a), id.has_value(), r.loc("id"));
}

void readAgentGrid(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "AgentGrid", agentGridTable(), {"journey"});
    const std::uint64_t generator = ctx.generatorCount++;
    const auto x = r.required("x"), y = r.required("y");
    const auto columns = r.required("columns"), rows = r.required("rows");
    const double spacing = r.value("spacing");
    const double radMin = r.value("rad_min"), radMax = r.value("rad_max");
    if (radMin > radMax)
        r.error(r.loc("rad_max"), "AgentGrid: rad_min (" + r.text("rad_min").value_or(r.spec("rad_min").defaultText()) +
                                      " m) must not exceed rad_max (" +
                                      r.text("rad_max").value_or(r.spec("rad_max").defaultText()) + " m)");
    AgentSpec proto;
    proto.loc = r.loc();
    proto.prefSpeed = r.value("pref_speed");
    proto.maxSpeed = r.value("max_speed");
    proto.maxAcceleration = r.value("max_acceleration");
    proto.removeAtGoal = r.value("remove_at_goal") != 0.0;
    proto.startTime = r.value("start_time");
    if (std::optional<double> g = r.optional("goal_radius")) proto.goalRadius = *g;
    proto.premovement = r.value("premovement");
    proto.journey = r.text("journey").value_or("");
    if (!proto.journey.empty()) ctx.journeyRefs.push_back({proto.journey, r.loc("journey")});
    const GeneratorChildren children = readGeneratorChildren(ctx, file, el, !proto.journey.empty());
    if (children.policy) proto.policyId = *children.policy;
    proto.goal = children.goal;
    const int groupSize = static_cast<int>(r.value("group_size"));
    if (groupSize == 1)
        r.error(r.loc("group_size"), "AgentGrid@group_size: 1 is not a group (0: everyone walks alone; groups have 2-" +
                                         std::to_string(kMaxGroupSize) + " members)");
    if (!x || !y || !columns || !rows || r.failed()) return;
    if (*columns * *rows > kMaxGeneratedAgents) {
        r.error(r.loc(), "AgentGrid: " + *r.text("columns") + " x " + *r.text("rows") +
                             " agents is more than the limit of 10000000");
        return;
    }
    const int nc = static_cast<int>(*columns), nr = static_cast<int>(*rows);
    // Room for the whole grid at once: a vector grown one agent at a time would hold up to twice
    // the specs' size, with both copies alive while it moves (a million agents: 168 MB of specs).
    // Grids that follow one another still grow geometrically.
    const std::size_t count = static_cast<std::size_t>(nc) * static_cast<std::size_t>(nr);
    reserveAgents(ctx, count);
    // The members of a group share one name (SharedName), as every agent shares the journey's.
    SharedName groupName;
    std::uint64_t groupNumber = std::numeric_limits<std::uint64_t>::max();
    for (int row = 0; row < nr; ++row) {
        for (int col = 0; col < nc; ++col) {
            // One stream per (generator, agent): radii depend only on the seed and the file.
            const std::uint64_t k = static_cast<std::uint64_t>(row) * nc + col;
            Rng rng(ctx.spec.seed, kStreamSpawn, generator, k);
            AgentSpec a = proto;
            a.position = Vec2(*x + col * spacing, *y + row * spacing);
            a.radius = rng.uniform(radMin, radMax);
            a.mass = autoMass(a.radius);
            // Groups of consecutive agents; the last may be smaller, and one left over walks alone.
            if (groupSize >= 2) {
                const std::uint64_t total = static_cast<std::uint64_t>(nc) * static_cast<std::uint64_t>(nr);
                const std::uint64_t first = k - k % static_cast<std::uint64_t>(groupSize);
                if (total - first >= 2) {
                    const std::uint64_t number = k / static_cast<std::uint64_t>(groupSize);
                    if (number != groupNumber) {
                        groupNumber = number;
                        groupName = "AgentGrid" + std::to_string(generator) + "." + std::to_string(number);
                    }
                    a.group = groupName;
                }
            }
            addAgent(ctx, std::move(a), false, r.loc());
        }
    }
}

void readSpawnRectangle(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "SpawnRectangle", spawnRectangleTable());
    const std::uint64_t generator = ctx.generatorCount++;
    const auto xmin = r.required("xmin"), xmax = r.required("xmax");
    const auto ymin = r.required("ymin"), ymax = r.required("ymax");
    const auto nh = r.required("NrAgentsHorizontal"), nv = r.required("NrAgentsVertical");
    const double start = r.value("StartTime");
    const std::optional<double> end = r.optional("EndTime");
    const double interval = r.value("Interval");
    const double noise = r.value("PositionNoise");
    const double radius = r.value("AgentRadius");
    const double radiusNoise = r.value("AgentRadiusNoise");
    if (xmin && xmax && *xmin > *xmax)
        r.error(r.loc("xmax"), "SpawnRectangle: xmin (" + *r.text("xmin") + ") must not exceed xmax (" + *r.text("xmax") + ")");
    if (ymin && ymax && *ymin > *ymax)
        r.error(r.loc("ymax"), "SpawnRectangle: ymin (" + *r.text("ymin") + ") must not exceed ymax (" + *r.text("ymax") + ")");
    if (radiusNoise >= radius)
        r.error(r.loc("AgentRadiusNoise"), "SpawnRectangle: AgentRadiusNoise must be smaller than AgentRadius, "
                                           "so every radius stays in (0, 10] m");
    else if (radius + radiusNoise > 10)
        r.error(r.loc("AgentRadiusNoise"), "SpawnRectangle: AgentRadius + AgentRadiusNoise exceeds 10 m");
    if (interval > 0 && !end)
        r.error(r.loc("Interval"), "SpawnRectangle: EndTime is required when Interval > 0");
    if (end && *end < start)
        r.error(r.loc("EndTime"), "SpawnRectangle: EndTime (" + *r.text("EndTime") + " s) is before StartTime");

    AgentSpec proto;
    proto.loc = r.loc();
    proto.removeAtGoal = r.value("RemoveAtGoal") != 0.0;
    proto.prefSpeed = r.value("pref_speed");
    proto.maxSpeed = r.value("max_speed");
    proto.maxAcceleration = r.value("max_acceleration");
    if (std::optional<double> g = r.optional("goal_radius")) proto.goalRadius = *g;
    const GeneratorChildren children = readGeneratorChildren(ctx, file, el);
    if (children.policy) proto.policyId = *children.policy;
    proto.goal = children.goal;
    if (!xmin || !xmax || !ymin || !ymax || !nh || !nv || r.failed()) return;

    // Waves at StartTime, StartTime + Interval, … up to EndTime inclusive (tolerant of decimal
    // input such as 0.1 steps).
    double waves = 1;
    if (interval > 0) waves = std::floor((*end - start) / interval + 1e-9) + 1;
    if (waves * *nh * *nv > kMaxGeneratedAgents) {
        r.error(r.loc(), "SpawnRectangle: would create more than 10000000 agents");
        return;
    }
    const int cols = static_cast<int>(*nh), rows = static_cast<int>(*nv);
    const double cellW = (*xmax - *xmin) / cols, cellH = (*ymax - *ymin) / rows;
    std::uint64_t counter = 0;
    for (int w = 0; w < static_cast<int>(waves); ++w) {
        const double t = start + w * interval;
        for (int row = 0; row < rows; ++row) {
            for (int col = 0; col < cols; ++col) {
                Rng rng(ctx.spec.seed, kStreamSpawn, generator, counter++);
                // Always three draws, in this order, so zero noise leaves later draws unchanged.
                const double dx = rng.uniform(-noise, noise);
                const double dy = rng.uniform(-noise, noise);
                const double dr = rng.uniform(-radiusNoise, radiusNoise);
                AgentSpec a = proto;
                a.position = Vec2(*xmin + (col + 0.5) * cellW + dx, *ymin + (row + 0.5) * cellH + dy);
                a.radius = radius + dr;
                a.startTime = t;
                addAgent(ctx, std::move(a), false, r.loc());
            }
        }
    }
}

}  // namespace ch::xmlio
