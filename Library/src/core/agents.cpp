// CrowdHealth — the agent columns.
#include "crowdhealth/core/agents.h"

#include "crowdhealth/core/scenario.h"

#include <type_traits>

namespace ch {

std::size_t AgentStore::add(const AgentSpec& s, int policyIndex, int recordIndex) {
    id.push_back(s.id);
    record.push_back(recordIndex);
    policy.push_back(policyIndex);
    radius.push_back(s.radius);
    prefSpeed.push_back(s.prefSpeed);
    maxSpeed.push_back(s.maxSpeed);
    basePrefSpeed.push_back(s.prefSpeed);
    baseMaxSpeed.push_back(s.maxSpeed);
    maxAcceleration.push_back(s.maxAcceleration);
    mass.push_back(s.mass);
    goalRadius.push_back(s.goalRadius >= 0 ? s.goalRadius : s.radius);
    removeAtGoal.push_back(s.removeAtGoal ? 1 : 0);
    hasGoal.push_back(s.goal ? 1 : 0);
    goal.push_back(s.goal ? *s.goal : s.position);
    pos.push_back(s.position);
    vel.push_back(Vec2(0, 0));
    prefVel.push_back(Vec2(0, 0));
    // UMANS: an agent starts looking towards its goal.
    const Vec2 toGoal = goal.back() - s.position;
    viewDir.push_back(toGoal.squaredNorm() > 0 ? Vec2(toGoal.normalized()) : Vec2(1, 0));
    density.push_back(0.0);
    contactAccel.push_back(Vec2(0, 0));
    if (navigationColumns) {
        journey.push_back(-1);
        stage.push_back(0);
        target.push_back(-1);
        navDistance.push_back(-1.0);
        navDir.push_back(Vec2(0, 0));
        holdUntil.push_back(0.0);
        navFlags.push_back(0);
        nextChoice.push_back(0.0);
    }
    group.push_back(s.groupIndex);
    return id.size() - 1;
}

namespace {
template <class T>
void compact(std::vector<T>& v, const std::vector<unsigned char>& remove) {
    std::size_t w = 0;
    for (std::size_t r = 0; r < v.size(); ++r)
        if (!remove[r]) {
            if (w != r) v[w] = std::move(v[r]);
            ++w;
        }
    v.resize(w);
}
}  // namespace

void AgentStore::removeMarked(const std::vector<unsigned char>& remove) {
    forEachColumn([&](auto& column) { compact(column, remove); });
}

void AgentStore::permute(const std::vector<int>& order) {
    // In place, as remapColumn (which a permutation never asks for a fresh value): every column
    // keeps its buffer and its room for agents still to come.
    forEachColumn([&](auto& column) {
        using T = typename std::remove_reference_t<decltype(column)>::value_type;
        if constexpr (std::is_same_v<T, Vec2>)
            remapColumn(column, order, Vec2(0, 0));
        else
            remapColumn(column, order, T{});
    });
}

void AgentStore::reserve(std::size_t n) {
    forEachColumn([n](auto& column) { column.reserve(n); });
}

}  // namespace ch
