// crowdhealth — the progress bar (see progress.h).
#include "progress.h"

#include <crowdhealth/core/simulation.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

namespace chcli {

namespace {
constexpr auto kRedrawInterval = std::chrono::milliseconds(100);  // at most ~10 redraws per second
constexpr int kBarWidth = 24;  // characters
}  // namespace

std::string formatDuration(double seconds) {
    if (!std::isfinite(seconds) || seconds < 0) return "--:--";
    const long s = std::lround(seconds);
    char buf[32];
    if (s >= 3600)
        std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    else
        std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
    return buf;
}

bool ProgressBar::stderrIsTerminal() { return ::isatty(STDERR_FILENO) == 1; }

ProgressBar::ProgressBar(std::ostream& out, bool enabled, double endTime)
    : out_(out), enabled_(enabled), endTime_(endTime),
      start_(std::chrono::steady_clock::now()), lastDraw_(start_) {}

void ProgressBar::update(const ch::Simulation& sim) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (drawn_ && now - lastDraw_ < kRedrawInterval) return;
    lastDraw_ = now;
    draw(sim);
}

void ProgressBar::finish(const ch::Simulation& sim) {
    if (!enabled_) return;
    draw(sim);
    out_ << '\n' << std::flush;
}

void ProgressBar::draw(const ch::Simulation& sim) {
    const double t = sim.time();
    const std::size_t total = sim.totalAgents();
    const std::size_t evacuated = sim.evacuations().size();
    const std::size_t left = sim.agents().size() + sim.pending();  // still to go
    double fraction = 0;
    if (sim.finished()) fraction = 1.0;  // also when everyone left before the end time
    else if (endTime_ > 0) fraction = t / endTime_;
    else if (total > 0) fraction = static_cast<double>(total - left) / static_cast<double>(total);
    fraction = std::clamp(fraction, 0.0, 1.0);

    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double eta = fraction > 0 ? elapsed * (1 - fraction) / fraction : -1;

    const int filled = static_cast<int>(fraction * kBarWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kBarWidth, '.');
    char line[256];
    std::snprintf(line, sizeof line, "\r[%s] %3d%%  t = %.1f s  agents %zu  evacuated %zu  elapsed %s  ETA %s",
                  bar.c_str(), static_cast<int>(fraction * 100), t, left, evacuated,
                  formatDuration(elapsed).c_str(), formatDuration(eta).c_str());
    // "\x1b[K" clears what a longer previous line left behind.
    out_ << line << "\x1b[K" << std::flush;
    drawn_ = true;
}

ReplicationProgress::ReplicationProgress(std::ostream& out, bool enabled, std::size_t total, double endTime)
    : out_(out), enabled_(enabled), total_(total), endTime_(endTime), start_(std::chrono::steady_clock::now()) {}

void ReplicationProgress::draw(std::size_t done, std::size_t running, double slowest) {
    if (!enabled_) return;
    const double fraction = total_ > 0 ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
    const int filled = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * kBarWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kBarWidth, '.');
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    char slow[96] = "";
    if (running > 0 && std::isfinite(slowest)) {  // NaN: not known (runs on other MPI ranks)
        if (endTime_ > 0) std::snprintf(slow, sizeof slow, "  slowest t = %.1f / %.0f s", slowest, endTime_);
        else std::snprintf(slow, sizeof slow, "  slowest t = %.1f s", slowest);
    }
    char line[256];
    std::snprintf(line, sizeof line, "\r[%s] runs %zu/%zu done  %zu running%s  elapsed %s", bar.c_str(), done,
                  total_, running, slow, formatDuration(elapsed).c_str());
    out_ << line << "\x1b[K" << std::flush;
    drawn_ = true;
}

void ReplicationProgress::clear() {
    if (!enabled_ || !drawn_) return;
    out_ << "\r\x1b[K" << std::flush;
}

void ReplicationProgress::finish() {
    if (!enabled_ || !drawn_) return;
    out_ << '\n' << std::flush;
    drawn_ = false;
}

}  // namespace chcli
