// CrowdHealth — measurement lines, exits' flows and measurement areas (recorder.h).
#include "crowdhealth/measure/recorder.h"

#include "crowdhealth/core/agents.h"
#include "crowdhealth/core/geometry.h"
#include "crowdhealth/core/simulation.h"
#include "crowdhealth/io/output.h"

#include <algorithm>
#include <cmath>

namespace ch {

namespace {
std::string number(double v, int digits = 6) { return formatNumber(v, digits); }
}  // namespace

int lineSide(const Vec2& a, const Vec2& b, const Vec2& p) {
    const Vec2 ab = b - a, ap = p - a;
    return ab.x() * ap.y() - ab.y() * ap.x() > 0 ? 1 : -1;
}

namespace {
/// m: a line's bounds are widened by this before a move is tested against them. A move counted
/// by crossing() meets the line inside both its own bounds and the line's; the margin covers the
/// rounding of that test (~1e-12 m), so skipping the moves outside the widened bounds changes no
/// count.
constexpr double kCrossingMargin = 1e-6;
}  // namespace

int crossing(const Vec2& a, const Vec2& b, const Vec2& p, const Vec2& q) {
    const int sp = lineSide(a, b, p), sq = lineSide(a, b, q);
    if (sp == sq) return 0;
    // Where the move meets the line's carrier, as a fraction u of a → b: inside [0, 1) counts (the
    // half-open range keeps a crossing through the shared end of two lines counted once).
    const Vec2 ab = b - a, pq = q - p, ap = p - a;
    const double denom = ab.x() * pq.y() - ab.y() * pq.x();
    if (denom == 0) return 0;
    const double u = (ap.x() * pq.y() - ap.y() * pq.x()) / denom;
    if (!(u >= 0 && u < 1)) return 0;
    return sp > 0 ? +1 : -1;  // left to right is forwards
}

MeasurementRecorder::MeasurementRecorder(const ScenarioSpec& spec, std::vector<double> exitWidths)
    : interval_(spec.measurement.interval > 0 ? spec.measurement.interval : 1.0), t_(spec.safety) {
    for (const MeasureLineSpec& m : spec.measurement.lines) {
        Line l;
        l.name = m.name;
        l.a = m.a;
        l.b = m.b;
        l.length = std::max(1e-9, m.length());
        l.bounds = Box(l.a, l.b).grown(kCrossingMargin);
        lines_.push_back(std::move(l));
    }
    if (!lines_.empty()) {
        AgentId most = -1;
        bool negative = false;
        for (const AgentSpec& a : spec.agents) {
            most = std::max(most, a.id);
            negative = negative || a.id < 0;
        }
        // Flat when the ids are not far more spread than the agents (ids past it use the map).
        const AgentId dense = 4 * static_cast<AgentId>(spec.agents.size()) + 4096;
        if (!negative && most >= 0 && most < dense) {
            lastById_.resize(static_cast<std::size_t>(most) + 1, Vec2(0, 0));
            hasLastById_.resize(static_cast<std::size_t>(most) + 1, 0);
        }
    }
    for (std::size_t k = 0; k < spec.venue.targets.size(); ++k) {
        const TargetSpec& t = spec.venue.targets[k];
        if (!t.exit) continue;
        Line l;
        l.name = t.name;
        l.exit = true;
        l.target = static_cast<int>(k);
        const Box box = t.shape.bounds();
        l.a = box.lo;
        l.b = box.hi;
        l.length = k < exitWidths.size() && exitWidths[k] > 0 ? exitWidths[k] : (t.width > 0 ? t.width : 1.0);
        exits_.push_back(std::move(l));
    }
    for (const MeasureAreaSpec& m : spec.measurement.areas) {
        Area a;
        a.name = m.name;
        a.polygon = m.polygon;
        a.area = std::abs(polygonArea(m.polygon));
        a.bounds = Box::around(m.polygon);
        areas_.push_back(std::move(a));
    }
    flowRows_.resize(lines_.size() + exits_.size());
    areaRows_.resize(areas_.size());
}

void MeasurementRecorder::record(const Simulation& sim) {
    if (empty()) return;
    std::vector<std::pair<AgentId, Vec2>> removed;
    const auto& all = sim.removed();
    for (; removedSeen_ < all.size(); ++removedSeen_) removed.push_back({all[removedSeen_].id, all[removedSeen_].position});
    std::vector<std::pair<int, double>> leaves;
    const auto& evac = sim.evacuations();
    for (; evacuationsSeen_ < evac.size(); ++evacuationsSeen_)
        if (evac[evacuationsSeen_].exit >= 0) leaves.push_back({evac[evacuationsSeen_].exit, evac[evacuationsSeen_].time});
    record(sim.agents(), sim.time(), removed, leaves);
}

void MeasurementRecorder::countCrossing(Line& l, int direction, double t) {
    if (direction > 0) ++l.forward, ++l.totalForward;
    else ++l.backward, ++l.totalBackward;
    l.recent.push_back(t);
}

void MeasurementRecorder::updateCapacity(Line& l, double t) {
    // The specific flow of the last flow_window seconds against the capacity, held for min_duration.
    while (!l.recent.empty() && l.recent.front() <= t - t_.flowWindow) l.recent.pop_front();
    const double flow = static_cast<double>(l.recent.size()) / t_.flowWindow / l.length;
    l.peakCount = std::max(l.peakCount, l.recent.size());
    l.peak = std::max(l.peak, flow);
    if (flow > t_.flowCapacity) {
        if (l.heldSince < 0) l.heldSince = t;
        const double held = t - l.heldSince;
        if (held >= t_.minDuration && l.first < 0) l.first = l.heldSince;
        if (held >= t_.minDuration) l.longest = std::max(l.longest, held);
    } else {
        l.heldSince = -1;
    }
}

void MeasurementRecorder::record(const AgentStore& agents, double t, const std::vector<std::pair<AgentId, Vec2>>& removed,
                                 const std::vector<std::pair<int, double>>& exitLeaves) {
    if (empty()) return;
    if (started_ && !(t > lastTime_)) return;  // one record per time
    if (!started_) {
        started_ = true;
        intervalStart_ = t;
    }
    // Lines: each agent's straight move since the last record.
    if (!lines_.empty()) {
        auto move = [&](const Vec2& from, const Vec2& to) {
            const Box path(from, to);
            for (Line& l : lines_) {
                if (!l.bounds.overlaps(path)) continue;
                if (const int c = crossing(l.a, l.b, from, to); c != 0) countCrossing(l, c, t);
            }
        };
        auto flat = [&](AgentId id) { return id >= 0 && static_cast<std::size_t>(id) < lastById_.size(); };
        for (std::size_t i = 0; i < agents.size(); ++i) {
            const AgentId id = agents.id[i];
            if (flat(id)) {
                const std::size_t k = static_cast<std::size_t>(id);
                if (hasLastById_[k]) move(lastById_[k], agents.pos[i]);
                hasLastById_[k] = 1;
                lastById_[k] = agents.pos[i];
                continue;
            }
            auto [it, inserted] = last_.try_emplace(id, agents.pos[i]);
            if (!inserted) {
                move(it->second, agents.pos[i]);
                it->second = agents.pos[i];
            }
        }
        for (const auto& [id, position] : removed) {
            if (flat(id)) {
                const std::size_t k = static_cast<std::size_t>(id);
                if (hasLastById_[k]) move(lastById_[k], position);
                hasLastById_[k] = 0;
                continue;
            }
            if (auto it = last_.find(id); it != last_.end()) {
                move(it->second, position);
                last_.erase(it);
            }
        }
    }
    // Exits: the people who left by each.
    for (const auto& [target, when] : exitLeaves)
        for (Line& l : exits_)
            if (l.target == target) countCrossing(l, +1, when);
    for (Line& l : lines_) updateCapacity(l, t);
    for (Line& l : exits_) updateCapacity(l, t);

    // Areas: the classic density (people whose centre is inside / area) and their mean speed.
    for (Area& a : areas_) {
        int people = 0;
        double speed = 0;
        for (std::size_t i = 0; i < agents.size(); ++i) {
            const Vec2& p = agents.pos[i];
            if (!a.bounds.contains(p) || !pointInPolygon(p, a.polygon)) continue;
            ++people;
            speed += agents.vel[i].norm();
        }
        const double density = people / a.area;
        const double meanSpeed = people > 0 ? speed / people : 0.0;
        a.sumDensity += density;
        a.sumSpeed += meanSpeed;
        a.occupied += people > 0;
        a.sumFlow += density * meanSpeed;
        a.sumPeople += people;
        ++a.samples;
        a.peak = std::max(a.peak, density);
        a.peakPeople = std::max(a.peakPeople, static_cast<double>(people));
        // Level of service F held for min_duration (measured from the record it began at).
        if (fruinLevel(density) == 'F') {
            if (a.heldSince < 0) a.heldSince = t;
            const double held = t - a.heldSince;
            if (held >= t_.minDuration) {
                if (a.first < 0) a.first = a.heldSince;
                a.longest = std::max(a.longest, held);
            }
        } else {
            a.heldSince = -1;
        }
    }
    lastTime_ = t;
    if (t >= intervalStart_ + interval_ - 1e-9 * std::max(1.0, std::abs(t))) closeInterval(t);
}

void MeasurementRecorder::closeInterval(double t) {
    std::size_t row = 0;
    for (std::vector<Line>* group : {&lines_, &exits_})
        for (Line& l : *group) {
            flowRows_[row++].push_back(FlowRow{intervalStart_, t, l.forward, l.backward});
            l.forward = l.backward = 0;
        }
    for (std::size_t k = 0; k < areas_.size(); ++k) {
        Area& a = areas_[k];
        if (a.samples == 0) continue;
        const double n = a.samples;
        const double density = a.sumDensity / n;
        const double speed = a.occupied > 0 ? a.sumSpeed / a.occupied : 0.0;
        areaRows_[k].push_back(AreaRow{t, density, speed, a.sumFlow / n, a.sumPeople / n, fruinLevel(density)});
        a.sumDensity = a.sumSpeed = a.sumFlow = a.sumPeople = 0;
        a.samples = a.occupied = 0;
    }
    intervalStart_ = t;
}

void MeasurementRecorder::finish() {
    if (!started_ || lastTime_ <= intervalStart_) return;
    closeInterval(lastTime_);
}

std::pair<int, int> MeasurementRecorder::lineTotals(std::size_t k) const {
    return {lines_[k].totalForward, lines_[k].totalBackward};
}

std::string MeasurementRecorder::flowsCsv() const {
    std::string out = "time,line,kind,forward,backward,flow,specific_flow\n";
    // Rows in time order, lines before exits at each time.
    const std::size_t groups = lines_.size() + exits_.size();
    const std::size_t rows = groups > 0 ? flowRows_[0].size() : 0;
    for (std::size_t r = 0; r < rows; ++r) {
        for (std::size_t k = 0; k < groups; ++k) {
            const Line& l = k < lines_.size() ? lines_[k] : exits_[k - lines_.size()];
            const FlowRow& row = flowRows_[k][r];
            const double span = std::max(1e-12, row.time - row.start);
            const double flow = (row.forward + row.backward) / span;
            out += number(row.time) + ',' + l.name + ',' + (l.exit ? "exit" : "line") + ',' + std::to_string(row.forward) +
                   ',' + std::to_string(row.backward) + ',' + number(flow) + ',' + number(flow / l.length) + '\n';
        }
    }
    return out;
}

std::string MeasurementRecorder::areasCsv() const {
    std::string out = "time,area,density,speed,specific_flow,los,people\n";
    const std::size_t rows = areas_.empty() ? 0 : areaRows_[0].size();
    for (std::size_t r = 0; r < rows; ++r)
        for (std::size_t k = 0; k < areas_.size(); ++k) {
            if (r >= areaRows_[k].size()) continue;
            const AreaRow& row = areaRows_[k][r];
            out += number(row.time) + ',' + areas_[k].name + ',' + number(row.density) + ',' + number(row.speed) + ',' +
                   number(row.specificFlow) + ',' + std::string(1, row.los) + ',' + number(row.people) + '\n';
        }
    return out;
}

std::vector<VerdictReason> MeasurementRecorder::reasons() const {
    std::vector<VerdictReason> out;
    for (const std::vector<Line>* group : {&lines_, &exits_})
        for (const Line& l : *group) {
            if (l.first < 0) continue;
            VerdictReason r;
            r.level = "caution";
            r.measure = "flow_capacity";
            r.threshold = t_.flowCapacity;
            r.unit = "P/(m*s)";
            r.firstTime = l.first;
            r.duration = l.longest;
            r.people = l.peakCount;  // most people through it within one flow window
            r.place = l.name;
            r.hasWhere = true;
            r.x = 0.5 * (l.a.x() + l.b.x());
            r.y = 0.5 * (l.a.y() + l.b.y());
            r.xmin = std::min(l.a.x(), l.b.x());
            r.xmax = std::max(l.a.x(), l.b.x());
            r.ymin = std::min(l.a.y(), l.b.y());
            r.ymax = std::max(l.a.y(), l.b.y());
            r.text = std::string(l.exit ? "exit '" : "line '") + l.name + "' at capacity: specific flow over " +
                     number(t_.flowWindow) + " s above " + number(t_.flowCapacity) + " P/(m*s) (IMO/SFPE) for " +
                     number(l.longest, 3) + " s from t = " + number(l.first, 4) + " s; peak " + number(l.peak, 3) +
                     " P/(m*s) over " + number(l.length, 3) + " m";
            out.push_back(std::move(r));
        }
    for (const Area& a : areas_) {
        if (a.first < 0) continue;
        VerdictReason r;
        r.level = "caution";
        r.measure = "level_of_service";
        r.threshold = fruinLowerDensity('F');
        r.unit = "persons/m2";
        r.firstTime = a.first;
        r.duration = a.longest;
        r.people = static_cast<std::size_t>(a.peakPeople);
        r.place = a.name;
        r.hasWhere = true;
        Vec2 c(0, 0);
        for (const Vec2& p : a.polygon) c += p;
        c /= static_cast<double>(std::max<std::size_t>(1, a.polygon.size()));
        r.x = c.x();
        r.y = c.y();
        r.xmin = a.bounds.lo.x();
        r.xmax = a.bounds.hi.x();
        r.ymin = a.bounds.lo.y();
        r.ymax = a.bounds.hi.y();
        r.text = "area '" + a.name + "' at Fruin's level of service F (density above " + number(r.threshold, 3) +
                 " persons/m2) for " + number(a.longest, 3) + " s from t = " + number(a.first, 4) + " s; peak " +
                 number(a.peak, 3) + " persons/m2";
        out.push_back(std::move(r));
    }
    return out;
}

}  // namespace ch
