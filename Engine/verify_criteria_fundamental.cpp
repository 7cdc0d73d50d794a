// crowdhealth verify — reference curves and errors of the fundamental-diagram tests
// (verify_criteria_fundamental.h).
#include "verify_criteria_fundamental.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace chverify {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// RMSE of `f(point)` over the measured points, and the point of the largest |f|.
struct Rms {
    double rmse = kNaN;
    std::size_t n = 0;
    const FdPoint* worst = nullptr;
    double worstDiff = 0;
};
template <class F>
Rms rmsOf(const std::vector<FdPoint>& points, F diff) {
    Rms r;
    double sum = 0;
    for (const FdPoint& p : points) {
        if (!p.measured) continue;
        const double d = diff(p);
        sum += d * d;
        ++r.n;
        if (!r.worst || std::abs(d) > std::abs(r.worstDiff)) r.worst = &p, r.worstDiff = d;
    }
    if (r.n > 0) r.rmse = std::sqrt(sum / static_cast<double>(r.n));
    return r;
}

}  // namespace

double weidmannSpeed(double density) {
    constexpr double v0 = 1.34, gamma = 1.913, rhoMax = 5.4;
    if (density <= 0) return v0;
    if (density >= rhoMax) return 0;
    return v0 * (1 - std::exp(-gamma * (1 / density - 1 / rhoMax)));
}

double sfpeSpecificFlow(double density) {
    constexpr double k = 1.40, a = 0.266;
    if (density <= 0) return 0;
    return std::max(0.0, k * (1 - a * density)) * density;
}

const std::vector<std::pair<double, double>>& imoTable() {
    static const std::vector<std::pair<double, double>> rows = {{0, 0}, {0.5, 0.65}, {1.9, 1.3}, {3.2, 0.65}, {3.5, 0.32}};
    return rows;
}

double imoSpecificFlow(double density) {
    const auto& t = imoTable();
    if (density <= t.front().first) return t.front().second;
    for (std::size_t k = 1; k < t.size(); ++k)
        if (density <= t[k].first) {
            const double u = (density - t[k - 1].first) / (t[k].first - t[k - 1].first);
            return t[k - 1].second + u * (t[k].second - t[k - 1].second);
        }
    return t.back().second;
}

Check weidmannError(const std::vector<FdPoint>& points) {
    const Rms r = rmsOf(points, [](const FdPoint& p) { return p.speed - weidmannSpeed(p.density); });
    if (r.n == 0) return {false, kNaN, "no density measured (nobody in the measuring area)"};
    return {true, r.rmse,
            "RMSE " + fixedText(r.rmse, 2) + " m/s over " + std::to_string(r.n) + " densities; largest " + fixedText(r.worstDiff, 2) +
                " m/s (" + fixedText(r.worst->speed, 2) + " against " + fixedText(weidmannSpeed(r.worst->density), 2) + ") at " +
                fixedText(r.worst->density, 2) + " P/m2"};
}

Check sfpeError(const std::vector<FdPoint>& points) {
    const Rms r = rmsOf(points, [](const FdPoint& p) { return p.density * p.speed - imoSpecificFlow(p.density); });
    if (r.n == 0) return {false, kNaN, "no density measured (nobody in the measuring area)"};
    const FdPoint* peak = nullptr;
    for (const FdPoint& p : points)
        if (p.measured && (!peak || p.density * p.speed > peak->density * peak->speed)) peak = &p;
    return {true, r.rmse,
            "RMSE " + fixedText(r.rmse, 2) + " P/(m s) over " + std::to_string(r.n) + " densities; largest " +
                fixedText(r.worstDiff, 2) + " at " + fixedText(r.worst->density, 2) + " P/m2; peak flow " +
                fixedText(peak->density * peak->speed, 2) + " P/(m s) at " + fixedText(peak->density, 2) + " P/m2 (IMO 1.3 at 1.9)"};
}

std::vector<std::pair<double, double>> corridorLattice(std::size_t count, double length, double width, double radius) {
    std::vector<std::pair<double, double>> out;
    const double band = width - 2 * radius;  // where centres may lie across the corridor
    if (count == 0 || band < 0 || length <= 0) return out;
    const double inf = std::numeric_limits<double>::infinity();
    std::size_t bestRows = 1;
    double best = -1;
    for (std::size_t rows = 1; rows <= count; ++rows) {
        const std::size_t per = (count + rows - 1) / rows;
        const double dx = length / static_cast<double>(per);
        const double dy = rows > 1 ? band / static_cast<double>(rows - 1) : inf;
        double spacing = per > 1 ? dx : inf;
        if (rows > 1) spacing = std::min(spacing, std::hypot(0.5 * dx, dy));
        if (rows > 2) spacing = std::min(spacing, 2 * dy);
        if (spacing > best) best = spacing, bestRows = rows;
    }
    const std::size_t rows = bestRows, per = (count + rows - 1) / rows, slots = rows * per;
    const double dx = length / static_cast<double>(per);
    const double dy = rows > 1 ? band / static_cast<double>(rows - 1) : 0;
    // count of the slots, spread evenly over them (the empty ones do not bunch in one row).
    for (std::size_t k = 0; k < count; ++k) {
        const std::size_t s = k * slots / count, row = s / per, col = s % per;
        const double x = -0.5 * length + (static_cast<double>(col) + 0.25 + 0.5 * static_cast<double>(row % 2)) * dx;
        const double y = rows > 1 ? -0.5 * band + static_cast<double>(row) * dy : 0.0;
        out.emplace_back(x, y);
    }
    return out;
}

double smallestSpacing(const std::vector<std::pair<double, double>>& points, double length) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < points.size(); ++i)
        for (std::size_t j = i + 1; j < points.size(); ++j) {
            double dx = points[j].first - points[i].first;
            dx -= length * std::round(dx / length);
            best = std::min(best, std::hypot(dx, points[j].second - points[i].second));
        }
    return best;
}

}  // namespace chverify
