// CrowdHealth — SPH: the crowd as a fluid (van Toll, Chatagnon, Appert-Rolland, Cinquin, Pettré;
// "SPH crowds: agent-based crowd simulation up to extreme densities using fluid dynamics",
// Computers & Graphics 98, 2021), as the CrowdHealth paper re-designs it (DESIGN §4).
#pragma once

#include "crowdhealth/core/registry.h"

#include "WallArea.h"

#include <cstdint>
#include <vector>

namespace ch {

/// Density, dynamic rest density, pressure and viscosity with the 2D kernels of Müller et al.
/// (2003) and smoothing length h = `range`, capped at kMaxSmoothingLength ("limited smoothing
/// length"). Per step, in prepare():
///   ρ_i  = Σ_j m_j W(|x_i − x_j|)  (j over agents within h, i included) + walls;
///   ρ̄_i ← (1 − w) ρ̄_i + w ρ_i,  w = min(1, Δt/T_ρ);  ρ̄_i starts at the agent's first ρ_i;
///   ρ0_i = clamp(ρ̄_i, ρ0_min, ρ0_max);  p_i = k (ρ_i − ρ0_i).
/// Walls (`walls`):
///   * analytic (default) — per wall segment, the area V_s of the kernel disc hidden behind it,
///     each direction counting only the first segment hit (WallArea.h); the segment acts as fluid
///     at the agent's rest density at the point halfway between the segment's nearest point and
///     the kernel edge, r_s = (d_s + h)/2:  ρ_i += V_s ρ0_i W(r_s) (ρ0_i of the previous step);
///   * particles — the World's static boundary particles (mass 1) count in ρ_i. They never move:
///     only their density ρ_k is computed; their pressure p_k = k (ρ_k − ρ0_k) with ρ0_k their
///     density without agents (`wallPressure` fixed, default) or the agents' moving-average rule
///     (dynamic); mirrored uses p_k = p_i, ρ_k = ρ_i; densityOnly leaves them out of the pressure
///     sum. With `wallViscosity` (default) they are in the viscosity sum with v_k = 0.
/// Acceleration on agent i, only while p_i > 0 for the pressure term ("absolute pressure"):
///   a_i = (1/ρ_i) [ Σ_j m_j (p_i + p_j)/(2ρ_j) S(r_ij) x̂_ji  +  μ Σ_j m_j/ρ_j (v_j − v_i) L(r_ij) ]
///   with S the spiky gradient magnitude, L the viscosity Laplacian, x̂_ji the unit vector from j
///   to i; analytic walls add V_s p_i S(r_s) (away from the nearest point) to the pressure sum
///   (wall pressure = p_i, wall density = ρ0_i). Analytic walls get no viscosity (van Toll).
class SPH : public ForceComponent {
public:
    /// "Limited smoothing length": h = min(range, this) (m). Also the default, since the common
    /// `range` defaults to 5 m.
    static constexpr double kMaxSmoothingLength = 1.0;

    explicit SPH(const ParamSet& params);
    static ComponentInfo Info();

    void prepare(const StepContext& ctx) override;
    bool readsQueryAgents() const override { return false; }  ///< the step's lists, by index
    Vec2 acceleration(const AgentQuery& q, const StepContext& ctx) const override;
    void remapAgents(const std::vector<int>& previous) override;
    /// "density", "rest_density" (ρ0_i, after the clamp) or "pressure", per agent.
    const std::vector<double>* field(const std::string& name) const override;

    double smoothingLength() const;
    bool analyticWalls() const { return walls_ != 0.0; }

    /// How boundary particles (walls = particles) enter the agents' pressure sum.
    enum class WallPressure {
        Fixed,       ///< own density ρ_k, rest density = ρ_k without agents (the wall's rest state)
        Dynamic,     ///< own density ρ_k, rest density by the agents' moving-average rule
        Mirrored,    ///< the agent's own pressure and density (p_k = p_i, ρ_k = ρ_i)
        DensityOnly  ///< density only: no pressure term from walls
    };
    /// Pressure of each boundary particle (index = World::boundaryParticles()), walls = particles.
    const std::vector<double>& boundaryPressure() const { return wallPressure_; }
    WallPressure wallPressureRule() const { return static_cast<WallPressure>(static_cast<int>(wallPressureRule_)); }

private:
    /// kernels.h with the powers of h and the normalisations computed once per step instead of
    /// once per pair or per agent. Every expression keeps the order of operations of kernels.h,
    /// so the values are bit-identical.
    struct Kernels {
        double h = 1, h2 = 1, c6 = 0, cS = 0, cV = 0;
        Kernels() = default;
        explicit Kernels(double hh);
        double poly6(double r2) const {
            if (r2 >= h2) return 0.0;
            const double d = h2 - r2;
            return c6 * d * d * d;
        }
        double spikyGradMagnitude(double r) const { return r >= h ? 0.0 : cS * (h - r) * (h - r); }
        double viscosityLaplacian(double r) const { return r >= h ? 0.0 : cV * (h - r); }
    };
    /// This step's kernels (prepare(): the smoothing length may change between steps, by a ramp).
    Kernels kernels_;

    double gasConstant_ = 200;        ///< k, m²/s²
    double restDensityMin_ = 0;       ///< ρ0_min, 1/m²
    double restDensityMax_ = 5;       ///< ρ0_max, 1/m²
    double adaptationTime_ = 0.1;     ///< T_ρ, s
    double viscosity_ = 0;            ///< μ, 1/s
    double walls_ = 1;                ///< Choice: 0 = particles, 1 = analytic
    double wallViscosity_ = 1;        ///< Bool (particles): boundary particles in the viscosity sum
    double wallPressureRule_ = 0;     ///< Choice (particles), see WallPressure

    // per agent (index = AgentStore index), filled by prepare()
    std::vector<double> density_, restDensity_, pressure_;
    std::vector<double> average_;       ///< ρ̄_i, kept across steps
    std::vector<unsigned char> known_;  ///< 1 once ρ̄_i has been started
    // Analytic walls: each agent's wall pieces of this step, found by prepare() and read again by
    // acceleration() (the same position, h and segments give the same pieces; the occlusion's
    // arcs cost more than either sum over a wall agent's neighbours). Each thread of prepare()'s
    // loop keeps the pieces of its agents in agent order; pieceEnd_[i] is where agent i's end in
    // its thread's vector (4 bytes per agent), pieceFirst_[t] the first agent of thread t's chunk.
    std::vector<std::vector<wallarea::WallPiece>> threadPieces_;
    std::vector<std::uint32_t> pieceEnd_;
    std::vector<std::size_t> pieceFirst_;
    std::uint64_t pieceStep_ = 0;        ///< StepContext::stepIndex of the prepare() that found them
    const AgentStore* pieceAgents_ = nullptr;  ///< and its agents (null: none kept)
    /// Agent i's pieces as prepare() found them, or nothing when this step's prepare() kept none.
    bool storedPieces(std::size_t i, const StepContext& ctx, const wallarea::WallPiece*& first, std::size_t& count) const;
    // per boundary particle (index = World::boundaryParticles())
    std::vector<double> wallDensity_, wallPressure_, wallAverage_;
    std::vector<unsigned char> wallKnown_;

    double clampRest(double v) const;
};

}  // namespace ch
