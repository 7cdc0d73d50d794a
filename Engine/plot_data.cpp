// crowdhealth plot / compare — reading run folders (see plot_data.h).
#include "plot_data.h"

#include <crowdhealth/io/json.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace chplot {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string trim(std::string s) {
    const auto notSpace = [](unsigned char c) { return !std::isspace(c); };
    s.erase(s.begin(), std::find_if(s.begin(), s.end(), notSpace));
    s.erase(std::find_if(s.rbegin(), s.rend(), notSpace).base(), s.end());
    return s;
}

std::vector<std::string> splitCsv(const std::string& line) {
    std::vector<std::string> cells;
    std::string cur;
    for (const char c : line) {
        if (c == ',') {
            cells.push_back(trim(cur));
            cur.clear();
        } else {
            cur += c;
        }
    }
    cells.push_back(trim(cur));
    return cells;
}

double parseCell(const std::string& s) {
    if (s.empty()) return kNaN;
    double v = kNaN;
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    if (res.ec != std::errc() || res.ptr != s.data() + s.size()) {
        if (s == "true") return 1;
        if (s == "false") return 0;
        return kNaN;  // "nan", "inf" are parsed by from_chars; anything else is not a number
    }
    return v;
}

/// summary.json through the JSON library. Absent: not present. Present but broken (not JSON, a
/// key of the wrong type): throws ch::JsonError naming the file and what is wrong.
RunSummary readSummary(const fs::path& file) {
    RunSummary s;
    if (!fs::exists(file)) return s;
    const ch::Json tree = ch::readJsonFile(file);
    if (!tree.is_object()) throw ch::JsonError(file.string() + ": expected a JSON object, not " + std::string(tree.type_name()));
    auto text = [&](const ch::Json& object, const char* key, const std::string& where) -> std::string {
        const auto it = object.find(key);
        if (it == object.end() || it->is_null()) return "";
        if (!it->is_string()) throw ch::JsonError(file.string() + ": \"" + where + "\" should be a string, not " + it->dump());
        return it->get<std::string>();
    };
    auto finite = [](std::optional<double> v) { return v && std::isfinite(*v) ? v : std::nullopt; };
    s.present = true;
    s.scenario = text(tree, "scenario", "scenario");
    s.evacuationTime = finite(ch::jsonOptionalNumber(tree, "evacuation_time", file));
    if (const auto flow = tree.find("flow"); flow != tree.end() && !flow->is_null())
        s.flow = finite(ch::jsonOptionalNumber(*flow, "persons_per_second", file));
    if (const auto it = tree.find("interrupted"); it != tree.end() && !it->is_null()) {
        if (!it->is_boolean()) throw ch::JsonError(file.string() + ": \"interrupted\" should be true or false, not " + it->dump());
        s.interrupted = it->get<bool>();
    }
    if (const auto verdict = tree.find("verdict"); verdict != tree.end() && !verdict->is_null()) {
        if (!verdict->is_object()) throw ch::JsonError(file.string() + ": \"verdict\" should be an object, not " + verdict->dump());
        s.verdict = text(*verdict, "level", "verdict.level");
    }
    return s;
}

std::string loadRun(const fs::path& dir, RunData& run) {
    run.dir = dir;
    run.name = folderName(dir);
    if (std::string e = readCsv(dir / "metrics.csv", run.metrics); !e.empty()) return e;
    if (run.metrics.column("time") < 0) return (dir / "metrics.csv").string() + ": no 'time' column";
    if (fs::exists(dir / "health.csv")) {
        Table t;
        if (std::string e = readCsv(dir / "health.csv", t); !e.empty()) return e;
        run.health = std::move(t);
    }
    if (fs::exists(dir / "heatmap.csv")) {
        Table t;
        if (std::string e = readCsv(dir / "heatmap.csv", t); !e.empty()) return e;
        run.heatmap = std::move(t);
    }
    try {
        run.summary = readSummary(dir / "summary.json");
    } catch (const ch::JsonError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

int Table::column(std::string_view name) const {
    for (std::size_t i = 0; i < header.size(); ++i)
        if (header[i] == name) return static_cast<int>(i);
    return -1;
}

std::vector<double> Table::values(std::string_view name) const {
    std::vector<double> v;
    const int c = column(name);
    if (c < 0) return v;
    for (const auto& r : rows) v.push_back(static_cast<std::size_t>(c) < r.size() ? r[static_cast<std::size_t>(c)] : kNaN);
    return v;
}

std::string readCsv(const fs::path& file, Table& table) {
    std::ifstream in(file);
    if (!in) return "cannot read " + file.string();
    table = Table{};
    std::string line;
    if (!std::getline(in, line)) return file.string() + ": empty file (no header row)";
    if (!line.empty() && line.back() == '\r') line.pop_back();
    table.header = splitCsv(line);
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (trim(line).empty()) continue;
        std::vector<double> row;
        for (const std::string& cell : splitCsv(line)) row.push_back(parseCell(cell));
        row.resize(table.header.size(), kNaN);
        table.rows.push_back(std::move(row));
    }
    return "";
}

std::string folderName(const fs::path& dir) {
    fs::path p = dir.lexically_normal();
    if (!p.empty() && p.filename().empty()) p = p.parent_path();  // "out/base/"
    std::string name = p.filename().string();
    if (name.empty() || name == "." || name == "..") {
        std::error_code ec;
        const fs::path abs = fs::weakly_canonical(fs::absolute(dir), ec);
        name = abs.filename().string();
    }
    return name.empty() ? std::string("run") : name;
}

std::string loadExperiment(const fs::path& dir, Experiment& experiment) {
    experiment = Experiment{};
    experiment.dir = dir;
    experiment.name = folderName(dir);
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return dir.string() + ": no such folder";
    if (fs::exists(dir / "metrics.csv")) {
        RunData run;
        if (std::string e = loadRun(dir, run); !e.empty()) return e;
        experiment.runs.push_back(std::move(run));
        return "";
    }
    std::vector<fs::path> runDirs;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (entry.is_directory() && name.rfind("run_", 0) == 0 && fs::exists(entry.path() / "metrics.csv"))
            runDirs.push_back(entry.path());
    }
    if (ec) return dir.string() + ": cannot list the folder: " + ec.message();
    if (runDirs.empty())
        return dir.string() + ": neither metrics.csv nor run_*/metrics.csv found (not a crowdhealth output folder)";
    std::sort(runDirs.begin(), runDirs.end());
    experiment.replications = true;
    for (const fs::path& d : runDirs) {
        RunData run;
        if (std::string e = loadRun(d, run); !e.empty()) return e;
        experiment.runs.push_back(std::move(run));
    }
    return "";
}

Curve metricsCurve(const RunData& run, std::string_view name) {
    Curve c;
    const int ct = run.metrics.column("time"), cv = run.metrics.column(name);
    if (ct < 0 || cv < 0) return c;
    // A crowd property (density, speed, contact, panic, pressure) has no value once nobody is
    // left: metrics.csv writes 0 there, which would draw a drop to 0 at every run's end.
    const int ca = run.metrics.column("agents");
    const bool perCrowd = cv < kFixedMetricsColumns && name != "agents" && name != "evacuated" && name != "injured";
    for (const auto& r : run.metrics.rows) {
        if (perCrowd && ca >= 0 && r[static_cast<std::size_t>(ca)] == 0) continue;
        const double t = r[static_cast<std::size_t>(ct)], v = r[static_cast<std::size_t>(cv)];
        if (std::isfinite(t) && std::isfinite(v)) c.emplace_back(t, v);
    }
    return c;
}

std::vector<MeanPoint> meanCurve(const std::vector<Curve>& curves, bool holdLast) {
    // Times to the millisecond, so rows of runs sampled on the same interval line up.
    std::map<long long, double> times;
    for (const Curve& c : curves)
        for (const auto& [t, v] : c) times.emplace(std::llround(t * 1000.0), t);
    std::vector<MeanPoint> out;
    for (const auto& [key, t] : times) {
        std::vector<double> vals;
        bool someEnded = false;
        for (const Curve& c : curves) {
            if (c.empty()) continue;
            // The run's row at this time, else (when holdLast and the run has ended) its last value.
            const auto it = std::lower_bound(c.begin(), c.end(), key, [](const std::pair<double, double>& p, long long k) {
                return std::llround(p.first * 1000.0) < k;
            });
            if (it != c.end() && std::llround(it->first * 1000.0) == key) vals.push_back(it->second);
            else if (it == c.end() && holdLast) vals.push_back(c.back().second);
            else if (it == c.end()) someEnded = true;
            else if (it != c.end() && it != c.begin()) vals.push_back(std::prev(it)->second);  // between two rows
        }
        if (vals.empty() || someEnded) continue;
        double sum = 0;
        for (const double v : vals) sum += v;
        const double mean = sum / static_cast<double>(vals.size());
        double ss = 0;
        for (const double v : vals) ss += (v - mean) * (v - mean);
        const double sd = vals.size() > 1 ? std::sqrt(ss / static_cast<double>(vals.size() - 1)) : 0.0;
        out.push_back({t, mean, sd, vals.size()});
    }
    return out;
}

static std::optional<std::pair<double, double>> rampWindow(const RunData& run, std::size_t c) {
    const Table& m = run.metrics;
    const int ct = m.column("time");
    if (ct < 0 || m.rows.size() < 2 || c >= m.header.size()) return std::nullopt;
    std::optional<double> start, end;
    const double first = m.rows.front()[c], last = m.rows.back()[c];
    for (std::size_t i = 1; i < m.rows.size(); ++i) {
        if (m.rows[i][c] != first && std::isfinite(m.rows[i][c])) {
            start = m.rows[i - 1][static_cast<std::size_t>(ct)];  // last row still at the start value
            break;
        }
    }
    for (std::size_t i = m.rows.size(); i-- > 1;) {
        if (m.rows[i - 1][c] != last && std::isfinite(m.rows[i - 1][c])) {
            end = m.rows[i][static_cast<std::size_t>(ct)];  // first row at the final value
            break;
        }
    }
    if (!start || !end || *end <= *start) return std::nullopt;
    return std::make_pair(*start, *end);
}

std::optional<std::pair<double, double>> rampWindow(const RunData& run, const std::string& column) {
    const int c = run.metrics.column(column);
    if (c < static_cast<int>(kFixedMetricsColumns)) return std::nullopt;
    return rampWindow(run, static_cast<std::size_t>(c));
}

std::optional<std::pair<double, double>> rampWindow(const RunData& run) {
    std::optional<std::pair<double, double>> all;
    for (std::size_t c = kFixedMetricsColumns; c < run.metrics.header.size(); ++c)
        if (const auto w = rampWindow(run, c))
            all = all ? std::make_pair(std::min(all->first, w->first), std::max(all->second, w->second)) : *w;
    return all;
}

std::optional<double> peak(const Curve& c) {
    std::optional<double> p;
    for (const auto& [t, v] : c)
        if (std::isfinite(v) && (!p || v > *p)) p = v;
    return p;
}

std::optional<double> valueAt(const Curve& c, double t) {
    for (const auto& [ti, v] : c)
        if (ti >= t - 1e-9) return v;
    return std::nullopt;
}

}  // namespace chplot
