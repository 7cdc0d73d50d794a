// crowdhealth plot — the data of paths.png (see plot_paths_data.h).
#include "plot_paths_data.h"

#include <fstream>
#include <sstream>

namespace chplot {

namespace {

std::vector<std::string> cells(const std::string& line) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream in(line);
    while (std::getline(in, cell, ',')) out.push_back(cell);
    if (!line.empty() && line.back() == ',') out.emplace_back();
    return out;
}

}  // namespace

std::string readEvacuationExits(const std::filesystem::path& csv, std::map<long long, std::string>& exitOf) {
    exitOf.clear();
    std::ifstream in(csv);
    if (!in) return "cannot read " + csv.string();
    std::string line;
    if (!std::getline(in, line)) return csv.string() + ": empty (expected the header id,time[,exit])";
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::vector<std::string> header = cells(line);
    int idCol = -1, exitCol = -1;
    for (std::size_t c = 0; c < header.size(); ++c) {
        if (header[c] == "id") idCol = static_cast<int>(c);
        if (header[c] == "exit") exitCol = static_cast<int>(c);
    }
    if (idCol < 0) return csv.string() + ":1: no column 'id' in the header '" + line + "'";
    if (exitCol < 0) return "";  // a run without exits: nobody left by one
    for (int number = 2; std::getline(in, line); ++number) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) continue;
        const std::vector<std::string> row = cells(line);
        if (static_cast<int>(row.size()) <= idCol) return csv.string() + ":" + std::to_string(number) + ": no id";
        long long id = 0;
        std::size_t used = 0;
        try {
            id = std::stoll(row[static_cast<std::size_t>(idCol)], &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != row[static_cast<std::size_t>(idCol)].size())
            return csv.string() + ":" + std::to_string(number) + ": '" + row[static_cast<std::size_t>(idCol)] +
                   "' is not an agent id";
        if (static_cast<int>(row.size()) > exitCol && !row[static_cast<std::size_t>(exitCol)].empty())
            exitOf[id] = row[static_cast<std::size_t>(exitCol)];
    }
    return "";
}

std::vector<PathGroup> pathsByExit(const std::map<std::int64_t, std::vector<chcli::Sample>>& byFrame,
                                   const std::map<long long, std::string>& exitOf) {
    // Agent id → its path, frames in order (byFrame is ordered by frame).
    std::map<long long, Polyline> pathOf;
    for (const auto& [frame, samples] : byFrame)
        for (const chcli::Sample& s : samples) pathOf[s.id].emplace_back(s.x, s.y);
    std::map<std::string, PathGroup> named;
    PathGroup none;
    for (auto& [id, path] : pathOf) {
        const auto it = exitOf.find(id);
        PathGroup& g = it == exitOf.end() ? none : named[it->second];
        if (it != exitOf.end()) g.exit = it->second;
        g.ids.push_back(id);
        g.paths.push_back(std::move(path));
    }
    std::vector<PathGroup> out;
    for (auto& [name, g] : named) out.push_back(std::move(g));
    if (!none.paths.empty()) out.push_back(std::move(none));
    return out;
}

}  // namespace chplot
