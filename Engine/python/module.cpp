// crowdhealth — the Python module (pybind11): load a scenario as the program does, step it, read
// the agents into numpy arrays, change parameters, and write the program's outputs
// (docs/python.md). The run goes through chcli::RunSession, the program's own recorders, so
// metrics.csv is byte-identical to `crowdhealth -i … -o …` with the same seed.
#include "../scenario_run.h"
#include "../output_folder.h"
#include "../text_numbers.h"

#include <crowdhealth/core/plugins.h>
#include <crowdhealth/core/registry.h>
#include <crowdhealth/health/health.h>
#include <crowdhealth/io/output.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

/// A scenario that cannot be loaded or built: the message holds the `path:line: error:` lines.
struct ScenarioError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

PyObject* g_scenarioWarning = nullptr;

/// Removes the trailing newline of collected messages.
std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
    return s;
}

/// A private folder for the trajectory files streamed during a run (removed with the simulation).
fs::path makeTempFolder() {
    std::string pattern = (fs::temp_directory_path() / "crowdhealth-py-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("cannot create a temporary folder for trajectories");
    return fs::path(pattern);
}


py::object jsonLoads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

class PySimulation {
public:
    PySimulation(const std::string& path, std::optional<std::uint64_t> seed, int threads, std::optional<std::string> name) {
        if (threads < 1) throw py::value_error("threads must be at least 1");
        options_.input = path;
        options_.quiet = true;
        options_.threads = threads;
        std::ostringstream err;
        std::optional<ch::ScenarioSpec> spec = chcli::loadSpec(options_, seed, true, err);
        if (!spec) throw ScenarioError(trimmed(err.str()));
        if (name) {
            options_.input = *name;
            spec->sourceFile = *name;
        }
        sim_ = chcli::buildSimulation(std::move(*spec), options_, err);
        if (!sim_) throw ScenarioError(trimmed(err.str()));
        plan_ = chcli::planRun(options_, sim_->spec(), true, err);
        if (!plan_) throw ScenarioError(trimmed(err.str()));
        warnings_ = trimmed(err.str());
        if (plan_->trajectories.any()) trajectoryDir_ = makeTempFolder();
        session_ = std::make_unique<chcli::RunSession>(*sim_, *plan_, trajectoryDir_.empty() ? fs::path(".") : trajectoryDir_,
                                                       threads);
        session_->begin();
        if (!warnings_.empty()) {
            for (const std::string& line : chcli::splitOn(warnings_, '\n'))
                if (PyErr_WarnEx(g_scenarioWarning, line.c_str(), 1) != 0) throw py::error_already_set();
        }
    }

    ~PySimulation() {
        session_.reset();
        if (!trajectoryDir_.empty()) {
            std::error_code ec;
            fs::remove_all(trajectoryDir_, ec);
        }
    }

    double time() const { return sim_->time(); }
    std::size_t agentCount() const { return sim_->agents().size(); }
    bool finished() { return session_->done(); }

    /// One coarse step; false (and nothing done) when the run is over.
    bool step() {
        checkOpen();
        if (session_->done()) return false;
        {
            py::gil_scoped_release release;
            session_->step();
        }
        return true;
    }

    /// Steps to the end (end time, everyone left, or the safety cap) or until time >= until.
    double run(std::optional<double> until) {
        checkOpen();
        while (!session_->done()) {
            if (until) {
                const double t = sim_->time();
                if (t + 1e-9 * std::max(1.0, std::abs(t)) >= *until) break;
            }
            {
                py::gil_scoped_release release;
                session_->step();
            }
            if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C between steps
        }
        return sim_->time();
    }

    py::array_t<std::int64_t> ids() const {
        const ch::AgentStore& a = sim_->agents();
        py::array_t<std::int64_t> out(static_cast<py::ssize_t>(a.size()));
        auto v = out.mutable_unchecked<1>();
        for (std::size_t i = 0; i < a.size(); ++i) v(static_cast<py::ssize_t>(i)) = a.id[i];
        return out;
    }

    static py::array_t<double> columns(const std::vector<ch::Vec2>& xs) {
        py::array_t<double> out({static_cast<py::ssize_t>(xs.size()), static_cast<py::ssize_t>(2)});
        auto v = out.mutable_unchecked<2>();
        for (std::size_t i = 0; i < xs.size(); ++i) {
            v(static_cast<py::ssize_t>(i), 0) = xs[i].x();
            v(static_cast<py::ssize_t>(i), 1) = xs[i].y();
        }
        return out;
    }
    py::array_t<double> positions() const { return columns(sim_->agents().pos); }
    py::array_t<double> velocities() const { return columns(sim_->agents().vel); }

    static std::vector<std::string> fieldNames() {
        return {"density", "contact_accel", "panic", "speed", "pref_speed", "radius", "injured", "dose", "fallen"};
    }

    /// Per-agent values, in the order of ids().
    py::array_t<double> field(const std::string& name) {
        const ch::AgentStore& a = sim_->agents();
        const std::size_t n = a.size();
        std::vector<double> v(n, 0.0);
        const ch::HealthLayer& h = std::as_const(*sim_).health();
        if (name == "density") {
            sim_->measureDensity(1.0);  // the metrics' SPH density (h = 1 m, walls included); changes nothing else
            v = a.density;
        } else if (name == "contact_accel") {
            for (std::size_t i = 0; i < n; ++i) v[i] = a.contactAccel[i].norm();
        } else if (name == "panic") {
            for (std::size_t i = 0; i < n; ++i) v[i] = h.recordOf(a, i).panic;
        } else if (name == "speed") {
            for (std::size_t i = 0; i < n; ++i) v[i] = a.vel[i].norm();
        } else if (name == "pref_speed") {
            v = a.prefSpeed;
        } else if (name == "radius") {
            v = a.radius;
        } else if (name == "injured") {
            for (std::size_t i = 0; i < n; ++i) v[i] = h.recordOf(a, i).injured() ? 1.0 : 0.0;
        } else if (name == "dose") {
            for (std::size_t i = 0; i < n; ++i) v[i] = h.recordOf(a, i).dose;
        } else if (name == "fallen") {
            for (std::size_t i = 0; i < n; ++i) v[i] = h.recordOf(a, i).fallen ? 1.0 : 0.0;
        } else if (const auto dot = name.find('.'); dot != std::string::npos) {
            // Component.field, as <Step BlendField> names it (e.g. SPH.rest_density): NaN for
            // agents whose policy has no such component.
            const std::string comp = name.substr(0, dot), fieldName = name.substr(dot + 1);
            std::vector<const std::vector<double>*> perPolicy;
            bool any = false;
            for (ch::Policy& p : sim_->policies()) {
                ch::Component* c = p.findComponent(comp);
                perPolicy.push_back(c != nullptr ? c->field(fieldName) : nullptr);
                any = any || perPolicy.back() != nullptr;
            }
            if (!any) throw py::value_error("no policy has a component " + comp + " with a field '" + fieldName + "'");
            for (std::size_t i = 0; i < n; ++i) {
                const int p = a.policy[i];
                const std::vector<double>* f = p >= 0 ? perPolicy[static_cast<std::size_t>(p)] : nullptr;
                v[i] = f != nullptr && i < f->size() ? (*f)[i] : std::nan("");
            }
        } else {
            std::string known;
            for (const std::string& f : fieldNames()) known += (known.empty() ? "" : ", ") + f;
            throw py::value_error("unknown field '" + name + "'; known: " + known + ", or Component.field (e.g. SPH.rest_density)");
        }
        return py::array_t<double>(static_cast<py::ssize_t>(n), v.data());
    }

    /// Sets a parameter as <Ramp component="…" policy="…" parameter="…"> would.
    void setParameter(std::optional<int> policyId, const std::string& component, const std::string& parameter, double value) {
        checkOpen();
        const ch::ParamTable* table = nullptr;
        ch::ParamTable full;
        if (component == "CrowdHealth") {
            table = &ch::crowdHealthTable();
        } else if (const ch::ComponentInfo* info = ch::Registry::instance().find(component)) {
            full = ch::Registry::fullTable(*info);
            table = &full;
        } else {
            throw py::value_error("unknown component '" + component + "' (crowdhealth.list_policies() names them; or CrowdHealth)");
        }
        const ch::ParamSpec* spec = nullptr;
        std::string names;
        for (const ch::ParamSpec& p : *table) {
            names += (names.empty() ? "" : ", ") + p.name;
            if (p.name == parameter) spec = &p;
        }
        if (spec == nullptr)
            throw py::value_error(component + " has no parameter '" + parameter + "'; its parameters: " + names);
        if (spec->type != ch::ParamType::Real)
            throw py::value_error(component + "." + parameter + " is not a real number (only real parameters can be set, as with <Ramp>)");
        if (const std::string fixed = ch::fixedForTheRun(component, parameter); !fixed.empty())
            throw py::value_error(fixed);
        if (!spec->contains(value))
            throw py::value_error(ch::formatNumber(value) + " is out of range for " + component + "." + parameter +
                                  " (allowed: " + spec->rangeText() + ")");
        int hits = 0;
        std::vector<ch::Policy>& policies = sim_->policies();
        for (std::size_t p = 0; p < policies.size(); ++p) {
            if (policyId && policies[p].id() != *policyId) continue;
            if (component == "CrowdHealth") {
                sim_->health().params(p).set(parameter, value);
                ++hits;
                continue;
            }
            for (ch::PolicyStep& s : policies[p].steps())
                for (auto& e : s.components())
                    if (e.name == component) {
                        if (!e.component->setParameter(parameter, value))
                            throw py::value_error(component + "." + parameter + " cannot be changed while running");
                        ++hits;
                    }
        }
        if (hits == 0)
            throw py::value_error(component + "." + parameter + " targets no component of " +
                                  (policyId ? "policy " + std::to_string(*policyId) : std::string("any policy")));
    }

    /// The value of a parameter in the first matching component (as metrics.csv reports a ramp).
    double parameter(std::optional<int> policyId, const std::string& component, const std::string& parameter) {
        std::vector<ch::Policy>& policies = sim_->policies();
        for (std::size_t p = 0; p < policies.size(); ++p) {
            if (policyId && policies[p].id() != *policyId) continue;
            if (component == "CrowdHealth") return std::as_const(*sim_).health().params(p).get(parameter);
            for (ch::PolicyStep& s : policies[p].steps())
                for (auto& e : s.components())
                    if (e.name == component) {
                        const double v = e.component->parameter(parameter);
                        if (v == v) return v;
                    }
        }
        throw py::value_error(component + "." + parameter + " is not found in " +
                              (policyId ? "policy " + std::to_string(*policyId) : std::string("any policy")));
    }

    /// The metrics.csv columns so far (the final row once the run has ended or its outputs were written).
    py::dict metrics() const {
        const auto& rows = session_->metrics().rows();
        const std::vector<std::string> header = chcli::splitOn(ch::kMetricsHeader, ',');
        const py::ssize_t n = static_cast<py::ssize_t>(rows.size());
        py::dict out;
        auto real = [&](const char* name, auto get) {
            py::array_t<double> a(n);
            auto v = a.mutable_unchecked<1>();
            for (py::ssize_t i = 0; i < n; ++i) v(i) = get(rows[static_cast<std::size_t>(i)]);
            out[name] = a;
        };
        auto count = [&](const char* name, auto get) {
            py::array_t<std::int64_t> a(n);
            auto v = a.mutable_unchecked<1>();
            for (py::ssize_t i = 0; i < n; ++i) v(i) = static_cast<std::int64_t>(get(rows[static_cast<std::size_t>(i)]));
            out[name] = a;
        };
        using R = ch::MetricsRow;
        real("time", [](const R& r) { return r.time; });
        count("agents", [](const R& r) { return r.agents; });
        count("evacuated", [](const R& r) { return r.evacuated; });
        real("mean_density", [](const R& r) { return r.meanDensity; });
        real("max_density", [](const R& r) { return r.maxDensity; });
        real("mean_rest_density", [](const R& r) { return r.meanRestDensity; });
        real("mean_speed", [](const R& r) { return r.meanSpeed; });
        real("max_speed", [](const R& r) { return r.maxSpeed; });
        real("mean_contact_accel", [](const R& r) { return r.meanContactAccel; });
        real("max_contact_accel", [](const R& r) { return r.maxContactAccel; });
        real("max_wall_penetration", [](const R& r) { return r.maxWallPenetration; });
        real("mean_panic", [](const R& r) { return r.meanPanic; });
        count("injured", [](const R& r) { return r.injured; });
        real("crowd_pressure", [](const R& r) { return r.crowdPressure; });
        if (out.size() != header.size()) throw std::logic_error("metrics(): the columns do not match metrics.csv's header");
        const std::vector<std::string>& ramps = sim_->scheduleColumns();
        for (std::size_t c = 0; c < ramps.size(); ++c) {
            py::array_t<double> a(n);
            auto v = a.mutable_unchecked<1>();
            for (py::ssize_t i = 0; i < n; ++i) {
                const auto& s = rows[static_cast<std::size_t>(i)].schedule;
                v(i) = c < s.size() ? s[c] : std::nan("");
            }
            out[py::str(ramps[c])] = a;
        }
        return out;
    }

    py::object verdict() const { return jsonLoads(ch::verdictJson(session_->verdict())); }

    /// summary.json as a dict (the run so far; ended runs: as written).
    py::object summary() const {
        const ch::Verdict v = session_->verdict();
        return jsonLoads(ch::summaryJson(*sim_, session_->info(), session_->peaks(), &v));
    }

    /// Writes the program's files for this run into `dir`; the run ends (no more steps).
    std::vector<std::string> writeOutputs(const std::string& dir, bool overwrite) {
        if (written_ && plan_->trajectories.any())
            throw std::runtime_error("the outputs were written already (the trajectories were moved there)");
        const fs::path outDir(dir);
        if (const auto problem = chcli::checkOutputFolder(outDir, overwrite)) throw std::runtime_error(problem->message);
        std::vector<std::string> warnings;
        warnings = session_->write(outDir, [&] {
            if (trajectoryDir_.empty()) return;
            // The trajectory files were streamed into the private folder; move them next to the others
            // (summary.json is still to come, so the folder's rules hold).
            for (const auto& entry : fs::directory_iterator(trajectoryDir_)) {
                const fs::path to = outDir / entry.path().filename();
                std::error_code ec;
                fs::rename(entry.path(), to, ec);
                if (ec) {
                    fs::copy_file(entry.path(), to, fs::copy_options::overwrite_existing);
                    fs::remove(entry.path());
                }
            }
        });
        written_ = true;
        return warnings;
    }

    void end() { session_->end(); }
    bool ended() const { return session_->ended(); }
    double deltaTime() const { return sim_->deltaTime(); }
    double endTime() const { return sim_->endTime(); }
    std::uint64_t seed() const { return sim_->spec().seed; }
    std::uint64_t coarseSteps() const { return sim_->coarseSteps(); }
    std::size_t evacuated() const { return sim_->evacuations().size(); }
    std::size_t pending() const { return sim_->pending(); }
    std::vector<int> policyIds() const {
        std::vector<int> ids;
        for (const ch::Policy& p : std::as_const(*sim_).policies()) ids.push_back(p.id());
        return ids;
    }
    const std::string& warnings() const { return warnings_; }

private:
    void checkOpen() const {
        if (session_->ended())
            throw std::runtime_error("the run has ended (write_outputs() or end() was called); load the scenario again to run more");
    }

    chcli::Options options_;
    std::unique_ptr<ch::Simulation> sim_;
    std::optional<chcli::RunPlan> plan_;
    std::unique_ptr<chcli::RunSession> session_;
    fs::path trajectoryDir_;
    std::string warnings_;
    bool written_ = false;
};

/// crowdhealth.load_plugin(path): the names of the components it added ([] when loaded before).
py::list loadPlugin(const std::string& path) {
    const ch::PluginLoad load = ch::loadPlugin(ch::findPlugin(path, ""));
    if (!load.ok) throw ScenarioError(path + ": " + load.error);
    return py::cast(load.components);
}

py::list listPolicies() {
    py::list out;
    for (const ch::ComponentInfo* info : ch::Registry::instance().all()) {
        py::dict d;
        d["name"] = info->name;
        d["kind"] = info->kind == ch::ComponentKind::Force ? "force" : "cost function";
        d["summary"] = info->summary;
        d["reference"] = info->reference;
        d["models_contact"] = info->modelsContact;
        d["plugin"] = info->origin;  // "" for a built-in component
        py::list params;
        for (const ch::ParamSpec& p : ch::Registry::fullTable(*info)) {
            py::dict q;
            q["name"] = p.name;
            q["unit"] = p.unit;
            q["default"] = p.defaultText();
            q["range"] = p.rangeText();
            q["description"] = p.description;
            params.append(q);
        }
        d["parameters"] = params;
        out.append(d);
    }
    return out;
}

}  // namespace

PYBIND11_MODULE(_crowdhealth, m) {
    m.doc() = "CrowdHealth's simulator: the compiled part of the crowdhealth package (docs/python.md)";
    py::register_exception<ScenarioError>(m, "ScenarioError", PyExc_ValueError);
    static py::exception<int> scenarioWarning(m, "ScenarioWarning", PyExc_UserWarning);
    g_scenarioWarning = scenarioWarning.ptr();

    py::class_<PySimulation>(m, "Simulation")
        .def(py::init<const std::string&, std::optional<std::uint64_t>, int, std::optional<std::string>>(), py::arg("path"),
             py::arg("seed") = py::none(), py::arg("threads") = 1, py::arg("name") = py::none())
        .def_property_readonly("time", &PySimulation::time, "simulated time (s)")
        .def_property_readonly("agent_count", &PySimulation::agentCount, "agents in the world now")
        .def_property_readonly("finished", &PySimulation::finished, "True when the run is over")
        .def_property_readonly("delta_time", &PySimulation::deltaTime, "the coarse step (s)")
        .def_property_readonly("end_time", &PySimulation::endTime, "end time (s); < 0: until everyone has left")
        .def_property_readonly("seed", &PySimulation::seed)
        .def_property_readonly("steps", &PySimulation::coarseSteps, "coarse steps done")
        .def_property_readonly("evacuated", &PySimulation::evacuated, "agents removed at their goal or exit so far")
        .def_property_readonly("pending", &PySimulation::pending, "agents still to appear")
        .def_property_readonly("policy_ids", &PySimulation::policyIds)
        .def_property_readonly("warnings", &PySimulation::warnings, "the loader's warnings (also issued as ScenarioWarning)")
        .def("step", &PySimulation::step, "one coarse step; False (nothing done) once the run is over")
        .def("run", &PySimulation::run, py::arg("until") = py::none(),
             "steps to the end time or until everyone has left (or until time >= until); returns the time")
        .def("ids", &PySimulation::ids)
        .def("positions", &PySimulation::positions)
        .def("velocities", &PySimulation::velocities)
        .def("field", &PySimulation::field, py::arg("name"))
        .def_static("field_names", &PySimulation::fieldNames)
        .def("set_parameter", &PySimulation::setParameter, py::arg("policy"), py::arg("component"), py::arg("parameter"),
             py::arg("value"))
        .def("parameter", &PySimulation::parameter, py::arg("policy"), py::arg("component"), py::arg("parameter"))
        .def("metrics", &PySimulation::metrics)
        .def("verdict", &PySimulation::verdict)
        .def("summary", &PySimulation::summary)
        .def("end", &PySimulation::end, "ends the run (adds the final metrics row); no more steps")
        .def_property_readonly("ended", &PySimulation::ended)
        .def("write_outputs", &PySimulation::writeOutputs, py::arg("dir"), py::arg("overwrite") = false);

    m.def("load_plugin", &loadPlugin, py::arg("path"),
          "loads a plugin (shared library of cost functions and forces, docs/adding-a-policy.md); "
          "returns the names it added; raises ScenarioError when it cannot be loaded");
    m.def("list_policies", &listPolicies, "every registered cost function and force with its parameters");
    m.attr("metrics_columns") = py::cast(chcli::splitOn(ch::kMetricsHeader, ','));
}
