// The registry: names, duplicates, parameter tables and runtime parameter changes.
#define BOOST_TEST_MODULE core_registry
#include <boost/test/unit_test.hpp>

#include "crowdhealth/core/registry.h"

using namespace ch;

namespace {
ComponentInfo fakeInfo(const std::string& name) {
    ComponentInfo info;
    info.name = name;
    info.summary = "test";
    info.params = {ParamSpec::real("gain", "-", 2.0, 0.0, 10.0, "a gain")};
    info.create = [](const ParamSet&) -> std::unique_ptr<Component> { return nullptr; };
    return info;
}
}  // namespace

BOOST_AUTO_TEST_CASE(registering_a_name_twice_is_an_error) {
    Registry& r = Registry::instance();
    BOOST_TEST(r.add(fakeInfo("RegistryTestOnly")));
    BOOST_CHECK_THROW(r.add(fakeInfo("RegistryTestOnly")), RegistryError);
}

BOOST_AUTO_TEST_CASE(redeclaring_a_common_parameter_is_an_error) {
    ComponentInfo info = fakeInfo("RegistryTestCommon");
    info.params.push_back(ParamSpec::real("range", "m", 1, 0, 2, "again"));
    BOOST_CHECK_THROW(Registry::instance().add(info), RegistryError);
}

BOOST_AUTO_TEST_CASE(foundation_components_are_registered_with_full_tables) {
    const Registry& r = Registry::instance();
    for (const char* name : {"GoalReachingForce", "SocialForcesAvoidance"}) {
        const ComponentInfo* info = r.find(name);
        BOOST_TEST_REQUIRE(info != nullptr, name);
        const ParamTable t = Registry::fullTable(*info);
        BOOST_TEST(t.at(0).name == "coeff");
        BOOST_TEST(t.at(1).name == "range");
        for (const ParamSpec& p : t) {
            BOOST_TEST(!p.unit.empty(), name << "." << p.name << " needs a unit");
            BOOST_TEST(!p.description.empty(), name << "." << p.name << " needs a description");
            BOOST_TEST((p.defaultValue >= p.min && p.defaultValue <= p.max), name << "." << p.name);
        }
    }
    const ParamTable sf = Registry::fullTable(*r.find("SocialForcesAvoidance"));
    auto value = [&](const std::string& n) {
        for (const ParamSpec& p : sf)
            if (p.name == n) return p.defaultValue;
        return -1.0;
    };
    // UMANS' parameterisation of Helbing & Molnár.
    BOOST_TEST(value("dt") == 2.0);
    BOOST_TEST(value("V0") == 2.1);
    BOOST_TEST(value("sigma") == 0.3);
    BOOST_TEST(value("U0") == 10.0);
    BOOST_TEST(value("R") == 0.2);
}

BOOST_AUTO_TEST_CASE(parameters_can_change_while_running) {
    ParamSet p(Registry::fullTable(*Registry::instance().find("GoalReachingForce")));
    p.set("strength", 1.5);
    auto c = createComponent("GoalReachingForce", p);
    BOOST_TEST(c->parameter("strength") == 1.5);
    BOOST_TEST(c->setParameter("strength", 2.5));
    BOOST_TEST(c->parameter("strength") == 2.5);
    BOOST_TEST(!c->setParameter("nonexistent", 1.0));
}

BOOST_AUTO_TEST_CASE(unknown_component_names_throw) {
    BOOST_CHECK_THROW(createComponent("NoSuchModel", ParamSet{}), RegistryError);
}
