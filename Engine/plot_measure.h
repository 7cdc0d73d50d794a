// crowdhealth plot — los.png, flows.png and areas.png (docs/measurement.md, "Plots"):
//   los.png    Fruin's level of service per cell (heatmap.csv's worst_los: the worst level the
//              cell's local density held for <Safety min_duration>) in Fruin's colours, over the
//              walls, exits, targets and measurement lines and areas; the worst over the runs
//   flows.png  the specific flow through each measurement line and exit over the last
//              <Safety flow_window> seconds (the verdict's measure) with <Safety flow_capacity>
//              dashed, and the cumulative crossings per direction (flows.csv)
//   areas.png  the density in each measurement area over time against Fruin's levels, and the
//              mean speed there (areas.csv)
// Each is drawn only when its input exists (flows.png and areas.png: of the first run that has
// the file); otherwise a stale one is removed and a note says why.
#pragma once

#include "plot_data.h"

#include <filesystem>
#include <string>
#include <vector>

namespace chplot {

void drawLos(const Experiment& e, std::vector<std::filesystem::path>& written, std::vector<std::string>& errors,
             std::vector<std::string>& notes);
void drawFlows(const Experiment& e, std::vector<std::filesystem::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes);
void drawAreas(const Experiment& e, std::vector<std::filesystem::path>& written, std::vector<std::string>& errors,
               std::vector<std::string>& notes);

}  // namespace chplot
