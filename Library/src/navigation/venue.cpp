// CrowdHealth — venue specs: name lookups, drawn attributes and the expansion of sources.
#include "crowdhealth/navigation/venue.h"

#include "crowdhealth/core/rng.h"
#include "crowdhealth/core/scenario.h"

#include <algorithm>
#include <cmath>

namespace ch {

namespace {
template <class T>
int indexByName(const std::vector<T>& items, const std::string& name) {
    for (std::size_t k = 0; k < items.size(); ++k)
        if (items[k].name == name) return static_cast<int>(k);
    return -1;
}
}  // namespace

int VenueSpec::targetIndex(const std::string& name) const { return indexByName(targets, name); }
int VenueSpec::exitSetIndex(const std::string& name) const { return indexByName(exitSets, name); }
int VenueSpec::journeyIndex(const std::string& name) const { return indexByName(journeys, name); }

double DrawSpec::draw(Rng& rng) const {
    switch (kind) {
        case Kind::Constant: return value;
        case Kind::Uniform: return rng.uniform(min, max);
        case Kind::Normal: {
            // Truncated normal by rejection; after 64 misses (bounds far in a tail) the mean,
            // clamped, stands in.
            for (int k = 0; k < 64; ++k) {
                const double v = mean + sd * rng.normal();
                if (v >= min && v <= max) return v;
            }
            return std::clamp(mean, min, max);
        }
        case Kind::Lognormal: {
            // The same for the log: truncated by rejection, else the median clamped.
            for (int k = 0; k < 64; ++k) {
                const double v = std::exp(mu + sigma * rng.normal());
                if (v >= min && v <= max) return v;
            }
            return std::clamp(std::exp(mu), min, max);
        }
    }
    return value;
}

std::vector<double> sourceArrivals(const SourceSpec& s, std::size_t limit) {
    std::vector<double> times;
    const std::size_t wanted = s.count >= 0 ? static_cast<std::size_t>(s.count) : limit;
    // The rate as pieces [t0, t1) with a constant value.
    std::vector<std::pair<double, double>> pieces = s.table;
    if (pieces.empty()) pieces.push_back({s.start, s.rate});
    double cumulative = 0;  // persons arrived (as a real number) by the start of the piece
    for (std::size_t p = 0; p < pieces.size() && times.size() < wanted; ++p) {
        const double t0 = std::max(pieces[p].first, s.start);
        const double t1 = std::min(p + 1 < pieces.size() ? pieces[p + 1].first : kInf, s.end);
        if (!(t1 > t0)) continue;
        const double rate = pieces[p].second;
        if (rate > 0) {
            // Arrival k comes when the cumulative count reaches k: t0 + (k − cumulative)/rate.
            while (times.size() < wanted) {
                const double t = t0 + (static_cast<double>(times.size()) - cumulative) / rate;
                if (!(t < t1)) break;
                times.push_back(t);
            }
        }
        if (!std::isfinite(t1)) break;
        cumulative += std::max(0.0, rate) * (t1 - t0);
    }
    return times;
}

void expandSources(ScenarioSpec& spec) {
    for (std::size_t k = 0; k < spec.venue.sources.size(); ++k) {
        const SourceSpec& s = spec.venue.sources[k];
        const std::vector<double> times = sourceArrivals(s, 10'000'000);
        Vec2 centre(0, 0);
        for (const Vec2& p : s.area) centre += p;
        if (!s.area.empty()) centre /= static_cast<double>(s.area.size());
        for (std::size_t n = 0; n < times.size(); ++n) {
            Rng rng(spec.seed, kStreamSource, k, n);
            AgentSpec a;
            a.position = centre;  // replaced by the place chosen on arrival
            a.goal = s.goal;
            a.radius = s.radius.draw(rng);
            a.prefSpeed = s.prefSpeed.draw(rng);
            a.maxSpeed = std::max(s.maxSpeed.draw(rng), a.prefSpeed);
            a.premovement = std::max(0.0, s.premovement.draw(rng));
            a.maxAcceleration = s.maxAcceleration;
            a.mass = (a.radius / 0.24) * (a.radius / 0.24);
            a.removeAtGoal = s.removeAtGoal;
            a.startTime = times[n];
            a.policyId = s.policyId;
            a.journey = s.journey;
            a.source = static_cast<int>(k);
            a.loc = s.loc;
            spec.agents.push_back(std::move(a));
        }
    }
}

}  // namespace ch
