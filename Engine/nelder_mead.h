// crowdhealth calibrate — the Nelder–Mead simplex search inside a box (docs/sweeps.md, Calibration).
//
// The search runs in unbounded coordinates u, mapped into the box [lo, hi] by
//     x_j = lo_j + (hi_j − lo_j) · (1 + sin u_j) / 2,
// so every point it asks for lies inside the box whatever the simplex does, and an optimum on a
// bound is reached smoothly (the map is flat there) instead of by clipping, which would flatten the
// simplex against the wall. It starts at the box's centre (u = 0) or at a given point.
//
// The steps are the textbook ones (reflection 1, expansion 2, contraction 1/2, shrink 1/2), with
// ties broken by the order the points were made in, so the same objective gives the same search
// bit for bit. Points that can be evaluated together are asked for in one batch (the first simplex,
// a shrink): the caller runs each batch as one set of jobs.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace chcli {

struct BoxSearchOptions {
    std::vector<double> lo, hi;   ///< the box (lo < hi for every coordinate)
    std::vector<double> start;    ///< where to start (inside the box); empty: the centre
    /// Stop when every vertex of the simplex lies within this share of the box's width of the
    /// best vertex, in every coordinate (0.01: 1 % of HI − LO).
    double tolerance = 0.01;
    /// Stop once this many points have been evaluated (a shrink in progress is finished, so up to
    /// p − 1 more are possible with p coordinates).
    std::size_t maxEvaluations = 100;
    double initialStep = 0.6;  ///< radians in u: 0.6 moves x from the centre by 28 % of the box
};

/// Values of the objective at `points` (one per point; +inf where it cannot be evaluated), or
/// nullopt when the search must stop (interrupted). `step` names why the points are asked for:
/// "start", "reflect", "expand", "contract", "shrink".
using BatchObjective =
    std::function<std::optional<std::vector<double>>(const std::vector<std::vector<double>>& points, const std::string& step)>;

struct BoxSearchResult {
    std::vector<double> best;   ///< the best point found (inside the box)
    double value = 0;           ///< the objective there
    std::size_t evaluations = 0;
    bool converged = false;     ///< stopped by the tolerance (not by maxEvaluations)
    bool interrupted = false;   ///< the objective returned nullopt
};

/// Minimises `f` inside the box with the Nelder–Mead method (see the top of this file).
BoxSearchResult nelderMeadInBox(const BatchObjective& f, const BoxSearchOptions& options);

}  // namespace chcli
