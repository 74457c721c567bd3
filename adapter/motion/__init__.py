"""The body in time: the gait (stroke, fluke table), the drive (the stroke and the fluke gate in
the integrators' right-hand side), the integrators (the family, its compiled kernels) and their
stability, the animator that marches the whale, and the dry-run. May import :mod:`adapter.body`
and :mod:`adapter.reports` (the dry-run's pictures)."""
