// crowdhealth — reading a finished run's trajectories back (see trajectory_read.h).
#include "trajectory_read.h"

#include <crowdhealth/io/output.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>

namespace chcli {

namespace fs = std::filesystem;

namespace {
/// The whole of `s` as a number, or nullopt (never throws, unlike std::stod).
std::optional<double> number(const std::string& s) {
    double v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
    return v;
}
}  // namespace

namespace {
bool readUnchecked(const fs::path& dir, double& dt, std::map<std::int64_t, std::vector<Sample>>& byFrame,
                   bool& explicitFrames, std::string& error) {
    if (!(dt > 0) || !std::isfinite(dt)) {
        error = "no valid time step for the trajectories in " + dir.string();
        return false;
    }
    const fs::path bin = dir / "trajectories.bin";
    explicitFrames = fs::exists(bin);
    if (explicitFrames) {
        try {
            const ch::BinaryTrajectories t = ch::readBinaryTrajectories(bin);
            if (t.deltaTime > 0) dt = t.deltaTime;
            for (const ch::TrajectoryFrame& f : t.frames) {
                std::vector<Sample>& samples = byFrame[static_cast<std::int64_t>(f.step)];  // ids already sorted
                for (std::size_t k = 0; k < f.id.size(); ++k) samples.push_back({f.id[k], f.x[k], f.y[k]});
            }
        } catch (const std::exception& e) {
            error = e.what();
            return false;
        }
        return true;
    }
    const fs::path txt = dir / "trajectories.txt";
    if (fs::exists(txt)) {
        std::ifstream in(txt);
        std::string line;
        while (std::getline(in, line)) {
            if (line.empty()) continue;
            if (line[0] == '#') {
                std::smatch m;
                static const std::regex fr("#\\s*framerate:\\s*([0-9.eE+-]+)");
                if (std::regex_search(line, m, fr)) {
                    const std::optional<double> rate = number(m[1].str());
                    if (rate && *rate > 0 && std::isfinite(1.0 / *rate) && 1.0 / *rate > 0) dt = 1.0 / *rate;
                }
                continue;
            }
            std::istringstream s(line);
            long long id;
            std::int64_t frame;
            double x, y;
            if (!(s >> id >> frame >> x >> y) || !std::isfinite(x) || !std::isfinite(y)) {
                error = txt.string() + ": cannot read the line \"" + line.substr(0, 200) + "\"";
                return false;
            }
            byFrame[frame].push_back({id, x, y});
        }
        return true;
    }
    bool any = false;
    static const std::regex name("^output_(-?[0-9]+)\\.csv$");
    for (const auto& e : fs::directory_iterator(dir)) {
        std::smatch m;
        const std::string fn = e.path().filename().string();
        if (!std::regex_match(fn, m, name)) continue;
        any = true;
        const std::optional<double> idValue = number(m[1].str());
        if (!idValue || std::abs(*idValue) > 9e18) continue;  // not an id we could have written
        const long long id = static_cast<long long>(*idValue);
        std::ifstream in(e.path());
        std::string line;
        while (std::getline(in, line)) {
            double t, x, y;
            char c1, c2;
            std::istringstream s(line);
            if (!(s >> t >> c1 >> x >> c2 >> y)) continue;
            const double index = std::round(t / dt);
            if (!std::isfinite(x) || !std::isfinite(y) || !(std::abs(index) < 9e18)) continue;
            byFrame[static_cast<std::int64_t>(index)].push_back({id, x, y});
        }
    }
    if (!any) {
        error = "no trajectories in " + dir.string() +
                " (no trajectories.bin, trajectories.txt or output_<id>.csv); run the scenario with "
                "--trajectories bin, txt or umans";
        return false;
    }
    for (auto& [frame, samples] : byFrame)
        std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.id < b.id; });
    return true;
}
}  // namespace

bool readTrajectories(const fs::path& dir, double& dt, std::map<std::int64_t, std::vector<Sample>>& byFrame,
                      bool& explicitFrames, std::string& error) {
    try {
        return readUnchecked(dir, dt, byFrame, explicitFrames, error);
    } catch (const std::exception& e) {  // a folder that cannot be listed, a file that cannot be read
        error = dir.string() + ": cannot read the trajectories: " + e.what();
        return false;
    }
}

}  // namespace chcli
