"""The OpenFOAM case: the case run (parameters, dictionaries, tools, log watch, summary), the
swim-and-glide run, loads and y+; the C++ boundary condition's sources in ``plugin/``. May
import :mod:`adapter.coupling`, :mod:`adapter.motion`, :mod:`adapter.body` and
:mod:`adapter.reports`."""
