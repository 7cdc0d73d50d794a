// CrowdHealth — the C API (crowdhealth/crowdhealth_c.h, docs/c-api.md): a thin shell over
// ch::loadScenario and ch::Simulation. Every entry point catches every exception: none crosses
// into C.
#include "crowdhealth/crowdhealth_c.h"

#include "crowdhealth/core/plugins.h"

#include "crowdhealth/core/registry.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/health/health.h"
#include "crowdhealth/io/output.h"
#include "crowdhealth/io/xml.h"

#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <vector>

#ifndef CH_VERSION
#define CH_VERSION "unknown"
#endif

struct ch_simulation {
    std::unique_ptr<ch::Simulation> sim;
    std::string warnings;  ///< the loader's warning lines
    int threads = 1;
};

namespace {

/// The calling thread's last error (ch_last_error).
thread_local std::string t_lastError;

ch_status fail(ch_status status, std::string message) {
    try {
        t_lastError = std::move(message);
    } catch (...) {  // out of memory while keeping the message: keep a fixed one
        t_lastError.clear();
    }
    return status;
}

/// Runs f() and turns any exception into CH_ERROR_RUNTIME with its message.
template <class F>
ch_status guarded(const char* what, F&& f) noexcept {
    try {
        return f();
    } catch (const std::bad_alloc&) {
        return fail(CH_ERROR_RUNTIME, std::string(what) + ": out of memory");
    } catch (const std::exception& e) {
        return fail(CH_ERROR_RUNTIME, std::string(what) + ": " + e.what());
    } catch (...) {
        return fail(CH_ERROR_RUNTIME, std::string(what) + ": unknown error");
    }
}

std::string joined(const std::vector<std::string>& words) {
    std::string out;
    for (std::size_t i = 0; i < words.size(); ++i) out += (i ? ", " : "") + words[i];
    return out;
}

/// Where a parameter addressed as <Ramp> addresses it lives: the components of the selected
/// policies, or their CrowdHealth parameters; with the parameter's spec for range checks.
struct Target {
    std::vector<ch::Component*> components;
    std::vector<std::size_t> healthPolicies;
    const ch::ParamSpec* spec = nullptr;
    ch::ParamTable table;  ///< owns `spec` for components
};

/// Resolves (policy, component, parameter) as the loader checks a <Ramp>; on failure returns the
/// status and sets the thread's error.
ch_status resolve(const ch_simulation* h, int policyId, const char* component, const char* parameter, Target& out,
                  const char* what) {
    if (h == nullptr || !h->sim) return fail(CH_ERROR_NULL_ARGUMENT, std::string(what) + ": the simulation handle is NULL");
    if (component == nullptr || parameter == nullptr)
        return fail(CH_ERROR_NULL_ARGUMENT, std::string(what) + ": component and parameter must not be NULL");
    const std::string comp = component, param = parameter;
    const bool health = comp == "CrowdHealth";
    const ch::ParamTable* table = nullptr;
    if (health) {
        table = &ch::crowdHealthTable();
    } else if (const ch::ComponentInfo* info = ch::Registry::instance().find(comp)) {
        out.table = ch::Registry::fullTable(*info);
        table = &out.table;
    } else {
        std::vector<std::string> names = ch::Registry::instance().names();
        names.push_back("CrowdHealth");
        std::string msg = std::string(what) + ": unknown component '" + comp + "'";
        const std::string hint = ch::closestMatch(comp, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        return fail(CH_ERROR_UNKNOWN_NAME, msg + "; known: " + joined(names));
    }
    std::vector<std::string> names;
    for (const ch::ParamSpec& p : *table) {
        names.push_back(p.name);
        if (p.name == param) out.spec = &p;
    }
    if (out.spec == nullptr) {
        std::string msg = std::string(what) + ": " + comp + " has no parameter '" + param + "'";
        const std::string hint = ch::closestMatch(param, names);
        if (!hint.empty()) msg += " (did you mean '" + hint + "'?)";
        return fail(CH_ERROR_UNKNOWN_NAME, msg + "; its parameters: " + joined(names));
    }
    if (out.spec->type != ch::ParamType::Real)
        return fail(CH_ERROR_INVALID_VALUE, std::string(what) + ": " + comp + "." + param +
                                                " is not a real number (only real parameters can change while running)");
    if (const std::string fixed = ch::fixedForTheRun(comp, param); !fixed.empty())
        return fail(CH_ERROR_INVALID_VALUE, std::string(what) + ": " + fixed);

    const std::vector<ch::Policy>& policies = h->sim->policies();
    bool policyFound = policyId == CH_ALL_POLICIES;
    for (std::size_t p = 0; p < policies.size(); ++p) {
        if (policyId != CH_ALL_POLICIES && policies[p].id() != policyId) continue;
        policyFound = true;
        if (health) {
            out.healthPolicies.push_back(p);
            continue;
        }
        for (const ch::PolicyStep& s : policies[p].steps())
            for (const auto& e : s.components())
                if (e.name == comp) out.components.push_back(e.component.get());
    }
    if (!policyFound) return fail(CH_ERROR_UNKNOWN_NAME, std::string(what) + ": the scenario has no policy " + std::to_string(policyId));
    if (out.components.empty() && out.healthPolicies.empty())
        return fail(CH_ERROR_UNKNOWN_NAME,
                    std::string(what) + ": " +
                        (policyId == CH_ALL_POLICIES ? std::string("no policy") : "policy " + std::to_string(policyId)) +
                        " of the scenario has the component " + comp);
    return CH_OK;
}

/// Copies one per-agent column into the caller's buffer (see the header for the rules).
template <class Fill>
ch_status copyOut(const ch_simulation* h, void* buffer, std::size_t capacity, std::size_t* count, const char* what,
                  Fill&& fill) {
    if (h == nullptr || !h->sim) return fail(CH_ERROR_NULL_ARGUMENT, std::string(what) + ": the simulation handle is NULL");
    const std::size_t n = h->sim->agents().size();
    if (count != nullptr) *count = n;
    if (capacity < n)
        return fail(CH_ERROR_BUFFER_TOO_SMALL, std::string(what) + ": the buffer holds " + std::to_string(capacity) +
                                                   " agents, but there are " + std::to_string(n));
    if (buffer == nullptr && n > 0) return fail(CH_ERROR_NULL_ARGUMENT, std::string(what) + ": the buffer is NULL");
    fill(n);
    return CH_OK;
}

}  // namespace

extern "C" {

const char* ch_version(void) { return CH_VERSION; }

const char* ch_last_error(void) { return t_lastError.c_str(); }

ch_status ch_load_plugin(const char* path) {
    if (path == nullptr) return fail(CH_ERROR_NULL_ARGUMENT, "ch_load_plugin: the path is NULL");
    return guarded("ch_load_plugin", [&]() -> ch_status {
        const ch::PluginLoad load = ch::loadPlugin(ch::findPlugin(path, ""));
        if (!load.ok) return fail(CH_ERROR_RUNTIME, std::string(path) + ": " + load.error);
        return CH_OK;
    });
}

ch_simulation* ch_simulation_load(const char* path, const uint64_t* seed) {
    if (path == nullptr) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_load: the path is NULL");
        return nullptr;
    }
    ch_simulation* result = nullptr;
    guarded("ch_simulation_load", [&]() -> ch_status {
        const std::string file = path;
        ch::Diagnostics diags;
        ch::LoadOptions options;
        if (seed != nullptr) options.seed = *seed;
        std::optional<ch::ScenarioSpec> spec;
        try {
            spec = ch::loadScenario(file, diags, options);
        } catch (const std::exception& e) {  // the loader reports rather than throws; be safe anyway
            diags.error(ch::SourceLoc{file, 0}, std::string("cannot load the scenario: ") + e.what());
        }
        if (!spec || diags.hasErrors()) {
            std::string msg;
            for (const ch::Diagnostic& d : diags.all()) msg += d.format() + "\n";
            if (!diags.hasErrors()) msg += file + ": error: the scenario could not be loaded\n";
            if (!msg.empty()) msg.pop_back();
            return fail(CH_ERROR_RUNTIME, msg);
        }
        auto handle = std::make_unique<ch_simulation>();
        for (const ch::Diagnostic& d : diags.all()) handle->warnings += d.format() + "\n";
        try {
            // Throws for names the registry does not know (as the program, scenario_run.cpp).
            handle->sim = std::make_unique<ch::Simulation>(std::move(*spec));
        } catch (const std::exception& e) {
            return fail(CH_ERROR_RUNTIME, file + ": error: " + e.what());
        }
        result = handle.release();
        return CH_OK;
    });
    return result;
}

void ch_simulation_free(ch_simulation* sim) { delete sim; }

const char* ch_simulation_warnings(const ch_simulation* sim) {
    if (sim == nullptr) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_warnings: the simulation handle is NULL");
        return nullptr;
    }
    return sim->warnings.c_str();
}

ch_status ch_simulation_set_threads(ch_simulation* sim, int threads) {
    if (sim == nullptr) return fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_set_threads: the simulation handle is NULL");
    sim->threads = threads < 1 ? 1 : threads;
    return CH_OK;
}

ch_status ch_simulation_step(ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) return fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_step: the simulation handle is NULL");
    return guarded("ch_simulation_step", [&] {
        // OpenMP's thread count belongs to the calling thread: set it for every step.
        sim->sim->setThreads(sim->threads);
        sim->sim->stepCoarse();
        return CH_OK;
    });
}

double ch_simulation_time(const ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_time: the simulation handle is NULL");
        return std::numeric_limits<double>::quiet_NaN();
    }
    return sim->sim->time();
}

double ch_simulation_delta_time(const ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_delta_time: the simulation handle is NULL");
        return std::numeric_limits<double>::quiet_NaN();
    }
    return sim->sim->deltaTime();
}

double ch_simulation_end_time(const ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_end_time: the simulation handle is NULL");
        return std::numeric_limits<double>::quiet_NaN();
    }
    return sim->sim->endTime();
}

int ch_simulation_finished(const ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_finished: the simulation handle is NULL");
        return -1;
    }
    return sim->sim->finished() ? 1 : 0;
}

size_t ch_simulation_agent_count(const ch_simulation* sim) {
    if (sim == nullptr || !sim->sim) {
        fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_agent_count: the simulation handle is NULL");
        return 0;
    }
    return sim->sim->agents().size();
}

ch_status ch_simulation_agent_ids(const ch_simulation* sim, int64_t* ids, size_t capacity, size_t* count) {
    return copyOut(sim, ids, capacity, count, "ch_simulation_agent_ids", [&](std::size_t n) {
        const ch::AgentStore& a = sim->sim->agents();
        for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<int64_t>(a.id[i]);
    });
}

ch_status ch_simulation_positions(const ch_simulation* sim, double* xy, size_t capacity, size_t* count) {
    return copyOut(sim, xy, capacity, count, "ch_simulation_positions", [&](std::size_t n) {
        const ch::AgentStore& a = sim->sim->agents();
        for (std::size_t i = 0; i < n; ++i) {
            xy[2 * i] = a.pos[i].x();
            xy[2 * i + 1] = a.pos[i].y();
        }
    });
}

ch_status ch_simulation_velocities(const ch_simulation* sim, double* vxy, size_t capacity, size_t* count) {
    return copyOut(sim, vxy, capacity, count, "ch_simulation_velocities", [&](std::size_t n) {
        const ch::AgentStore& a = sim->sim->agents();
        for (std::size_t i = 0; i < n; ++i) {
            vxy[2 * i] = a.vel[i].x();
            vxy[2 * i + 1] = a.vel[i].y();
        }
    });
}

ch_status ch_simulation_set_parameter(ch_simulation* sim, int policy_id, const char* component, const char* parameter,
                                      double value) {
    return guarded("ch_simulation_set_parameter", [&] {
        Target t;
        if (const ch_status s = resolve(sim, policy_id, component, parameter, t, "ch_simulation_set_parameter"); s != CH_OK)
            return s;
        if (!std::isfinite(value) || !t.spec->contains(value))
            return fail(CH_ERROR_INVALID_VALUE, "ch_simulation_set_parameter: " + std::string(component) + "." + parameter +
                                                    " " + ch::formatNumber(value) + " is out of range (allowed: " +
                                                    t.spec->rangeText() + ")");
        // Check every target before changing any, so a failure changes nothing.
        for (ch::Component* c : t.components)
            if (std::isnan(c->parameter(parameter)))
                return fail(CH_ERROR_INVALID_VALUE, "ch_simulation_set_parameter: " + std::string(component) + "." +
                                                        parameter + " cannot change while running");
        for (ch::Component* c : t.components) c->setParameter(parameter, value);
        for (std::size_t p : t.healthPolicies) sim->sim->health().params(p).set(parameter, value);
        return CH_OK;
    });
}

ch_status ch_simulation_get_parameter(const ch_simulation* sim, int policy_id, const char* component,
                                      const char* parameter, double* value) {
    return guarded("ch_simulation_get_parameter", [&] {
        if (value == nullptr) return fail(CH_ERROR_NULL_ARGUMENT, "ch_simulation_get_parameter: value is NULL");
        Target t;
        if (const ch_status s = resolve(sim, policy_id, component, parameter, t, "ch_simulation_get_parameter"); s != CH_OK)
            return s;
        const double v = !t.components.empty() ? t.components.front()->parameter(parameter)
                                                : sim->sim->health().params(t.healthPolicies.front()).get(parameter);
        if (std::isnan(v))
            return fail(CH_ERROR_INVALID_VALUE, "ch_simulation_get_parameter: " + std::string(component) + "." + parameter +
                                                    " is not readable while running");
        *value = v;
        return CH_OK;
    });
}

}  // extern "C"
