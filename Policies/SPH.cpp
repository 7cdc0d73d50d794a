// CrowdHealth — SPH crowds (van Toll et al. 2021), see SPH.h.
#include "SPH.h"

#include "PairSums.h"
#include "WallArea.h"

#include "crowdhealth/core/kernels.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <span>

namespace ch {

CH_REGISTER_COMPONENT(SPH);

SPH::Kernels::Kernels(double hh) : h(hh), h2(hh * hh) {
    const double h8 = h2 * h2 * h2 * h2;
    const double h5 = h * h * h * h * h;
    c6 = 4.0 / (kPi * h8);
    cS = 30.0 / (kPi * h5);
    cV = 360.0 / (29.0 * kPi * h5);
}

ComponentInfo SPH::Info() {
    ComponentInfo info;
    info.name = "SPH";
    info.kind = ComponentKind::Force;
    info.defaultRange = 1.0;
    info.summary = "crowd as a fluid: SPH density, dynamic rest density, pressure (only when compressed) and viscosity; "
                   "range = smoothing length h (capped at 1 m)";
    info.reference = "van Toll et al. 2021, SPH crowds, Computers & Graphics 98; Mueller, Charypar & Gross 2003 (kernels)";
    ParamSpec T = ParamSpec::real("densityAdaptationTime", "s", 0.1, 0.0, 1e4,
                                  "T_rho: time scale of the moving average that gives the rest density");
    T.minExclusive = true;
    info.params = {
        ParamSpec::real("gasConstant", "m2/s2", 200.0, 0.0, 1e6, "k: pressure per unit of excess density, p = k (rho - rho0)"),
        ParamSpec::real("restDensityMin", "1/m2", 0.0, 0.0, 1e3, "rho0_min: lower clamp of the dynamic rest density"),
        ParamSpec::real("restDensityMax", "1/m2", 5.0, 0.0, 1e3, "rho0_max: upper clamp of the dynamic rest density"),
        T,
        ParamSpec::real("viscosity", "1/s", 0.0, 0.0, 1e4, "mu: viscosity (velocity smoothing between neighbours)"),
        ParamSpec::choice("walls", {"particles", "analytic"}, 1,
                          "wall density from static boundary particles (<Box particles=\"true\">) or from the area of "
                          "the kernel disc behind each wall segment, with occlusion"),
        ParamSpec::boolean("wallViscosity", true,
                           "walls=particles: boundary particles take part in the viscosity sum as fluid at rest (v = 0), "
                           "i.e. friction along walls and door jambs"),
        ParamSpec::choice("wallPressure", {"fixed", "dynamic", "mirrored", "densityOnly"}, 0,
                          "walls=particles, boundary particles in the pressure sum: own density against their rest "
                          "state without agents (fixed), own density against the agents' dynamic rest density (dynamic), "
                          "the agent's pressure and density (mirrored), or not at all (densityOnly)"),
    };
    info.create = [](const ParamSet& p) { return std::make_unique<SPH>(p); };
    return info;
}

SPH::SPH(const ParamSet& params) {
    bind(params, "range", range_);
    bind(params, "gasConstant", gasConstant_);
    bind(params, "restDensityMin", restDensityMin_);
    bind(params, "restDensityMax", restDensityMax_);
    bind(params, "densityAdaptationTime", adaptationTime_);
    bind(params, "viscosity", viscosity_);
    bind(params, "walls", walls_);
    bind(params, "wallViscosity", wallViscosity_);
    bind(params, "wallPressure", wallPressureRule_);
}

double SPH::smoothingLength() const { return std::min(range_, kMaxSmoothingLength); }

double SPH::clampRest(double v) const {
    // ρ0_max wins if a schedule ever moves ρ0_min above it.
    return std::min(std::max(v, restDensityMin_), restDensityMax_);
}

void SPH::remapAgents(const std::vector<int>& previous) {
    // Columns not yet sized stay empty until prepare() sizes them with the same fresh values.
    remapColumn(density_, previous, 0.0, true);
    remapColumn(restDensity_, previous, 0.0, true);
    remapColumn(pressure_, previous, 0.0, true);
    remapColumn(average_, previous, 0.0, true);
    remapColumn(known_, previous, static_cast<unsigned char>(0), true);
    pieceAgents_ = nullptr;  // the pieces were numbered by the old order: the next prepare() finds them again
}

bool SPH::storedPieces(std::size_t i, const StepContext& ctx, const wallarea::WallPiece*& first,
                       std::size_t& count) const {
    if (pieceAgents_ != &ctx.agents || pieceStep_ != ctx.stepIndex || i >= pieceEnd_.size()) return false;
    // The thread whose chunk holds i: the last chunk starting at or before it (chunks are
    // contiguous, in thread order; a thread without agents starts at n).
    std::size_t t = 0;
    for (std::size_t u = 1; u < pieceFirst_.size(); ++u)
        if (pieceFirst_[u] <= i) t = u;
    const std::size_t begin = i == pieceFirst_[t] ? 0 : pieceEnd_[i - 1];
    first = threadPieces_[t].data() + begin;
    count = pieceEnd_[i] - begin;
    return true;
}

void SPH::prepare(const StepContext& ctx) {
    const AgentStore& A = ctx.agents;
    const std::size_t n = A.size();
    density_.resize(n, 0.0);
    restDensity_.resize(n, 0.0);
    pressure_.resize(n, 0.0);
    average_.resize(n, 0.0);
    known_.resize(n, 0);

    kernels_ = Kernels(smoothingLength());
    const Kernels& K = kernels_;
    const double h = K.h;
    const double w = std::min(1.0, ctx.dt / adaptationTime_);
    const bool analytic = analyticWalls();
    const std::vector<Vec2>& particles = ctx.world.boundaryParticles();
    const PointGrid& particleGrid = ctx.world.particleGrid();
    const bool useParticles = !analytic && !particles.empty();
    const std::size_t threads = static_cast<std::size_t>(std::max(1, omp_get_max_threads()));
    pieceAgents_ = nullptr;
    if (analytic) {
        if (threadPieces_.size() < threads) threadPieces_.resize(threads);
        pieceFirst_.assign(threads, n);
        pieceEnd_.resize(n);
    }

#pragma omp parallel if (parallelNeighbourLoop(n))
    {
        std::vector<int> near;
        std::vector<wallarea::WallPiece> pieces;
        std::vector<NeighbourAgent> agentsNear;  // the grid's agents, where the step's list does not reach
        const std::size_t t = static_cast<std::size_t>(omp_get_thread_num());
        std::vector<wallarea::WallPiece>* kept = analytic ? &threadPieces_[t] : nullptr;
        if (kept != nullptr) kept->clear();
        bool first = true;
#pragma omp for schedule(static)
        for (std::ptrdiff_t ii = 0; ii < static_cast<std::ptrdiff_t>(n); ++ii) {
            const std::size_t i = static_cast<std::size_t>(ii);
            const Vec2& x = A.pos[i];
            double rho = A.mass[i] * K.poly6(0.0);  // the agent itself (r = 0), then the others
            // The step's list, or the grid's agents where it does not reach (tests without lists),
            // through one sum (PairSums.h: eight at a time where the CPU has AVX-512).
            pairs::DensityInput in;
            pairs::setList(in, ctx, i, h, agentsNear);
            in.mass = A.mass.data();
            in.h2 = K.h2;
            in.c6 = K.c6;
            in.start = rho;
            rho = pairs::sphDensity(in);
            if (useParticles) {
                particleGrid.forEachWithin(x, h, [&](int, const Vec2&, double d2) { rho += K.poly6(d2); });
            } else if (analytic) {
                // Walls are fluid at the agent's rest density (the previous step's; at the first
                // step, the clamp of its density without walls).
                const double rest = known_[i] ? restDensity_[i] : clampRest(rho);
                ctx.segmentsNear(i, h, near);
                wallarea::occludedAreas(x, h, ctx.world.segments(), near, pieces);
                for (const wallarea::WallPiece& s : pieces) {
                    const double r = 0.5 * (s.distance + h);
                    rho += s.area * rest * K.poly6(r * r);
                }
                if (first) pieceFirst_[t] = i;
                first = false;
                kept->insert(kept->end(), pieces.begin(), pieces.end());
                pieceEnd_[i] = static_cast<std::uint32_t>(kept->size());
            }
            average_[i] = known_[i] ? (1.0 - w) * average_[i] + w * rho : rho;
            known_[i] = 1;
            density_[i] = rho;
            restDensity_[i] = clampRest(average_[i]);
            pressure_[i] = gasConstant_ * (rho - restDensity_[i]);
        }
    }
    if (analytic) {
        pieceStep_ = ctx.stepIndex;
        pieceAgents_ = &A;
    }

    if (!useParticles) return;
    // Boundary particles: density from agents and particles (itself included). They never move;
    // their pressure p_k = k (ρ_k − ρ0_k) with ρ0_k either their density without agents (fixed:
    // a wall does not adapt to being pressed) or the agents' moving-average rule (dynamic).
    const std::size_t np = particles.size();
    wallDensity_.resize(np, 0.0);
    wallPressure_.resize(np, 0.0);
    wallAverage_.resize(np, 0.0);
    wallKnown_.resize(np, 0);
    const WallPressure rule = wallPressureRule();
#pragma omp parallel for schedule(static) if (parallelNeighbourLoop(np))
    for (std::ptrdiff_t kk = 0; kk < static_cast<std::ptrdiff_t>(np); ++kk) {
        const std::size_t k = static_cast<std::size_t>(kk);
        const Vec2& x = particles[k];
        double walls = 0;
        particleGrid.forEachWithin(x, h, [&](int, const Vec2&, double d2) { walls += K.poly6(d2); });
        double rho = walls;
        ctx.grid.forEachWithin(x, h, [&](int j, const Vec2&, double d2) { rho += A.mass[j] * K.poly6(d2); });
        double rest;
        if (rule == WallPressure::Fixed) {
            rest = walls;  // the wall's own rest state (not clamped: it is not a pedestrian's choice)
        } else {
            wallAverage_[k] = wallKnown_[k] ? (1.0 - w) * wallAverage_[k] + w * rho : rho;
            rest = clampRest(wallAverage_[k]);
        }
        wallKnown_[k] = 1;
        wallDensity_[k] = rho;
        wallPressure_[k] = gasConstant_ * (rho - rest);
    }
}

Vec2 SPH::acceleration(const AgentQuery& q, const StepContext& ctx) const {
    const std::size_t i = static_cast<std::size_t>(q.i);
    if (i >= density_.size() || !(density_[i] > 0)) return {0, 0};
    const AgentStore& A = ctx.agents;
    const Kernels& K = kernels_;  // this step's (prepare() ran before any per-agent call)
    const double h = K.h;
    const double rhoI = density_[i], pI = pressure_[i];
    const bool pressure = pI > 0;  // absolute pressure: only a compressed agent is pushed

    // The pairs (PairSums.h: eight at a time where the CPU has AVX-512, the same bits either way),
    // over the step's stored list by index: q.agents is left unread (readsQueryAgents), so the
    // simulation need not compute its offsets. In a periodic world the stored list's entries are
    // written into per-thread scratch as q.agents had them (StepContext::neighbourList), and
    // where no stored list reaches h (components called outside a step) the grid's agents within
    // h are. With the step's lists either way is the sum over q.agents, to the bit: the same
    // entries, offsets and order.
    Vec2 a(0, 0);
    if (pressure || viscosity_ > 0) {
        thread_local std::vector<NeighbourAgent> scratch;
        pairs::SphInput in;
        pairs::setList(in, ctx, i, h, scratch);
        in.mass = A.mass.data();
        in.density = density_.data();
        in.pressure = pressure_.data();
        in.velocity = A.vel.data();
        in.h = h;
        in.h2 = K.h2;
        in.cS = K.cS;
        in.cV = K.cV;
        in.pressureI = pI;
        in.pushes = pressure;
        in.viscosity = viscosity_;
        in.velocityI = q.velocity;
        a = pairs::sphForce(in);
    }

    if (!analyticWalls() && !wallDensity_.empty()) {
        const WallPressure rule = wallPressureRule();
        const bool wallPush = pressure && rule != WallPressure::DensityOnly;
        const bool wallVisc = viscosity_ > 0 && wallViscosity_ != 0.0;
        if (wallPush || wallVisc)
            ctx.world.particleGrid().forEachWithin(q.position, h, [&](int kk, const Vec2& d, double d2) {
                const std::size_t k = static_cast<std::size_t>(kk);
                const double r = std::sqrt(d2);
                // mass 1; mirrored: the particle takes the agent's pressure and density.
                const double rhoK = rule == WallPressure::Mirrored ? rhoI : wallDensity_[k];
                if (r < 1e-12 || !(rhoK > 0)) return;
                if (wallPush) {
                    const double pK = rule == WallPressure::Mirrored ? pI : wallPressure_[k];
                    a += (pI + pK) / (2.0 * rhoK) * K.spikyGradMagnitude(r) * Vec2(-d / r);
                }
                // A boundary particle is fluid at rest: v_k = 0.
                if (wallVisc) a -= viscosity_ / rhoK * K.viscosityLaplacian(r) * q.velocity;
            });
    } else if (pressure && analyticWalls()) {
        // The pieces prepare() found at this position, else (acceleration() asked for at another
        // step than prepare()'s) found again, in per-thread scratch reused from call to call.
        const wallarea::WallPiece* first = nullptr;
        std::size_t count = 0;
        if (!storedPieces(i, ctx, first, count)) {
            thread_local std::vector<int> near;
            thread_local std::vector<wallarea::WallPiece> pieces;
            ctx.segmentsNear(i, h, near);
            wallarea::occludedAreas(q.position, h, ctx.world.segments(), near, pieces);
            first = pieces.data();
            count = pieces.size();
        }
        for (const wallarea::WallPiece& s : std::span<const wallarea::WallPiece>(first, count)) {
            if (s.distance < 1e-12) continue;
            const double r = 0.5 * (s.distance + h);
            a += s.area * pI * K.spikyGradMagnitude(r) * Vec2((q.position - s.nearest) / s.distance);
        }
    }
    return a / rhoI;
}

const std::vector<double>* SPH::field(const std::string& name) const {
    if (name == "density") return &density_;
    if (name == "rest_density") return &restDensity_;
    if (name == "pressure") return &pressure_;
    return nullptr;
}

}  // namespace ch
