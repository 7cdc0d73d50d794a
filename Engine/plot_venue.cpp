// crowdhealth plot — the venue drawn over a map (see plot_venue.h).
#include "plot_venue.h"

#include "plot.h"
#include "plot_measure_data.h"

#include <crowdhealth/io/output.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace chplot {

namespace {

std::string num(double v) { return ch::formatNumber(v, 10); }

/// "30 s" with at most 3 significant decimals.
std::string seconds(double t) { return ch::formatNumber(t, 4) + " s"; }

constexpr const char* kMapExitColour = "#000000";

}  // namespace

void Extent::grow(double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    x0 = std::min(x0, x);
    x1 = std::max(x1, x);
    y0 = std::min(y0, y);
    y1 = std::max(y1, y);
}

void Extent::pad(double fraction) {
    if (empty()) x0 = y0 = -1, x1 = y1 = 1;
    const double p = fraction * std::max({x1 - x0, y1 - y0, 1.0});
    x0 -= p, x1 += p, y0 -= p, y1 += p;
}

VenueOverlay::VenueOverlay(std::optional<ch::ScenarioSpec> spec) : spec_(std::move(spec)) {
    if (!spec_) return;
    marks_ = chrender::venueMarks(*spec_);
    for (const chrender::VenueMark& m : marks_)
        if (m.exit) exitNames_.push_back(m.name);
}

VenueOverlay VenueOverlay::load(const RunData& run, std::string& note) {
    std::ostringstream diagnostics;  // the loader's warnings are not repeated here
    std::string error;
    std::optional<ch::ScenarioSpec> spec = chrender::loadRunScenario(run.dir, error, diagnostics);
    if (!spec) note = error;
    return VenueOverlay(std::move(spec));
}

void VenueOverlay::addExitName(const std::string& name) {
    if (!name.empty() && std::find(exitNames_.begin(), exitNames_.end(), name) == exitNames_.end())
        exitNames_.push_back(name);
}

std::string VenueOverlay::exitColour(const std::string& exit) const {
    const auto it = std::find(exitNames_.begin(), exitNames_.end(), exit);
    return it == exitNames_.end() ? kNoExitColour : seriesColour(static_cast<std::size_t>(it - exitNames_.begin()));
}

void VenueOverlay::grow(Extent& e) const {
    if (!spec_) return;
    for (const ch::ObstacleSpec& o : spec_->obstacles)
        for (const ch::Vec2& p : o.points) e.grow(p.x(), p.y());
    for (const chrender::VenueMark& m : marks_) {
        for (const ch::Vec2& p : m.outline) e.grow(p.x(), p.y());
        if (m.point) {
            e.grow(m.centre.x() - m.radius, m.centre.y() - m.radius);
            e.grow(m.centre.x() + m.radius, m.centre.y() + m.radius);
        }
    }
    for (const ch::MeasureLineSpec& l : spec_->measurement.lines) {
        e.grow(l.a.x(), l.a.y());
        e.grow(l.b.x(), l.b.y());
    }
    for (const ch::MeasureAreaSpec& a : spec_->measurement.areas)
        for (const ch::Vec2& p : a.polygon) e.grow(p.x(), p.y());
}

int VenueOverlay::setObjects(GnuplotJob& job, int tag, const VenueStyle& style, double arrow) const {
    if (!spec_) return tag;
    job.cmd("set style textbox opaque noborder margins 1,1");
    // Walls: obstacles of three or more points filled grey (pillars, boxes).
    for (const ch::ObstacleSpec& o : spec_->obstacles) {
        if (o.points.size() < 3) continue;
        std::string cmd = "set object " + std::to_string(tag++) + " polygon from ";
        for (std::size_t i = 0; i <= o.points.size(); ++i) {
            const ch::Vec2& p = o.points[i % o.points.size()];
            cmd += (i ? " to " : "") + num(p.x()) + "," + num(p.y());
        }
        cmd += std::string(" fillcolor rgb '#b4b4b4' fillstyle solid 1.0 noborder ") + (style.fillInFront ? "front" : "behind");
        job.cmd(cmd);
    }
    // Targets and exits: labels (an exit that closes says when) and point targets' circles.
    for (const chrender::VenueMark& m : marks_) {
        std::string label = m.name;
        for (const auto& [t, opens] : m.events) label += std::string(opens ? ", opens " : ", closes ") + seconds(t);
        const std::string colour = !m.exit ? kTargetColour : style.exitColours ? exitColour(m.name) : kMapExitColour;
        job.cmd("set label " + std::to_string(tag++) + " " + gpString(label) + " at " + num(m.centre.x()) + "," +
                num(m.centre.y()) + " center front boxed noenhanced font ',11' textcolor rgb '" + colour + "'");
        if (m.point)
            job.cmd("set object " + std::to_string(tag++) + " circle at " + num(m.centre.x()) + "," + num(m.centre.y()) +
                    " size " + num(std::max(m.radius, 0.15)) + " fillstyle empty border lc rgb '" + colour + "' lw 2 front");
    }
    // Measurement lines: an arrow from the middle to the forward side (the right-hand side seen
    // from the first end looking at the second); the name just beyond the second end, along the
    // line (upright text: turned by at most 90°).
    for (const ch::MeasureLineSpec& l : spec_->measurement.lines) {
        const ch::Vec2 d = l.b - l.a;
        const double len = d.norm();
        if (!(len > 0)) continue;
        const ch::Vec2 dir = d / len, forward = forwardDirection(l.a, l.b);
        const ch::Vec2 mid = 0.5 * (l.a + l.b), tip = mid + arrow * forward, text = l.b + 0.2 * arrow * dir;
        job.cmd("set arrow " + std::to_string(tag++) + " from " + num(mid.x()) + "," + num(mid.y()) + " to " +
                num(tip.x()) + "," + num(tip.y()) + " head filled size screen 0.012,25 lw 2 lc rgb '" + kMeasureColour +
                "' front");
        double angle = std::atan2(dir.y(), dir.x()) * 180 / M_PI;
        const bool flipped = angle > 90.0001 || angle < -89.9999;  // the text would read upside down
        if (flipped) angle += angle > 0 ? -180 : 180;
        job.cmd("set label " + std::to_string(tag++) + " " + gpString(l.name) + " at " + num(text.x()) + "," +
                num(text.y()) + (flipped ? " right" : " left") + " rotate by " + num(angle) +
                " front boxed noenhanced font ',10' textcolor rgb '" + kMeasureColour + "'");
    }
    // Measurement areas: the name inside, at the middle of the bounding box's lower edge (clear
    // of the doors and lines an area usually lies against with its other edges, and of the middle,
    // where the map's colours matter).
    for (const ch::MeasureAreaSpec& a : spec_->measurement.areas) {
        if (a.polygon.empty()) continue;
        double x0 = a.polygon[0].x(), x1 = x0, y0 = a.polygon[0].y();
        for (const ch::Vec2& p : a.polygon) x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x()), y0 = std::min(y0, p.y());
        job.cmd("set label " + std::to_string(tag++) + " " + gpString(a.name) + " at " + num(0.5 * (x0 + x1)) + "," +
                num(y0) + " center offset 0,0.8 front boxed noenhanced font ',9' textcolor rgb '" + kMeasureColour + "'");
    }
    return tag;
}

void VenueOverlay::addElements(std::vector<std::string>& elements, std::vector<Rows>& blocks,
                               const VenueStyle& style) const {
    if (!spec_) return;
    const double nan = std::nan("");
    Rows walls;
    for (const ch::ObstacleSpec& o : spec_->obstacles) {
        if (o.points.empty()) continue;
        for (std::size_t i = 0; i <= o.points.size(); ++i) {
            if (i == o.points.size() && o.points.size() < 3) break;  // a wall segment: no closing edge
            const ch::Vec2& p = o.points[i % o.points.size()];
            walls.push_back({p.x(), p.y()});
        }
        walls.push_back({nan, nan});
    }
    if (!walls.empty()) {
        elements.push_back(std::string("'-' using 1:2 with lines lw 2.5 lc rgb '") + kWallColour + "' title 'walls'");
        blocks.push_back(std::move(walls));
    }
    Rows targets, mapExits;
    bool anyExit = false, anyCloses = false;
    for (const chrender::VenueMark& m : marks_) {
        anyExit = anyExit || m.exit;
        anyCloses = anyCloses || (m.exit && !m.events.empty());
        if (m.point || m.outline.empty()) continue;
        Rows outline;
        for (std::size_t i = 0; i <= m.outline.size(); ++i)
            outline.push_back({m.outline[i % m.outline.size()].x(), m.outline[i % m.outline.size()].y()});
        if (m.exit && style.exitColours) {
            // Each exit in its colour; dashed when it closes at some time.
            elements.push_back("'-' using 1:2 with lines lw 2.5 " + std::string(m.events.empty() ? "" : "dt 2 ") +
                               "lc rgb '" + exitColour(m.name) + "' notitle");
            blocks.push_back(std::move(outline));
        } else {
            Rows& into = m.exit ? mapExits : targets;
            into.insert(into.end(), outline.begin(), outline.end());
            into.push_back({nan, nan});
        }
    }
    if (!targets.empty()) {
        elements.push_back(std::string("'-' using 1:2 with lines lw 1.5 dt 3 lc rgb '") + kTargetColour + "' title 'targets'");
        blocks.push_back(std::move(targets));
    }
    if (!mapExits.empty()) {
        elements.push_back(std::string("'-' using 1:2 with lines lw 2.5 lc rgb '") + kMapExitColour + "' title 'exits'");
        blocks.push_back(std::move(mapExits));
    } else if (anyExit && style.exitColours) {
        elements.push_back(std::string("keyentry with lines lw 2.5 lc rgb '#606060' title '") +
                           (anyCloses ? "exits (dashed: closes at some time)" : "exits") + "'");
    }
    Rows lines, areas;
    for (const ch::MeasureLineSpec& l : spec_->measurement.lines) {
        lines.push_back({l.a.x(), l.a.y()});
        lines.push_back({l.b.x(), l.b.y()});
        lines.push_back({nan, nan});
    }
    for (const ch::MeasureAreaSpec& a : spec_->measurement.areas) {
        for (std::size_t i = 0; i <= a.polygon.size(); ++i)
            areas.push_back({a.polygon[i % a.polygon.size()].x(), a.polygon[i % a.polygon.size()].y()});
        areas.push_back({nan, nan});
    }
    if (!areas.empty()) {
        elements.push_back(std::string("'-' using 1:2 with lines lw 2 dt (6,4) lc rgb '") + kMeasureColour +
                           "' title 'measurement areas'");
        blocks.push_back(std::move(areas));
    }
    if (!lines.empty()) {
        elements.push_back(std::string("'-' using 1:2 with lines lw 3 lc rgb '") + kMeasureColour +
                           "' title 'measurement lines (arrow: forward)'");
        blocks.push_back(std::move(lines));
    }
}

}  // namespace chplot
