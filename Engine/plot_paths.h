// crowdhealth plot — paths.png (docs/navigation.md, "Plots"): every agent's path over the venue,
// coloured by the exit it left by, with the walls and the targets and exits outlined and named.
#pragma once

#include "plot_data.h"

#include <filesystem>
#include <string>
#include <vector>

namespace chplot {

/// Draws e.dir/paths.png from the trajectories of the first run of `e` that has any
/// (trajectories.bin, trajectories.txt or UMANS output_<id>.csv), its evacuations.csv and its
/// scenario (named in summary.json; without it the paths are drawn alone, with a note). Without
/// trajectories removes a stale paths.png and adds a note. Appends to written/errors/notes as
/// drawExperiment does.
void drawPaths(const Experiment& e, std::vector<std::filesystem::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes);

}  // namespace chplot
