// A shared library that is not a CrowdHealth plugin (no entry points): the loader must refuse it.
extern "C" __attribute__((visibility("default"))) int some_function() { return 42; }
