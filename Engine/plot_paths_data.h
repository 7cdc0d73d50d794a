// crowdhealth plot — the data of paths.png (docs/navigation.md, "Plots"): every agent's path from a
// run's trajectories, grouped by the exit it left by (evacuations.csv's `exit` column). Nothing
// here draws; plot_paths.cpp does.
#pragma once

#include "trajectory_read.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace chplot {

/// One agent's path: its recorded positions (m) in time order.
using Polyline = std::vector<std::pair<double, double>>;

/// The paths of the agents that left by one exit.
struct PathGroup {
    std::string exit;             ///< the exit's name; "" = did not leave by an exit (still there,
                                  ///< removed at a plain goal, left the world, or no exit column)
    std::vector<long long> ids;   ///< agent ids, ascending, one per path
    std::vector<Polyline> paths;  ///< paths[k] is agent ids[k]'s
};

/// Reads evacuations.csv (header `id,time[,exit]`): agent id → the exit it left by; agents
/// without an exit (no `exit` column, or an empty cell) are not in the map. Returns an error
/// message naming the file and line, or "" on success.
std::string readEvacuationExits(const std::filesystem::path& csv, std::map<long long, std::string>& exitOf);

/// Every agent's path from `byFrame` (frame → samples, as readTrajectories gives them), grouped
/// by `exitOf`: one group per exit name in name order, then the group "" (every agent not in
/// `exitOf`) when it has any path. Points are in frame order; an agent seen in one frame only
/// has a path of one point. Groups without paths are left out.
std::vector<PathGroup> pathsByExit(const std::map<std::int64_t, std::vector<chcli::Sample>>& byFrame,
                                   const std::map<long long, std::string>& exitOf);

}  // namespace chplot
