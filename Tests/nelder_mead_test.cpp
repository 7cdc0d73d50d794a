// The Nelder–Mead search in a box of `crowdhealth calibrate` (Engine/nelder_mead.h), on smooth
// functions whose minimum is known.
#define BOOST_TEST_MODULE nelder_mead
#include <boost/test/unit_test.hpp>

#include "nelder_mead.h"

#include <cmath>

using namespace chcli;

namespace {

/// A batch objective from a function of one point, counting the points and the batches asked for.
struct Counted {
    std::function<double(const std::vector<double>&)> f;
    std::size_t points = 0, batches = 0;
    std::vector<std::vector<double>> asked{};
    BatchObjective objective() {
        return [this](const std::vector<std::vector<double>>& xs, const std::string&) -> std::optional<std::vector<double>> {
            ++batches;
            std::vector<double> v;
            for (const auto& x : xs) {
                ++points;
                asked.push_back(x);
                v.push_back(f(x));
            }
            return v;
        };
    }
};

}  // namespace

BOOST_AUTO_TEST_CASE(finds_the_minimum_of_a_quadratic_inside_the_box) {
    Counted c{[](const std::vector<double>& x) { return (x[0] - 1.3) * (x[0] - 1.3) + 4 * (x[1] + 0.4) * (x[1] + 0.4); }};
    BoxSearchOptions o;
    o.lo = {0, -2};
    o.hi = {4, 2};
    o.tolerance = 1e-4;
    o.maxEvaluations = 500;
    const BoxSearchResult r = nelderMeadInBox(c.objective(), o);
    BOOST_TEST(r.converged);
    BOOST_TEST(std::abs(r.best[0] - 1.3) < 2e-3, r.best[0]);
    BOOST_TEST(std::abs(r.best[1] + 0.4) < 2e-3, r.best[1]);
    BOOST_TEST(r.evaluations == c.points);
    BOOST_TEST(r.evaluations < 200u);
    // The first batch is the whole first simplex, starting at the box's centre.
    BOOST_TEST(c.asked[0] == (std::vector<double>{2, 0}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(stays_in_the_box_and_finds_a_minimum_on_its_bound) {
    // The unconstrained minimum (5, -3) is outside [0, 2] x [-1, 1]: the answer is the corner (2, -1).
    Counted c{[](const std::vector<double>& x) { return (x[0] - 5) * (x[0] - 5) + (x[1] + 3) * (x[1] + 3); }};
    BoxSearchOptions o;
    o.lo = {0, -1};
    o.hi = {2, 1};
    o.tolerance = 1e-5;
    o.maxEvaluations = 400;
    const BoxSearchResult r = nelderMeadInBox(c.objective(), o);
    for (const auto& x : c.asked) {
        BOOST_TEST((x[0] >= 0 && x[0] <= 2 && x[1] >= -1 && x[1] <= 1), "asked outside the box: " << x[0] << ", " << x[1]);
    }
    BOOST_TEST(std::abs(r.best[0] - 2) < 1e-3, r.best[0]);
    BOOST_TEST(std::abs(r.best[1] + 1) < 1e-3, r.best[1]);
}

BOOST_AUTO_TEST_CASE(one_parameter_and_the_evaluation_limit) {
    Counted c{[](const std::vector<double>& x) { return std::abs(x[0] - 0.37); }};
    BoxSearchOptions o;
    o.lo = {0};
    o.hi = {1};
    o.tolerance = 1e-6;
    o.maxEvaluations = 12;
    const BoxSearchResult r = nelderMeadInBox(c.objective(), o);
    BOOST_TEST(!r.converged);
    BOOST_TEST(r.evaluations >= 12u);
    BOOST_TEST(r.evaluations <= 13u);  // at most p more than the limit (a shrink finishes)
    o.maxEvaluations = 200;
    const BoxSearchResult full = nelderMeadInBox(Counted{c.f}.objective(), o);
    BOOST_TEST(full.converged);
    BOOST_TEST(std::abs(full.best[0] - 0.37) < 1e-5, full.best[0]);
}

BOOST_AUTO_TEST_CASE(same_search_twice_and_failures_are_worst) {
    auto f = [](const std::vector<double>& x) {
        // +inf (a failed evaluation) on part of the box: the search must go round it.
        if (x[0] > 3.5) return std::numeric_limits<double>::infinity();
        return std::pow(x[0] - 2.9, 2) + std::pow(x[1] - 0.5, 2) + 0.3 * x[0] * x[1];
    };
    BoxSearchOptions o;
    o.lo = {0, 0};
    o.hi = {4, 1};
    o.maxEvaluations = 300;
    o.tolerance = 1e-6;
    Counted a{f}, b{f};
    const BoxSearchResult ra = nelderMeadInBox(a.objective(), o), rb = nelderMeadInBox(b.objective(), o);
    BOOST_TEST(a.asked == b.asked);
    BOOST_TEST(ra.best == rb.best);
    BOOST_TEST(std::isfinite(ra.value));
    // The minimum of the finite part: d/dx0 = 2(x0 - 2.9) + 0.3 x1 = 0, d/dx1 = 2(x1 - 0.5) + 0.3 x0 = 0.
    const double x1 = (0.5 - 0.15 * 2.9) / (1 - 0.0225), x0 = 2.9 - 0.15 * x1;
    BOOST_TEST(std::abs(ra.best[0] - x0) < 1e-3, ra.best[0] << " vs " << x0);
    BOOST_TEST(std::abs(ra.best[1] - x1) < 1e-3, ra.best[1] << " vs " << x1);
}

BOOST_AUTO_TEST_CASE(interrupted_when_the_objective_says_so) {
    std::size_t calls = 0;
    BatchObjective f = [&](const std::vector<std::vector<double>>& xs, const std::string&) -> std::optional<std::vector<double>> {
        if (++calls == 3) return std::nullopt;
        return std::vector<double>(xs.size(), 1.0 * static_cast<double>(calls));
    };
    BoxSearchOptions o;
    o.lo = {0};
    o.hi = {1};
    const BoxSearchResult r = nelderMeadInBox(f, o);
    BOOST_TEST(r.interrupted);
    BOOST_TEST(calls == 3u);
}

BOOST_AUTO_TEST_CASE(the_textbook_steps_on_a_slope) {
    // f(x) = -x on [0, 1] in one dimension, so every step can be followed by hand in u
    // (x = (1 + sin u) / 2): the simplex {0, 0.6} (the centre and the first step); the best is
    // 0.6, the reflection of 0 through it is 1.2, better than the best, so the expansion 1.8 is
    // tried, is better still and replaces the worst vertex; the simplex {1.8, 0.6} then reflects
    // 0.6 through 1.8 to 3.0.
    std::vector<std::string> steps;
    Counted c{[](const std::vector<double>& x) { return -x[0]; }};
    BatchObjective inner = c.objective();
    BatchObjective f = [&](const std::vector<std::vector<double>>& xs, const std::string& step) {
        for (std::size_t k = 0; k < xs.size(); ++k) steps.push_back(step);
        return inner(xs, step);
    };
    BoxSearchOptions o;
    o.lo = {0};
    o.hi = {1};
    o.maxEvaluations = 5;
    nelderMeadInBox(f, o);
    BOOST_REQUIRE_GE(c.asked.size(), 5u);
    const std::vector<double> u = {0, 0.6, 1.2, 1.8, 3.0};
    const std::vector<std::string> names = {"start", "start", "reflect", "expand", "reflect"};
    for (std::size_t k = 0; k < 5; ++k) {
        BOOST_TEST(std::abs(c.asked[k][0] - 0.5 * (1 + std::sin(u[k]))) < 1e-12, "point " << k << ": " << c.asked[k][0]);
        BOOST_TEST(steps[k] == names[k]);
    }
}
