// CrowdHealth — XML loader: <CrowdHealth> inside <Policy>, and <Schedule> with <Ramp> and
// <PanicEvent> (docs/crowd-health.md, docs/xml-reference.md).
#include "crowdhealth/health/health.h"
#include "crowdhealth/core/registry.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/io/xml.h"

#include "xml_internal.h"

#include <algorithm>
#include <string>
#include <vector>

namespace ch::xmlio {

namespace {

std::string joined(const std::vector<std::string>& words) {
    std::string out;
    for (std::size_t i = 0; i < words.size(); ++i) out += (i ? ", " : "") + words[i];
    return out;
}

/// The agent attributes a ramp may move (same ranges as <Agent>).
const ParamTable& agentRampTable() {
    static const ParamTable t = {
        ParamSpec::real("pref_speed", "m/s", AgentSpec{}.prefSpeed, 0, 20, "preferred walking speed"),
        ParamSpec::real("max_speed", "m/s", AgentSpec{}.maxSpeed, 0, 20, "speed limit"),
        ParamSpec::real("max_acceleration", "m/s2", AgentSpec{}.maxAcceleration, 0, 1e300, "acceleration limit"),
    };
    return t;
}

const ParamTable& rampTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::integer("policy", 0, 0, 1e300, "id of the policy whose component is ramped; absent: every policy that has it"),
            ParamSpec::real("from", "param", 0, -1e300, 1e300, "value at `start`"),
            ParamSpec::real("to", "param", 0, -1e300, 1e300, "value at `end` and afterwards"),
            ParamSpec::real("start", "s", 0, 0, 1e300, "time at which the ramp starts"),
            ParamSpec::real("end", "s", 0, 0, 1e300, "time at which it reaches `to`"),
        };
        return table;
    }();
    return t;
}

const ParamTable& panicEventTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::real("time", "s", 0, 0, 1e300, "when the event happens"),
            ParamSpec::real("x", "m", 0, -1e300, 1e300, "centre x"),
            ParamSpec::real("y", "m", 0, -1e300, 1e300, "centre y"),
            ParamSpec::real("radius", "m", 1, 0, 1e300, "agents within this distance of the centre panic"),
            ParamSpec::real("strength", "-", 1, 0, 1, "their panic becomes at least this"),
        };
        table[3].minExclusive = true;
        return table;
    }();
    return t;
}

void readRamp(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "Ramp", rampTable(), {"component", "agents", "parameter"});
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    RampSpec ramp;
    ramp.loc = r.loc();
    const std::optional<std::string> component = r.text("component");
    const std::optional<std::string> agents = r.text("agents");
    const std::optional<std::string> parameter = r.text("parameter");
    const std::optional<double> from = r.required("from"), to = r.required("to");
    const std::optional<double> start = r.required("start"), end = r.required("end");
    if (start && end && *end < *start)
        r.error(r.loc("end"), "Ramp@end: " + *r.text("end") + " s is before start (" + *r.text("start") + " s)");
    if (!parameter) r.error(r.loc(), "Ramp@parameter: missing required value (the name of the parameter to ramp)");

    const ParamTable* table = nullptr;
    std::string owner;
    if (component && agents) {
        r.error(r.loc("agents"), "Ramp: give either component=\"…\" (with policy=\"…\") or agents=\"all\", not both");
        return;
    }
    if (agents) {
        ramp.target = RampSpec::Target::Agents;
        if (*agents != "all") r.error(r.loc("agents"), "Ramp@agents: '" + *agents + "' is not supported; use agents=\"all\"");
        if (r.has("policy")) r.error(r.loc("policy"), "Ramp@policy: not used with agents=\"all\" (it ramps every agent)");
        table = &agentRampTable();
        owner = "agents";
    } else if (component) {
        ramp.target = RampSpec::Target::Component;
        ramp.component = *component;
        if (*component == "CrowdHealth") {
            table = &crowdHealthTable();
        } else if (const ComponentInfo* info = Registry::instance().find(*component)) {
            static thread_local ParamTable full;
            full = Registry::fullTable(*info);
            table = &full;
        } else {
            std::vector<std::string> names = Registry::instance().names();
            names.push_back("CrowdHealth");
            std::string msg = "Ramp@component: unknown component '" + *component + "'";
            const std::string hint = closestMatch(*component, names);
            if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
            r.error(r.loc("component"), msg + "; known: " + joined(names));
        }
        owner = *component;
        if (const std::optional<double> p = r.optional("policy")) ramp.policyId = static_cast<int>(*p);
    } else {
        r.error(r.loc(), "Ramp: missing the target: component=\"…\" (a registered component or CrowdHealth, "
                         "with policy=\"…\") or agents=\"all\"");
        return;
    }
    if (table == nullptr || !parameter) return;
    ramp.parameter = *parameter;
    const ParamSpec* spec = nullptr;
    std::vector<std::string> names;
    for (const ParamSpec& p : *table) {
        names.push_back(p.name);
        if (p.name == *parameter) spec = &p;
    }
    if (spec == nullptr) {
        std::string msg = "Ramp@parameter: " + owner + " has no parameter '" + *parameter + "'";
        const std::string hint = closestMatch(*parameter, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        r.error(r.loc("parameter"), msg + "; its parameters: " + joined(names));
        return;
    }
    if (spec->type != ParamType::Real) {
        r.error(r.loc("parameter"), "Ramp@parameter: " + owner + "." + *parameter +
                                        " is not a real number (only real parameters can be ramped)");
        return;
    }
    if (const std::string fixed = fixedForTheRun(owner, *parameter); !fixed.empty()) {
        r.error(r.loc("parameter"), "Ramp@parameter: " + fixed + " and cannot be ramped");
        return;
    }
    for (const char* attr : {"from", "to"}) {
        const std::optional<double> v = std::string(attr) == "from" ? from : to;
        if (v && !spec->contains(*v))
            r.error(r.loc(attr), std::string("Ramp@") + attr + ": " + *r.text(attr) + " is out of range for " + owner +
                                     "." + *parameter + " (allowed: " + spec->rangeText() + ")");
    }
    if (r.failed() || !from || !to || !start || !end) return;
    ramp.from = *from;
    ramp.to = *to;
    ramp.start = *start;
    ramp.end = *end;
    ctx.spec.ramps.push_back(ramp);
}

void readPanicEvent(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    ElementReader r(ctx, file, el, "PanicEvent", panicEventTable());
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    PanicEventSpec e;
    e.loc = r.loc();
    const auto time = r.required("time"), x = r.required("x"), y = r.required("y"), radius = r.required("radius");
    e.strength = r.value("strength");
    if (r.failed() || !time || !x || !y || !radius) return;
    e.time = *time;
    e.position = Vec2(*x, *y);
    e.radius = *radius;
    ctx.spec.panicEvents.push_back(e);
}

}  // namespace

void readCrowdHealth(LoadContext& ctx, const std::string& file, const XMLElement* el, PolicySpec& policy) {
    ElementReader r(ctx, file, el, "CrowdHealth", crowdHealthTable());
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    if (policy.health) {
        r.error(r.loc(), "more than one <CrowdHealth> in policy " + std::to_string(policy.id) + " (the first is at line " +
                             std::to_string(policy.health->loc.line) + ")");
        return;
    }
    CrowdHealthSpec h;
    h.loc = r.loc();
    h.params = ParamSet(crowdHealthTable());
    for (const ParamSpec& p : crowdHealthTable())
        if (const std::optional<double> v = r.optional(p.name)) h.params.set(p.name, *v);
    policy.health = h;
}

void readSchedule(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    static const ParamTable none;
    ElementReader r(ctx, file, el, "Schedule", none);
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "Ramp")) readRamp(ctx, file, c);
        else if (is(c, "PanicEvent")) readPanicEvent(ctx, file, c);
        else if (is(c, "CloseExit")) readExitEvent(ctx, file, c, false);
        else if (is(c, "OpenExit")) readExitEvent(ctx, file, c, true);
        else reportUnexpectedElement(ctx, file, c, el->Name(), {"Ramp", "PanicEvent", "CloseExit", "OpenExit"});
    }
}

}  // namespace ch::xmlio

namespace ch {

std::string rampTargetProblem(const ScenarioSpec& spec, const RampSpec& ramp) {
    using namespace xmlio;
    ParamTable componentTable;
    const ParamTable* table = nullptr;
    std::string owner;
    if (ramp.target == RampSpec::Target::Agents) {
        table = &agentRampTable();
        owner = "agents";
    } else if (ramp.component == "CrowdHealth") {
        table = &crowdHealthTable();
        owner = "CrowdHealth";
    } else if (const ComponentInfo* info = Registry::instance().find(ramp.component)) {
        componentTable = Registry::fullTable(*info);
        table = &componentTable;
        owner = ramp.component;
    } else {
        std::vector<std::string> names = Registry::instance().names();
        names.push_back("CrowdHealth");
        std::string msg = "unknown component '" + ramp.component + "'";
        const std::string hint = closestMatch(ramp.component, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        return msg + "; known: " + joined(names);
    }
    const ParamSpec* p = nullptr;
    std::vector<std::string> names;
    for (const ParamSpec& q : *table) {
        names.push_back(q.name);
        if (q.name == ramp.parameter) p = &q;
    }
    if (p == nullptr) {
        std::string msg = owner + " has no parameter '" + ramp.parameter + "'";
        const std::string hint = closestMatch(ramp.parameter, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        return msg + "; its parameters: " + joined(names);
    }
    if (p->type != ParamType::Real) return owner + "." + ramp.parameter + " is not a real number (only real parameters can be ramped)";
    if (const std::string fixed = fixedForTheRun(owner, ramp.parameter); !fixed.empty()) return fixed + " and cannot be ramped";
    for (const double v : {ramp.from, ramp.to})
        if (!p->contains(v))
            return formatNumber(v) + " is out of range for " + owner + "." + ramp.parameter + " (allowed: " + p->rangeText() + ")";
    if (ramp.target == RampSpec::Target::Agents) return {};
    bool policyFound = false, found = false;
    std::vector<std::string> components, ids;
    for (const PolicySpec& pol : spec.policies) {
        ids.push_back(std::to_string(pol.id));
        if (ramp.policyId && pol.id != *ramp.policyId) continue;
        policyFound = true;
        if (ramp.component == "CrowdHealth") {
            found = found || pol.health.has_value();
            continue;
        }
        for (const StepSpec& s : pol.steps)
            for (const ComponentSpec& c : s.components) {
                components.push_back(c.name);
                found = found || c.name == ramp.component;
            }
    }
    if (!policyFound)
        return "policy " + std::to_string(*ramp.policyId) + " does not exist (defined: " + (ids.empty() ? std::string("none") : joined(ids)) + ")";
    if (found) return {};
    const std::string who = ramp.policyId ? "policy " + std::to_string(*ramp.policyId) + " has no" : std::string("no policy has a");
    if (ramp.component == "CrowdHealth") return who + " <CrowdHealth> layer; add <CrowdHealth/> to the policy";
    std::string msg = who + " component '" + ramp.component + "'";
    const std::string hint = closestMatch(ramp.component, components);
    if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
    if (ramp.policyId) msg += "; its components: " + (components.empty() ? std::string("(none)") : joined(components));
    return msg;
}

}  // namespace ch

namespace ch::xmlio {

void checkSchedule(LoadContext& ctx) {
    const std::vector<PolicySpec>& policies = ctx.spec.policies;
    for (const RampSpec& ramp : ctx.spec.ramps) {
        if (ramp.target != RampSpec::Target::Component) continue;
        if (ramp.policyId && ctx.policyIds.count(*ramp.policyId) == 0) {
            if (ctx.policiesIncomplete) continue;
            std::string known;
            for (const auto& [id, loc] : ctx.policyIds) known += (known.empty() ? "" : ", ") + std::to_string(id);
            ctx.diags.error(ramp.loc, "Ramp@policy: policy " + std::to_string(*ramp.policyId) +
                                          " does not exist (defined: " + (known.empty() ? "none" : known) + ")");
            continue;
        }
        bool found = false;
        std::vector<std::string> names;
        for (const PolicySpec& p : policies) {
            if (ramp.policyId && p.id != *ramp.policyId) continue;
            if (ramp.component == "CrowdHealth") {
                found = found || p.health.has_value();
                continue;
            }
            for (const StepSpec& s : p.steps)
                for (const ComponentSpec& c : s.components) {
                    names.push_back(c.name);
                    found = found || c.name == ramp.component;
                }
        }
        if (found || ctx.policiesIncomplete) continue;
        const std::string who = ramp.policyId ? "policy " + std::to_string(*ramp.policyId) + " has no" : std::string("no policy has a");
        if (ramp.component == "CrowdHealth") {
            ctx.diags.error(ramp.loc, "Ramp@component: " + who + " <CrowdHealth> layer to ramp; add <CrowdHealth/> to the policy");
            continue;
        }
        std::string msg = "Ramp@component: " + who + " component '" + ramp.component + "'";
        const std::string hint = closestMatch(ramp.component, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        if (ramp.policyId) msg += "; its components: " + (names.empty() ? std::string("(none)") : joined(names));
        ctx.diags.error(ramp.loc, msg);
    }
    if (!ctx.spec.panicEvents.empty() &&
        std::none_of(policies.begin(), policies.end(), [](const PolicySpec& p) { return p.health.has_value(); }))
        ctx.diags.warning(ctx.spec.panicEvents.front().loc,
                          "<PanicEvent>: no policy has a <CrowdHealth> layer, so panic is recorded but changes no motion");
}

}  // namespace ch::xmlio
