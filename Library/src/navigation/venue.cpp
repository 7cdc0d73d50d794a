// CrowdHealth — venue specs: name lookups, drawn attributes and the expansion of sources.
#include "crowdhealth/navigation/venue.h"

#include "crowdhealth/core/rng.h"
#include "crowdhealth/core/scenario.h"

#include <algorithm>
#include <cmath>
#include <string>

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

double sourceGroupProbability(const SourceSpec& s) {
    if (s.groupSizeMin < 2) return 0;
    const double share = std::clamp(s.groupShare, 0.0, 1.0);
    const double meanSize = 0.5 * (s.groupSizeMin + s.groupSizeMax);
    return share / (share + (1 - share) * meanSize);
}

void expandSources(ScenarioSpec& spec) {
    for (std::size_t k = 0; k < spec.venue.sources.size(); ++k) {
        const SourceSpec& s = spec.venue.sources[k];
        const std::vector<double> times = sourceArrivals(s, 10'000'000);
        const SharedName journey(s.journey);  // one name for all the source's agents
        Vec2 centre(0, 0);
        for (const Vec2& p : s.area) centre += p;
        if (!s.area.empty()) centre /= static_cast<double>(s.area.size());
        const double groupProbability = sourceGroupProbability(s);
        int groups = 0;
        // Units of consecutive arrivals: one person, or a group arriving at its first member's time.
        for (std::size_t first = 0; first < times.size();) {
            std::size_t size = 1;
            if (groupProbability > 0) {
                Rng rng(spec.seed, kStreamSourceGroup, k, first);
                if (rng.uniform() < groupProbability) {
                    const int span = s.groupSizeMax - s.groupSizeMin + 1;
                    size = static_cast<std::size_t>(
                        s.groupSizeMin + std::min(span - 1, static_cast<int>(rng.uniform() * span)));
                }
            }
            size = std::min(size, times.size() - first);  // `count` or `end` cuts the last group
            const SharedName group = size >= 2 ? SharedName(s.name + "/g" + std::to_string(++groups)) : SharedName();
            for (std::size_t n = first; n < first + size; ++n) {
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
                a.startTime = times[first];
                a.policyId = s.policyId;
                a.journey = journey;
                a.source = static_cast<int>(k);
                a.group = group;
                a.loc = s.loc;
                spec.agents.push_back(std::move(a));
            }
            first += size;
        }
    }
}

}  // namespace ch
