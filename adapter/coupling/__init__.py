"""The coupling: the wire protocol, the mapping of the whale onto the flow mesh's patch
points, and the step-server the C++ boundary condition asks. May import
:mod:`adapter.motion` and :mod:`adapter.body`."""
