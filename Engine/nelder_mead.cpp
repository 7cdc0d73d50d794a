// crowdhealth calibrate — Nelder–Mead in a box: see nelder_mead.h.
#include "nelder_mead.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace chcli {

namespace {

constexpr double kReflect = 1.0, kExpand = 2.0, kContract = 0.5, kShrink = 0.5;

struct Vertex {
    std::vector<double> u;  ///< unbounded coordinates
    double f = std::numeric_limits<double>::infinity();
    std::size_t order = 0;  ///< when it was made (ties in f go to the older)
};

}  // namespace

BoxSearchResult nelderMeadInBox(const BatchObjective& f, const BoxSearchOptions& o) {
    const std::size_t p = o.lo.size();
    if (p == 0 || o.hi.size() != p || (!o.start.empty() && o.start.size() != p))
        throw std::invalid_argument("nelderMeadInBox: the box and the start must have the same dimension");
    for (std::size_t j = 0; j < p; ++j)
        if (!(o.lo[j] < o.hi[j])) throw std::invalid_argument("nelderMeadInBox: lo must be below hi");

    // u ↔ x and the share of the box (z in [0, 1]) used by the stopping rule.
    auto share = [&](const std::vector<double>& u, std::size_t j) { return 0.5 * (1.0 + std::sin(u[j])); };
    auto toX = [&](const std::vector<double>& u) {
        std::vector<double> x(p);
        for (std::size_t j = 0; j < p; ++j) x[j] = o.lo[j] + (o.hi[j] - o.lo[j]) * share(u, j);
        return x;
    };

    BoxSearchResult result;
    std::size_t made = 0;
    // Evaluates a batch of vertices (their f filled in); false when interrupted.
    auto evaluate = [&](std::vector<Vertex*> vs, const std::string& step) {
        std::vector<std::vector<double>> xs;
        for (const Vertex* v : vs) xs.push_back(toX(v->u));
        const std::optional<std::vector<double>> values = f(xs, step);
        if (!values || values->size() != vs.size()) return false;
        for (std::size_t k = 0; k < vs.size(); ++k) {
            vs[k]->f = std::isnan((*values)[k]) ? std::numeric_limits<double>::infinity() : (*values)[k];
            vs[k]->order = made++;
        }
        result.evaluations += vs.size();
        return true;
    };

    // The first simplex: the start and one step along each coordinate.
    std::vector<Vertex> simplex(p + 1);
    simplex[0].u.assign(p, 0.0);
    if (!o.start.empty())
        for (std::size_t j = 0; j < p; ++j) {
            const double z = std::clamp((o.start[j] - o.lo[j]) / (o.hi[j] - o.lo[j]), 0.0, 1.0);
            simplex[0].u[j] = std::asin(2.0 * z - 1.0);
        }
    for (std::size_t j = 0; j < p; ++j) {
        simplex[j + 1].u = simplex[0].u;
        // Towards the inside of the box when the start is on the upper half.
        simplex[j + 1].u[j] += simplex[0].u[j] > 0 ? -o.initialStep : o.initialStep;
    }
    {
        std::vector<Vertex*> all;
        for (Vertex& v : simplex) all.push_back(&v);
        if (!evaluate(all, "start")) {
            result.interrupted = true;
            return result;
        }
    }
    auto byValue = [](const Vertex& a, const Vertex& b) { return a.f < b.f || (a.f == b.f && a.order < b.order); };

    for (;;) {
        std::sort(simplex.begin(), simplex.end(), byValue);
        double spread = 0;
        for (std::size_t v = 1; v <= p; ++v)
            for (std::size_t j = 0; j < p; ++j)
                spread = std::max(spread, std::abs(share(simplex[v].u, j) - share(simplex[0].u, j)));
        if (spread < o.tolerance) {
            result.converged = true;
            break;
        }
        if (result.evaluations >= o.maxEvaluations) break;

        std::vector<double> centroid(p, 0.0);
        for (std::size_t v = 0; v < p; ++v)
            for (std::size_t j = 0; j < p; ++j) centroid[j] += simplex[v].u[j] / static_cast<double>(p);
        Vertex& worst = simplex[p];
        auto along = [&](double t, const std::vector<double>& from) {  // centroid + t (from − centroid)
            Vertex v;
            v.u.resize(p);
            for (std::size_t j = 0; j < p; ++j) v.u[j] = centroid[j] + t * (from[j] - centroid[j]);
            return v;
        };
        Vertex reflected = along(-kReflect, worst.u);
        if (!evaluate({&reflected}, "reflect")) {
            result.interrupted = true;
            break;
        }
        if (reflected.f < simplex[0].f) {
            Vertex expanded = along(kExpand, reflected.u);
            if (!evaluate({&expanded}, "expand")) {
                result.interrupted = true;
                break;
            }
            worst = expanded.f < reflected.f ? expanded : reflected;
            continue;
        }
        if (reflected.f < simplex[p - 1].f) {
            worst = reflected;
            continue;
        }
        // Contract: outside (towards the reflected point) when it beat the worst, else inside.
        const bool outside = reflected.f < worst.f;
        Vertex contracted = along(kContract, outside ? reflected.u : worst.u);
        if (!evaluate({&contracted}, "contract")) {
            result.interrupted = true;
            break;
        }
        if (contracted.f < (outside ? reflected.f : worst.f) ||
            (outside && contracted.f == reflected.f)) {
            worst = contracted;
            continue;
        }
        // Shrink every vertex towards the best, evaluated together.
        std::vector<Vertex*> moved;
        for (std::size_t v = 1; v <= p; ++v) {
            for (std::size_t j = 0; j < p; ++j)
                simplex[v].u[j] = simplex[0].u[j] + kShrink * (simplex[v].u[j] - simplex[0].u[j]);
            moved.push_back(&simplex[v]);
        }
        if (!evaluate(moved, "shrink")) {
            result.interrupted = true;
            break;
        }
    }
    const Vertex& best = *std::min_element(simplex.begin(), simplex.end(), byValue);
    result.best = toX(best.u);
    result.value = best.f;
    return result;
}

}  // namespace chcli
