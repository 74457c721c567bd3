"""The OpenFOAM case: its numbers (parameters), dictionaries, the case folder (case, folders),
meshing (mesh), OpenFOAM's tools (tools), logs and the log watch (logs), the step-server as a
child process (stepserver), the ranks' launcher and reconstruction (parallel), the run (run)
and its summary (summary); the swim-and-glide run (swimrun), loads and y+; the C++ boundary
condition's sources in ``plugin/``. May import :mod:`adapter.coupling`, :mod:`adapter.motion`,
:mod:`adapter.body` and :mod:`adapter.reports`."""
