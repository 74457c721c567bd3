"""The body at rest: the whale's surface and its spring network. May import only
:mod:`adapter.errors`, :mod:`adapter.scene` and :mod:`adapter.resources`.

:mod:`~adapter.body.geometry` (:func:`build_surface`, the ``geometry`` command),
:mod:`~adapter.body.surface` (:class:`WhaleSurface`), :mod:`~adapter.body.procedural` (the
procedural right whale), :mod:`~adapter.body.meshfile` (mesh files in and out),
:mod:`~adapter.body.checks` (mesh checks), :mod:`~adapter.body.landmarks` (:data:`LANDMARKS`,
the one list of landmark names), :mod:`~adapter.body.regions` (body, flippers, flukes),
:mod:`~adapter.body.polygons` (triangles and edges of a face set), :mod:`~adapter.body.springs`
(the spring network)."""
