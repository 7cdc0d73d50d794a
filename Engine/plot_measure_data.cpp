// crowdhealth plot — the data of los.png, flows.png and areas.png (see plot_measure_data.h).
#include "plot_measure_data.h"

#include <crowdhealth/health/safety.h>
#include <crowdhealth/io/output.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <deque>
#include <fstream>
#include <map>

namespace chplot {

namespace {

std::vector<std::string> splitLine(const std::string& line) {
    std::vector<std::string> out(1);
    for (const char c : line) {
        if (c == ',') out.emplace_back();
        else out.back() += c;
    }
    return out;
}

bool number(const std::string& s, double& v) {
    if (s.empty()) return false;
    const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
    return res.ec == std::errc() && res.ptr == s.data() + s.size();
}

/// A CSV file read as text: its header and, per data row, its cells and line number.
struct TextCsv {
    std::vector<std::string> header;
    std::vector<std::pair<int, std::vector<std::string>>> rows;
    int column(const std::string& name) const {
        for (std::size_t i = 0; i < header.size(); ++i)
            if (header[i] == name) return static_cast<int>(i);
        return -1;
    }
};

std::string readText(const std::filesystem::path& file, TextCsv& t) {
    std::ifstream in(file);
    if (!in) return "cannot read " + file.string();
    std::string line;
    if (!std::getline(in, line)) return file.string() + ": empty file (no header row)";
    if (!line.empty() && line.back() == '\r') line.pop_back();
    t.header = splitLine(line);
    for (int n = 2; std::getline(in, line); ++n) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) continue;
        std::vector<std::string> cells = splitLine(line);
        cells.resize(t.header.size());
        t.rows.emplace_back(n, std::move(cells));
    }
    return "";
}

/// The columns `names` of `t`, or an error naming the first missing one.
std::string columns(const std::filesystem::path& file, const TextCsv& t, const std::vector<std::string>& names,
                    std::vector<std::size_t>& at) {
    at.clear();
    for (const std::string& n : names) {
        const int c = t.column(n);
        if (c < 0) return file.string() + ":1: no column '" + n + "'";
        at.push_back(static_cast<std::size_t>(c));
    }
    return "";
}

std::string where(const std::filesystem::path& file, int line) { return file.string() + ":" + std::to_string(line); }

std::string fixed(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

}  // namespace

ch::Vec2 forwardDirection(const ch::Vec2& a, const ch::Vec2& b) {
    const ch::Vec2 d = b - a;
    const double len = d.norm();
    if (!(len > 0)) return ch::Vec2(0, 0);
    return ch::Vec2(d.y() / len, -d.x() / len);
}

std::string readLosGrid(const std::filesystem::path& heatmapCsv, std::vector<LosCell>& cells, bool& hasLos) {
    cells.clear();
    hasLos = false;
    TextCsv t;
    if (std::string e = readText(heatmapCsv, t); !e.empty()) return e;
    if (t.column("worst_los") < 0) return "";
    hasLos = true;
    std::vector<std::size_t> c;
    if (std::string e = columns(heatmapCsv, t, {"x", "y", "max_density", "worst_los"}, c); !e.empty()) return e;
    for (const auto& [line, row] : t.rows) {
        LosCell cell;
        double density = 0;
        if (!number(row[c[0]], cell.x) || !number(row[c[1]], cell.y) || !number(row[c[2]], density))
            return where(heatmapCsv, line) + ": x, y and max_density must be numbers";
        const std::string& level = row[c[3]];
        if (level.size() != 1 || level[0] < 'A' || level[0] > 'F')
            return where(heatmapCsv, line) + ": worst_los '" + level + "' is not one of Fruin's levels A to F";
        cell.level = level[0];
        cell.reached = density > 0;
        cells.push_back(cell);
    }
    return "";
}

std::vector<LosCell> combineLos(const std::vector<std::vector<LosCell>>& runs) {
    std::map<std::pair<long long, long long>, LosCell> grid;
    for (const std::vector<LosCell>& run : runs)
        for (const LosCell& c : run) {
            const auto key = std::make_pair(std::llround(c.y * 1000), std::llround(c.x * 1000));
            auto [it, inserted] = grid.try_emplace(key, c);
            if (inserted) continue;
            it->second.level = std::max(it->second.level, c.level);
            it->second.reached = it->second.reached || c.reached;
        }
    std::vector<LosCell> out;
    out.reserve(grid.size());
    for (const auto& [k, c] : grid) out.push_back(c);
    return out;
}

unsigned losColour(char level) {
    switch (level) {
        case 'A': return 0x2166ac;  // blue
        case 'B': return 0x67c5e8;  // light blue
        case 'C': return 0x4daf4a;  // green
        case 'D': return 0xffe135;  // yellow
        case 'E': return 0xff8c1a;  // orange
        case 'F': return 0xd7191c;  // red
        default: return 0xffffff;
    }
}

std::string losColourHex(char level) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%06x", losColour(level));
    return buf;
}

std::string losLegend(char level) {
    // fruinLevel: a level holds from its lower area per person (inclusive) up; in densities, from
    // above the previous level's upper density to its own upper density (inclusive).
    const double lower = level > 'A' ? ch::fruinLowerDensity(level) : 0.0;  // exclusive
    const double upper = level < 'F' ? ch::fruinLowerDensity(static_cast<char>(level + 1)) : 0.0;  // inclusive
    std::string s(1, level);
    s += ": ";
    if (level == 'A') s += "ρ ≤ " + fixed(upper) + " P/m² (≥ " + fixed(1 / upper) + " m²/P)";
    else if (level == 'F') s += "ρ > " + fixed(lower) + " P/m² (< " + fixed(1 / lower) + " m²/P)";
    else s += fixed(lower) + " < ρ ≤ " + fixed(upper) + " P/m² (" + fixed(1 / upper) + " to " + fixed(1 / lower) + " m²/P)";
    return s;
}

std::string readFlows(const std::filesystem::path& csv, std::vector<FlowSeries>& series) {
    series.clear();
    TextCsv t;
    if (std::string e = readText(csv, t); !e.empty()) return e;
    std::vector<std::size_t> c;
    if (std::string e = columns(csv, t, {"time", "line", "kind", "forward", "backward", "flow", "specific_flow"}, c);
        !e.empty())
        return e;
    std::map<std::string, std::size_t> index;
    for (const auto& [line, row] : t.rows) {
        double time = 0, forward = 0, backward = 0, flow = 0, specific = 0;
        if (!number(row[c[0]], time) || !number(row[c[3]], forward) || !number(row[c[4]], backward) ||
            !number(row[c[5]], flow) || !number(row[c[6]], specific))
            return where(csv, line) + ": time, forward, backward, flow and specific_flow must be numbers";
        const std::string& name = row[c[1]];
        if (name.empty()) return where(csv, line) + ": no line name";
        // By kind and name: a measurement line may share its name with an exit.
        const bool exit = row[c[2]] == "exit";
        auto [it, inserted] = index.try_emplace((exit ? "exit:" : "line:") + name, series.size());
        if (inserted) {
            series.emplace_back();
            series.back().name = name;
            series.back().exit = exit;
        }
        FlowSeries& s = series[it->second];
        if (flow > 0 && specific > 0 && s.width == 0) s.width = flow / specific;
        s.specificFlow.emplace_back(time, specific);
        s.forward.emplace_back(time, forward);
        s.backward.emplace_back(time, backward);
        s.totalForward += static_cast<int>(forward);
        s.totalBackward += static_cast<int>(backward);
    }
    return "";
}

Curve windowedSpecificFlow(const FlowSeries& s, double window) {
    Curve out;
    if (!(s.width > 0) || !(window > 0)) return out;
    std::deque<std::pair<double, double>> recent;  // (time, crossings) of the rows in the window
    double sum = 0;
    for (std::size_t i = 0; i < s.forward.size(); ++i) {
        const double t = s.forward[i].first;
        const double n = s.forward[i].second + (i < s.backward.size() ? s.backward[i].second : 0.0);
        recent.emplace_back(t, n);
        sum += n;
        while (!recent.empty() && recent.front().first <= t - window + 1e-9) {
            sum -= recent.front().second;
            recent.pop_front();
        }
        out.emplace_back(t, sum / window / s.width);
    }
    return out;
}

std::string readAreas(const std::filesystem::path& csv, std::vector<AreaSeries>& series) {
    series.clear();
    TextCsv t;
    if (std::string e = readText(csv, t); !e.empty()) return e;
    std::vector<std::size_t> c;
    if (std::string e = columns(csv, t, {"time", "area", "density", "speed", "specific_flow", "los", "people"}, c);
        !e.empty())
        return e;
    std::map<std::string, std::size_t> index;
    for (const auto& [line, row] : t.rows) {
        double time = 0, density = 0, speed = 0, specific = 0, people = 0;
        if (!number(row[c[0]], time) || !number(row[c[2]], density) || !number(row[c[3]], speed) ||
            !number(row[c[4]], specific) || !number(row[c[6]], people))
            return where(csv, line) + ": time, density, speed, specific_flow and people must be numbers";
        const std::string& los = row[c[5]];
        if (los.size() != 1 || los[0] < 'A' || los[0] > 'F')
            return where(csv, line) + ": los '" + los + "' is not one of Fruin's levels A to F";
        const std::string& name = row[c[1]];
        if (name.empty()) return where(csv, line) + ": no area name";
        auto [it, inserted] = index.try_emplace(name, series.size());
        if (inserted) {
            series.emplace_back();
            series.back().name = name;
        }
        AreaSeries& s = series[it->second];
        s.density.emplace_back(time, density);
        s.speed.emplace_back(time, speed);
        s.specificFlow.emplace_back(time, specific);
        s.people.emplace_back(time, people);
        s.los.push_back(los[0]);
    }
    return "";
}

}  // namespace chplot
