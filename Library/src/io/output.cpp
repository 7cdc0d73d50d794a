// CrowdHealth — recorders and writers for a run's outputs (see output.h).
#include "crowdhealth/io/output.h"

#include "crowdhealth/core/grid.h"
#include "crowdhealth/io/json.h"
#include "crowdhealth/core/kernels.h"
#include "crowdhealth/core/registry.h"
#include "crowdhealth/health/safety.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <system_error>
#include <type_traits>

namespace ch {

namespace fs = std::filesystem;

// ---- number formatting ---------------------------------------------------------------------

void appendNumber(std::string& out, double v, int digits) {
    if (std::isnan(v)) { out += "nan"; return; }
    if (std::isinf(v)) { out += v > 0 ? "inf" : "-inf"; return; }
    if (v == 0.0) v = 0.0;  // -0 → 0: the sign of a zero carries no information in a report
    char buf[64];
    // to_chars never looks at the locale (printf would write "0,5" under a German LC_NUMERIC).
    const auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
    out.append(buf, res.ptr);
}

std::string formatNumber(double v, int digits) {
    std::string s;
    appendNumber(s, v, digits);
    return s;
}

/// Fixed-point with `decimals` decimals (PedPy columns), locale-independent.
static void appendFixed(std::string& out, double v, int decimals) {
    if (!std::isfinite(v)) { appendNumber(out, v); return; }
    char buf[64];
    auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, decimals);
    if (res.ec != std::errc()) { appendNumber(out, v, 17); return; }
    std::string_view text(buf, static_cast<std::size_t>(res.ptr - buf));
    // "-0.0000" (a tiny negative value) reads oddly; it is the same position as "0.0000".
    if (text.front() == '-' && text.find_first_not_of("-0.") == std::string_view::npos) text.remove_prefix(1);
    out += text;
}

// ---- atomic files --------------------------------------------------------------------------

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
    temp_ = target_;
    temp_ += ".tmp";
    // Binary: the bytes we format are the bytes on disk (no newline translation anywhere).
    out_.open(temp_, std::ios::out | std::ios::trunc | std::ios::binary);
    if (!out_) throw OutputError("cannot create " + temp_.string());
}

AtomicFile::~AtomicFile() {
    if (committed_) return;
    out_.close();
    std::error_code ec;
    fs::remove(temp_, ec);  // best effort: never throw from a destructor
}

void AtomicFile::commit() {
    if (committed_) return;
    out_.flush();
    const bool writeOk = static_cast<bool>(out_);
    out_.close();
    std::error_code ec;
    if (!writeOk || out_.fail()) {
        fs::remove(temp_, ec);
        throw OutputError("cannot write " + temp_.string() + " (disk full or no permission?)");
    }
    fs::rename(temp_, target_, ec);
    if (ec) {
        std::error_code ignored;
        fs::remove(temp_, ignored);
        throw OutputError("cannot rename " + temp_.string() + " to " + target_.string() + ": " + ec.message());
    }
    committed_ = true;
}

void writeFileAtomic(const fs::path& target, std::string_view content) {
    AtomicFile f(target);
    f.write(content);
    f.commit();
}

// ---- metrics -------------------------------------------------------------------------------

/// The per-agent "rest_density" field of the component that provides it in each policy
/// (nullptr where the policy has none).
static std::vector<const std::vector<double>*> restDensityFields(const Simulation& sim) {
    std::vector<const std::vector<double>*> fields;
    for (const Policy& p : sim.policies()) {
        const std::vector<double>* found = nullptr;
        for (const PolicyStep& step : p.steps()) {
            for (const PolicyStep::Entry& e : step.components()) {
                if (e.component && (found = e.component->field("rest_density")) != nullptr) break;
            }
            if (found) break;
        }
        fields.push_back(found);
    }
    return fields;
}

MetricsRow measureMetrics(Simulation& sim, double h) {
    sim.measureDensity(h);
    const AgentStore& a = sim.agents();
    const std::size_t n = a.size();

    MetricsRow row;
    row.time = sim.time();
    row.agents = n;
    row.evacuated = sim.evacuations().size();
    row.maxWallPenetration = sim.maxWallPenetration();

    // Every sum below runs in agent order on one thread: the same bits whatever the thread count.
    double sumDensity = 0, sumSpeed = 0, sumContact = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double rho = i < a.density.size() ? a.density[i] : 0.0;
        sumDensity += rho;
        row.maxDensity = std::max(row.maxDensity, rho);
        const double speed = a.vel[i].norm();
        sumSpeed += speed;
        row.maxSpeed = std::max(row.maxSpeed, speed);
        const double contact = i < a.contactAccel.size() ? a.contactAccel[i].norm() : 0.0;
        sumContact += contact;
        row.maxContactAccel = std::max(row.maxContactAccel, contact);
    }
    // The mean over an empty crowd is reported as 0 so plots need no special case.
    const double inv = n > 0 ? 1.0 / static_cast<double>(n) : 0.0;
    row.meanDensity = sumDensity * inv;
    row.meanSpeed = sumSpeed * inv;
    row.meanContactAccel = sumContact * inv;

    const auto fields = restDensityFields(sim);
    const bool anyProvider =
        std::any_of(fields.begin(), fields.end(), [](const auto* f) { return f != nullptr; });
    // Before the first step no component has computed a rest density yet (SPH starts it at the
    // agent's first density): an empty cell, not the zeros its arrays hold.
    if (!anyProvider || sim.fineSteps() == 0) {
        row.meanRestDensity = std::numeric_limits<double>::quiet_NaN();
    } else {
        double sum = 0;
        std::size_t count = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const int p = a.policy[i];
            if (p < 0 || static_cast<std::size_t>(p) >= fields.size() || fields[p] == nullptr) continue;
            if (i >= fields[p]->size()) continue;
            sum += (*fields[p])[i];
            ++count;
        }
        // No value yet (e.g. at t = 0, before the component's first step): an empty cell, not 0.
        row.meanRestDensity = count > 0 ? sum / static_cast<double>(count) : std::numeric_limits<double>::quiet_NaN();
    }

    row.meanPanic = sim.health().meanPanic(a);
    row.injured = sim.health().injuredCount();
    // Crowd pressure is a time average at each place: only a recorder that follows the run
    // (SafetyRecorder, via MetricsRecorder::setCrowdPressure) knows it; one instant does not.
    row.crowdPressure = std::numeric_limits<double>::quiet_NaN();
    row.schedule = sim.scheduleValues();
    return row;
}

/// Tolerance (s) when comparing a simulated time with a multiple of an interval: times are
/// products fineSteps·dt, so 3·0.1 is 0.30000000000000004, not 0.3.
static double timeTolerance(double t) { return 1e-9 * std::max(1.0, std::abs(t)); }

bool SampleClock::due(double t) const {
    if (!(interval_ > 0)) return true;  // also NaN
    return t + timeTolerance(t) >= static_cast<double>(nextIndex_) * interval_;
}

void SampleClock::taken(double t) {
    if (!(interval_ > 0)) return;
    const auto reached = static_cast<std::uint64_t>(std::floor((t + timeTolerance(t)) / interval_));
    nextIndex_ = std::max(nextIndex_, reached + 1);
}

MetricsRecorder::MetricsRecorder(double interval, double smoothingLength)
    : clock_(interval), h_(smoothingLength) {}

void MetricsRecorder::sample(Simulation& sim) {
    const double t = sim.time();
    if (!rows_.empty() && rows_.back().time == t) return;
    if (rows_.empty()) scheduleColumns_ = sim.scheduleColumns();
    rows_.push_back(measure(sim));
    clock_.taken(t);
}

MetricsRow MetricsRecorder::measure(Simulation& sim) const {
    MetricsRow row = measureMetrics(sim, h_);
    if (pressure_ != nullptr) row.crowdPressure = pressure_->maxPressure();
    return row;
}

bool MetricsRecorder::maybeSample(Simulation& sim) {
    if (!clock_.due(sim.time())) return false;
    const std::size_t before = rows_.size();
    sample(sim);
    return rows_.size() != before;
}

void MetricsRecorder::finish(Simulation& sim) {
    if (rows_.empty()) scheduleColumns_ = sim.scheduleColumns();
    if (rows_.empty() || rows_.back().time != sim.time()) rows_.push_back(measure(sim));
}

MetricsPeaks MetricsRecorder::peaks() const {
    MetricsPeaks p;
    for (const MetricsRow& r : rows_) {
        p.maxDensity = std::max(p.maxDensity, r.maxDensity);
        p.maxMeanDensity = std::max(p.maxMeanDensity, r.meanDensity);
        p.maxContactAccel = std::max(p.maxContactAccel, r.maxContactAccel);
        p.maxWallPenetration = std::max(p.maxWallPenetration, r.maxWallPenetration);
    }
    return p;
}

std::string MetricsRecorder::csv() const {
    std::string out = kMetricsHeader;
    for (const std::string& c : scheduleColumns_) out += "," + c;
    out += '\n';
    out.reserve(out.size() + rows_.size() * 120);
    for (const MetricsRow& r : rows_) {
        appendNumber(out, r.time, 10);  // time: enough digits that 3599.9 stays 3599.9
        out += ',';
        out += std::to_string(r.agents);
        out += ',';
        out += std::to_string(r.evacuated);
        for (const double v : {r.meanDensity, r.maxDensity}) { out += ','; appendNumber(out, v); }
        out += ',';
        if (!std::isnan(r.meanRestDensity)) appendNumber(out, r.meanRestDensity);  // empty: no provider
        for (const double v : {r.meanSpeed, r.maxSpeed, r.meanContactAccel, r.maxContactAccel,
                               r.maxWallPenetration, r.meanPanic}) {
            out += ',';
            appendNumber(out, v);
        }
        out += ',';
        out += std::to_string(r.injured);
        out += ',';
        appendNumber(out, r.crowdPressure);
        for (std::size_t c = 0; c < scheduleColumns_.size(); ++c) {
            out += ',';
            if (c < r.schedule.size() && !std::isnan(r.schedule[c])) appendNumber(out, r.schedule[c], 10);
        }
        out += '\n';
    }
    return out;
}

// ---- evacuations ---------------------------------------------------------------------------

std::string evacuationsCsv(const Simulation& sim) {
    // A venue with exits adds the exit each person left by (empty: a plain goal).
    const VenueSpec& venue = sim.spec().venue;
    const bool exits = std::any_of(venue.targets.begin(), venue.targets.end(), [](const TargetSpec& t) { return t.exit; });
    std::string out = exits ? "id,time,exit\n" : "id,time\n";
    for (const Evacuation& e : sim.evacuations()) {
        out += std::to_string(e.id);
        out += ',';
        appendNumber(out, e.time, 10);
        if (exits) {
            out += ',';
            if (e.exit >= 0) out += venue.targets[static_cast<std::size_t>(e.exit)].name;
        }
        out += '\n';
    }
    return out;
}

// ---- trajectories --------------------------------------------------------------------------

/// Fills `order` with the indices of the agents by increasing id. Cheap when nothing moved: the
/// store in id order (agents keep their order when others leave and newcomers are appended), or
/// `order` still valid from the previous frame (the store is re-ordered only every so many
/// steps); both checked in O(n). Sorted otherwise.
static void agentsById(const AgentStore& a, std::vector<std::size_t>& order) {
    const std::size_t n = a.size();
    if (order.size() == n && n > 0) {
        bool valid = order[0] < n;
        for (std::size_t k = 1; k < n && valid; ++k) valid = order[k] < n && a.id[order[k - 1]] < a.id[order[k]];
        if (valid) return;  // ids are unique, so strictly increasing ids make it a permutation
    }
    order.resize(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    if (!std::is_sorted(a.id.begin(), a.id.end()))
        std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return a.id[x] < a.id[y]; });
}

/// The unsigned integer type of the same size as T (2, 4 or 8 bytes), to get at T's bytes.
template <class T>
using BitsOf = std::conditional_t<sizeof(T) == 2, std::uint16_t,
                                  std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>;

/// Stores v at p in little-endian byte order and advances p (the bytes are the same on any host).
template <class T>
static void storeLittleEndian(char*& p, T v) {
    static_assert(std::is_arithmetic_v<T> && (sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8));
    const auto bits = std::bit_cast<BitsOf<T>>(v);
    for (std::size_t k = 0; k < sizeof(T); ++k) *p++ = static_cast<char>((bits >> (8 * k)) & 0xffu);
}

/// Reads a little-endian T at p.
template <class T>
static T loadLittleEndian(const char* p) {
    BitsOf<T> bits = 0;
    for (std::size_t k = 0; k < sizeof(T); ++k)
        bits |= static_cast<BitsOf<T>>(static_cast<BitsOf<T>>(static_cast<unsigned char>(p[k])) << (8 * k));
    return std::bit_cast<T>(bits);
}

BinaryTrajectoryWriter::BinaryTrajectoryWriter(fs::path file, double deltaTime, double interval, bool velocities)
    : file_(std::move(file)), velocities_(velocities) {
    char header[trajbin::kHeaderBytes];
    char* p = header;
    for (const char c : trajbin::kMagic) *p++ = c;
    storeLittleEndian(p, trajbin::kVersion);
    storeLittleEndian(p, velocities ? trajbin::kFlagVelocities : std::uint32_t{0});
    storeLittleEndian(p, static_cast<std::uint32_t>(trajbin::recordBytes(velocities)));
    storeLittleEndian(p, deltaTime);
    storeLittleEndian(p, interval);
    file_.write(std::string_view(header, sizeof header));
}

void BinaryTrajectoryWriter::writeFrame(const Simulation& sim) {
    const AgentStore& a = sim.agents();
    const std::uint64_t step = sim.coarseSteps();
    if (step > trajbin::kMaxId)
        throw OutputError(file_.target().string() + ": coarse step " + std::to_string(step) +
                          " does not fit in the file's 32-bit step numbers");
    agentsById(a, order_);
    buffer_.resize(trajbin::kFrameHeaderBytes + a.size() * trajbin::recordBytes(velocities_));
    char* p = buffer_.data();
    storeLittleEndian(p, sim.time());
    storeLittleEndian(p, static_cast<std::uint32_t>(step));
    storeLittleEndian(p, static_cast<std::uint32_t>(a.size()));
    for (const std::size_t i : order_) {
        const AgentId id = a.id[i];
        if (id < 0 || static_cast<std::uint64_t>(id) > trajbin::kMaxId)
            throw OutputError(file_.target().string() + ": agent id " + std::to_string(id) +
                              " does not fit in the file's 32-bit ids");
        storeLittleEndian(p, static_cast<std::uint32_t>(id));
        storeLittleEndian(p, static_cast<float>(a.pos[i].x()));
        storeLittleEndian(p, static_cast<float>(a.pos[i].y()));
        if (velocities_) {
            storeLittleEndian(p, static_cast<float>(a.vel[i].x()));
            storeLittleEndian(p, static_cast<float>(a.vel[i].y()));
        }
    }
    file_.write(buffer_);
}

BinaryTrajectories readBinaryTrajectories(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw OutputError("cannot open " + file.string());
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw OutputError("cannot read " + file.string());
    auto fail = [&](std::size_t offset, const std::string& why) {
        return OutputError(file.string() + ": byte " + std::to_string(offset) + ": " + why);
    };
    if (bytes.size() < trajbin::kHeaderBytes || bytes.compare(0, 6, trajbin::kMagic, 6) != 0)
        throw fail(0, "not a CrowdHealth binary trajectory file (no CHTRJ1 header)");
    const char* p = bytes.data();
    const auto version = loadLittleEndian<std::uint16_t>(p + 6);
    if (version != trajbin::kVersion)
        throw fail(6, "version " + std::to_string(version) + " is not supported (this program reads version " +
                          std::to_string(trajbin::kVersion) + ")");
    BinaryTrajectories t;
    t.flags = loadLittleEndian<std::uint32_t>(p + 8);
    const bool velocities = (t.flags & trajbin::kFlagVelocities) != 0;
    const std::size_t record = loadLittleEndian<std::uint32_t>(p + 12);
    if (record != trajbin::recordBytes(velocities))
        throw fail(12, "record size " + std::to_string(record) + " does not match the flags");
    t.deltaTime = loadLittleEndian<double>(p + 16);
    t.interval = loadLittleEndian<double>(p + 24);

    std::size_t at = trajbin::kHeaderBytes;
    while (at < bytes.size()) {
        if (bytes.size() - at < trajbin::kFrameHeaderBytes) throw fail(at, "the file ends inside a frame header");
        TrajectoryFrame f;
        f.time = loadLittleEndian<double>(p + at);
        f.step = loadLittleEndian<std::uint32_t>(p + at + 8);
        const std::size_t n = loadLittleEndian<std::uint32_t>(p + at + 12);
        if ((bytes.size() - at - trajbin::kFrameHeaderBytes) / record < n)
            throw fail(at, "the file ends inside the frame of step " + std::to_string(f.step));
        at += trajbin::kFrameHeaderBytes;
        f.id.resize(n);
        f.x.resize(n);
        f.y.resize(n);
        if (velocities) {
            f.vx.resize(n);
            f.vy.resize(n);
        }
        for (std::size_t k = 0; k < n; ++k, at += record) {
            f.id[k] = loadLittleEndian<std::uint32_t>(p + at);
            f.x[k] = loadLittleEndian<float>(p + at + 4);
            f.y[k] = loadLittleEndian<float>(p + at + 8);
            if (velocities) {
                f.vx[k] = loadLittleEndian<float>(p + at + 12);
                f.vy[k] = loadLittleEndian<float>(p + at + 16);
            }
        }
        t.frames.push_back(std::move(f));
    }
    return t;
}

PedPyTrajectoryWriter::PedPyTrajectoryWriter(fs::path file, double deltaTime) : file_(std::move(file)) {
    // PedPy reads the frame rate from the first number on a comment line containing "framerate"
    // and the unit from "x/m"; comment lines must come before the data.
    std::string text = "# framerate: ";
    appendNumber(text, 1.0 / deltaTime, 10);
    text += "\n# x/m\n# y/m\n# z/m\n# id frame x y z\n";
    file_.write(text);
}

void PedPyTrajectoryWriter::writeFrame(const Simulation& sim) {
    const AgentStore& a = sim.agents();
    agentsById(a, order_);
    buffer_.clear();
    std::string frame = " ";  // " <frame> ", the same on every row
    frame += std::to_string(sim.coarseSteps());
    frame += ' ';
    for (const std::size_t i : order_) {
        buffer_ += std::to_string(a.id[i]);
        buffer_ += frame;
        appendFixed(buffer_, a.pos[i].x(), 4);  // 0.1 mm: far below any pedestrian measurement
        buffer_ += ' ';
        appendFixed(buffer_, a.pos[i].y(), 4);
        buffer_ += " 0\n";
    }
    file_.write(buffer_);
}

void TrajectoryRecorder::record(const Simulation& sim) {
    const std::uint64_t step = sim.coarseSteps();
    if (!frameStep_.empty() && frameStep_.back() == step) return;
    const std::size_t frame = frameTime_.size();
    frameTime_.push_back(sim.time());
    frameStep_.push_back(step);

    const AgentStore& a = sim.agents();
    for (std::size_t i = 0; i < a.size(); ++i) {
        auto [it, inserted] = trackOf_.try_emplace(a.id[i], tracks_.size());
        if (inserted) tracks_.push_back(Track{a.id[i], {}, {}});
        Track& tr = tracks_[it->second];
        // A new run when the agent was absent at the previous recorded frame (normally only its
        // first appearance: agents enter once and leave once).
        if (tr.runs.empty() || tr.runs.back().firstFrame + tr.runs.back().count != frame)
            tr.runs.push_back(Run{frame, tr.rows.size() / 4, 0});
        const Vec2& p = a.pos[i];
        const Vec2& d = a.viewDir[i];
        tr.rows.insert(tr.rows.end(), {p.x(), p.y(), d.x(), d.y()});
        ++tr.runs.back().count;
    }
}

std::vector<std::string> TrajectoryRecorder::umansFileNames() const {
    std::vector<std::string> names;
    for (const Track& tr : tracks_) names.push_back("output_" + std::to_string(tr.id) + ".csv");
    return names;
}

void TrajectoryRecorder::writeUmans(const fs::path& dir) const {
    std::vector<std::size_t> order(tracks_.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return tracks_[x].id < tracks_[y].id; });
    std::string text;
    for (const std::size_t t : order) {
        const Track& tr = tracks_[t];
        text.clear();
        for (const Run& run : tr.runs) {
            for (std::size_t k = 0; k < run.count; ++k) {
                const std::size_t frame = run.firstFrame + k;
                if (frameStep_[frame] == 0) continue;  // UMANS writes the state after each step, never t = 0
                const double* r = &tr.rows[(run.firstRow + k) * 4];
                // UMANS streams doubles with the default ostream precision: 6 significant digits.
                appendNumber(text, frameTime_[frame]);
                for (int c = 0; c < 4; ++c) {
                    text += ',';
                    appendNumber(text, r[c]);
                }
                text += '\n';
            }
        }
        writeFileAtomic(dir / ("output_" + std::to_string(tr.id) + ".csv"), text);
    }
}

TrajectoryOutput::TrajectoryOutput(const fs::path& dir, const TrajectoryFormats& formats, double interval,
                                   double deltaTime, bool velocities)
    : dir_(dir), clock_(interval) {
    if (formats.umans) umans_.emplace();
    if (formats.txt) txt_.emplace(dir / "trajectories.txt", deltaTime);
    // The header's interval is the nominal time between frames: never less than one coarse step.
    if (formats.bin) bin_.emplace(dir / "trajectories.bin", deltaTime, interval > deltaTime ? interval : deltaTime, velocities);
}

void TrajectoryOutput::record(const Simulation& sim) {
    const std::uint64_t step = sim.coarseSteps();
    if (frames_ > 0 && step == lastStep_) return;
    lastStep_ = step;
    ++frames_;
    clock_.taken(sim.time());
    if (umans_) umans_->record(sim);
    if (txt_) txt_->writeFrame(sim);
    if (bin_) bin_->writeFrame(sim);
}

bool TrajectoryOutput::maybeRecord(const Simulation& sim) {
    if (!clock_.due(sim.time())) return false;
    const std::size_t before = frames_;
    record(sim);
    return frames_ != before;
}

std::vector<std::string> TrajectoryOutput::fileNames() const {
    std::vector<std::string> names;
    if (umans_) names = umans_->umansFileNames();
    if (txt_) names.push_back("trajectories.txt");
    if (bin_) names.push_back("trajectories.bin");
    return names;
}

void TrajectoryOutput::commit() {
    if (umans_) umans_->writeUmans(dir_);
    if (txt_) txt_->commit();
    if (bin_) bin_->commit();
}

// ---- summary -------------------------------------------------------------------------------

std::optional<double> evacuationFlow(const std::vector<Evacuation>& evacuations, int first, int last) {
    if (first < 1 || last <= first || evacuations.size() < static_cast<std::size_t>(last)) return std::nullopt;
    const double t0 = evacuations[static_cast<std::size_t>(first - 1)].time;
    const double t1 = evacuations[static_cast<std::size_t>(last - 1)].time;
    if (!(t1 > t0)) return std::nullopt;
    return static_cast<double>(last - first) / (t1 - t0);
}

std::string summaryJson(const Simulation& sim, const RunInfo& info, const MetricsPeaks& peaks, const Verdict* verdict) {
    const ScenarioSpec& spec = sim.spec();
    const auto& evac = sim.evacuations();
    const std::size_t total = sim.totalAgents();
    const std::size_t remaining = sim.agents().size() + sim.pending();

    // Flow from the first-th to the last-th evacuee; a scenario with fewer agents than `last`
    // (e.g. 50 agents, default last = 350) measures up to its last agent instead.
    const int first = spec.output.flowFirst;
    const int last = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(std::max(spec.output.flowLast, 0)), total));
    const std::optional<double> flow = evacuationFlow(evac, first, last);

    // Evacuation time: when the last agent was removed at its goal, once nobody is left.
    std::optional<double> evacTime;
    if (remaining == 0 && !evac.empty()) evacTime = evac.back().time;

    const std::string scenario = info.scenario.empty() ? spec.sourceFile : info.scenario;
    auto opt = [](const std::optional<double>& v) { return v ? jsonNumber(*v) : Json(nullptr); };

    Json j;  // keys in the documented order (docs/user-guide.md, summary.json)
    j["scenario"] = scenario;
    j["seed"] = spec.seed;
    // Provenance: the plugins named by the scenario and those of the components its policies use.
    {
        std::vector<std::string> plugins = spec.plugins;
        for (const PolicySpec& p : spec.policies)
            for (const StepSpec& st : p.steps)
                for (const ComponentSpec& c : st.components)
                    if (const ComponentInfo* info = Registry::instance().find(c.name); info != nullptr && !info->origin.empty() &&
                                                                                      std::find(plugins.begin(), plugins.end(), info->origin) == plugins.end())
                        plugins.push_back(info->origin);
        j["plugins"] = plugins;
    }
    j["delta_time"] = jsonNumber(sim.deltaTime());
    j["delta_time_fine"] = jsonNumber(sim.deltaTimeFine());
    j["end_time"] = info.endTime >= 0 ? jsonNumber(info.endTime) : Json(nullptr);
    j["end_time_source"] = info.endTimeSource.empty() ? std::string("none") : info.endTimeSource;
    j["simulated_time"] = jsonNumber(sim.time());
    j["coarse_steps"] = sim.coarseSteps();
    j["interrupted"] = info.interrupted;
    j["stopped_at_safety_cap"] = info.stoppedAtSafetyCap;
    j["agents_total"] = total;
    j["evacuated"] = evac.size();
    j["left_world"] = sim.leftWorld();
    j["remaining"] = remaining;
    j["evacuation_time"] = opt(evacTime);
    j["flow"] = Json{{"first", first}, {"last", last}, {"persons_per_second", opt(flow)}};
    j["peaks"] = Json{{"max_density", jsonNumber(peaks.maxDensity)},
                      {"max_mean_density", jsonNumber(peaks.maxMeanDensity)},
                      {"max_contact_accel", jsonNumber(peaks.maxContactAccel)},
                      {"max_wall_penetration", jsonNumber(peaks.maxWallPenetration)}};
    // The CrowdHealth layer's people counts (health.csv has them per person).
    {
        const HealthLayer& h = sim.health();
        double helpTime = 0;
        for (const HealthRecord& r : h.records()) helpTime += h.careOf(r).helpTime;
        j["health"] = Json{{"injured", h.injuredCount()},
                           {"fallen", h.fallenCount()},
                           {"falls", h.fallEvents().size()},
                           {"helpers", h.helperCount()},
                           {"helped", h.helpedCount()},
                           {"help_time_s", jsonNumber(helpTime)}};
    }
    if (verdict != nullptr) {
        j["verdict"] = verdictJsonValue(*verdict);
        // What the verdict was judged by, under the <Safety> attribute names.
        const SafetyThresholds& t = sim.spec().safety;
        j["safety_thresholds"] = Json{{"cell_size", jsonNumber(t.cellSize)},
                                      {"gaussian_radius", jsonNumber(t.gaussianRadius)},
                                      {"density_caution", jsonNumber(t.densityCaution)},
                                      {"density_dangerous", jsonNumber(t.densityDangerous)},
                                      {"density_critical", jsonNumber(t.densityCritical)},
                                      {"crowd_pressure", jsonNumber(t.crowdPressureCritical)},
                                      {"pressure_window", jsonNumber(t.pressureWindow)},
                                      {"min_duration", jsonNumber(t.minDuration)},
                                      {"dose_dangerous_fraction", jsonNumber(t.doseDangerousFraction)}};
    }
    j["threads"] = info.threads;
    j["wall_time_s"] = jsonNumber(info.wallTimeSeconds);
    return jsonText(j);
}

std::optional<double> runEvacuationTime(const Simulation& sim) {
    const auto& evac = sim.evacuations();
    if (sim.agents().size() + sim.pending() == 0 && !evac.empty()) return evac.back().time;
    return std::nullopt;
}

std::optional<double> runFlow(const Simulation& sim) {
    const OutputSpec& out = sim.spec().output;
    const int last = static_cast<int>(
        std::min<std::size_t>(static_cast<std::size_t>(std::max(out.flowLast, 0)), sim.totalAgents()));
    return evacuationFlow(sim.evacuations(), out.flowFirst, last);
}

// ---- replications (summary.csv) -------------------------------------------------------------

std::array<std::optional<double>, kReplicationStatColumns.size()> ReplicationRow::statValues() const {
    return {static_cast<double>(evacuated), evacuationTime, flow, peakMeanDensity, meanDensityAt15s,
            peakMaxContactAccel, peakWallPenetration};
}

SampleStats sampleStats(const std::vector<std::optional<double>>& values) {
    // Deviations from the first value, then two passes over them: no cancellation when the runs
    // are close together, and equal values give exactly that value as mean and exactly 0 as sd.
    SampleStats s;
    std::optional<double> shift;
    double sum = 0;
    for (const auto& v : values) {
        if (!v || !std::isfinite(*v)) continue;
        if (!shift) shift = *v;
        sum += *v - *shift;
        ++s.count;
    }
    if (s.count == 0) return s;
    const double meanDeviation = sum / static_cast<double>(s.count);
    s.mean = *shift + meanDeviation;
    if (s.count < 2) return s;
    double squares = 0;
    for (const auto& v : values)
        if (v && std::isfinite(*v)) squares += (*v - *shift - meanDeviation) * (*v - *shift - meanDeviation);
    s.sd = std::sqrt(squares / static_cast<double>(s.count - 1));
    return s;
}

std::array<SampleStats, kReplicationStatColumns.size()> replicationStats(const std::vector<ReplicationRow>& rows) {
    std::array<SampleStats, kReplicationStatColumns.size()> stats;
    for (std::size_t c = 0; c < kReplicationStatColumns.size(); ++c) {
        std::vector<std::optional<double>> column;
        for (const ReplicationRow& r : rows)
            if (!r.interrupted) column.push_back(r.statValues()[c]);
        stats[c] = sampleStats(column);
    }
    return stats;
}

std::string replicationsCsv(const std::vector<ReplicationRow>& rows) {
    auto cell = [](std::string& out, const std::optional<double>& v) {
        out += ',';
        if (v && !std::isnan(*v)) appendNumber(out, *v, 10);
    };
    std::string out = kReplicationsHeader;
    out += '\n';
    for (const ReplicationRow& r : rows) {
        out += r.run;
        out += ',';
        out += std::to_string(r.seed);
        out += ',';
        out += std::to_string(r.evacuated);
        for (const auto& v : {r.evacuationTime, r.flow, std::optional<double>(r.peakMeanDensity), r.meanDensityAt15s,
                              std::optional<double>(r.peakMaxContactAccel),
                              std::optional<double>(r.peakWallPenetration)})
            cell(out, v);
        out += r.interrupted ? ",true\n" : ",false\n";
    }
    const auto stats = replicationStats(rows);
    out += "mean,";
    for (const SampleStats& s : stats) cell(out, s.mean);
    out += ",\nsd,";
    for (const SampleStats& s : stats) cell(out, s.sd);
    out += ",\nn,";
    for (const SampleStats& s : stats) { out += ','; out += std::to_string(s.count); }
    out += ",\n";
    return out;
}

}  // namespace ch
