"""The body in time: the gait (stroke, fluke table), the integrators and their stability, the
animator that marches the whale, and the dry-run. May import :mod:`adapter.body` and
:mod:`adapter.reports` (the dry-run's pictures)."""
