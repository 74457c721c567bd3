"""The body at rest: the whale's surface (procedural whale, mesh files, checks, landmarks) and
its spring network. May import only :mod:`adapter.errors` and :mod:`adapter.scene`."""
