// CrowdHealth tests — the dense crowd's pair sums (Policies/PairSums.h, issue 20): SPH's density,
// SPH's pressure and viscosity and ContactForces' agent springs, in their scalar and AVX-512 builds, against the
// models' own expressions written out here pair by pair (as SPH.cpp and ContactForces.cpp had
// them before the sums moved), bit for bit, on lists of every length up to five groups of eight (and long ones),
// with the entries each test must skip: beyond the range, exactly at it, at distance 0, neighbours
// of zero or undefined density, neighbours out of contact.
#define BOOST_TEST_MODULE policies_pair_sums
#include <boost/test/unit_test.hpp>

#include "PairSums.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

using namespace ch;

namespace {

bool sameBits(const Vec2& a, const Vec2& b) {
    return std::memcmp(a.data(), b.data(), sizeof(double)) == 0 && std::memcmp(a.data() + 1, b.data() + 1, sizeof(double)) == 0;
}

/// The builds this CPU runs (0 always; 1 with AVX-512), the current one restored afterwards.
std::vector<int> paths() {
    std::vector<int> p{0};
    const int was = pairs::path();
    if (pairs::setPath(1)) p.push_back(1);
    pairs::setPath(was);
    return p;
}

struct RestorePath {
    int was = pairs::path();
    ~RestorePath() { pairs::setPath(was); }
};

/// Columns of kAgents agents and lists into them, with every kind of entry a sum must skip.
constexpr int kAgents = 60;
struct Crowd {
    std::vector<double> mass, density, pressure, radius;
    std::vector<Vec2> velocity;
    explicit Crowd(std::uint64_t seed) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        for (int j = 0; j < kAgents; ++j) {
            mass.push_back(0.7 + 0.6 * u(rng));
            // Mostly a crowd's densities; some 0 and one NaN (skipped: !(ρ_j > 0)).
            density.push_back(j % 11 == 3 ? 0.0 : j == 17 ? std::numeric_limits<double>::quiet_NaN() : 2.0 + 4.0 * u(rng));
            pressure.push_back(400.0 * (u(rng) - 0.4));  // either sign
            radius.push_back(0.2 + 0.08 * u(rng));
            velocity.emplace_back(2.0 * u(rng) - 1.0, 2.0 * u(rng) - 1.0);
        }
    }
};

/// List lengths a sum is checked on: every one up to five groups of eight, then long lists whose
/// candidates for contact pass the AVX-512 build's buffer of 64 (once, several times, with and
/// without a remainder).
std::vector<int> lengths() {
    std::vector<int> n;
    for (int k = 0; k <= 40; ++k) n.push_back(k);
    for (int k : {63, 64, 65, 71, 72, 73, 130, 203}) n.push_back(k);
    return n;
}

/// n entries: most within `range`, and among them (by position in the list) one exactly at it,
/// one at distance 0, one at 1e-13, a few beyond it.
std::vector<NeighbourAgent> list(int n, double range, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::uniform_int_distribution<int> index(0, kAgents - 1);
    std::vector<NeighbourAgent> out;
    for (int k = 0; k < n; ++k) {
        NeighbourAgent e;
        e.index = index(rng);
        Vec2 off(range * u(rng), range * u(rng));
        if (k % 13 == 4) off = Vec2(0.6, 0.8) * range;  // |off| = range (exactly for range 1)
        if (k % 17 == 6) off = Vec2(0, 0);
        if (k % 19 == 8) off = Vec2(1e-13, 0);
        if (k % 7 == 5) off *= 1.6;  // beyond the range, or not
        e.offset = off;
        out.push_back(e);
    }
    return out;
}

/// SPH's pair loop as SPH::acceleration wrote it before PairSums (Eigen's Vec2 arithmetic).
Vec2 sphReference(const std::vector<NeighbourAgent>& entries, const Crowd& c, double h, double pI, double mu, const Vec2& vI) {
    const double h5 = h * h * h * h * h;
    const double cS = 30.0 / (kPi * h5), cV = 360.0 / (29.0 * kPi * h5);
    Vec2 a(0, 0);
    for (const NeighbourAgent& nb : entries) {
        const double d2 = nb.distanceSquared();
        if (d2 >= h * h) continue;
        const double r = std::sqrt(d2);
        if (r < 1e-12) continue;
        const std::size_t j = static_cast<std::size_t>(nb.index);
        const double rhoJ = c.density[j];
        if (!(rhoJ > 0)) continue;
        if (pI > 0) {
            const Vec2 away = -nb.offset / r;
            const double spiky = r >= h ? 0.0 : cS * (h - r) * (h - r);
            a += c.mass[j] * (pI + c.pressure[j]) / (2.0 * rhoJ) * spiky * away;
        }
        if (mu > 0) a += mu * c.mass[j] / rhoJ * (r >= h ? 0.0 : cV * (h - r)) * (c.velocity[j] - vI);
    }
    return a;
}

/// SPH's density sum as SPH::prepare wrote it (forEachNeighbour within h, then the poly6 kernel).
double densityReference(const std::vector<NeighbourAgent>& entries, const Crowd& c, double h, double start) {
    const double h2 = h * h, h8 = h2 * h2 * h2 * h2;
    const double c6 = 4.0 / (kPi * h8);
    const auto poly6 = [&](double r2) {
        if (r2 >= h2) return 0.0;
        const double d = h2 - r2;
        return c6 * d * d * d;
    };
    double rho = start;
    for (const NeighbourAgent& nb : entries) {
        const double d2 = nb.distanceSquared();
        if (d2 <= h * h) rho += c.mass[static_cast<std::size_t>(nb.index)] * poly6(d2);
    }
    return rho;
}

/// ContactForces' agent springs as its prepare() wrote them (through StepContext::forEachNeighbour).
Vec2 contactReference(const std::vector<NeighbourAgent>& entries, const Crowd& c, double D, double maxD, double k) {
    const double r2 = (D + maxD) * (D + maxD);
    Vec2 a(0, 0);
    for (const NeighbourAgent& nb : entries) {
        const double d2 = nb.distanceSquared();
        if (!(d2 <= r2)) continue;
        const Vec2 off = nb.offset;
        const double reach = D + c.radius[static_cast<std::size_t>(nb.index)];
        if (d2 >= reach * reach) continue;
        const double r = std::sqrt(d2);
        const double overlap = reach - r;
        if (overlap > 0 && r > 1e-12) a += k * overlap * Vec2(-off / r);
    }
    return a;
}

}  // namespace

BOOST_AUTO_TEST_CASE(sph_force_is_the_models_sum_bit_for_bit_in_every_build) {
    RestorePath restore;
    const Crowd c(11);
    std::mt19937_64 rng(5);
    int nonZero = 0;
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(pairs::setPath(path));
        for (const double h : {1.0, 0.7}) {
            const double h5 = h * h * h * h * h;
            for (int n = 0; n <= 40; ++n) {
                const std::vector<NeighbourAgent> entries = list(n, h, rng);
                for (const double pI : {250.0, -30.0})
                    for (const double mu : {0.0, 0.8}) {
                        pairs::SphInput in;
                        in.entries = entries.data();
                        in.count = entries.size();
                        in.mass = c.mass.data();
                        in.density = c.density.data();
                        in.pressure = c.pressure.data();
                        in.velocity = c.velocity.data();
                        in.h = h;
                        in.h2 = h * h;
                        in.cS = 30.0 / (kPi * h5);
                        in.cV = 360.0 / (29.0 * kPi * h5);
                        in.pressureI = pI;
                        in.pushes = pI > 0;
                        in.viscosity = mu;
                        in.velocityI = Vec2(0.3, -0.7);
                        const Vec2 got = pairs::sphForce(in);
                        const Vec2 want = sphReference(entries, c, h, pI, mu, in.velocityI);
                        BOOST_TEST(sameBits(got, want), "path " << path << " h " << h << " n " << n << " p_i " << pI
                                                                << " mu " << mu << ": " << got.transpose() << " against "
                                                                << want.transpose());
                        nonZero += want.squaredNorm() > 0;
                    }
            }
        }
    }
    BOOST_TEST(nonZero > 100);  // the sums are not all zero (the comparison would then prove little)
}

BOOST_AUTO_TEST_CASE(sph_density_is_the_models_sum_bit_for_bit_in_every_build) {
    RestorePath restore;
    const Crowd c(17);
    std::mt19937_64 rng(9);
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(pairs::setPath(path));
        for (const double h : {1.0, 0.7}) {
            const double h2 = h * h;
            for (int n = 0; n <= 40; ++n) {
                const std::vector<NeighbourAgent> entries = list(n, h, rng);
                pairs::DensityInput in;
                in.entries = entries.data();
                in.count = entries.size();
                in.mass = c.mass.data();
                in.h2 = h2;
                in.c6 = 4.0 / (kPi * (h2 * h2 * h2 * h2));
                in.start = 1.1 * in.c6 * h2 * h2 * h2;  // m_i W(0)
                const double got = pairs::sphDensity(in), want = densityReference(entries, c, h, in.start);
                BOOST_TEST(std::memcmp(&got, &want, sizeof got) == 0,
                           "path " << path << " h " << h << " n " << n << ": " << got << " against " << want);
                if (n > 3) BOOST_TEST(want > in.start);  // neighbours within h add to it
            }
        }
    }
}

BOOST_AUTO_TEST_CASE(contact_force_is_the_models_sum_bit_for_bit_in_every_build) {
    RestorePath restore;
    const Crowd c(23);
    std::mt19937_64 rng(7);
    int touching = 0;
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(pairs::setPath(path));
        for (const int n : lengths()) {
            // Lists of 1 m (SPH's range) round an agent of radius 0.24: a few neighbours touch it;
            // of radius 1.2, every entry is within reach (whole groups of eight in contact).
            const std::vector<NeighbourAgent> entries = list(n, 1.0, rng);
            for (const double D : {0.24, 0.5, 1.2}) {
                const double maxD = 0.28;
                pairs::ContactInput in;
                in.entries = entries.data();
                in.count = entries.size();
                in.radius = c.radius.data();
                in.radiusI = D;
                in.reach2 = (D + maxD) * (D + maxD);
                in.stiffness = 50.0;
                const Vec2 got = pairs::contactForce(in);
                const Vec2 want = contactReference(entries, c, D, maxD, 50.0);
                BOOST_TEST(sameBits(got, want), "path " << path << " n " << n << " D " << D << ": " << got.transpose()
                                                        << " against " << want.transpose());
                touching += want.squaredNorm() > 0;
            }
        }
    }
    BOOST_TEST(touching > 40);
}

BOOST_AUTO_TEST_CASE(contact_force_looks_no_farther_than_asked) {
    // The first filter (|offset|² ≤ reach2, the largest reach of any pair) decides on its own: a
    // neighbour with a radius larger than the one reach2 was computed with is not pushed.
    RestorePath restore;
    Crowd c(3);
    c.radius.assign(kAgents, 0.25);
    c.radius[9] = 0.6;
    std::vector<NeighbourAgent> entries(2);
    entries[0].index = 9;
    entries[0].offset = Vec2(0.7, 0.0);  // within 0.25 + 0.6, beyond 0.25 + 0.25
    entries[1].index = 2;
    entries[1].offset = Vec2(0.0, -0.4);  // within 0.5: pushed up with 50 · 0.1
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(pairs::setPath(path));
        pairs::ContactInput in;
        in.entries = entries.data();
        in.count = entries.size();
        in.radius = c.radius.data();
        in.radiusI = 0.25;
        in.reach2 = 0.5 * 0.5;
        in.stiffness = 50.0;
        const Vec2 a = pairs::contactForce(in);
        BOOST_TEST(a.x() == 0.0);
        BOOST_TEST(a.y() == 50.0 * (0.5 - 0.4), boost::test_tools::tolerance(1e-12));
        in.reach2 = 0.85 * 0.85;  // now the large neighbour is looked at: pushed away along −x
        BOOST_TEST(pairs::contactForce(in).x() == -50.0 * (0.85 - 0.7), boost::test_tools::tolerance(1e-12));
        in.reach2 = 0.7 * 0.7;  // exactly at the reach (0.7² both ways): still looked at (≤)
        BOOST_TEST(pairs::contactForce(in).x() == -50.0 * (0.85 - 0.7), boost::test_tools::tolerance(1e-12));
    }
}

BOOST_AUTO_TEST_CASE(sums_over_a_stored_list_by_index_have_the_bits_of_its_whole_entries) {
    // NeighbourLists stores indices; SPH's density and force and ContactForces read them through
    // pairs::IndexList, computing each offset p_j − p_i themselves. The same list as whole entries
    // (offsets computed the same way) must give the same bits, in every build, at every length.
    RestorePath restore;
    const Crowd c(31);
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::uniform_int_distribution<int> index(0, kAgents - 1);
    std::vector<Vec2> pos;
    for (int j = 0; j < kAgents; ++j) pos.emplace_back(3.0 + 0.9 * u(rng), -2.0 + 0.9 * u(rng));
    pos[5] = pos[0];  // a neighbour at distance 0
    int pushed = 0, forced = 0;
    for (const int path : paths()) {
        BOOST_TEST_REQUIRE(pairs::setPath(path));
        for (const int n : lengths()) {
            const std::size_t self = static_cast<std::size_t>(n % 3);
            std::vector<int> indices;
            std::vector<NeighbourAgent> entries;
            for (int k = 0; k < n; ++k) {
                const int j = k % 9 == 2 ? 5 : index(rng);
                indices.push_back(j);
                entries.push_back(NeighbourAgent{pos[static_cast<std::size_t>(j)] - pos[self], j});
            }
            const pairs::IndexList byIndex{indices.data(), pos.data(), pos[self]};

            pairs::DensityInput d;
            d.count = entries.size();
            d.mass = c.mass.data();
            d.h2 = 0.64;
            d.c6 = 3.0;
            d.start = 0.5;
            d.entries = entries.data();
            const double whole = pairs::sphDensity(d);
            d.entries = nullptr;
            d.byIndex = byIndex;
            const double indexed = pairs::sphDensity(d);
            BOOST_TEST(std::memcmp(&whole, &indexed, sizeof whole) == 0, "path " << path << " n " << n);

            pairs::ContactInput k;
            k.count = entries.size();
            k.radius = c.radius.data();
            k.radiusI = 0.4;
            k.reach2 = 0.7 * 0.7;
            k.stiffness = 50.0;
            k.entries = entries.data();
            const Vec2 a = pairs::contactForce(k);
            k.entries = nullptr;
            k.byIndex = byIndex;
            const Vec2 b = pairs::contactForce(k);
            BOOST_TEST(sameBits(a, b), "path " << path << " n " << n << ": " << a.transpose() << " against " << b.transpose());
            pushed += a.squaredNorm() > 0;

            // SPH's pressure and viscosity (read by index since issue 20's twenty-ninth round).
            for (const double pI : {250.0, -30.0}) {
                pairs::SphInput f;
                f.count = entries.size();
                f.mass = c.mass.data();
                f.density = c.density.data();
                f.pressure = c.pressure.data();
                f.velocity = c.velocity.data();
                f.h = 0.8;
                f.h2 = 0.64;
                f.cS = 4.0;
                f.cV = 1.5;
                f.pressureI = pI;
                f.pushes = pI > 0;
                f.viscosity = 0.8;
                f.velocityI = Vec2(0.3, -0.7);
                f.entries = entries.data();
                const Vec2 fw = pairs::sphForce(f);
                f.entries = nullptr;
                f.byIndex = byIndex;
                const Vec2 fi = pairs::sphForce(f);
                BOOST_TEST(sameBits(fw, fi), "sph path " << path << " n " << n << " p_i " << pI << ": " << fw.transpose()
                                                         << " against " << fi.transpose());
                forced += fw.squaredNorm() > 0;
            }
        }
    }
    BOOST_TEST(pushed > 20);  // the lists do touch agent i
    BOOST_TEST(forced > 40);  // and the SPH sums are not all zero
}
