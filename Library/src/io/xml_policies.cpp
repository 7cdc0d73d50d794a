// CrowdHealth — XML loader: <Policy> (UMANS 1.x and SPH-era <Step> form) and its components.
#include "crowdhealth/core/registry.h"

#include "xml_internal.h"

#include <exception>
#include <memory>
#include <string>
#include <vector>

namespace ch::xmlio {

namespace {

/// UMANS' sampling attributes, shared by a 1.x <Policy> and an SPH-era <Step>. Defaults come from
/// SamplingSpec so the header stays the one source of truth.
ParamTable samplingParams() {
    const SamplingSpec d;
    ParamTable t = {
        ParamSpec::choice("SamplingType", {"regular", "random"}, static_cast<int>(d.type),
                          "regular rings × directions, or uniform random samples"),
        ParamSpec::choice("SamplingBase", {"zero", "current velocity"}, static_cast<int>(d.base),
                          "origin of the sampled disk or cone"),
        ParamSpec::choice("SamplingBaseDirection", {"unit", "current velocity", "preferred velocity"},
                          static_cast<int>(d.baseDirection), "central direction of the sampled cone"),
        ParamSpec::choice("SamplingRadius", {"preferred speed", "maximum speed", "maximum acceleration"},
                          static_cast<int>(d.radius), "radius of the sampled disk or cone"),
        ParamSpec::real("SamplingAngle", "deg", d.angle, 0, 360, "full opening angle of the sampled cone"),
        ParamSpec::integer("SpeedSamples", d.speedSamples, 1, 1e300, "regular sampling: number of rings"),
        ParamSpec::integer("AngleSamples", d.angleSamples, 1, 1e300, "regular sampling: directions per ring"),
        ParamSpec::integer("RandomSamples", d.randomSamples, 1, 1e300, "random sampling: samples per step"),
        ParamSpec::boolean("IncludeBaseAsSample", d.includeBaseAsSample, "also evaluate the base velocity"),
        ParamSpec::boolean("IncludePreferredAsSample", d.includePreferredAsSample,
                           "also evaluate the preferred velocity (CrowdHealth; UMANS does not)"),
    };
    t[4].minExclusive = true;
    return t;
}

ParamSpec methodParam() {
    return ParamSpec::choice("OptimizationMethod", {"gradient", "sampling", "global"}, 0,
                             "how the components' cost is minimised");
}

ParamSpec relaxationParam() {
    return ParamSpec::real("RelaxationTime", "s", 0, 0, 1e300,
                           "time to reach the optimal velocity; 0 = within one step");
}

/// Attributes a policy takes in both forms.
ParamTable basePolicyParams() {
    return {
        ParamSpec::integer("id", 0, 0, 1e300, "policy id, referred to by agents"),
        ParamSpec::real("ContactForceScale", "1/s2", PolicySpec{}.contactForceScale, 0, 1e300,
                        "UMANS' post-step contact stiffness per unit mass; 0 disables it"),
    };
}

/// A UMANS 1.x policy: the policy is its one step.
const ParamTable& policyTable() {
    static const ParamTable t = [] {
        ParamTable table = basePolicyParams();
        table.push_back(methodParam());
        table.push_back(relaxationParam());
        const ParamTable s = samplingParams();
        table.insert(table.end(), s.begin(), s.end());
        return table;
    }();
    return t;
}

const ParamTable& stepTable() {
    static const ParamTable t = [] {
        ParamTable table = {
            ParamSpec::choice("DeltaTime", {"coarse", "fine"}, 0,
                              "time step of this step: coarse = delta_time, fine = delta_time_fine"),
            ParamSpec::boolean("StopAtGoal", StepSpec{}.stopAtGoal, "agents at their goal stand still"),
            methodParam(),
            relaxationParam(),
            ParamSpec::real("BlendFrom", "field", 0, -1e300, 1e300,
                            "with BlendField: field value at which the step's weight is 0"),
            ParamSpec::real("BlendTo", "field", 1, -1e300, 1e300,
                            "with BlendField: field value at which the step's weight is 1 (linear, clamped between)"),
        };
        const ParamTable s = samplingParams();
        table.insert(table.end(), s.begin(), s.end());
        return table;
    }();
    return t;
}

SamplingSpec readSampling(ElementReader& r) {
    SamplingSpec s;
    s.type = static_cast<SamplingSpec::Type>(static_cast<int>(r.value("SamplingType")));
    s.base = static_cast<SamplingSpec::Base>(static_cast<int>(r.value("SamplingBase")));
    s.baseDirection = static_cast<SamplingSpec::BaseDirection>(static_cast<int>(r.value("SamplingBaseDirection")));
    s.radius = static_cast<SamplingSpec::Radius>(static_cast<int>(r.value("SamplingRadius")));
    s.angle = r.value("SamplingAngle");
    s.speedSamples = static_cast<int>(r.value("SpeedSamples"));
    s.angleSamples = static_cast<int>(r.value("AngleSamples"));
    s.randomSamples = static_cast<int>(r.value("RandomSamples"));
    s.includeBaseAsSample = r.value("IncludeBaseAsSample") != 0.0;
    s.includePreferredAsSample = r.value("IncludePreferredAsSample") != 0.0;
    return s;
}

std::string registeredNames() {
    const std::vector<std::string> names = Registry::instance().names();
    if (names.empty()) return "(none)";
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i) out += (i ? ", " : "") + names[i];
    return out;
}

/// `<costfunction name coeff range …/>`: the component's own table validates the attributes.
std::optional<ComponentSpec> readComponent(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    const char* rawName = el->Attribute("name");
    if (rawName == nullptr) {
        ctx.diags.error(locOf(file, el), std::string(el->Name()) +
                                             "@name: missing required value (one of: " + registeredNames() + ")");
        return std::nullopt;
    }
    const std::string name = rawName;
    const ComponentInfo* info = Registry::instance().find(name);
    if (info == nullptr) {
        std::string msg = "unknown cost function '" + name + "'";
        const std::string hint = closestMatch(name, Registry::instance().names());
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        msg += "; registered: " + registeredNames();
        if (ctx.pluginFailed) msg += " (a <Plugin> of this scenario could not be loaded; see above)";
        else if (hint.empty()) msg += " (a component from a plugin needs <Plugin file=\"…\"/> or --plugin FILE)";
        const tinyxml2::XMLAttribute* a = el->FindAttribute("name");
        ctx.diags.error(SourceLoc{file, a->GetLineNum()}, msg);
        return std::nullopt;
    }
    const ParamTable table = Registry::fullTable(*info);
    ElementReader r(ctx, file, el, info->name, table, {"name"});
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        reportUnexpectedElement(ctx, file, c, el->Name(), {});
    ComponentSpec spec;
    spec.name = info->name;
    spec.loc = r.loc();
    spec.params = ParamSet(table);
    for (const ParamSpec& p : table)
        if (std::optional<double> v = r.optional(p.name)) {
            spec.params.set(p.name, *v);
            spec.written[p.name] = r.loc(p.name);
        }
    spec.coeff = spec.params.get("coeff");
    return spec;
}

/// Reads the components of a 1.x policy or of a step. Returns how many component elements there
/// were (valid or not), so "no component" is only reported when there really is none.
int readComponents(LoadContext& ctx, const std::string& file, const XMLElement* el, StepSpec& step,
                   const std::vector<std::string>& allowed) {
    int elements = 0;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        if (is(c, "costfunction")) {
            ++elements;
            if (std::optional<ComponentSpec> comp = readComponent(ctx, file, c)) step.components.push_back(*comp);
        } else if (!is(c, "Step") && !is(c, "CrowdHealth")) {  // handled (or refused) by the caller
            reportUnexpectedElement(ctx, file, c, el->Name(), allowed);
        }
    }
    return elements;
}

/// <Step BlendField="Component.field" BlendFrom BlendTo>: the per-agent step weight (BlendSpec).
/// Whether the component and field exist is checked once the whole policy is read.
std::optional<BlendSpec> readBlend(ElementReader& r) {
    const std::optional<std::string> field = r.text("BlendField");
    if (!field) {
        for (const char* a : {"BlendFrom", "BlendTo"})
            if (r.has(a))
                r.error(r.loc(a), std::string("Step@") + a +
                                      ": needs Step@BlendField (the per-agent field the weight follows, e.g. "
                                      "BlendField=\"SPH.density\")");
        return std::nullopt;
    }
    BlendSpec b;
    b.loc = r.loc("BlendField");
    const std::size_t dot = field->find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 >= field->size() || field->find('.', dot + 1) != std::string::npos) {
        r.error(b.loc, "Step@BlendField: '" + *field + "' is not of the form Component.field (e.g. SPH.density)");
        return std::nullopt;
    }
    b.component = field->substr(0, dot);
    b.field = field->substr(dot + 1);
    const std::optional<double> from = r.required("BlendFrom");
    const std::optional<double> to = r.required("BlendTo");
    if (!from || !to) return std::nullopt;
    b.from = *from;
    b.to = *to;
    if (b.from == b.to) {
        r.error(r.loc("BlendTo"), "Step@BlendTo: must differ from BlendFrom (both " + r.text("BlendTo").value_or("") +
                                      "): the weight ramps linearly from 0 at BlendFrom to 1 at BlendTo");
        return std::nullopt;
    }
    return b;
}

/// Every blend must follow a component of the same policy that has the named per-agent field.
void checkBlends(LoadContext& ctx, const PolicySpec& policy) {
    for (const StepSpec& step : policy.steps) {
        if (!step.blend) continue;
        const BlendSpec& b = *step.blend;
        const ComponentSpec* source = nullptr;
        std::vector<std::string> names;
        for (const StepSpec& s : policy.steps)
            for (const ComponentSpec& c : s.components) {
                names.push_back(c.name);
                if (source == nullptr && c.name == b.component) source = &c;
            }
        if (source == nullptr) {
            std::string msg = "Step@BlendField: policy " + std::to_string(policy.id) + " has no component '" +
                              b.component + "'";
            const std::string hint = closestMatch(b.component, names);
            if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
            std::string list;
            for (std::size_t k = 0; k < names.size(); ++k) list += (k ? ", " : "") + names[k];
            msg += "; its components: " + (list.empty() ? std::string("(none)") : list);
            ctx.diags.error(b.loc, msg);
            continue;
        }
        // Ask an instance which per-agent fields it has (components build cheaply).
        bool known = false;
        try {
            const std::unique_ptr<Component> probe = createComponent(source->name, source->params);
            known = probe->field(b.field) != nullptr;
        } catch (const std::exception&) {
            known = false;
        }
        if (!known)
            ctx.diags.error(b.loc, "Step@BlendField: component '" + b.component + "' has no per-agent field '" +
                                       b.field + "' (docs/policies.md lists the fields of each component)");
    }
}

/// Contact is applied once. UMANS' post-step contact (Policy@ContactForceScale, default 62.5 as in
/// UMANS 1.x) and a component that models contact (ContactForces) are two models of the same
/// bodies pushing apart; a policy that lists such a component gets no implicit UMANS contact. A
/// file that asks for both explicitly gets them, with a warning that names both places.
void settleContact(LoadContext& ctx, ElementReader& r, PolicySpec& policy) {
    const ComponentSpec* contact = nullptr;
    for (const StepSpec& step : policy.steps)
        for (const ComponentSpec& c : step.components) {
            const ComponentInfo* info = Registry::instance().find(c.name);
            if (contact == nullptr && info != nullptr && info->modelsContact) contact = &c;
        }
    if (contact == nullptr) return;
    if (!r.has("ContactForceScale")) {
        policy.contactForceScale = 0;
        return;
    }
    if (policy.contactForceScale > 0)
        ctx.diags.warning(r.loc("ContactForceScale"),
                          "Policy@ContactForceScale=" + r.text("ContactForceScale").value_or("") +
                              " adds UMANS' post-step contact on top of " + contact->name + " (" + contact->loc.file +
                              ":" + std::to_string(contact->loc.line) +
                              "): body contact is applied twice; remove ContactForceScale (or set it to 0) to "
                              "keep only " + contact->name);
}

void readStep(LoadContext& ctx, const std::string& file, const XMLElement* el, PolicySpec& policy) {
    ElementReader r(ctx, file, el, "Step", stepTable(), {"BlendField"});
    StepSpec step;
    step.blend = readBlend(r);
    step.loc = r.loc();
    step.timing = r.value("DeltaTime") == 1.0 ? StepTiming::Fine : StepTiming::Coarse;
    step.stopAtGoal = r.value("StopAtGoal") != 0.0;
    step.method = static_cast<OptimisationMethod>(static_cast<int>(r.value("OptimizationMethod")));
    step.relaxationTime = r.value("RelaxationTime");
    step.sampling = readSampling(r);
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
        if (is(c, "Step") || is(c, "CrowdHealth")) reportUnexpectedElement(ctx, file, c, el->Name(), {"costfunction"});
    const int elements = readComponents(ctx, file, el, step, {"costfunction"});
    if (elements == 0)
        r.error(r.loc(), "Step: needs at least one <costfunction> (policy " + std::to_string(policy.id) + ")");
    policy.steps.push_back(std::move(step));
}

}  // namespace

void checkWallModels(LoadContext& ctx) {
    // SPH's wall density comes either from boundary particles (<Box particles="true">) or from the
    // analytic area behind each wall segment. Where the file does not choose, the obstacles decide:
    // particles when it has them (they were written to be used), analytic otherwise. A choice that
    // contradicts the obstacles is kept and warned about, naming both places.
    const ObstacleSpec* withParticles = nullptr;
    for (const ObstacleSpec& o : ctx.spec.obstacles)
        if (withParticles == nullptr && !o.particles.empty()) withParticles = &o;
    const auto where = [](const SourceLoc& l) { return l.file + ":" + std::to_string(l.line); };
    for (PolicySpec& policy : ctx.spec.policies)
        for (StepSpec& step : policy.steps)
            for (ComponentSpec& c : step.components) {
                if (c.name != "SPH" || !c.params.has("walls")) continue;
                const auto written = c.written.find("walls");
                if (written == c.written.end()) {
                    if (withParticles != nullptr) c.params.set("walls", 0);  // "particles"
                    continue;
                }
                const std::string walls = c.params.choice("walls");
                if (walls == "analytic" && withParticles != nullptr)
                    ctx.diags.warning(written->second,
                                      "SPH@walls=\"analytic\" ignores the SPH boundary particles of the obstacle at " +
                                          where(withParticles->loc) +
                                          ": wall density comes from the wall segments only; use walls=\"particles\" "
                                          "or drop particles=\"true\"");
                else if (walls == "particles" && withParticles == nullptr)
                    ctx.diags.warning(written->second,
                                      "SPH@walls=\"particles\" but no obstacle carries boundary particles "
                                      "(<Box particles=\"true\">): walls add no SPH density; use walls=\"analytic\"");
            }
}

void readPolicy(LoadContext& ctx, const std::string& file, const XMLElement* el) {
    bool hasSteps = false, hasComponents = false;
    for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
        hasSteps = hasSteps || is(c, "Step");
        hasComponents = hasComponents || is(c, "costfunction");
    }
    ElementReader r(ctx, file, el, "Policy", policyTable(), {"name"});
    PolicySpec policy;
    policy.loc = r.loc();
    policy.name = r.text("name").value_or("");
    policy.contactForceScale = r.value("ContactForceScale");

    const std::optional<double> id = r.required("id");
    bool idUsable = false;
    if (id) {
        policy.id = static_cast<int>(*id);
        auto [it, inserted] = ctx.policyIds.emplace(policy.id, r.loc("id"));
        if (!inserted)
            r.error(r.loc("id"), "duplicate policy id " + std::to_string(policy.id) + " (first defined at " +
                                     it->second.file + ":" + std::to_string(it->second.line) + ")");
        idUsable = inserted;
    }

    if (hasSteps) {
        // SPH-era form: the optimisation settings live on each <Step>.
        for (const ParamSpec& p : policyTable())
            if (r.has(p.name) && p.name != "id" && p.name != "ContactForceScale")
                r.error(r.loc(p.name), "Policy@" + p.name + ": in a policy made of <Step> elements, " + p.name +
                                           " belongs on each <Step>");
        if (hasComponents)
            r.error(r.loc(), "Policy " + std::to_string(policy.id) +
                                 ": mixes <Step> and <costfunction> children; put every <costfunction> inside a <Step>");
        for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
            if (is(c, "Step")) readStep(ctx, file, c, policy);
            else if (is(c, "CrowdHealth")) readCrowdHealth(ctx, file, c, policy);
            else if (!is(c, "costfunction")) reportUnexpectedElement(ctx, file, c, el->Name(), {"Step", "CrowdHealth"});
        }
        checkBlends(ctx, policy);
    } else {
        // UMANS 1.x form: the policy is a single coarse step.
        StepSpec step;
        step.loc = policy.loc;
        step.timing = StepTiming::Coarse;
        const std::optional<double> method = r.required("OptimizationMethod");
        if (method) step.method = static_cast<OptimisationMethod>(static_cast<int>(*method));
        step.relaxationTime = r.value("RelaxationTime");
        step.sampling = readSampling(r);
        const int elements = readComponents(ctx, file, el, step, {"costfunction", "Step", "CrowdHealth"});
        for (const XMLElement* c = el->FirstChildElement(); c != nullptr; c = c->NextSiblingElement())
            if (is(c, "CrowdHealth")) readCrowdHealth(ctx, file, c, policy);
        if (elements == 0)
            r.error(r.loc(), "Policy " + std::to_string(policy.id) + ": needs at least one <costfunction>");
        policy.steps.push_back(std::move(step));
    }
    settleContact(ctx, r, policy);
    if (idUsable) ctx.spec.policies.push_back(std::move(policy));
}

}  // namespace ch::xmlio
