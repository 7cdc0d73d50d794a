// crowdhealth — reading a finished run's trajectories back (render --replay): trajectories.bin,
// else trajectories.txt (PedPy), else UMANS' output_<id>.csv files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace chcli {

/// One recorded position.
struct Sample {
    long long id;
    double x, y;
};

/// Reads DIR/trajectories.bin (compact binary), else DIR/trajectories.txt (PedPy), else
/// DIR/output_<id>.csv (UMANS) into frame index (coarse step) → samples, sorted by id; `dt` is
/// the time of one frame index (s), i.e. delta_time (the files' own value replaces it when they
/// carry one). With a trajectory interval, not every index has a frame. `explicitFrames`: every
/// recorded frame is in byFrame, also those without agents (binary file). Returns false with
/// `error` set (naming the file and what is wrong) for files it cannot read; never throws for
/// bad file contents.
bool readTrajectories(const std::filesystem::path& dir, double& dt,
                      std::map<std::int64_t, std::vector<Sample>>& byFrame, bool& explicitFrames, std::string& error);

}  // namespace chcli
