// The source of the target that builds the tests' precompiled header (cmake/Fieldline.cmake).
